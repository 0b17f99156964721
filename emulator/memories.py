"""Memories of a PE (the paper's two-level memory of IC and SC; docs/timing.md §2): local,
resident, cache (direct-mapped or set-associative), global.

Every memory is a numpy array of raw machine words (uint32 in fp32 mode, uint64 in fp64 mode);
addresses count words. What each processor reaches:

| processor | `ld`/`st`        | `ldr`                  | `ldg`                                  |
| OS        | local (voxel data + kernel data) | —      | —                                      |
| IC        | local (kernel data) | resident (read-only) | ICGM through IC's cache             |
| SC        | local (kernel data) | resident (read-only) | SCGM through SC's cache             |

A program's `.data` words are loaded at local address 0; a memory image may add more words.
Resident memory and the global memories are written only by the host (the memory image); the
PEs only read them. All PEs share one ICGM and one SCGM (no contention is modelled: every PE's
cache miss costs t_g, however many PEs miss at once).

Access times (cycles from issue until the result is readable; the issuing processor is held
for the whole access, see core.py):

    OS ld          the `ld` latency (opcode table, overridable as os.latency.ld)
    IC/SC ld, ldr  t_r
    ldg, cache hit t_c
    ldg, miss      t_g          (the block is filled at once: a later access to it hits)
    st             writes at issue; no hold

The cache has `block_bytes` blocks, `cache_bytes` capacity and `cache_ways` ways per set
(1, the default: direct-mapped; 2, 4 or 8 with LRU replacement): for word address a, byte
address b = a × word_bytes, block = b // block_bytes, set = block % sets (sets = cache_bytes //
(block_bytes × ways)), tag = block // sets. The rule — placement, hit, LRU update — has one
home, emulator/cacherule.py, which the compiled engine and the trace-driven model compile.
Since every database is read-only, the cache keeps only tags (its data would be a copy of
global memory). A cache of 0 bytes makes every `ldg` a miss. When `cache_share` /
`resident_share` is set, the size is that share of the global memory image (the primitive
database), rounded down to whole sets (cache) or words (resident).

Counters: local {reads, writes}; resident {accesses}; cache {accesses, hits, misses}; global
{accesses} (= cache misses). An optional `RegionMap` per memory (isa/regions.py) names address
ranges (voxel_data, primitive_list, shape_data, luminance_data, ...) and optionally a primitive id
per range; every load that falls in a range counts towards that region (and, for a cache, its
hits/misses) and towards the range's primitive (give one word per primitive, e.g. the head of
its shape record, to count intersection tests). `record` (a list, set by
`Engine.record_loads`; None by default) receives every `ldr` and `ldg` (with `record_local`
also every local `ld`) as a code of emulator/loads.py, in issue order.

An access outside a memory raises `MemoryFault`; the core turns it into a run-time fault that
names processor, PC and cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from netsushisen.emulator import cacherule as rule
from netsushisen.emulator.loads import encode, encode_local
from netsushisen.isa.config import MachineConfig, MemoryConfig
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.regions import REGION_NAMES, Region, RegionMap, cache_bytes, resident_words
from netsushisen.isa.stalls import CACHE_HIT, CACHE_MISS, LOCAL, RESIDENT

__all__ = ["Cache", "Level", "Memory", "MemoryFault", "MemorySystem", "RegionCounters",
           "memory_levels",
           # defined in isa/regions.py (the host reads them there), used here and by pe.py
           "REGION_NAMES", "Region", "RegionMap", "cache_bytes", "resident_words"]


class MemoryFault(Exception):
    """An access outside a memory (the core adds processor, PC and cycle)."""


# ---------------------------------------------------------------------------------------------
# Region counters (the region maps themselves: isa/regions.py)


@dataclass
class RegionCounters:
    """Loads per region name (+ cache hits/misses) and per primitive id."""

    regions: dict[str, list[int]] = field(default_factory=dict)  # name -> [accesses, hits, misses]
    primitives: dict[int, int] = field(default_factory=dict)

    def count(self, region: Region, hit: bool | None) -> None:
        c = self.regions.setdefault(region.name, [0, 0, 0])
        c[0] += 1
        if hit is True:
            c[1] += 1
        elif hit is False:
            c[2] += 1
        if region.primitive is not None:
            self.primitives[region.primitive] = self.primitives.get(region.primitive, 0) + 1


# ---------------------------------------------------------------------------------------------
# Memories


class Memory:
    """A word-addressed array with counters; `name` appears in fault messages."""

    def __init__(self, name: str, words: np.ndarray, regions: RegionMap | None = None):
        self.name = name
        self.words = words
        self.regions = regions
        self.region_counts = RegionCounters()
        self.reads = 0
        self.writes = 0

    @property
    def size(self) -> int:
        return len(self.words)

    def check(self, address: int) -> None:
        if not 0 <= address < len(self.words):
            raise MemoryFault(f"{self.name} address {address} is outside 0..{len(self.words) - 1}"
                              if len(self.words) else f"{self.name} address {address}: "
                              f"{self.name} is empty (size 0)")

    def read(self, address: int) -> int:
        self.check(address)
        self.reads += 1
        if self.regions is not None:
            r = self.regions.lookup(address)
            if r is not None:
                self.region_counts.count(r, None)
        return int(self.words[address])

    def write(self, address: int, word: int) -> None:
        self.check(address)
        self.writes += 1
        self.words[address] = word


class Cache:
    """Set-associative with LRU replacement (one way: direct-mapped), tags only (the databases
    are read-only), in front of a global memory; the rule itself is emulator/cacherule.py."""

    def __init__(self, name: str, cache_bytes: int, block_bytes: int, word_bytes: int,
                 ways: int = 1):
        self.name = name
        self.geometry = rule.geometry(cache_bytes, block_bytes, ways, word_bytes)
        self.block_bytes = block_bytes
        self.word_bytes = word_bytes
        self.ways = ways
        self.sets = self.geometry.sets
        self.tags = np.full(self.geometry.lines, -1, dtype=np.int64)  # set by set, MRU first
        self.accesses = 0
        self.hits = 0
        self.misses = 0

    def locate(self, address: int) -> tuple[int, int]:
        """(set, tag) of a word address (sets = 0: no cache, every access misses)."""
        if self.sets == 0:
            return -1, (address * self.word_bytes) // self.block_bytes
        return rule.locate(address, self.word_bytes, self.block_bytes, self.sets)

    def probe(self, address: int) -> bool:
        """Would this access hit? (No side effects: the core asks before it decides to issue.)"""
        s, tag = self.locate(address)
        return s >= 0 and rule.find(self.tags, s * self.ways, self.ways, tag) >= 0

    def access(self, address: int) -> tuple[bool, int]:
        """Count one access (a miss fills a line, LRU); (hit, set touched or -1)."""
        s, tag = self.locate(address)
        self.accesses += 1
        hit = s >= 0 and rule.touch(self.tags, s * self.ways, self.ways, tag)
        if hit:
            self.hits += 1
        else:
            self.misses += 1
        return hit, s


@dataclass(frozen=True)
class Level:
    """One level of IC's or SC's memory hierarchy (nearest first): its access time in cycles
    (for a cache, a hit's) and, for a cache, its geometry."""

    name: str
    time: int
    cache: rule.CacheGeometry | None = None


def memory_levels(mc: MemoryConfig, global_words: int, word_bytes: int) -> list[Level]:
    """IC's or SC's memory as a list of levels — resident, the caches in front of global memory
    in order, global — sized from the configuration as every model of the memory sizes it: the
    reference and compiled engines (through `MemorySystem`) and the trace-driven model
    (`emulator/tracesim.py`). A cache's organisation is one level's geometry here and the rule
    in emulator/cacherule.py; another cache level would be one more entry."""
    return [Level("resident", mc.t_r),
            Level("cache", mc.t_c, rule.geometry(cache_bytes(mc, global_words, word_bytes),
                                                 mc.block_bytes, mc.cache_ways, word_bytes)),
            Level("global", mc.t_g)]


class MemorySystem:
    """One processor's memories and their timing (see the module docstring)."""

    def __init__(self, proc: str, pe: int, config: MachineConfig, local: np.ndarray,
                 resident: np.ndarray | None = None, global_memory: Memory | None = None,
                 regions: dict[str, RegionMap] | None = None):
        regions = regions or {}
        self.proc = proc
        self.local = Memory("local memory", local, regions.get("local"))
        self.resident = Memory("resident memory", resident, regions.get("resident")) \
            if resident is not None else None
        self.global_memory = global_memory
        self.cache: Cache | None = None
        self.global_regions = regions.get("global")
        self.global_counts = RegionCounters()
        self.global_accesses = 0
        self.record: list[int] | None = None  # codes of recorded loads (emulator/loads.py), or off
        self.record_local = False  # also local loads (`Engine.record_loads(local=True)`)
        if proc == "os":
            latency = config.os.latency.get("ld")
            self.t_local = latency if latency is not None else OPCODES["ld"].latency
            self.t_r = self.t_c = self.t_g = 0
        else:
            mc: MemoryConfig = config.ic_memory if proc == "ic" else config.sc_memory
            gwords = global_memory.size if global_memory is not None else 0
            resident_level, cache_level, global_level = memory_levels(mc, gwords,
                                                                      config.word_bytes)
            self.t_local = self.t_r = resident_level.time
            self.t_c, self.t_g = cache_level.time, global_level.time
            g = cache_level.cache
            self.cache = Cache(f"{proc} cache", g.capacity, g.block_bytes, g.word_bytes, g.ways)

    # -- timing, without side effects (the core decides whether to issue first) --------------

    def access_time(self, space: str, address: int) -> tuple[int, str]:
        """(cycles, stall cause) of a load from `space` at `address`."""
        if space == "local":
            return self.t_local, LOCAL
        if space == "resident":
            return self.t_r, RESIDENT
        if self.cache is not None and self.cache.probe(address):
            return self.t_c, CACHE_HIT
        return self.t_g, CACHE_MISS

    # -- the accesses themselves --------------------------------------------------------------

    def load(self, space: str, address: int) -> tuple[int, int]:
        """The word at `address` of `space`; (word, cache set touched or -1)."""
        if space == "local":
            word = self.local.read(address)
            if self.record is not None and self.record_local:
                self.record.append(encode_local(address))
            return word, -1
        if space == "resident":
            if self.resident is None:
                raise MemoryFault("this processor has no resident memory")
            word = self.resident.read(address)
            if self.record is not None:
                self.record.append(encode(address, True, False))
            return word, -1
        gm = self.global_memory
        if gm is None or self.cache is None:
            raise MemoryFault("this processor has no global memory")
        gm.check(address)
        hit, s = self.cache.access(address)
        if self.record is not None:
            self.record.append(encode(address, False, hit))
        if not hit:
            self.global_accesses += 1
        if self.global_regions is not None:
            r = self.global_regions.lookup(address)
            if r is not None:
                self.global_counts.count(r, hit)
        return int(gm.words[address]), s

    def store(self, address: int, word: int) -> None:
        self.local.write(address, word)

    # -- statistics ---------------------------------------------------------------------------

    def stats(self) -> dict:
        out: dict = {"local": {"reads": self.local.reads, "writes": self.local.writes,
                               "words": self.local.size}}
        regions: dict[str, dict] = {}
        primitives: dict[int, int] = {}

        def merge(counts: RegionCounters, space: str) -> None:
            for name, (a, h, m) in counts.regions.items():
                entry = {"accesses": a}
                if space == "global":
                    entry.update(hits=h, misses=m)
                regions[f"{space}.{name}"] = entry
            for p, n in counts.primitives.items():
                primitives[p] = primitives.get(p, 0) + n

        merge(self.local.region_counts, "local")
        if self.resident is not None:
            out["resident"] = {"accesses": self.resident.reads, "words": self.resident.size}
            merge(self.resident.region_counts, "resident")
        if self.cache is not None:
            c = self.cache
            out["cache"] = {"accesses": c.accesses, "hits": c.hits, "misses": c.misses,
                            "sets": c.sets, "ways": c.ways, "block_bytes": c.block_bytes}
            out["global"] = {"accesses": self.global_accesses}
            merge(self.global_counts, "global")
        if regions:
            out["regions"] = regions
        if primitives:
            out["primitives"] = {str(p): n for p, n in sorted(primitives.items())}
        return out
