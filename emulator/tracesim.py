"""Trace-driven model of IC's memory: resident memory + cache + global memory.

It replays a stream of (space, word address) loads — the IC access protocol's stream from the
golden model's reference trace (`host/ic_access.py`) — with the emulator's own cache rule
(`emulator/cacherule.py`, compiled here by numba: the functions the reference engine's
`memories.Cache` calls): word bytes from the precision, byte address = word × word_bytes,
block = byte // block_bytes, set = block % sets, tag = block // sets, hit when the tag is in its
set, LRU over the set's ways (one way: direct-mapped, a miss replaces the line), a cache of 0
bytes misses every time; and it keeps the same counters in the same dictionary shape as
`MemorySystem.stats()` (resident, cache, global, per-region and per-primitive counts; there is
no local memory in a trace).

The stream in the machine's ray order comes from the host (`host/ic_access.py`:
`machine_order`, `ordered_stream_chunks`); `SweepStream` replays one trace under many memory
configurations at once (the paper's Figures 4 and 5) from a run-collapsed form of the stream.

It lives beside the machine's memories and shares their definitions: the cache rule
(`emulator/cacherule.py`), the sizes (`memories.memory_levels`) and the address-to-region rule
(`isa.regions.RegionMap`, whose `lookup` the reference engine calls per load and whose
`indices` this model calls per chunk). It imports nothing from the host: a layout is anything
with the `record_space`, `record_address` and `list_words` of `host.databases.DatabaseLayout`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any, Iterable

import numpy as np

from netsushisen.emulator import cacherule
from netsushisen.emulator.memories import memory_levels
from netsushisen.isa.regions import GLOBAL, RESIDENT, Region, RegionMap

DatabaseLayout = Any
"""A host.databases.DatabaseLayout (record_space, record_address, list_words): read, not typed
here, so the machine's side imports nothing from the host."""

SPACES = {GLOBAL: "global", RESIDENT: "resident"}


# ------------------------------------------------------------------------------------------------
# The cache: the emulator's rule, compiled on first use (numba is imported then, not when this
# module is: a command that never replays a trace starts without it)

_touch = cacherule.touch  # replaced by its compiled form in `_compiled()`


@functools.cache
def _compiled() -> SimpleNamespace:
    """The replay loops compiled by numba (once per process; its own cache on disk)."""
    from numba import njit  # noqa: PLC0415 (numba only where a compiled function is needed)

    global _touch, _hits_of_references
    _touch = njit(nogil=True, inline="always")(cacherule.touch)
    _hits_of_references = njit(nogil=True, inline="always")(reference_hits)
    return SimpleNamespace(replay=njit(nogil=True)(_replay), replay_point=njit(nogil=True)(_replay_point),
                           reference_hits=njit(nogil=True)(reference_hits))


def block_numbers(addresses: np.ndarray, word_bytes: int, block_bytes: int) -> np.ndarray:
    """Block of each word address: (address × word_bytes) // block_bytes, as the emulator."""
    return (np.asarray(addresses, np.int64) * word_bytes) // block_bytes


def _replay(blocks, tags, sets, ways, hits):  # pragma: no cover - compiled
    for i in range(len(blocks)):
        b = blocks[i]
        hits[i] = _touch(tags, (b % sets) * ways, ways, b // sets)


def replay_blocks(blocks: np.ndarray, tags: np.ndarray, ways: int = 1) -> np.ndarray:
    """Hit (True) or miss of each access to `blocks`, in order, through a cache whose line tags
    are `tags` (sets × ways, a set's ways most recent first, -1 = invalid; updated in place, so
    consecutive chunks of one stream replay as one). No sets: every access misses."""
    blocks = np.asarray(blocks, np.int64)
    hits = np.zeros(len(blocks), np.bool_)
    sets = len(tags) // ways
    if len(blocks) and sets:
        _compiled().replay(blocks, tags, sets, ways, hits)
    return hits


class TraceCache:
    """The trace-driven twin of `emulator.memories.Cache` (tags only, counters)."""

    def __init__(self, cache_bytes: int, block_bytes: int, word_bytes: int, ways: int = 1):
        self.geometry = cacherule.geometry(cache_bytes, block_bytes, ways, word_bytes)
        self.block_bytes = block_bytes
        self.word_bytes = word_bytes
        self.ways = ways
        self.sets = self.geometry.sets
        self.tags = np.full(self.geometry.lines, -1, np.int64)
        self.accesses = self.hits = self.misses = 0

    def replay(self, addresses: np.ndarray) -> np.ndarray:
        """Replay word addresses in order; hit per access."""
        hits = replay_blocks(block_numbers(addresses, self.word_bytes, self.block_bytes),
                             self.tags, self.ways)
        h = int(np.count_nonzero(hits))
        self.accesses += len(hits)
        self.hits += h
        self.misses += len(hits) - h
        return hits


class VectorRegions:
    """A region map looked up for many addresses at once (`RegionMap.indices`: the rule the
    reference engine's `RegionMap.lookup` applies per load), with region names numbered in a
    list shared by the maps of one memory system."""

    def __init__(self, regions: Iterable[Region], names: list[str]):
        self.map = RegionMap(regions)
        for r in self.map.regions:
            if r.name not in names:
                names.append(r.name)
        self.name = np.array([names.index(r.name) for r in self.map.regions], np.int64)
        self.primitive = np.array([-1 if r.primitive is None else r.primitive
                                   for r in self.map.regions], np.int64)

    def lookup(self, addresses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(name index or -1, primitive id or -1) of each address."""
        i = self.map.indices(addresses)
        j = np.maximum(i, 0)
        if not len(self.name):
            return i, i.copy()
        return np.where(i >= 0, self.name[j], -1), np.where(i >= 0, self.primitive[j], -1)


# ------------------------------------------------------------------------------------------------
# One processor's resident + cache + global memory, trace-driven


class TraceMemory:
    """IC's (or SC's) memory counters from a replayed (space, address) stream.

    `regions` maps "resident" / "global" to region lists (as `MachineImages.regions["ic.…"]`).
    `global_words` / `resident_words` bound the addresses like the emulator's memories (an access
    outside raises ValueError naming it); None = unbounded."""

    def __init__(self, cache_bytes: int, block_bytes: int, word_bytes: int, resident_words: int = 0,
                 regions: dict[str, list[Region]] | None = None, global_words: int | None = None,
                 ways: int = 1):
        self.cache = TraceCache(cache_bytes, block_bytes, word_bytes, ways)
        self.resident_words = resident_words
        self.global_words = global_words
        self.resident_accesses = 0
        self.names: list[str] = []
        regions = regions or {}
        self.maps = {space: VectorRegions(regions.get(space, ()), self.names)
                     for space in ("resident", "global")}
        self.region_counts: dict[str, np.ndarray] = {}  # "space.name" -> [accesses, hits, misses]
        self.primitive_counts = np.zeros(0, np.int64)

    @classmethod
    def for_images(cls, images, proc: str = "ic") -> TraceMemory:
        """The memory of `proc` for machine images (`host.databases.MachineImages`), sized from
        `images.config` as the emulator sizes it."""
        mc = images.config.ic_memory if proc == "ic" else images.config.sc_memory
        wb = images.config.word_bytes
        glob = images.icgm if proc == "ic" else images.scgm
        cache = memory_levels(mc, len(glob), wb)[1].cache
        return cls(cache.capacity, cache.block_bytes, wb, mc.resident_bytes // wb,
                   {"resident": images.regions.get(f"{proc}.resident", []),
                    "global": images.regions.get(f"{proc}.global", [])}, global_words=len(glob),
                   ways=cache.ways)

    def _count(self, space: str, address: np.ndarray, hits: np.ndarray | None) -> None:
        name, prim = self.maps[space].lookup(address)
        for k in np.unique(name[name >= 0]).tolist():
            sel = name == k
            key = f"{space}.{self.names[k]}"
            c = self.region_counts.setdefault(key, np.zeros(3, np.int64))
            c[0] += int(np.count_nonzero(sel))
            if hits is not None:
                h = int(np.count_nonzero(hits[sel]))
                c[1] += h
                c[2] += int(np.count_nonzero(sel)) - h
        p = prim[prim >= 0]
        if len(p):
            counts = np.bincount(p)
            if len(counts) > len(self.primitive_counts):
                counts[:len(self.primitive_counts)] += self.primitive_counts
                self.primitive_counts = counts
            else:
                self.primitive_counts[:len(counts)] += counts

    def replay(self, space: np.ndarray, address: np.ndarray) -> None:
        """Replay one chunk of loads: `space` GLOBAL (ldg) / RESIDENT (ldr) per load."""
        space = np.asarray(space)
        address = np.asarray(address, np.int64)
        res = space == RESIDENT
        ra, ga = address[res], address[~res]
        for what, a, bound in (("resident", ra, self.resident_words),
                               ("global", ga, self.global_words)):
            if bound is not None and len(a) and (a.min() < 0 or a.max() >= bound):
                bad = int(a[(a < 0) | (a >= bound)][0])
                raise ValueError(f"{what} memory address {bad} is outside 0..{bound - 1}")
        self.resident_accesses += len(ra)
        self._count("resident", ra, None)
        hits = self.cache.replay(ga)
        self._count("global", ga, hits)

    def stats(self) -> dict:
        """The counters in `MemorySystem.stats()`'s shape (without `local`)."""
        c = self.cache
        out: dict = {"resident": {"accesses": self.resident_accesses, "words": self.resident_words},
                     "cache": {"accesses": c.accesses, "hits": c.hits, "misses": c.misses,
                               "sets": c.sets, "ways": c.ways, "block_bytes": c.block_bytes},
                     "global": {"accesses": c.misses}}
        regions = {}
        for key, (a, h, m) in self.region_counts.items():
            if a:
                regions[key] = {"accesses": int(a)} | ({"hits": int(h), "misses": int(m)}
                                                       if key.startswith("global.") else {})
        if regions:
            out["regions"] = regions
        prims = {str(p): int(n) for p, n in enumerate(self.primitive_counts.tolist()) if n}
        if prims:
            out["primitives"] = prims
        return out


# ------------------------------------------------------------------------------------------------
# Many configurations at once: the run-collapsed stream


def _replay_point(first, span, loads, prim, segment, fetch_is_reference, fetch_prim, resident,
                  shift, tags, ways, word_bytes, block_bytes, lists_cached):  # pragma: no cover - compiled
    """One configuration's cache over one chunk of runs, in stream order: (hits of record
    loads, hits of list loads, references through the cache whose every block hit). A run's
    first load of each block is a real access; its other loads of that block hit (the block is
    the set's most recent line then, so LRU order is unchanged)."""
    sets = len(tags) // ways
    missed = np.zeros(len(fetch_is_reference), np.bool_)
    h_shape = 0
    h_list = 0
    for i in range(len(first)):
        p = prim[i]
        if p < 0:
            if not lists_cached:
                continue
            f = first[i]
        else:
            if resident[p]:
                continue
            f = first[i] + shift[p]
        b1 = (f * word_bytes) // block_bytes
        b2 = ((f + span[i]) * word_bytes) // block_bytes
        hits = loads[i] - (b2 - b1 + 1)
        miss = False
        for b in range(b1, b2 + 1):
            if _touch(tags, (b % sets) * ways, ways, b // sets):
                hits += 1
            else:
                miss = True
        if p < 0:
            h_list += hits
        else:
            h_shape += hits
            if miss:
                missed[segment[i]] = True
    return h_shape, h_list, _hits_of_references(fetch_is_reference, fetch_prim, resident, missed)


# ------------------------------------------------------------------------------------------------
# The per-reference rule (docs/databases.md), shared by the trace-driven sweep and the machine's
# recorded stream (`stream_references`)


@dataclass
class Fetches:
    """A stream's fetches: `segment` per item (its fetch, -1 for a list cell), `heads` (the
    first item of each fetch), `is_reference` per fetch."""

    segment: np.ndarray
    heads: np.ndarray
    is_reference: np.ndarray


def fetches(prim: np.ndarray) -> Fetches:
    """The paper's references in a sequence of items — loads, or runs of loads of one record —
    given each item's primitive (-1: a list cell): a *fetch* is a maximal sequence of record
    items of one primitive; a fetch that follows a list cell is one reference (one test); a
    fetch that follows another record (a winner's hit words, read after the ray's last test) is
    none."""
    prim = np.asarray(prim, np.int64)
    is_rec = prim >= 0
    prev = np.concatenate([[-2], prim[:-1]])
    seg_start = is_rec & (prev != prim)
    segment = np.where(is_rec, np.cumsum(seg_start) - 1, -1)
    return Fetches(segment, np.flatnonzero(seg_start), (prev == -1)[seg_start])


def reference_hits(is_reference, fetch_prim, resident, missed) -> int:  # compiled by numba too
    """References through the cache (`resident[fetch_prim]` false) whose every block hit
    (`missed` false): the paper's cache hits."""
    n = 0
    for k in range(len(is_reference)):
        if is_reference[k] and not resident[fetch_prim[k]] and not missed[k]:
            n += 1
    return n


_hits_of_references = reference_hits  # replaced by its compiled form in `_compiled()`


def reference_counts(fetch_prim: np.ndarray, f: Fetches, resident: np.ndarray,
                     missed: np.ndarray) -> dict[str, int]:
    """`ref.resident`, `ref.cache`, `ref.hits` of one stream: its fetches `f`, each fetch's
    primitive, which primitives are resident and which fetches missed."""
    refs = fetch_prim[f.is_reference]
    res = int(np.count_nonzero(resident[refs]))
    hits = _compiled().reference_hits(f.is_reference, fetch_prim, resident, missed) \
        if len(refs) else 0
    return {"ref.resident": res, "ref.cache": len(refs) - res, "ref.hits": int(hits)}


def stream_references(prim: np.ndarray, hit: np.ndarray, resident: np.ndarray) -> dict[str, int]:
    """The per-reference counts of a recorded load stream (emulator/loads.py) mapped to
    primitives (`prim` per load, -1 a list cell; `resident` per primitive), each reference's
    hit decided by the machine's own per-load hit flags (`hit`): every load of a fetch hit."""
    prim = np.asarray(prim, np.int64)
    f = fetches(prim)
    missed = np.bincount(f.segment[(prim >= 0) & ~np.asarray(hit, bool)],
                         minlength=len(f.heads)) > 0
    return reference_counts(prim[f.heads], f, np.asarray(resident, bool), missed)


@dataclass
class SweepPoint:
    """One memory configuration of a sweep (a layout decides resident vs ICGM and addresses).

    `counts` holds, per word (every load): `resident.shape_data`, `global.<region>` (cache
    accesses), `hits.<region>`, `local.primitive_list` (list loads served by local memory when
    the lists are not cached); and per primitive reference (one record fetched for one test):
    `ref.resident`, `ref.cache` (fetches through the cache), `ref.hits` (fetches whose every
    block hit)."""

    layout: DatabaseLayout
    cache_bytes: int
    block_bytes: int
    ways: int = 1
    tags: np.ndarray = field(init=False)
    resident: np.ndarray = field(init=False)  # (N,) bool
    shift: np.ndarray = field(init=False)  # (N,) ICGM address − reference ICGM address
    counts: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.tags = np.full(self.cache_bytes // (self.block_bytes * self.ways) * self.ways, -1,
                            np.int64)
        self.resident = self.layout.record_space == RESIDENT
        for k in COUNT_KEYS:
            self.counts[k] = 0


COUNT_KEYS = ("resident.primitive_list", "resident.shape_data", "global.primitive_list",
              "global.shape_data", "hits.primitive_list", "hits.shape_data", "local.primitive_list",
              "ref.resident", "ref.cache", "ref.hits")


@dataclass
class Runs:
    """A chunk of the reference layout's stream, run-collapsed (see `SweepStream`)."""

    first: np.ndarray  # first word address of each run
    span: np.ndarray  # last − first
    loads: np.ndarray  # loads in the run
    prim: np.ndarray  # primitive of a record run, -1 for a list-cell run
    segment: np.ndarray  # record runs: their fetch (consecutive runs of one record), else -1
    fetch_is_reference: np.ndarray  # per fetch: after a list cell (a test), not a winner's hit words
    fetch_prim: np.ndarray  # per fetch: its primitive


class SweepStream:
    """Replays one trace under many configurations that share the lists and the priorities.

    The stream is taken once in a reference layout with every record in ICGM (id order) and cut
    into *runs*: consecutive loads of one list cell pair or of one record, at ascending addresses
    no more than `min block words` apart. In any configuration a run's loads stay in one space,
    move by one offset (the record's new address) and touch every block between its first and
    last word, each block's loads back to back: the first load of a block is a real cache access,
    the others hit. So a configuration replays only each run's blocks, exactly.

    Per primitive reference (the paper's counting, docs/databases.md): a *fetch* is a maximal
    sequence of record runs of one primitive; a fetch that follows a list cell pair is one
    reference (one test; the winner's hit words, read after a ray's last test, join it when the
    winner was tested last and are no reference otherwise). A reference through the cache hits
    when every block it touches hits.

    `lists_cached=False` models list cells held in local memory beside the resident data (read
    at t_r, never in the cache, not part of the sized database): their loads are counted as
    `local.primitive_list` and skip the cache."""

    def __init__(self, reference: DatabaseLayout, points: list[SweepPoint], word_bytes: int,
                 lists_cached: bool = True):
        self.reference = reference
        self.points = points
        self.wb = word_bytes
        self.lists_cached = lists_cached
        self.list_words = reference.list_words
        if np.any(reference.record_space != GLOBAL):
            raise ValueError("the reference layout must keep every record in ICGM")
        self.addr0 = reference.record_address
        self.starts = np.sort(self.addr0)
        self.start_prim = np.argsort(self.addr0, kind="stable")
        self.max_gap = max(1, min(p.block_bytes for p in points) // word_bytes) if points else 1
        for p in points:
            glob = p.layout.record_space == GLOBAL
            p.shift = np.where(glob, p.layout.record_address - self.addr0, 0)

    def reset(self) -> None:
        """Empty every configuration's cache (the next stream is another PE's, with memories of
        its own); the counts go on adding up."""
        for p in self.points:
            p.tags[:] = -1

    def runs(self, address: np.ndarray) -> Runs:
        """The chunk's runs and fetches."""
        a = np.asarray(address, np.int64)
        if not len(a):
            z = np.zeros(0, np.int64)
            return Runs(z, z, z, z, z, np.zeros(0, bool), z)
        cell = a < self.list_words
        i = np.searchsorted(self.starts, a, side="right") - 1
        prim = np.where(cell, -1, self.start_prim[np.maximum(i, 0)])
        d = np.diff(a)
        brk = np.ones(len(a), bool)
        brk[1:] = (prim[1:] != prim[:-1]) | (d <= 0) | (d > self.max_gap)
        start = np.flatnonzero(brk)
        end = np.concatenate([start[1:], [len(a)]]) - 1
        rp = prim[start]
        f = fetches(rp)
        return Runs(a[start], a[end] - a[start], end - start + 1, rp, f.segment, f.is_reference,
                    rp[f.heads])

    def replay(self, space: np.ndarray, address: np.ndarray) -> None:
        """One chunk of the reference layout's stream (every load GLOBAL)."""
        r = self.runs(address)
        first, span, loads, prim, seg = r.first, r.span, r.loads, r.prim, r.segment
        n = len(self.addr0)
        is_rec = prim >= 0
        p = np.maximum(prim, 0)
        fetch_prim = r.fetch_prim
        refs = r.fetch_is_reference
        # what does not depend on the cache, per primitive: O(N) per configuration, not O(runs)
        rec_loads = np.bincount(p[is_rec], loads[is_rec], minlength=n).astype(np.int64)
        ref_count = np.bincount(fetch_prim[refs], minlength=n)
        list_loads = int(loads[~is_rec].sum())
        all_rec_loads, all_refs = int(rec_loads.sum()), int(ref_count.sum())
        for pt in self.points:
            c = pt.counts
            res_loads = int(rec_loads[pt.resident].sum())
            res_refs = int(ref_count[pt.resident].sum())
            c["resident.shape_data"] += res_loads
            c["global.shape_data"] += all_rec_loads - res_loads
            c["ref.resident"] += res_refs
            c["ref.cache"] += all_refs - res_refs
            if self.lists_cached:
                c["global.primitive_list"] += list_loads
            else:
                c["local.primitive_list"] += list_loads
            if not len(pt.tags):
                continue
            h_shape, h_list, ref_hits = _compiled().replay_point(
                first, span, loads, prim, seg, refs, fetch_prim, pt.resident, pt.shift, pt.tags,
                pt.ways, self.wb, pt.block_bytes, self.lists_cached)
            c["hits.shape_data"] += int(h_shape)
            c["hits.primitive_list"] += int(h_list)
            c["ref.hits"] += int(ref_hits)

    @staticmethod
    def figures(pt: SweepPoint, t_r: float = 1, t_c: float = 2, t_g: float = 8) -> dict:
        """ρ, μ, measured t (in cycles with these times) and the paper's model t: per word over
        all IC database loads (`all`) and over shape data alone (`shape`), and per primitive
        reference (`ref`, the paper's counting)."""
        c = pt.counts
        out = {}
        cases = (("all", c["resident.shape_data"] + c["local.primitive_list"],
                  c["global.shape_data"] + c["global.primitive_list"],
                  c["hits.shape_data"] + c["hits.primitive_list"]),
                 ("shape", c["resident.shape_data"], c["global.shape_data"], c["hits.shape_data"]),
                 ("ref", c["ref.resident"], c["ref.cache"], c["ref.hits"]))
        for what, res, acc, hits in cases:
            total = res + acc
            rho = res / total if total else 0.0
            mu = hits / acc if acc else 0.0
            measured = (res * t_r + hits * t_c + (acc - hits) * t_g) / total if total else 0.0
            out[what] = {"loads": total, "resident": res, "cache_accesses": acc, "cache_hits": hits,
                         "rho": rho, "mu": mu, "miss_rate": 1 - mu if acc else 0.0,
                         "t_measured": measured, "t_model": t_r * (rho + (1 - rho) * (8 - 6 * mu))}
        return out
