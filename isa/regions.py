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

from netsushisen.isa.config import MemoryConfig

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
    """Named, non-overlapping address ranges of one memory, looked up by bisection."""

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
        self.names = sorted({r.name for r in regs})

    def lookup(self, address: int) -> Region | None:
        i = bisect.bisect_right(self.starts, address) - 1
        if i >= 0 and address < self.regions[i].end:
            return self.regions[i]
        return None

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
