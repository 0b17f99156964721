"""Database regions and memory sizes: what the host and the machine agree on.

The host lays the four databases out in the machine's memories (host/databases.py) and names
each address range in a region map; the machine counts every load that falls in a range
towards that region, and towards the range's primitive when it has one (emulator/memories.py,
docs/databases.md "Region maps"). Both also size resident memory and the cache the same way
from the configuration: a fixed size, or a share of the global memory image. Both read these
definitions from here, below them, so neither imports the other.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from netsushisen.isa.config import MemoryConfig

GLOBAL, RESIDENT, LOCAL = 0, 1, 2
"""Where an IC load goes, in an access stream (host/ic_access.py → emulator/tracesim.py): `ldg`
through the cache to ICGM, or `ldr` to resident memory; LOCAL, in a stream recorded on the
machine only (emulator/loads.py): an `ld` of IC's local memory (the list cells, in the findings'
reading, netsushisen/paper_machine.py)."""

REGION_NAMES = ("voxel_data", "primitive_list", "shape_data", "luminance_data")
"""The databases' names (the paper's four databases; docs/databases.md); a region map may use
others too."""


@dataclass(frozen=True)
class Region:
    start: int
    end: int  # exclusive
    name: str
    primitive: int | None = None


class RegionMap:
    """Named, non-overlapping address ranges of one memory, looked up by bisection: an address
    is in the last region starting at or before it, if it lies before that region's end — per
    load (`lookup`, the reference engine) or for a whole stream at once (`indices`, the
    trace-driven model); the compiled engine expands the same regions into a per-word table."""

    def __init__(self, regions: Iterable[Region] = ()):
        regs = sorted(regions, key=lambda r: r.start)
        for a, b in zip(regs, regs[1:]):
            if b.start < a.end:
                raise ValueError(f"regions {a.name} [{a.start}, {a.end}) and {b.name} "
                                 f"[{b.start}, {b.end}) overlap")
        for r in regs:
            if r.end <= r.start:
                raise ValueError(f"region {r.name} [{r.start}, {r.end}) is empty")
        self.regions = regs
        self.starts = [r.start for r in regs]
        self.ends = [r.end for r in regs]
        self.names = sorted({r.name for r in regs})

    def lookup(self, address: int) -> Region | None:
        i = bisect.bisect_right(self.starts, address) - 1
        if i >= 0 and address < self.ends[i]:
            return self.regions[i]
        return None

    def indices(self, addresses) -> np.ndarray:
        """`lookup` for many addresses: the index in `regions` of each one's region, or −1."""
        a = np.asarray(addresses, np.int64)
        if not self.regions:
            return np.full(len(a), -1, np.int64)
        i = np.searchsorted(np.asarray(self.starts, np.int64), a, side="right") - 1
        inside = (i >= 0) & (a < np.asarray(self.ends, np.int64)[np.maximum(i, 0)])
        return np.where(inside, i, -1).astype(np.int64)

    def __len__(self) -> int:
        return len(self.regions)


def cache_bytes(mc: MemoryConfig, global_words: int, word_bytes: int) -> int:
    """The cache capacity in bytes: `cache_bytes`, or `cache_share` of the global image rounded
    down to whole sets (block_bytes × cache_ways)."""
    if mc.cache_share is None:
        return mc.cache_bytes
    size = int(mc.cache_share * global_words * word_bytes)
    return size - size % (mc.block_bytes * mc.cache_ways)


def resident_words(mc: MemoryConfig, global_words: int, word_bytes: int) -> int:
    """Resident capacity in words: `resident_bytes`, or `resident_share` of the global image."""
    if mc.resident_share is None:
        return mc.resident_bytes // word_bytes
    return int(mc.resident_share * global_words)
