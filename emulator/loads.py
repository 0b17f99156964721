"""A processor's database loads as a recorded stream: every `ldr` and `ldg`, in issue order.

The per-word counters (`MemorySystem.stats()`) say how many loads each memory and region took;
the stream says which, in which order, and whether each `ldg` hit the cache — what a per-reference
count (one record fetched for one intersection test, docs/databases.md) or a replay through other
memory configurations (`emulator/tracesim.py`) needs from a run on the machine.

Recording is opt-in (`Engine.record_loads`) and off by default. Both engines produce the same
codes: one int64 per load, `address << 2 | hit << 1 | resident` (hit 0 for a resident load;
a local `ld`, recorded only with `record_loads(local=True)`, has the low bits 3 — space LOCAL),
which the reference engine appends per load (`MemorySystem.load`) and the compiled engine writes
into a preallocated buffer it hands back between chunks of cycles (emulator/compiled). A
`LoadRecorder` keeps them per processor as numpy arrays (8 bytes a load); `stream(name)` decodes
one processor's into a `LoadStream`. `sink` (optional) takes each processor's codes as they
come instead, so a long run need not keep them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from netsushisen.isa.regions import GLOBAL, LOCAL, RESIDENT  # noqa: F401 (LOCAL: the API's)

Sink = Callable[[str, np.ndarray], None]
"""Called with (processor name, codes) for each piece of a processor's stream, in order."""


def encode(address: int, resident: bool, hit: bool) -> int:
    """One `ldr` or `ldg` load's code (the rule both engines apply)."""
    return (address << 2) | (int(hit) << 1) | int(resident)


def encode_local(address: int) -> int:
    """One local `ld`'s code (recorded with `record_loads(local=True)`): the low bits 3."""
    return (address << 2) | 3


@dataclass
class LoadStream:
    """One processor's recorded database loads, in issue order."""

    space: np.ndarray  # int8: GLOBAL (ldg, through the cache), RESIDENT (ldr) or LOCAL (ld)
    address: np.ndarray  # int64 word address in that space
    hit: np.ndarray  # bool: the ldg hit the cache (False for every ldr)

    @classmethod
    def decode(cls, codes: np.ndarray) -> LoadStream:
        codes = np.asarray(codes, np.int64)
        low = codes & 3
        space = np.where(low == 3, LOCAL, np.where(low == 1, RESIDENT, GLOBAL)).astype(np.int8)
        return cls(space, codes >> 2, low == 2)

    def __len__(self) -> int:
        return len(self.address)

    def counts(self) -> dict[str, int]:
        """The totals the per-word counters must equal: resident accesses, cache accesses,
        hits and misses."""
        res = self.space == RESIDENT
        hits = int(np.count_nonzero(self.hit & ~res))
        acc = int(np.count_nonzero(self.space == GLOBAL))
        return {"resident": int(np.count_nonzero(res)), "cache": acc, "hits": hits,
                "misses": acc - hits}


class LoadRecorder:
    """The recorded streams of some processors (by name), kept as arrays of codes."""

    def __init__(self, processors: list[str], sink: Sink | None = None):
        self.processors = list(processors)
        self.sink = sink
        self.pending: dict[str, list[int]] = {p: [] for p in self.processors}  # reference engine
        self.parts: dict[str, list[np.ndarray]] = {p: [] for p in self.processors}

    def buffer(self, processor: str) -> list[int]:
        """The list the reference engine appends a processor's codes to."""
        return self.pending[processor]

    def add(self, processor: str, codes: np.ndarray) -> None:
        """A piece of `processor`'s stream (after the pieces added before)."""
        self._flush(processor)
        self._take(processor, np.asarray(codes, np.int64))

    def _take(self, processor: str, codes: np.ndarray) -> None:
        if not len(codes):
            return
        if self.sink is not None:
            self.sink(processor, codes)
        else:
            self.parts[processor].append(codes)

    def _flush(self, processor: str) -> None:
        pending = self.pending[processor]
        if pending:
            codes = np.array(pending, np.int64)
            pending.clear()
            self._take(processor, codes)

    def flush(self) -> None:
        """Hand every code appended so far on (to the sink, or into the arrays)."""
        for p in self.processors:
            self._flush(p)

    def codes(self, processor: str) -> np.ndarray:
        self._flush(processor)
        parts = self.parts[processor]
        if len(parts) > 1:
            parts[:] = [np.concatenate(parts)]
        return parts[0] if parts else np.zeros(0, np.int64)

    def stream(self, processor: str) -> LoadStream:
        """`processor`'s stream so far (empty with a sink: the sink had it)."""
        return LoadStream.decode(self.codes(processor))
