"""The cache rule, in one home: where a word lives in a cache and what one access does to it.

A cache of IC or SC (docs/timing.md §2) keeps tags only (every database is read-only, so its
data would be a copy of global memory). Its geometry is `sets` sets of `ways` lines of
`block_bytes`: for word address a, byte address b = a × word_bytes, block = b // block_bytes,
set = block % sets, tag = block // sets. The tags live in one flat int64 array, set s in
tags[s·ways : (s+1)·ways], most recently used first, −1 an invalid line. An access hits when
its tag is in its set; either way its tag moves to the front (a hit shifts the more recent lines
down by one; a miss shifts the whole set, dropping the least recently used line): LRU. With one
way this is the direct-mapped cache (a miss replaces the set's one line). A cache of no sets
misses every access.

Everything that models a cache calls these functions: the reference engine's `memories.Cache`
as plain Python, the compiled engine's loop and the trace-driven model (`emulator/tracesim.py`)
compiled by numba from the same source — the functions use nothing numba cannot compile, and
this file is part of the compiled loop's cache key (emulator/compiled/build.py).
"""

from __future__ import annotations

from dataclasses import dataclass

WAYS = (1, 2, 4, 8)
"""The associativities a configuration may ask for (`ic_memory.cache_ways`)."""


@dataclass(frozen=True)
class CacheGeometry:
    """One cache's shape: sets × ways lines of block_bytes, for words of word_bytes."""

    sets: int
    ways: int
    block_bytes: int
    word_bytes: int

    @property
    def lines(self) -> int:
        return self.sets * self.ways

    @property
    def capacity(self) -> int:
        return self.lines * self.block_bytes


def geometry(cache_bytes: int, block_bytes: int, ways: int, word_bytes: int) -> CacheGeometry:
    """The geometry of a cache of `cache_bytes` (whole sets; a remainder is unused)."""
    return CacheGeometry(cache_bytes // (block_bytes * ways), ways, block_bytes, word_bytes)


def locate(address: int, word_bytes: int, block_bytes: int, sets: int) -> tuple[int, int]:
    """(set, tag) of a word address in a cache of `sets` > 0 sets."""
    block = (address * word_bytes) // block_bytes
    return block % sets, block // sets


def find(tags, base: int, ways: int, tag: int) -> int:
    """The way of set tags[base : base + ways] holding `tag`, or −1 (no side effects: a
    processor asks before it decides to issue)."""
    for k in range(ways):
        if tags[base + k] == tag:
            return k
    return -1


def touch(tags, base: int, ways: int, tag: int) -> bool:
    """One access to `tag` in set tags[base : base + ways]: True on a hit; the tag becomes
    the set's most recently used line (on a miss, the least recently used line is dropped)."""
    k = ways - 1  # a miss: the least recently used line goes
    hit = False
    for j in range(ways):  # find(), written out: numba compiles each function on its own
        if tags[base + j] == tag:
            k = j
            hit = True
            break
    while k > 0:
        tags[base + k] = tags[base + k - 1]
        k -= 1
    tags[base] = tag
    return hit
