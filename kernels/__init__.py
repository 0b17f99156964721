"""The hand-written stage programs (`os.s`, `ic.s`, `sc.s`), their shared includes, and worked
examples. Python code reads their numbers from the includes, never types them again."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

KERNELS = Path(__file__).resolve().parent


@lru_cache(maxsize=1)
def protocol() -> dict[str, int]:
    """The message protocol's constants (tags, header words, ray record offsets) from
    `protocol.inc` (docs/kernels.md)."""
    from netsushisen.asm.assembler import read_constants
    return read_constants(KERNELS / "protocol.inc")
