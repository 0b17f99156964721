"""The trace-driven memory model (emulator/tracesim.py) against the emulator's own memory system
(emulator/memories.py) driven access by access with the same stream: counters must be equal,
for several cache and block sizes, fp32 and fp64; the run-collapsed sweep must equal the full
model; the machine's ray order is level order per pixel."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netsushisen.emulator.memories import Cache, Memory, MemorySystem, Region, RegionMap
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import GLOBAL, RESIDENT, build_images, plan_layout
from netsushisen.host.golden import SHADOW, render
from netsushisen.host.grid import build_grid
from netsushisen.host.prepass import priorities_from_counts
from netsushisen.isa.config import load_config
from netsushisen.emulator.tracesim import SweepPoint, SweepStream, TraceMemory, replay_blocks
from netsushisen.host.ic_access import machine_order, ordered_stream_chunks

GLOBAL_WORDS, RESIDENT_WORDS = 4096, 512


def regions() -> dict[str, list[Region]]:
    """A list area, then records whose first word names a primitive (as the host's maps)."""
    out = {"global": [Region(0, 1000, "primitive_list")], "resident": []}
    a, p = 1000, 0
    while a + 7 < GLOBAL_WORDS:
        out["global"] += [Region(a, a + 1, "shape_data", p), Region(a + 1, a + 7, "shape_data")]
        a, p = a + 7 + p % 3, p + 1
    a = 0
    while a + 5 < RESIDENT_WORDS:
        out["resident"] += [Region(a, a + 1, "shape_data", p), Region(a + 1, a + 5, "shape_data")]
        a, p = a + 5, p + 1
    return out


def emulator_counts(space, address, cache_bytes, block_bytes, precision, ways=1) -> dict:
    config = load_config(None, [f"ic_memory.cache_bytes={cache_bytes}", f"ic_memory.cache_ways={ways}",
                                f"ic_memory.block_bytes={block_bytes}", f"precision={precision}",
                                f"ic_memory.resident_bytes={RESIDENT_WORDS * (4 if precision == 'fp32' else 8)}"])
    dt = np.uint32 if precision == "fp32" else np.uint64
    regs = regions()
    mem = MemorySystem("ic", 0, config, np.zeros(16, dt), np.zeros(RESIDENT_WORDS, dt),
                       Memory("ICGM", np.zeros(GLOBAL_WORDS, dt)),
                       {"resident": RegionMap(regs["resident"]), "global": RegionMap(regs["global"])})
    for s, a in zip(space.tolist(), address.tolist()):
        mem.load("resident" if s == RESIDENT else "global", a)
    out = mem.stats()
    del out["local"]
    return out


def model_counts(space, address, cache_bytes, block_bytes, precision, chunk=None, ways=1) -> dict:
    wb = 4 if precision == "fp32" else 8
    m = TraceMemory(cache_bytes, block_bytes, wb, RESIDENT_WORDS, regions(), GLOBAL_WORDS, ways)
    step = chunk or max(len(address), 1)
    for i in range(0, len(address), step):
        m.replay(space[i:i + step], address[i:i + step])
    return m.stats()


def structured_stream(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell pairs then record words, like the IC protocol: loops over lists and records."""
    sp, ad = [], []
    while len(ad) < n:
        cell = int(rng.integers(1, 998)) & ~1
        for k in range(int(rng.integers(1, 6))):
            sp += [GLOBAL, GLOBAL]
            ad += [cell + 2 * k, cell + 2 * k + 1]
            if rng.random() < 0.3:
                base = int(rng.integers(0, RESIDENT_WORDS - 5))
                sp += [RESIDENT] * 4
                ad += [base, base + 1, base + 2, base + 4]
            else:
                base = int(rng.integers(1000, GLOBAL_WORDS - 12))
                words = [0, 3, 4, 5, 6, 7, 8, 9, 10][:int(rng.integers(2, 10))]
                sp += [GLOBAL] * len(words)
                ad += [base + w for w in words]
    return np.array(sp[:n], np.int8), np.array(ad[:n], np.int64)


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
@pytest.mark.parametrize("cache_bytes,block_bytes,ways", [
    (0, 64, 1), (64, 64, 1), (1024, 64, 1), (4096, 32, 1), (2048, 16, 1), (8192, 128, 1), (512, 8, 1),
    (1024, 64, 2), (4096, 32, 4), (2048, 16, 8), (128, 64, 2)])
@pytest.mark.parametrize("kind", ["random", "structured"])
def test_model_counters_equal_the_emulators(precision, cache_bytes, block_bytes, ways, kind):
    rng = np.random.default_rng(hash((precision, cache_bytes, block_bytes, ways, kind)) % 2**32)
    if kind == "random":
        n = 3000
        space = rng.choice([GLOBAL, RESIDENT], size=n, p=[0.8, 0.2]).astype(np.int8)
        address = np.where(space == RESIDENT, rng.integers(0, RESIDENT_WORDS, n),
                           rng.integers(0, GLOBAL_WORDS, n))
    else:
        space, address = structured_stream(rng, 3000)
    want = emulator_counts(space, address, cache_bytes, block_bytes, precision, ways)
    assert model_counts(space, address, cache_bytes, block_bytes, precision, ways=ways) == want
    assert model_counts(space, address, cache_bytes, block_bytes, precision, 97, ways) == want
    assert want["cache"]["ways"] == ways
    assert want["cache"]["accesses"] > 0 and (cache_bytes == 0 or want["cache"]["hits"] > 0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 300), max_size=200), st.sampled_from([0, 1, 2, 4, 8]),
       st.sampled_from([4, 8]), st.sampled_from([8, 16, 64]), st.sampled_from([1, 2, 4, 8]))
def test_replay_blocks_equals_the_emulators_cache(words, sets, wb, block, ways):
    c = Cache("t", sets * block * ways, block, wb, ways)
    want = [c.access(a)[0] for a in words]
    tags = np.full(sets * ways, -1, np.int64)
    half = len(words) // 2
    blocks = (np.array(words, np.int64) * wb) // block
    got = np.concatenate([replay_blocks(blocks[:half], tags, ways),
                          replay_blocks(blocks[half:], tags, ways)])
    assert got.tolist() == want
    assert tags.tolist() == c.tags.tolist()


def test_a_wrong_model_would_be_caught():
    """The comparison can fail: a cache one set smaller gives different counters."""
    rng = np.random.default_rng(5)
    space, address = structured_stream(rng, 2000)
    assert model_counts(space, address, 1024, 64, "fp32") != emulator_counts(space, address, 2048, 64, "fp32")


def test_access_outside_memory_is_named():
    m = TraceMemory(1024, 64, 4, 8, global_words=100)
    with pytest.raises(ValueError, match="global memory address 100 is outside 0..99"):
        m.replay(np.array([GLOBAL]), np.array([100]))


# ------------------------------------------------------------------------------------------------
# Machine order and the sweep on a real golden trace


@pytest.fixture(scope="module")
def small_render():
    scene = load_scene("mount:2")  # reflective and transparent: trees that branch
    config = load_config()
    grid = build_grid(scene, config)
    golden = render(scene, config, res=12, keep_trace=True, grid=grid)
    return scene, config, grid, golden


def test_machine_order_is_level_order_per_pixel(small_render):
    _, _, _, g = small_render
    order = machine_order(g)
    assert sorted(order.tolist()) == list(range(len(g.trace_kind)))
    pix, kind, depth = g.trace_pixel[order], g.trace_kind[order], g.trace_depth[order].astype(int)
    gen = np.where(kind == SHADOW, depth, depth - 1)
    assert np.all(np.diff(pix) >= 0)
    same = pix[1:] == pix[:-1]
    assert np.all(np.diff(gen)[same] >= 0)  # generations never go back within a pixel
    assert (kind[np.r_[True, ~same]] == 0).all()  # each tree starts with its eye ray
    assert np.any(g.trace_depth > 2) and not np.array_equal(order, np.arange(len(order)))
    # a pixel whose eye ray spawned a reflection and a refraction ray that both spawn rays:
    # level order visits both children before any grandchild; depth-first order does not
    for p in np.unique(pix):
        rays = order[pix == p]
        d, k = g.trace_depth[rays], g.trace_kind[rays]
        if np.count_nonzero((d == 2) & (k != SHADOW)) == 2 and np.count_nonzero(d == 3) >= 1:
            break
    else:
        pytest.fail("no branching ray tree in the test scene")
    first_grandchild = np.flatnonzero((d == 3) & (k != SHADOW) | (d == 2) & (k == SHADOW))[0]
    assert np.flatnonzero((d == 2) & (k != SHADOW))[-1] < first_grandchild
    assert k[0] == 0 and k[1] == SHADOW and list(k[np.flatnonzero((d == 2) & (k != SHADOW))]) == [1, 2]
    dfs = np.sort(rays)
    assert not np.array_equal(dfs, rays)


def test_machine_order_keeps_every_rays_loads(small_render):
    scene, config, grid, g = small_render
    lay = plan_layout(scene, config, grid=grid)
    dfs = np.concatenate([a for _, a in ordered_stream_chunks(lay, g)])
    mo = np.concatenate([a for _, a in ordered_stream_chunks(lay, g, machine_order(g), rays_per_chunk=50)])
    assert len(dfs) == len(mo) and np.array_equal(np.sort(dfs), np.sort(mo))
    assert not np.array_equal(dfs, mo)


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_sweep_equals_the_full_model(small_render, precision):
    scene, config, grid, g = small_render
    config = load_config(None, [f"precision={precision}"])
    prio = priorities_from_counts(g.references)
    ref = plan_layout(scene, load_config(None, ["ic_memory.resident_bytes=0", f"precision={precision}"]),
                      prio, grid)
    settings_ = [("0.0", "0.05", 1), ("0.02", "0.1", 1), ("0.2", "0.1", 1), ("0.5", "0.0", 1),
                 ("0.1", "0.3", 1), ("0.0", "0.1", 2), ("0.02", "0.3", 4)]
    points, images = [], []
    for res_share, cache_share, ways in settings_:
        cfg = load_config(None, [f"precision={precision}", f"ic_memory.resident_share={res_share}",
                                 f"ic_memory.cache_share={cache_share}", f"ic_memory.cache_ways={ways}"])
        im = build_images(scene, cfg, priorities=prio, grid=grid)
        images.append(im)
        points.append(SweepPoint(im.layout, im.config.ic_memory.cache_bytes, 64, ways))
    sweep = SweepStream(ref, points, config.word_bytes)
    order = machine_order(g)
    for s, a in ordered_stream_chunks(ref, g, order, rays_per_chunk=64):
        sweep.replay(s, a)
    for im, pt in zip(images, points):
        full = TraceMemory.for_images(im)
        for s, a in ordered_stream_chunks(im.layout, g, order, rays_per_chunk=64):
            full.replay(s, a)
        want = full.stats()["regions"]
        got = pt.counts
        for space in ("resident", "global"):
            for r in ("primitive_list", "shape_data"):
                assert got[f"{space}.{r}"] == want.get(f"{space}.{r}", {}).get("accesses", 0)
        for r in ("primitive_list", "shape_data"):
            assert got[f"hits.{r}"] == want.get(f"global.{r}", {}).get("hits", 0)
    assert points[2].counts["resident.shape_data"] > 0 and points[0].counts["hits.shape_data"] > 0


def _reference_oracle(layout, stream, cache_bytes, block_bytes, word_bytes, lists_cached=True):
    """Per primitive reference, load by load in plain Python: a reference is the record loads
    after a list cell pair, while they stay in one record; it hits when none of its cache
    loads misses. Lists not cached: their loads never touch the cache."""
    sets = cache_bytes // block_bytes
    tags = [-1] * sets
    owner = {}
    for prim, (sp, ad, size) in enumerate(zip(layout.record_space.tolist(), layout.record_address.tolist(),
                                              layout.record_size.tolist())):
        for w in range(size):
            owner[(sp, ad + w)] = prim
    out = {"resident": 0, "cache": 0, "hits": 0}
    current, missed, space_of, after_cell = None, False, None, False

    def close():
        if current is not None:
            if space_of == RESIDENT:
                out["resident"] += 1
            else:
                out["cache"] += 1
                out["hits"] += not missed
    for s, a in stream:
        is_cell = s == GLOBAL and a < layout.list_words
        prim = None if is_cell else owner[(s, a)]
        if prim != current or is_cell:
            close()
            current = prim if (prim is not None and after_cell) else None
            missed, space_of = False, s
        after_cell = is_cell
        if s == GLOBAL and (lists_cached or not is_cell) and sets:
            block = a * word_bytes // block_bytes
            hit = tags[block % sets] == block // sets
            tags[block % sets] = block // sets
            missed |= not hit
        elif s == GLOBAL and (lists_cached or not is_cell):
            missed = True
    close()
    return out


@pytest.mark.parametrize("lists_cached", [True, False])
def test_sweep_counts_per_reference_like_a_plain_replay(small_render, lists_cached):
    scene, config, grid, g = small_render
    prio = priorities_from_counts(g.references)
    ref = plan_layout(scene, load_config(None, ["ic_memory.resident_bytes=0"]), prio, grid)
    points, layouts = [], []
    for res_share, cache_share in [("0.0", "0.05"), ("0.1", "0.1"), ("0.3", "0.0")]:
        lay = plan_layout(scene, load_config(None, [f"ic_memory.resident_share={res_share}",
                                                   f"ic_memory.cache_share={cache_share}"]), prio, grid)
        layouts.append(lay)
        points.append(SweepPoint(lay, lay.cache_bytes, 64))
    sweep = SweepStream(ref, points, config.word_bytes, lists_cached=lists_cached)
    order = machine_order(g)
    for s, a in ordered_stream_chunks(ref, g, order, rays_per_chunk=64):
        sweep.replay(s, a)
    for lay, pt in zip(layouts, points):
        stream = [(s, a) for sp, ad in ordered_stream_chunks(lay, g, order)
                  for s, a in zip(sp.tolist(), ad.tolist())]
        want = _reference_oracle(lay, stream, lay.cache_bytes, 64, config.word_bytes, lists_cached)
        c = pt.counts
        assert (c["ref.resident"], c["ref.cache"], c["ref.hits"]) == (want["resident"], want["cache"], want["hits"])
        # one reference per intersection test
        assert c["ref.resident"] + c["ref.cache"] == int(g.references.sum())
        assert (c["local.primitive_list"] > 0) != lists_cached
        f = SweepStream.figures(pt)
        assert f["ref"]["loads"] == int(g.references.sum())
    assert points[0].counts["ref.hits"] < points[0].counts["ref.cache"]  # some reference misses
    assert points[1].counts["ref.resident"] > 0 and points[2].counts["ref.hits"] == 0


# ------------------------------------------------------------------------------------------------
# One address-to-region rule, one cache rule


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 400), st.integers(1, 9)), max_size=30),
       st.lists(st.integers(-5, 500), min_size=1, max_size=200))
def test_region_indices_are_lookup_for_many_addresses(spans, addresses):
    """RegionMap.indices (the trace-driven model, per chunk) is RegionMap.lookup (the
    reference engine, per load) for every address."""
    regs, end = [], 0
    for k, (gap, size) in enumerate(spans):
        regs.append(Region(end + gap, end + gap + size, f"r{k % 3}", k if k % 2 else None))
        end += gap + size
    rmap = RegionMap(regs)
    got = rmap.indices(np.array(addresses))
    want = [rmap.regions.index(r) if (r := rmap.lookup(a)) is not None else -1 for a in addresses]
    assert got.tolist() == want


def test_the_models_import_nothing_above_the_machine():
    """emulator/tracesim.py and emulator/cacherule.py read the host's layouts without importing
    host/ (or reports/): the machine's side imports only isa/ and itself."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "emulator"
    for name in ("tracesim.py", "cacherule.py", "memories.py"):
        tree = ast.parse((root / name).read_text())
        mods = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module]
        mods += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
        ours = [m for m in mods if m.startswith("netsushisen")]
        assert all(m.startswith(("netsushisen.emulator", "netsushisen.isa")) for m in ours), \
            (name, ours)
