"""Database layout (docs/databases.md): the images decoded back with the documented offsets and
compared field by field with the grid, the shape data and the luminance data; lists; resident
placement; sizes; region maps in the emulator; the IC access stream; impossible configs."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.disasm import disassemble
from netsushisen.emulator.machine import Machine
from netsushisen.emulator.memories import RegionMap
from netsushisen.isa.errors import ConfigError
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import RESIDENT, build_images, database_bytes, resident_fill
from netsushisen.host.golden import Luminance, offset_scale, render, scene_epsilon
from netsushisen.host.ic_access import golden_stream, golden_stream_chunks, ic_address_stream
from netsushisen.host.nff import parse_nff
from netsushisen.host.records import CELL_WORDS
from netsushisen.host.scenes import Kind
from netsushisen.host.traversal import OSGrid
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.images import load_image

# every kind, a 4-vertex patch, a transparent (two-sided) material, two materials equal after
# Kd*colour (one luminance record), a concave polygon, 2 lights
MIXED = """b 0.1 0.2 0.3
v
from 0 0 -12
at 0 0 0
up 0 1 0
angle 45
hither 0.5
resolution 8 8
l 4 4 -8
l -4 5 -6 0.5 0.5 0.5
f 1 1 1 0.5 0.3 20 0 0
s -2 -2 0 1
s 2 -2 0 0.7
f 0.5 0.5 0.5 1 0.3 20 0 0
c 0 -1 3 1 0 2 3 1
c 3 1 1 0.8 3 3 1 0.2
f 0.9 0.9 0.9 0.1 0.2 10 0.8 1.5
s 0 2 -1 0.8
pp 4
-4 -4 4 0 0 -1
4 -4 4 0 0.1 -1
4 4 4 0 0 -1
-4 4 4 0.1 0 -1
p 5
-3 -3 -2
-1 -3 -2
-2 -2 -2
-1 -1 -2
-3 -1 -2
"""


def mixed():
    return parse_nff(MIXED, "mixed.nff")


def config(precision="fp32", **ic):
    cfg = MachineConfig(precision=precision)
    cfg.grid.subdivide_threshold = 2  # make sub-grids even in small scenes
    for k, v in ic.items():
        setattr(cfg.ic_memory, k, v)
    return cfg


def shuffled(n, seed=7):
    return np.random.default_rng(seed).permutation(n) + 1


class Words:
    """A memory image read back the documented way (ints: 32-bit signed; floats: precision)."""

    def __init__(self, words: np.ndarray, base: int = 0):
        self.w, self.base = words, base
        self.fp = np.float32 if words.dtype == np.uint32 else np.float64
        self.it = np.int32 if words.dtype == np.uint32 else np.int64

    def i(self, a, n=1):
        v = self.w[a - self.base:a - self.base + n].view(self.it).astype(np.int64)
        return int(v[0]) if n == 1 else v

    def f(self, a, n=1):
        return self.w[a - self.base:a - self.base + n].view(self.fp)


def walk(icgm: Words, head: int) -> list[tuple[int, int]]:
    """A leaf's cells as (priority, shape pointer): consecutive 2-word cells, the last one's
    priority negated."""
    cells = []
    while True:
        p, shape = icgm.i(head), icgm.i(head + 1)
        cells.append((abs(p), shape))
        if p < 0:
            return cells
        head += 2


SCENES = ["mixed", "balls:2", "rings:2", "mount:2"]


def scene_of(name):
    return mixed() if name == "mixed" else load_scene(name)


@pytest.mark.parametrize("name, precision", [(n, p) for n in SCENES for p in ("fp32", "fp64")]
                         + [("tetra", "fp32"), ("rings", "fp64")])
def test_images_decode_to_grid_shapes_and_luminance(name, precision):
    sc = scene_of(name)
    cfg = config(precision, resident_share=0.2)
    img = build_images(sc, cfg, priorities=shuffled(sc.n_primitives))
    lay = img.layout
    g, sd = lay.grid, lay.shapes
    dt = sd.dtype
    osg = OSGrid.of(g, dt)
    os_ = Words(img.os_local, lay.os_base)
    icgm, res = Words(img.icgm), Words(img.ic_resident)
    b = lay.os_base
    # top header
    assert np.array_equal(os_.f(b, 3), osg.lo) and np.array_equal(os_.f(b + 3, 3), osg.cell)
    assert np.array_equal(os_.f(b + 6, 3), osg.inv_cell) and np.array_equal(os_.i(b + 9, 3), g.res)
    assert np.array_equal(os_.f(b + 12, 3), osg.lo + g.res.astype(dt) * osg.cell)
    assert os_.i(b + 15) == g.res[0] * g.res[1]
    assert len(g.sub_res) > 0
    m = lay.resident_count
    seen_leaves = []

    def check_leaf(word, leaf):
        if leaf < 0:
            assert word == 0
            return
        seen_leaves.append(leaf)
        cells = walk(icgm, word)
        prims = g.leaf_prims[g.leaf_offsets[leaf]:g.leaf_offsets[leaf + 1]]
        assert [c[0] for c in cells] == lay.priorities[prims].tolist()
        assert [c[1] for c in cells] == lay.record_address[prims].tolist()

    ntop = int(np.prod(g.res))
    for v in range(ntop):
        word = os_.i(b + 16 + v)
        s = g.top_sub[v]
        if s < 0:
            check_leaf(word, g.top_leaf[v])
            continue
        h = -word
        assert word < 0 and np.array_equal(os_.i(h + 9, 3), g.sub_res[s])
        for k, arr in enumerate((osg.sub_lo, osg.sub_cell, osg.sub_inv_cell)):
            assert np.array_equal(os_.f(h + 3 * k, 3), arr[s])
        for j in range(int(g.sub_res[s].prod())):
            check_leaf(os_.i(h + 12 + j), g.sub_leaf[g.sub_offset[s] + j])
    assert sorted(seen_leaves) == list(range(g.n_leaves))
    # shape records: resident iff P <= M, resident ones packed in priority order from 0, the
    # others in id order right after the lists
    resident = lay.priorities <= m
    assert np.array_equal(lay.record_space == RESIDENT, resident)
    by_priority = np.argsort(lay.priorities)[:m]
    packed = lay.record_size[by_priority]
    assert np.array_equal(lay.record_address[by_priority], np.cumsum(packed) - packed)
    glob = np.flatnonzero(~resident)
    assert np.all(np.diff(lay.record_address[glob]) > 0)
    assert lay.record_address[glob].min(initial=len(img.icgm)) == 1 + CELL_WORDS * len(g.leaf_prims)
    lum = Luminance.of(sc, dt)
    scgm = Words(img.scgm)
    for p in range(sc.n_primitives):
        mem = res if resident[p] else icgm
        a = int(lay.record_address[p])
        kind_word, loc = mem.i(a), sd.local[p]
        assert mem.i(a + 2) == p
        kind = kind_word & 3
        assert kind == sd.kind[p] and bool(kind_word & 4) == bool(sd.two_sided[p])
        if kind == Kind.POLYGON:
            n = int(sd.poly_count[loc])
            assert kind_word >> 8 == n and bool(kind_word & 8) == bool(sd.poly_is_patch[loc])
            assert np.array_equal(mem.f(a + 3, 3), sd.poly_normal[loc])
            v0 = sd.poly_start[loc]
            assert np.array_equal(mem.f(a + 6, 3 * n), sd.poly_vertices[v0:v0 + n].ravel())
            if sd.poly_is_patch[loc]:
                assert np.array_equal(mem.f(a + 6 + 3 * n, 3 * n), sd.poly_vertex_normals[v0:v0 + n].ravel())
        elif kind == Kind.SPHERE:
            assert np.array_equal(mem.f(a + 3, 4), np.r_[sd.sph_center[loc], sd.sph_r2[loc]])
            assert mem.f(a + 7)[0] == sd.sph_radius[loc]
        else:
            axis = np.r_[sd.cone_base[loc], sd.cone_axis[loc], sd.cone_length[loc]]
            assert np.array_equal(mem.f(a + 3, 7), axis)
            tail = [sd.cone_r2[loc], sd.cone_r0[loc]] if kind == Kind.CYLINDER else \
                [sd.cone_r0[loc], sd.cone_slope[loc], sd.cone_r2[loc]]
            assert np.array_equal(mem.f(a + 10, len(tail)), np.array(tail, dt))
        # luminance pointer -> the material record of the primitive's material
        lp, mt = mem.i(a + 1), sc.material[p]
        expect = np.r_[lum.kdc[mt], lum.ks[mt], lum.shine[mt], lum.t[mt], lum.ior[mt], lum.inv_ior[mt]]
        assert lp % 8 == 0 and np.array_equal(scgm.f(lp, 8), expect)
    # scene block
    sb = Words(img.sc_local, lay.sc_base)
    c = lay.sc_base
    nl = len(lum.light_pos)
    assert (sb.i(c), sb.i(c + 1), sb.i(c + 2)) == (nl, len(img.scgm) // 8, cfg.render.max_depth)
    assert sb.f(c + 3)[0] == scene_epsilon(g, cfg, dt) and np.array_equal(sb.f(c + 5, 3), lum.background)
    assert sb.f(c + 8)[0] == offset_scale(dt)
    lights = sb.f(c + 9, 6 * nl).reshape(nl, 6)
    assert np.array_equal(lights[:, :3], lum.light_pos) and np.array_equal(lights[:, 3:], lum.light_int)


def test_materials_deduplicated_by_their_words():
    sc = mixed()
    img = build_images(sc, config())
    assert len(sc.materials) == 3 and len(img.scgm) == 2 * 8  # Kd*colour equal: one record
    ptr = img.layout.luminance_pointer
    assert ptr[0] == ptr[2] and ptr[4] != ptr[0]


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_resident_records_are_the_global_records_word_for_word(precision):
    sc = load_scene("rings:2")
    pri = shuffled(sc.n_primitives, 3)
    split = build_images(sc, config(precision, resident_bytes=4000), priorities=pri)
    flat = build_images(sc, config(precision, resident_bytes=0), priorities=pri)
    lay, ref = split.layout, flat.layout
    assert ref.resident_count == 0 and 0 < lay.resident_count < sc.n_primitives
    assert len(split.ic_resident) * split.config.word_bytes <= 4000
    for p in np.flatnonzero(lay.priorities <= lay.resident_count):
        a, b, s = lay.record_address[p], ref.record_address[p], lay.record_size[p]
        assert np.array_equal(split.ic_resident[a:a + s], flat.icgm[b:b + s])
    # resident data have no copy in global memory
    assert len(split.icgm) + len(split.ic_resident) == len(flat.icgm)
    # the next record in priority order would not have fit
    order = np.argsort(pri)
    assert lay.record_size[order[:lay.resident_count + 1]].sum() * split.config.word_bytes > 4000


@pytest.mark.parametrize("sizes, capacity, m", [
    ([3, 5, 2], 8, 2),    # 3 + 5 fill the capacity exactly: both are resident
    ([3, 5, 2], 7, 1),    # 5 more would not fit after 3
    ([3, 5, 2], 10, 3),   # all of them, exactly
    ([3, 5, 2], 11, 3),
    ([3, 5, 2], 2, 0),    # not even the first
    ([3, 5, 2], 3, 1),    # the first, exactly
    ([3, 5, 2], 0, 0),
    ([4], 4, 1),
    ([], 5, 0),
    ([3, 5, 1], 8, 2),    # stops at the first that does not fit (in priority order)
])
def test_resident_fill_counts_a_record_that_fits_exactly(sizes, capacity, m):
    assert resident_fill(np.array(sizes, dtype=np.int64), capacity) == m


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_resident_capacity_exactly_filled_by_the_first_records(precision):
    # a resident memory exactly as large as the 3 highest-priority records holds all 3
    sc = load_scene("rings:2")
    pri = shuffled(sc.n_primitives, 3)
    flat = build_images(sc, config(precision, resident_bytes=0), priorities=pri).layout
    first3 = np.argsort(pri)[:3]
    words = int(flat.record_size[first3].sum())
    wb = MachineConfig(precision=precision).word_bytes
    img = build_images(sc, config(precision, resident_bytes=words * wb), priorities=pri)
    lay = img.layout
    assert lay.resident_count == 3
    assert sorted(np.flatnonzero(lay.record_space == RESIDENT)) == sorted(first3)
    assert len(img.ic_resident) == words == lay.resident_words
    # one word less: the third no longer fits
    short = build_images(sc, config(precision, resident_bytes=words * wb - wb), priorities=pri)
    assert short.layout.resident_count == 2


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_database_bytes_sum_to_the_images(precision):
    sc = load_scene("mount:2")
    cfg = config(precision, resident_share=0.3)
    img = build_images(sc, cfg, priorities=shuffled(sc.n_primitives))
    sizes = database_bytes(sc, cfg)
    wb = cfg.word_bytes
    assert sizes["voxel_data"] == len(img.os_local) * wb
    assert sizes["primitive_list"] + sizes["shape_data"] == (len(img.icgm) + len(img.ic_resident)) * wb
    assert sizes["luminance_data"] == (len(img.scgm) + len(img.sc_local)) * wb
    # the share resolves against primitive_list + shape_data; the resolved config carries it
    primdb_words = (sizes["primitive_list"] + sizes["shape_data"]) // wb
    assert img.config.ic_memory.resident_bytes == int(0.3 * primdb_words) * wb
    assert img.config.ic_memory.resident_share is None and img.config.ic_memory.cache_share is None


def test_images_load_into_the_emulator_with_region_counters(tmp_path):
    sc = mixed()
    img = build_images(sc, config(resident_share=0.3), priorities=shuffled(sc.n_primitives))
    lay = img.layout
    for image in (img.memory_image(), _npz(img, tmp_path)):
        machine = Machine(img.config, {}, image)
        mem = machine.pes[0].memories["ic"]
        assert np.array_equal(mem.resident.words[:len(img.ic_resident)], img.ic_resident)
        assert np.array_equal(machine.globals["ic"].words, img.icgm)
        os_local = machine.pes[0].memories["os"].local.words
        assert np.array_equal(os_local[lay.os_base:lay.os_base + len(img.os_local)], img.os_local)
        sc_local = machine.pes[0].memories["sc"].local.words
        assert np.array_equal(sc_local[lay.sc_base:lay.sc_base + len(img.sc_local)], img.sc_local)
        for p in range(sc.n_primitives):  # read every kind word once, and one more word
            space = "resident" if lay.record_space[p] == RESIDENT else "global"
            mem.load(space, int(lay.record_address[p]))
            mem.load(space, int(lay.record_address[p]) + 1)
        stats = mem.stats()
        assert stats["primitives"] == {str(p): 1 for p in range(sc.n_primitives)}
        m = lay.resident_count
        assert stats["regions"]["resident.shape_data"]["accesses"] == 2 * m
        assert stats["regions"]["global.shape_data"]["accesses"] == 2 * (sc.n_primitives - m)


def _npz(img, tmp_path):
    path = tmp_path / "images.npz"
    img.save_npz(path)
    return load_image(path)


def test_ic_stream_follows_the_protocol_and_counts_golden_references():
    sc = load_scene("balls:2")
    cfg = config(resident_share=0.25)
    golden = render(sc, cfg, res=24, keep_trace=True)
    img = build_images(sc, cfg, priorities=shuffled(sc.n_primitives), grid=golden.grid)
    lay = img.layout
    space, addr = golden_stream(lay, golden, hits=False)
    icgm = Words(img.icgm)
    # per reference: CELL_WORDS ldg of the cell, then the kind word in the space P <= M says
    maps = {s: RegionMap(r) for s, r in (("g", img.regions["ic.global"]), ("r", img.regions["ic.resident"]))}
    counts = np.zeros(sc.n_primitives, np.int64)
    k, refs = 0, 0
    while k < len(addr):
        assert space[k:k + 2].tolist() == [0, 0] and addr[k + 1] == addr[k] + 1
        prio, ptr = abs(icgm.i(int(addr[k]))), icgm.i(int(addr[k]) + 1)
        assert space[k + 2] == (1 if prio <= lay.resident_count else 0) and addr[k + 2] == ptr
        region = maps["r" if space[k + 2] else "g"].lookup(int(addr[k + 2]))
        counts[region.primitive] += 1
        prim = region.primitive
        sphere = lay.shapes.kind[prim] == Kind.SPHERE
        n_test = 5 if sphere else 4 + 3 * int(lay.shapes.poly_count[lay.shapes.local[prim]])
        assert np.all(space[k + 2:k + 2 + n_test] == space[k + 2])
        k += CELL_WORDS + n_test
        refs += 1
    assert refs == len(golden.trace_prims) and np.array_equal(counts, golden.references)
    # with hits: each winner's luminance pointer (word 1, read only then) follows its ray's tests
    space_h, addr_h = golden_stream(lay, golden)
    key = space_h.astype(np.int64) << 40 | addr_h
    lum_key = lay.record_space.astype(np.int64) << 40 | (lay.record_address + 1)
    order = np.argsort(lum_key)
    pos = np.clip(np.searchsorted(lum_key[order], key), 0, len(order) - 1)
    is_lum = lum_key[order][pos] == key
    hits = golden.trace_hit[golden.trace_hit >= 0]
    assert np.array_equal(np.bincount(order[pos[is_lum]], minlength=sc.n_primitives),
                          np.bincount(hits, minlength=sc.n_primitives))
    assert len(hits) >= golden.rays["eye_hits"] > 0
    extra = len(addr_h) - len(addr)  # sphere hits: luminance, id, centre; the floor: normal
    assert extra == 5 * len(hits)


def test_ic_stream_rejects_a_primitive_outside_its_leaf():
    sc = load_scene("balls:1")
    lay = build_images(sc, config()).layout
    leaf = 0
    outside = np.setdiff1d(np.arange(sc.n_primitives), lay.grid.leaf_prims[:lay.grid.leaf_offsets[1]])[0]
    with pytest.raises(ValueError, match="not in the list of leaf 0"):
        ic_address_stream(lay, np.array([outside]), np.array([leaf]))


def test_symbols_select_kernel_code():
    img = build_images(mixed(), config())
    sym = img.symbols
    assert {k: sym[k] for k in ("HAS_POLYGONS", "HAS_SPHERES", "HAS_CYLINDERS", "HAS_CONES", "HAS_PATCHES",
                                "HAS_REFLECTION", "HAS_REFRACTION", "NLIGHTS", "NMATERIALS")} == \
        dict(HAS_POLYGONS=1, HAS_SPHERES=1, HAS_CYLINDERS=1, HAS_CONES=1, HAS_PATCHES=1, HAS_REFLECTION=1,
             HAS_REFRACTION=1, NLIGHTS=2, NMATERIALS=2)
    # the offsets docs/databases.md documents
    assert {k: sym[k] for k in ("REC_PRIMITIVE", "POLY_NORMAL", "POLY_VERTICES", "SPH_R2", "CYL_R2",
                                "CONE_SLOPE", "SPHERE_WORDS", "CYLINDER_WORDS", "CONE_WORDS", "VD_HI",
                                "SG_RES", "CELL_SHAPE", "CELL_WORDS", "MAT_INV_IOR", "SCN_LIGHTS", "LIGHT_INT")} == \
        dict(REC_PRIMITIVE=2, POLY_NORMAL=3, POLY_VERTICES=6, SPH_R2=6, CYL_R2=10, CONE_SLOPE=11,
             SPHERE_WORDS=8, CYLINDER_WORDS=12, CONE_WORDS=13, VD_HI=12, SG_RES=9, CELL_SHAPE=1, CELL_WORDS=2,
             MAT_INV_IOR=7, SCN_LIGHTS=9, LIGHT_INT=3)
    assert (sym["VOXEL_BASE"], sym["TOP_VOXELS"], sym["SCENE_BASE"], sym["LIGHTS_BASE"]) == (256, 272, 256, 265)
    tetra = build_images(load_scene("tetra:2"), config()).symbols
    assert (tetra["HAS_SPHERES"], tetra["HAS_REFLECTION"], tetra["HAS_PATCHES"]) == (0, 0, 0)
    # the symbols select and fill kernel code: mixed has spheres, tetra has none
    text = ".proc ic\n.if HAS_SPHERES\n ldr r1, [r2 + SPH_R2]\n.endif\n ldg r3, [r4 + CELL_SHAPE]\n halt\n"
    assert disassemble(assemble_text(text, defines=sym)).splitlines()[1:] == \
        ["    ldr r1, [r2 + 6]", "    ldg r3, [r4 + 1]", "    halt"]
    assert disassemble(assemble_text(text, defines=tetra)).splitlines()[1:] == \
        ["    ldg r3, [r4 + 1]", "    halt"]
    assert img.defines()[:2] == ["-D", f"{next(iter(sym))}={next(iter(sym.values()))}"]


def test_impossible_configs_raise_config_error():
    sc = load_scene("balls:2")
    cfg = MachineConfig()
    cfg.grid.top_resolution = 64  # 262,144 top voxels
    with pytest.raises(ConfigError, match="voxel data .* do not fit os.local_words = 65536"):
        database_bytes(sc, cfg)
    small = MachineConfig()
    small.os.local_words = 200  # below the default voxel base
    with pytest.raises(ConfigError, match="do not fit os.local_words = 200"):
        build_images(sc, small)
    share = MachineConfig()
    share.ic_memory.resident_share = 1.5
    with pytest.raises(ConfigError, match="resident_share = 1.5: a share of the primitive database "
                                          "must lie in 0..1"):
        build_images(sc, share)
    with pytest.raises(ValueError, match="permutation of 1..9"):
        build_images(sc, MachineConfig(), priorities=np.ones(9))


# docs/databases.md, IC access protocol: words per test and per hit, by kind (n = vertices)
TEST_WORDS = {Kind.POLYGON: lambda n: 4 + 3 * n, Kind.SPHERE: lambda n: 5, Kind.CYLINDER: lambda n: 9,
              Kind.CONE: lambda n: 10}
HIT_WORDS = {Kind.POLYGON: lambda n, patch: 5 + 9 * patch, Kind.SPHERE: lambda n, patch: 5,
             Kind.CYLINDER: lambda n, patch: 8, Kind.CONE: lambda n, patch: 9}


def test_ic_stream_word_counts_per_kind():
    sc = mixed()
    cfg = config(resident_share=0.3)
    golden = render(sc, cfg, res=16, keep_trace=True)
    lay = build_images(sc, cfg, priorities=shuffled(sc.n_primitives), grid=golden.grid).layout
    sd = lay.shapes
    n = np.where(sd.kind == Kind.POLYGON, sd.poly_count[np.minimum(sd.local, len(sd.poly_count) - 1)], 0)
    patch = np.zeros(sc.n_primitives, int)
    polys = sd.kind == Kind.POLYGON
    patch[polys] = sd.poly_is_patch[sd.local[polys]]
    per_test = np.array([CELL_WORDS + TEST_WORDS[Kind(k)](n[p]) for p, k in enumerate(sd.kind)])
    per_hit = np.array([HIT_WORDS[Kind(k)](n[p], patch[p]) for p, k in enumerate(sd.kind)])
    space, addr = golden_stream(lay, golden, hits=False)
    assert len(addr) == per_test[golden.trace_prims].sum()
    # the ldr words are exactly the test words of the resident references
    resident = lay.priorities[golden.trace_prims] <= lay.resident_count
    assert (space == RESIDENT).sum() == (per_test[golden.trace_prims] - CELL_WORDS)[resident].sum() > 0
    hits = golden.trace_hit[golden.trace_hit >= 0]
    assert set(sd.kind[hits].tolist()) == {0, 1, 2, 3}
    assert len(golden_stream(lay, golden)[1]) == len(addr) + per_hit[hits].sum()


def test_golden_trace_leaves_group_references_into_list_prefixes():
    sc = load_scene("rings:2")
    golden = render(sc, config(), res=12, keep_trace=True)
    g = golden.grid
    off, prims, leaves = golden.trace_ray_offsets, golden.trace_prims, golden.trace_leaves
    assert len(leaves) == len(prims)
    for r in range(len(golden.trace_kind)):
        p, lf = prims[off[r]:off[r + 1]], leaves[off[r]:off[r + 1]]
        cut = np.flatnonzero(np.diff(lf)) + 1
        for k, (gp, gl) in enumerate(zip(np.split(p, cut), np.split(lf, cut))):
            full = g.leaf_prims[g.leaf_offsets[gl[0]]:g.leaf_offsets[gl[0] + 1]]
            last_shadow = golden.trace_kind[r] == 3 and k == len(cut)
            assert gp.tolist() == (full[:len(gp)] if last_shadow else full).tolist()


def test_kernel_data_must_stay_below_the_image_bases():
    img = build_images(load_scene("balls:1"), config(), os_base=4, sc_base=300)
    small = assemble_text(".proc os\n.data\nx: .word 1, 2, 3, 4\n.text\n halt\n")
    img.check_programs({"os": small})
    big = assemble_text(".proc os\n.data\nx: .space 5\n.text\n halt\n")
    with pytest.raises(ConfigError, match="OS kernel has 5 data words .* local address 4"):
        img.check_programs({"os": big})
    lay = img.layout
    p = int(np.argmax(lay.record_size))
    assert lay.primitive_of(int(lay.record_space[p]), int(lay.record_address[p])) == p
    assert lay.primitive_of(int(lay.record_space[p]), int(lay.record_address[p]) + 1) == -1


def test_ic_stream_in_chunks_equals_the_whole_stream():
    sc = mixed()
    golden = render(sc, config(), res=10, keep_trace=True)
    lay = build_images(sc, config(resident_share=0.3), grid=golden.grid).layout
    whole = golden_stream(lay, golden)
    parts = list(golden_stream_chunks(lay, golden, rays_per_chunk=7))
    assert len(parts) > 3
    for k in range(2):
        assert np.array_equal(np.concatenate([p[k] for p in parts]), whole[k])


@pytest.mark.parametrize("fan", [0, 1])
def test_patch_hit_reads_the_vertex_normals_of_its_fan_triangle(fan):
    sc = mixed()
    img = build_images(sc, config(resident_bytes=0))  # every record in ICGM
    lay = img.layout
    sd = lay.shapes
    patch = int(np.flatnonzero(sd.kind == Kind.POLYGON)[0])
    assert sd.poly_is_patch[sd.local[patch]] and sd.poly_count[sd.local[patch]] == 4
    entry = np.flatnonzero(lay.grid.leaf_prims == patch)[0]
    leaf = int(np.searchsorted(lay.grid.leaf_offsets, entry, "right") - 1)
    space, addr = ic_address_stream(lay, np.array([patch]), np.array([leaf]), np.array([0, 1]),
                                    np.array([patch]), np.array([fan]))
    assert len(addr) == CELL_WORDS + (4 + 12) + (5 + 9) and not space.any()
    a = int(lay.record_address[patch])
    assert addr[-14:-9].tolist() == [a + 1, a + 2, a + 3, a + 4, a + 5]  # luminance, id, normal
    words = Words(img.icgm).f(0, len(img.icgm))[addr[-9:]].reshape(3, 3)
    v0 = sd.poly_start[sd.local[patch]]
    assert np.array_equal(words, sd.poly_vertex_normals[v0 + np.array([0, fan + 1, fan + 2])])
