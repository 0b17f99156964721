"""kernels/os.s, the object-search stage, against the golden traversal (host/traversal.py).

OS runs for real on PE 0; the other two processors run stubs:

* the stage bench (`emulator/harness.py`): IC and SC only record. Every ray sends IC its first
  non-empty leaf as VISIT_FIRST (list pointer, t_exit, the ray record) or SC a MISS;
* an IC stub that answers every visit with NEXT and reports the leaf (pixel, list pointer,
  t_exit) to an SC stub, which records it: the whole leaf sequence of every ray, then its end
  (MISS, or COLOR for shadow rays). The SC stub can also send rays to OS over the ring first.

The expected leaves come from the golden `trace` with IC never hitting (its intersection
stubbed out): every visited leaf (`keep_visits`), its voxel word from the image layout, and the
leaf's t_exit recomputed with traversal.py's own crossing function. Everything is compared bit
for bit, in fp32 and fp64.

Every machine run goes through the engine interface and runs once per engine (`engine_name`,
tests/conftest.py): the stubs' logs are read back as registers and local memory words.
"""

from __future__ import annotations

from contextlib import contextmanager
from functools import lru_cache

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_file, assemble_text
from netsushisen.emulator.harness import encode_message, run_machine, run_stage, split_words
from netsushisen.host import traversal
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import build_images
from netsushisen.host.rays import dtype_of, primary_rays
from netsushisen.host.shapes import PairHits, ic_rays
from netsushisen.host.traversal import OSGrid, _boundary, _next_crossing, trace
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.images import Segment
from netsushisen.isa.ring import parse_header
from netsushisen.isa.words import word_format
from netsushisen.kernels import KERNELS, protocol
from netsushisen.pipeline import eye_ray_messages

P = protocol()
SCENES = "tests/scenes/"
SLOT_WORDS = 64  # kernels/os.s: the slot table's records; the overflow queue follows the table


# ------------------------------------------------------------------------------------------------
# Scenes, kernels, rays


@lru_cache(maxsize=None)
def images_of(spec: str, precision: str = "fp32"):
    config = MachineConfig()
    config.precision = precision
    return build_images(load_scene(spec), config)


def os_program(images, slots: int, **overrides):
    defines = dict(images.symbols) | {"SLOTS": slots} | overrides
    program = assemble_file(KERNELS / "os.s", proc="os", defines=defines, include_dirs=[KERNELS])
    images.check_programs({"os": program})
    return program


def eye_rays(spec: str, res: int, precision: str):
    """The host stream of `render` (eye-ray RAY messages) and the same rays as arrays."""
    images = images_of(spec, precision)
    wf = word_format(precision)
    scene = load_scene(spec)
    words = eye_ray_messages(scene, res, False, wf)
    messages = [list(map(int, m)) for m in np.asarray(words).reshape(-1, 1 + P["RAY_WORDS"])]
    eye = primary_rays(scene.camera, res, False, precision)
    n = eye.direction.shape[1]
    dt = dtype_of(precision)
    o = np.repeat(eye.origin[:, None], n, axis=1)
    return images, messages, o, eye.direction, np.full(n, eye.t_min, dt)


def crafted_rays(images, dt, n_random: int = 30, seed: int = 1):
    """Rays inside and through the grid: random ones starting inside; ones on voxel boundaries
    (lo + i*cell, the traversal's own boundary values) running along an axis, along a face
    diagonal or along the space diagonal (ties between crossings; one has a -0.0 component);
    and random ones from outside the grid aimed at a point inside (their entry point is rounded
    to either side of the grid's face: the start index's clamp)."""
    osg = OSGrid.of(images.layout.grid, dt)
    lo = osg.lo.astype(np.float64)
    hi = _boundary(osg.lo, osg.res, osg.cell, dt).astype(np.float64)
    size = hi - lo
    rng = np.random.default_rng(seed)
    o = [lo[:, None] + rng.random((3, n_random)) * size[:, None]]
    d = rng.normal(size=(3, n_random))
    d = [d / np.linalg.norm(d, axis=0)]
    dirs = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1), (1, 1, 0),
            (-1, 1, 0), (1, -1, 0), (0, 1, 1), (1, 0, -1), (1, 1, 1), (-1, -1, -1)]
    for k in range(2 * len(dirs)):
        idx = np.array([rng.integers(0, r + 1) for r in images.layout.grid.res])
        o.append(_boundary(osg.lo, idx, osg.cell, dt).astype(np.float64)[:, None])
        v = np.array(dirs[k % len(dirs)], float)
        d.append((v / np.linalg.norm(v))[:, None])
    outside = lo[:, None] + (rng.random((3, n_random)) * 3 - 1) * size[:, None]
    target = lo[:, None] + rng.random((3, n_random)) * size[:, None]
    v = target - outside
    o.append(outside)
    d.append(v / np.linalg.norm(v, axis=0))
    o = np.concatenate(o, axis=1).astype(dt)
    d = np.concatenate(d, axis=1).astype(dt)
    d[0, 3] = -0.0
    return o, d


def exact_t_max(images, o, d, t_min, seed: int = 2):
    """Shadow-ray t_max values that hit the traversal's own numbers: for most rays exactly the
    t_exit of one of the leaves it crosses (a sub-grid's last leaf: the divided voxel's T_exit
    too), for some a random distance, for a few 0 (before the grid) or t_min (= t_enter)."""
    dt = images.layout.shapes.dtype
    wf = word_format(images.config.precision)
    leaves = golden_leaves(images, o, d, t_min)
    extent = float(np.max(images.layout.grid.hi - images.layout.grid.lo))
    rng = np.random.default_rng(seed)
    t_max = (rng.random(d.shape[1]) * extent).astype(dt)
    for i, seq in enumerate(leaves):
        if seq and i % 4 != 3:
            t_max[i] = np.asarray(seq[rng.integers(len(seq))][1], wf.word_dtype).view(dt)
    t_max[::17] = 0
    t_max[5:30:6] = t_min[5:30:6]  # rays starting inside: t_enter = t_min, not < t_max: no traversal
    return t_max


def ray_messages(wf, o, d, t_min, t_max, weight, info) -> list[list[int]]:
    """RAY messages (header + the 13-word record) with pixel = ray index."""
    dt = wf.float_type
    out = []
    for i in range(d.shape[1]):
        fields = [i, int(info)] + [dt(x) for x in o[:, i]] + [dt(x) for x in d[:, i]] + \
            [dt(t_min[i]), dt(t_max[i])] + [dt(x) for x in weight[:, i]]
        out.append(encode_message(wf, "os", P["TAG_RAY"], fields))
    return out


# ------------------------------------------------------------------------------------------------
# The golden leaves


def _no_hits(sd, rays, ray_index, prim):
    n, dt = len(prim), sd.dtype
    return PairHits(t=np.full(n, np.inf, dt), fan=np.zeros(n, np.int32), b1=np.zeros(n, dt),
                    b2=np.zeros(n, dt))


@contextmanager
def ic_never_hits():
    saved = traversal.intersect
    traversal.intersect = _no_hits
    try:
        yield
    finally:
        traversal.intersect = saved


def golden_leaves(images, o, d, t_min, t_max=None) -> list[list[tuple[int, int]]]:
    """Per ray, the (voxel word, t_exit word) of every non-empty leaf the golden traversal
    visits when no primitive is hit (shadow rays: with their t_max)."""
    lay = images.layout
    g = lay.grid
    dt = lay.shapes.dtype
    wf = word_format(images.config.precision)
    osg = OSGrid.of(g, dt)
    with ic_never_hits():
        visits = trace(osg, lay.shapes, ic_rays(o, d, t_min), t_max=t_max, keep_visits=True).visits
    ray, top, sub = visits[:, 0], visits[:, 1], visits[:, 2]
    nx, ny = g.res[0], g.res[1]
    ti = np.stack([top % nx, (top // nx) % ny, top // (nx * ny)])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = dt(1) / d[:, ray]
        pos = (inv > 0) & (inv < dt(np.inf))
        neg = (inv < 0) & (inv > -dt(np.inf))
        t_exit, _ = _next_crossing(osg.lo[:, None], osg.cell[:, None], ti, o[:, ray], inv, pos, neg, dt)
        leaf = np.where(sub < 0, g.top_leaf[top], -1)
        s = np.flatnonzero(sub >= 0)
        if len(s):
            sg = g.top_sub[top[s]]
            r = osg.sub_res[sg]
            si = np.stack([sub[s] % r[:, 0], (sub[s] // r[:, 0]) % r[:, 1], sub[s] // (r[:, 0] * r[:, 1])])
            tn, _ = _next_crossing(osg.sub_lo[sg].T, osg.sub_cell[sg].T, si, o[:, ray[s]], inv[:, s],
                                   pos[:, s], neg[:, s], dt)
            t_exit[s] = np.minimum(tn, t_exit[s])
            leaf[s] = g.sub_leaf[g.sub_offset[sg] + sub[s]]
    bits = np.asarray(t_exit, dt).view(wf.word_dtype)
    out: list[list[tuple[int, int]]] = [[] for _ in range(d.shape[1])]
    for k in np.flatnonzero(leaf >= 0):
        out[ray[k]].append((int(lay.leaf_cell[leaf[k]]), int(bits[k])))
    return out


def weight_words(wf, weight, i) -> list[int]:
    return [int(x) for x in np.asarray(weight[:, i], wf.float_type).view(wf.word_dtype)]


# ------------------------------------------------------------------------------------------------
# Stubs: IC answers NEXT and reports the leaves (A, and B if the VISIT has one) to SC; SC records
# (and may send rays first)

TAG_LEAF = 15  # the stubs' own report message (no protocol tag)
IC_NEXT = f"""
.proc ic
.include "protocol.inc"
loop:   recv r1, ring                   # header
        recv r2, ring                   # slot
        recv r3, ring                   # list pointer
        recv r4, ring                   # t_exit
        srli r5, r1, HDR_TAG_SHIFT
        li r6, TAG_VISIT_FIRST
        bne r5, r6, visit
        recv r7, ring                   # the record: keep the pixel of the slot
        st r7, [r2]
        li r8, RAY_WORDS - 1
skip:   recv r9, ring
        addi r8, r8, -1
        bnez r8, skip
visit:  ld r7, [r2]
        li r10, ({TAG_LEAF} << HDR_TAG_SHIFT) | (DEST_SC << HDR_DEST_SHIFT) | 3
        send ring, r10
        send ring, r7
        send ring, r3
        send ring, r4
        recv r3, ring                   # leaf B: list pointer (CELL_NONE: none)
        recv r4, ring                   #   and t_exit
        blt r3, r0, next
        send ring, r10
        send ring, r7
        send ring, r3
        send ring, r4
next:   li r10, HDR_NEXT
        send ring, r10
        send ring, r2
        j loop
"""
SC_BASE_WORDS = 4096  # the SC stub records from here; its rays to send are at 1.. (count at 0)
SC_RECORD = f"""
.proc sc
        li r1, 0
        ld r2, [0]                      # words of RAY messages to send, from address 1
        li r60, {SC_BASE_WORDS}
loop:   poll r5, ring                   # receive whatever is there, between the sends
        bnez r5, take
        beq r1, r2, idle
        ld r3, [r1 + 1]
        send ring, r3
        addi r1, r1, 1
        j loop
take:   recv r4, ring
        st r4, [r60]
        addi r60, r60, 1
        j loop
idle:   recv r4, ring
        st r4, [r60]
        addi r60, r60, 1
        j loop
"""


def run_with_next(images, program, host=(), ring=(), engine="reference"):
    """OS with the NEXT-answering IC stub; `ring`: RAY messages SC sends OS first. Returns the
    engine that ran, the leaves and the ends."""
    wf = word_format(images.config.precision)
    programs = {"os": program, "ic": assemble_text(IC_NEXT, proc="ic", filename="<ic stub>"),
                "sc": assemble_text(SC_RECORD, proc="sc", filename="<sc stub>")}
    image = images.memory_image()
    image.host = [Segment(0, [("w", np.asarray([w for m in host for w in m], dtype=np.uint64))])]
    ring_words = [w for m in ring for w in m]
    image.memories["sc.local"] = image.memories.get("sc.local", []) + [
        Segment(0, [("w", np.asarray([wf.from_int(len(ring_words))] + ring_words, dtype=np.uint64))])]
    machine = run_machine(engine, images.config, programs, image, max_cycles=2_000_000)
    result = machine.result()
    assert result.status == "finished", result.error and result.error.format()
    n = machine.register("pe0.sc", 60) - SC_BASE_WORDS
    words = machine.memory("pe0.sc", "local")[SC_BASE_WORDS:SC_BASE_WORDS + n]
    leaves: dict[int, list[tuple[int, int]]] = {}
    ends: dict[int, tuple[int, list[int]]] = {}
    for msg in split_words([int(w) for w in words]):
        h = parse_header(msg[0])
        pixel = wf.to_int(msg[1])
        assert pixel not in ends, f"ray {pixel}: a message after its end"
        if h.tag == TAG_LEAF:
            leaves.setdefault(pixel, []).append((wf.to_int(msg[2]), int(msg[3])))
        else:
            assert h.length == 4, h
            ends[pixel] = (h.tag, [int(w) for w in msg[2:]])
    return machine, leaves, ends


def check_sequences(wf, expected, leaves, ends, end_tag, weight):
    n = len(expected)
    assert sorted(ends) == list(range(n)), "every ray ends exactly once"
    for i in range(n):
        assert leaves.get(i, []) == expected[i], f"ray {i}: leaf sequence"
        assert ends[i] == (end_tag, weight_words(wf, weight, i)), f"ray {i}: end message"


# ------------------------------------------------------------------------------------------------
# Tests

FIRST_VISIT_CASES = [("tetra:3", 8, "fp32"), ("balls:2", 8, "fp32"), ("rings:2", 8, "fp32"),
                     ("mount:2", 8, "fp32"), (SCENES + "axis_parallel.nff", 9, "fp32"),
                     (SCENES + "shared_edge.nff", 8, "fp32"), (SCENES + "grazing_sphere.nff", 8, "fp32"),
                     (SCENES + "far_tiny_sphere.nff", 8, "fp32"), ("balls:2", 8, "fp64"),
                     (SCENES + "axis_parallel.nff", 9, "fp64")]


@pytest.mark.parametrize("spec,res,precision", FIRST_VISIT_CASES)
def test_first_visit_of_every_eye_ray_matches_the_golden_traversal(spec, res, precision, engine_name):
    """Stage bench: IC and SC only record, so each ray gets as far as its first non-empty
    leaf (VISIT_FIRST: slot, list pointer, t_exit, record, and the leaf after it, found by OS's
    look-ahead) or misses (MISS: pixel, weight)."""
    images, messages, o, d, t_min = eye_rays(spec, res, precision)
    wf = word_format(precision)
    n = len(messages)
    expected = golden_leaves(images, o, d, t_min)
    run = run_stage("os", os_program(images, slots=n), messages, images.config, images.memory_image(),
                    engine=engine_name)
    assert run.result.status == "finished", run.result.error and run.result.error.format()
    visits, second, slots = {}, {}, set()
    for msg in run.received["ic"]:
        h = parse_header(msg[0])
        assert (h.tag, h.length, h.cls) == (P["TAG_VISIT_FIRST"], P["LEN_VISIT_FIRST"], P["CLS_WORK"])
        slot, record = wf.to_int(msg[1]), msg[4:4 + P["RAY_WORDS"]]
        assert 0 <= slot < n and slot not in slots
        slots.add(slot)
        pixel = wf.to_int(record[0])
        assert record == messages[pixel][1:], f"ray {pixel}: the record travels unchanged"
        visits[pixel] = (wf.to_int(msg[2]), int(msg[3]))
        second[pixel] = (wf.to_int(msg[-2]), int(msg[-1]))
    misses = {}
    for msg in run.received["sc"]:
        h = parse_header(msg[0])
        assert (h.tag, h.length) == (P["TAG_MISS"], P["LEN_MISS"])
        misses[wf.to_int(msg[1])] = [int(w) for w in msg[2:]]
    for i in range(n):
        if expected[i]:
            assert visits.get(i) == expected[i][0], f"ray {i}: first leaf"
            # OS looked ahead: the second leaf, or none (t_exit 0) if the ray has one
            b = expected[i][1] if len(expected[i]) > 1 else (P["CELL_NONE"], 0)
            assert second[i] == b, f"ray {i}: second leaf"
        else:
            assert i not in visits and misses.get(i) == [wf.from_float(1.0)] * 3, f"ray {i}: MISS"
    assert len(visits) + len(misses) == n and visits


@pytest.mark.parametrize("spec,res,slots", [(SCENES + "axis_parallel.nff", 9, 8), ("balls:2", 8, 8),
                                            ("rings:2", 8, 8), ("tetra:3", 8, 3), ("balls:2", 6, 1)])
def test_leaf_sequences_of_eye_rays_with_ic_answering_next(spec, res, slots, engine_name):
    """With IC answering NEXT, every eye ray walks all its non-empty leaves, in the golden order
    and with the golden t_exit (sub-grids included), then leaves the grid as MISS."""
    images, messages, o, d, t_min = eye_rays(spec, res, "fp32")
    wf = word_format("fp32")
    expected = golden_leaves(images, o, d, t_min)
    assert sum(len(x) for x in expected) > len(messages)  # several leaves per ray on average
    _, leaves, ends = run_with_next(images, os_program(images, slots), host=messages, engine=engine_name)
    check_sequences(wf, expected, leaves, ends, P["TAG_MISS"], np.ones((3, len(messages))))


def test_one_slot_and_eight_slots_give_the_same_leaf_sequences(engine_name):
    images, messages, *_ = eye_rays("rings:2", 6, "fp32")
    one = run_with_next(images, os_program(images, 1), host=messages, engine=engine_name)
    eight = run_with_next(images, os_program(images, 8), host=messages, engine=engine_name)
    assert one[1] == eight[1] and one[2] == eight[2]
    assert one[0].cycle > eight[0].cycle  # eight rays in flight overlap OS, IC and SC


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
@pytest.mark.parametrize("spec,precision,shadow,via_ring,slots", [
    ("balls:2", "fp32", False, False, 8),
    ("balls:2", "fp32", True, True, 2),
    ("rings:2", "fp32", True, False, 8),
    ("rings:2", "fp32", False, True, 3),
    (SCENES + "axis_parallel.nff", "fp32", False, False, 8),
    (SCENES + "axis_parallel.nff", "fp64", True, True, 1),
    ("tetra:3", "fp64", False, True, 2),
    ("mount:2", "fp32", True, False, 4),
])
def test_rays_starting_inside_the_grid(spec, precision, shadow, via_ring, slots, engine_name):
    """Secondary and shadow rays (`crafted_rays`: inside the grid, on voxel boundaries, from
    outside) from the host or from SC over the ring (few slots: the overflow queue fills).
    Surface rays end in MISS with their weight; shadow rays in COLOR with their contribution
    once a leaf's t_exit reaches t_max, which is mostly exactly some leaf's t_exit."""
    images = images_of(spec, precision)
    wf = word_format(precision)
    dt = dtype_of(precision)
    o, d = crafted_rays(images, dt)
    n = d.shape[1]
    t_min = np.full(n, dt(1e-4))
    weight = ((np.arange(3 * n).reshape(3, n) + 1) / 7).astype(dt)
    if shadow:
        t_max = exact_t_max(images, o, d, t_min)
        info, end = P["KIND_SHADOW"] + (2 << P["INFO_DEPTH_SHIFT"]), P["TAG_COLOR"]
    else:
        t_max = np.full(n, np.inf, dt)
        info, end = P["KIND_REFLECTION"] + (2 << P["INFO_DEPTH_SHIFT"]), P["TAG_MISS"]
    expected = golden_leaves(images, o, d, t_min, t_max if shadow else None)
    messages = ray_messages(wf, o, d, t_min, t_max, weight, info)
    program = os_program(images, slots)
    if via_ring:
        machine, leaves, ends = run_with_next(images, program, ring=messages, engine=engine_name)
        queue = images.symbols["OS_FREE_BASE"] + slots * SLOT_WORDS
        assert machine.memory("pe0.os", "local")[queue + 2] != 0, "the overflow queue was used"
    else:
        machine, leaves, ends = run_with_next(images, program, host=messages, engine=engine_name)
    check_sequences(wf, expected, leaves, ends, end, weight)
    if shadow:
        assert any(not e for e in expected) and any(len(e) > 1 for e in expected)


def test_specialised_and_generic_kernels_agree(engine_name):
    """Without sub-grids (HAS_SUBGRIDS = 0) and without secondary rays the kernel drops that
    code; the generic kernel (every HAS_* = 1) gives the same leaves and ends."""
    spec = SCENES + "axis_parallel.nff"
    images, messages, o, d, t_min = eye_rays(spec, 9, "fp32")
    assert images.symbols["HAS_SUBGRIDS"] == 0
    lean = os_program(images, 8, NLIGHTS=0, HAS_REFLECTION=0, HAS_REFRACTION=0)
    generic = os_program(images, 8, HAS_SUBGRIDS=1, HAS_REFLECTION=1, HAS_REFRACTION=1)
    assert len(lean.bundles) < len(generic.bundles)
    (_, lean_leaves, lean_ends), (_, leaves, ends) = (run_with_next(images, p, host=messages,
                                                                    engine=engine_name)
                                                      for p in (lean, generic))
    assert (lean_leaves, lean_ends) == (leaves, ends)
    expected = golden_leaves(images, o, d, t_min)
    check_sequences(word_format("fp32"), expected, leaves, ends, P["TAG_MISS"], np.ones((3, len(messages))))


def test_data_stays_below_the_voxel_data():
    images = images_of("rings:2")
    for slots in (1, 8, 200):
        program = os_program(images, slots)
        # the free-slot stack, top_rm (3 words) and SAVE_STEP's top-level index ends (6)
        assert len(program.data) == slots + 3 + 6 < images.symbols["VOXEL_BASE"]


# ------------------------------------------------------------------------------------------------
# Serial mode (-D SERIAL_TREES=1): one ray tree at a time, in level order

TAG_REPORT = 14  # the IC stub's "hit" report to the SC stub: the 13-word ray record
LOG_BASE = 40000  # the stubs' logs (IC: first visits; SC: ray ends), far above their data
TREE_DEPTH = 3  # the SC stub spawns children below this depth
IC_TREE = f"""
.proc ic
.include "protocol.inc"
# Every surface ray hits at its first leaf (DONE, then its record to SC); a shadow ray of an even
# pixel is occluded there (DONE), one of an odd pixel never (NEXT: it ends at OS as COLOR). The
# first visit of every ray is logged (pixel, info) at LOG_BASE.
        li r60, {LOG_BASE}
        li r13, RAY_WORDS
loop:   recv r1, ring                   # header
        recv r2, ring                   # slot
        recv r3, ring                   # list pointer
        recv r4, ring                   # t_exit
        srli r5, r1, HDR_TAG_SHIFT
        slli r11, r2, 4                 # the slot's record at 16 * slot
        li r6, TAG_VISIT_FIRST
        bne r5, r6, visit
        li r8, 0
rec:    recv r9, ring
        add r12, r11, r8
        st r9, [r12]
        addi r8, r8, 1
        blt r8, r13, rec
        ld r9, [r11 + RAY_PIXEL]
        st r9, [r60]
        ld r9, [r11 + RAY_INFO]
        st r9, [r60 + 1]
        addi r60, r60, 2
visit:  recv r9, ring                   # leaf B (never walked: the answer is leaf A's)
        recv r9, ring
        ld r7, [r11 + RAY_INFO]
        ld r8, [r11 + RAY_PIXEL]
        andi r9, r7, 3
        li r10, KIND_SHADOW
        bne r9, r10, hit
        andi r9, r8, 1
        beqz r9, done
        li r10, HDR_NEXT
        send ring, r10
        send ring, r2
        j loop
done:   li r10, HDR_DONE
        send ring, r10
        send ring, r2
        j loop
hit:    li r10, HDR_DONE
        send ring, r10
        send ring, r2
        li r10, ({TAG_REPORT} << HDR_TAG_SHIFT) | (DEST_SC << HDR_DEST_SHIFT) | RAY_WORDS
        send ring, r10
        li r8, 0
fwd:    add r12, r11, r8
        ld r9, [r12]
        send ring, r9
        addi r8, r8, 1
        blt r8, r13, fwd
        j loop
"""
SC_TREE = f"""
.proc sc
.include "protocol.inc"
.ifndef SERIAL_TREES
.equ SERIAL_TREES, 0
.endif
# A hit (the IC stub's report): think for a long while, then spawn (below depth TREE_DEPTH) a
# shadow ray (the hit's depth) and a reflection ray (depth + 1) along the same line, then, in
# serial mode, SHADED. MISS / COLOR: logged (tag, pixel) at LOG_BASE.
        li r60, {LOG_BASE}
        li r13, RAY_WORDS
        li r20, HDR_RAY_TO_OS
loop:   recv r1, ring
        srli r2, r1, HDR_TAG_SHIFT
        li r3, {TAG_REPORT}
        beq r2, r3, hit
        st r2, [r60]
        recv r4, ring
        st r4, [r60 + 1]
        addi r60, r60, 2
        recv r4, ring
        recv r4, ring
        recv r4, ring
        j loop
hit:    li r8, 0
rec:    recv r9, ring
        st r9, [r8]
        addi r8, r8, 1
        blt r8, r13, rec
        li r5, 400
think:  addi r5, r5, -1
        bnez r5, think
        ld r6, [RAY_INFO]
        srli r7, r6, INFO_DEPTH_SHIFT
        li r8, {TREE_DEPTH}
        bge r7, r8, shaded
        slli r9, r7, INFO_DEPTH_SHIFT
        ori r9, r9, KIND_SHADOW
        call spawn
        addi r9, r7, 1
        slli r9, r9, INFO_DEPTH_SHIFT
        ori r9, r9, KIND_REFLECTION
        call spawn
shaded:
.if SERIAL_TREES
        li r10, HDR_SHADED
        send ring, r10
        ld r11, [RAY_PIXEL]
        send ring, r11
.endif
        j loop
spawn:  send ring, r20                  # RAY: the hit's record with info r9
        ld r11, [RAY_PIXEL]
        send ring, r11
        send ring, r9
        li r8, 2
word:   ld r11, [r8]
        send ring, r11
        addi r8, r8, 1
        blt r8, r13, word
        ret
"""


def run_trees(images, messages, serial: bool, engine: str = "reference"):
    """OS (SLOTS=1) with the tree stubs: IC's log of first visits and SC's log of ray ends."""
    wf = word_format(images.config.precision)
    defines = {"SERIAL_TREES": 1} if serial else {}
    programs = {"os": os_program(images, 1, **defines),
                "ic": assemble_text(IC_TREE, proc="ic", filename="<ic stub>"),
                "sc": assemble_text(SC_TREE, proc="sc", filename="<sc stub>", defines=defines)}
    image = images.memory_image()
    image.host = [Segment(0, [("w", np.asarray([w for m in messages for w in m], dtype=np.uint64))])]
    machine = run_machine(engine, images.config, programs, image, max_cycles=3_000_000)
    result = machine.result()
    assert result.status == "finished", result.error and result.error.format()

    def log(stage):
        n = machine.register(f"pe0.{stage}", 60) - LOG_BASE
        words = machine.memory(f"pe0.{stage}", "local")[LOG_BASE:LOG_BASE + n]
        return [(wf.to_int(words[k]), wf.to_int(words[k + 1])) for k in range(0, n, 2)]
    return log("ic"), log("sc")


def test_serial_mode_finishes_each_ray_tree_before_the_next_eye_ray(engine_name):
    """SERIAL_TREES=1, SLOTS=1: OS takes the next host ray only once every ray of the current
    tree is finished — whichever way each ends: MISS (eye rays that miss the grid), COLOR (odd
    pixels' shadow rays, at OS), DONE of an occluded shadow ray (even pixels), DONE + SHADED of a
    hit — so IC sees each pixel's tree whole and in level order: eye ray; its shadow and
    reflection rays; their children. SC thinks long over each hit: in normal mode the next eye
    ray overtakes the tree's younger rays."""
    images, messages, *_ = eye_rays("tetra:3", 6, "fp32")
    n = len(messages)
    serial_ic, serial_sc = run_trees(images, messages, serial=True, engine=engine_name)
    normal_ic, normal_sc = run_trees(images, messages, serial=False, engine=engine_name)
    eye_hit = sorted({p for p, info in serial_ic if info == P["KIND_EYE"] + (1 << P["INFO_DEPTH_SHIFT"])})
    assert 0 < len(eye_hit) < n, "some eye rays reach a leaf, some miss the grid"

    def info(kind, depth):
        return P[kind] + (depth << P["INFO_DEPTH_SHIFT"])
    tree = [info("KIND_EYE", 1), info("KIND_SHADOW", 1), info("KIND_REFLECTION", 2),
            info("KIND_SHADOW", 2), info("KIND_REFLECTION", 3)]
    assert serial_ic == [(p, i) for p in eye_hit for i in tree]
    # the ends: a MISS per eye ray that missed the grid, a COLOR per odd pixel's shadow ray
    ends = sorted([(P["TAG_MISS"], p) for p in range(n) if p not in eye_hit] +
                  [(P["TAG_COLOR"], p) for p in eye_hit if p % 2 for _ in range(2)])
    assert sorted(serial_sc) == ends == sorted(normal_sc)
    assert any(p % 2 for p in eye_hit) and any(p % 2 == 0 for p in eye_hit)
    # normal mode: the same rays, but trees overlap
    assert sorted(normal_ic) == sorted(serial_ic) and normal_ic != serial_ic


def test_serial_mode_kernel_assembles_only_when_asked():
    """Without SERIAL_TREES the kernel is the same program as with SERIAL_TREES=0; with it, code
    changes and the data only loses SAVE_STEP's table (the serial mode recomputes the crossings
    on a NEXT: its memory operations stay the paper trace's), the slot table and queue stay."""
    images = images_of(SCENES + "axis_parallel.nff")
    plain, off, on = os_program(images, 1), os_program(images, 1, SERIAL_TREES=0), \
        os_program(images, 1, SERIAL_TREES=1)
    assert plain.bundles == off.bundles and plain.data == off.data
    assert on.data == plain.data[:len(on.data)] and len(plain.data) - len(on.data) == 6
    assert on.bundles != plain.bundles
    lean = os_program(images, 1, NLIGHTS=0, HAS_REFLECTION=0, HAS_REFRACTION=0, SERIAL_TREES=1)
    assert "on_shaded" in lean.labels and "on_ray" not in lean.labels  # SHADED without secondary rays


def test_serial_mode_renders_what_normal_mode_renders(engine_name):
    """The whole machine (render), serial mode with one slot against normal mode with eight: the
    same image bit for bit, hit ids, ray counts and IC references per primitive — only the order
    of the work differs. With the paper's load order (PRELOAD=0, LAZY_WORDS=0, as serial mode
    assembles it) also the same accesses per region, resident and cache; the default kernel reads
    fewer record words (LAZY_WORDS) and some list cells ahead (PRELOAD; docs/kernels.md)."""
    from netsushisen.isa.config import load_config
    from netsushisen.paper_machine import PAPER_ORDER
    from netsushisen.pipeline import render

    config = load_config()
    serial = render("mount:2", config, res=6, slots=1, defines={"SERIAL_TREES": 1}, engine=engine_name)
    normal = render("mount:2", config, res=6, slots=8, engine=engine_name)
    paper = render("mount:2", config, res=6, slots=8, defines=PAPER_ORDER,
                   engine=engine_name)
    for r in (serial, normal, paper):
        assert r.run.status == "finished", r.run
    assert serial.setup.defines["SERIAL_TREES"] == 1 and "SERIAL_TREES" not in normal.setup.defines
    for r in (normal, paper):
        assert serial.image.tobytes() == r.image.tobytes()
        np.testing.assert_array_equal(serial.hit_ids, r.hit_ids)
        assert serial.rays == r.rays and serial.rays["reflection"] and serial.rays["refraction"]
        assert serial.stats["memory"]["pe0.ic"]["primitives"] == r.stats["memory"]["pe0.ic"]["primitives"]

    def accesses(r):
        m = r.stats["memory"]["pe0.ic"]
        return ({k: v["accesses"] for k, v in m["regions"].items()},
                (m["resident"]["accesses"], m["cache"]["accesses"]))

    assert accesses(serial) == accesses(paper)
    lazy, full = accesses(normal)[0], accesses(paper)[0]
    shapes = [k for k in full if k.endswith("shape_data")]
    assert shapes and sum(lazy[k] for k in shapes) < sum(full[k] for k in shapes)
    assert serial.run.cycles > normal.run.cycles  # one ray at a time
