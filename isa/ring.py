"""CMU messages: the header word the ring hardware reads (the paper leaves the formats open: ours).

FIFO operations move one word at a time; a message is a header word followed by `length`
payload words, and travels by wormhole routing: the CMU reads the header, routes the message
towards `dest` (forwarding through an intermediate CMU without using its processor — IC → OS goes
through SC's CMU), and passes the payload words behind it. `cls` selects the buffer class of the
structured buffer pool (deadlock avoidance); `tag` is free for the kernels (message kind).

Header word layout (32-bit integer):
    bits  0..7   length   payload words that follow (0..255)
    bits  8..9   dest     0 = OS, 1 = IC, 2 = SC, 3 = COL (SC's output port only)
    bits 10..13  cls      buffer class 0..15
    bits 16..31  tag      kernel-defined message kind
"""

from __future__ import annotations

from dataclasses import dataclass

LENGTH_BITS, DEST_SHIFT, CLS_SHIFT, TAG_SHIFT = 8, 8, 10, 16
MAX_LENGTH = (1 << LENGTH_BITS) - 1
N_CLASSES = 16
DESTS = {"os": 0, "ic": 1, "sc": 2, "col": 3}
DEST_NAMES = {v: k for k, v in DESTS.items()}


@dataclass(frozen=True)
class Header:
    length: int
    dest: int
    cls: int = 0
    tag: int = 0

    @property
    def dest_name(self) -> str:
        return DEST_NAMES[self.dest]


def make_header(length: int, dest: int, cls: int = 0, tag: int = 0) -> int:
    if not 0 <= length <= MAX_LENGTH:
        raise ValueError(f"message length {length} out of range 0..{MAX_LENGTH}")
    return (tag << TAG_SHIFT) | (cls << CLS_SHIFT) | (dest << DEST_SHIFT) | length


def parse_header(word: int) -> Header:
    word &= 0xFFFFFFFF
    return Header(word & MAX_LENGTH, (word >> DEST_SHIFT) & 3, (word >> CLS_SHIFT) & 15,
                  word >> TAG_SHIFT)


def predefined_symbols() -> dict[str, int]:
    """Constants every kernel sees without defining them (the assembler predefines these)."""
    return {
        "DEST_OS": DESTS["os"], "DEST_IC": DESTS["ic"], "DEST_SC": DESTS["sc"],
        "DEST_COL": DESTS["col"],
        "HDR_DEST_SHIFT": DEST_SHIFT, "HDR_CLS_SHIFT": CLS_SHIFT, "HDR_TAG_SHIFT": TAG_SHIFT,
        "HDR_LENGTH_MASK": MAX_LENGTH,
    }
