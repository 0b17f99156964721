"""The SC kernel (kernels/sc.s) on the stage bench, against the golden model, bit for bit.

Every wavefront of a small golden render (`host/golden.py`, `keep_trace=True`) is captured as it
is shaded, by wrapping golden's `_shade`, `trace` and `_Recorder.add`: the surface rays that hit
(o, d, weight, t, primitive, fan, barycentrics), the ones that missed, the shadow rays `_shade`
spawned (contributions, light distances, occluded or not) and the reflection / refraction rays it
returned. They become SC's input — HIT messages (normals from `host/shapes.py: surface_normals`,
luminance pointers from the images), MISS messages, and a COLOR message per unoccluded shadow
ray — sent through the host stream (the bench's OS stub forwards them round the ring to SC).

SC must answer with exactly the golden model's spawned rays as RAY messages to OS — every word:
pixel, info, origin, direction, t_min, t_max, weight / contribution — hit by hit, in golden's
order (shadow rays by light, then reflection, then refraction); its counters must equal golden's
ray counts; COL's hit-id buffer must be golden's hit ids; COL's frame must be the float64 sum of
the COLOR / MISS pixel values in message order (and close to golden's image).

Golden's weights stay grey (w*Ks, w*T of a white eye ray); "tint" cases colour the weights of the
rays `_shade` returns before the next wavefront is traced and shaded (golden then shades those),
so a kernel that mixes up weight components fails. Besides the paper's scenes (reduced sizes) and
tests/scenes, three small inline NFF scenes cover refraction with total internal reflection in
one scene, patches (shading normal != geometric normal) and a scene without lights.

The bench runs once per engine (`engine_name`, tests/conftest.py) and reads the run back through
the engine interface (messages, SC's local memory, frame and id buffers).
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from unittest.mock import patch

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_file
from netsushisen.emulator.harness import encode_message, run_stage
from netsushisen.host import golden
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import MachineImages, build_images
from netsushisen.host.nff import parse_nff
from netsushisen.host.shapes import build_shape_data, surface_normals
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.ring import parse_header
from netsushisen.isa.words import word_format
from netsushisen.kernels import KERNELS, protocol

P = protocol()
SCENES = Path(__file__).resolve().parent / "scenes"
GLASS_ROOM = """# eye inside an off-centre glass sphere: refraction out of it and total internal reflection
b 0.1 0.2 0.3
v
from 0 0.8 0.1
at 1 0.6 0.3
up 0 0 1
angle 120
hither 0
resolution 1 1
l 0 0 5
l 3 -2 1 0.5 0.8 1
f 0.9 0.9 1 0.5 0.2 50 0.9 1.5
s 0 0 0 1
f 1 0.6 0.3 0.8 0 0 0 0
p 4
3 -3 -1.5
3 3 -1.5
-3 3 -1.5
-3 -3 -1.5
f 0.3 1 0.4 0.7 0.5 20 0 0
s 2 1.5 0 0.5
"""
PATCHES = """# a `pp` patch (shading normal != geometric normal) and a mirror ball, coloured second light
b 0.2 0.1 0.05
v
from 0 -4 1.5
at 0 0 0
up 0 0 1
angle 50
hither 0.01
resolution 1 1
l 3 -3 4
l -3 -2 3 1 0.7 0.4
f 0.8 0.6 0.4 0.6 0.4 30 0 0
pp 4
-2 -2 0 -0.3 -0.3 1
2 -2 0 0.3 -0.3 1
2 2 0 0.3 0.3 1
-2 2 0 -0.3 0.3 1
f 0.4 0.8 1 0.7 0.3 10 0 0
s 0 0.5 0.6 0.6
"""
NO_LIGHTS = """# no light at all (NLIGHTS = 0: no light loop), a mirror floor and a glass ball
b 0.3 0.5 0.7
v
from 0 -4 1.5
at 0 0 0
up 0 0 1
angle 50
hither 0.01
resolution 1 1
f 0.8 0.6 0.4 0.6 0.4 30 0 0
p 4
-2 -2 0
2 -2 0
2 2 0
-2 2 0
f 0.4 0.8 1 0.7 0.3 10 0.5 1.3
s 0 0.5 0.6 0.6
"""
INLINE = {"glass_room": GLASS_ROOM, "patches": PATCHES, "no_lights": NO_LIGHTS}
RAY_FIELDS = ("pixel", "info", "ox", "oy", "oz", "dx", "dy", "dz", "t_min", "t_max", "wr", "wg", "wb")
COUNTERS = ("eye_hits", "reflection", "refraction", "shadow")


# ------------------------------------------------------------------------------------------------
# The golden model's shading, captured wavefront by wavefront


@dataclass
class Wave:
    """One `golden._shade` call: a wavefront's surface rays, their trace, what was spawned."""

    batch: golden.RayBatch
    h: np.ndarray
    tr: object
    shadow: golden.RayBatch | None = None
    shadow_t_max: np.ndarray | None = None
    shadow_occluded: np.ndarray | None = None
    out: golden.RayBatch | None = None


def tint_of(sample: np.ndarray, dt) -> np.ndarray:
    """(3, n) per-ray colour factors: golden weights are grey (w * Ks, w * T), tinted ones tell
    the three components apart."""
    s = np.asarray(sample, np.int64)
    return np.stack([np.ones(len(s)), 0.5 + (s % 5) / 10, 0.25 + (s % 3) / 4]).astype(dt)


def golden_waves(scene, config: MachineConfig, res: int, tint: bool = False):
    """Render with the golden model and keep every wavefront `_shade` saw. With `tint`, the
    rays `_shade` returns (reflection, refraction) get coloured weights before the next
    wavefront is traced and shaded (the recorded `out` keeps the weights `_shade` gave them)."""
    waves: list[Wave] = []
    shade0, trace0, add0 = golden._shade, golden.trace, golden._Recorder.add

    def shade(batch, h, tr, *args):
        waves.append(Wave(batch, h, tr))
        out = shade0(batch, h, tr, *args)
        waves[-1].out = dataclasses.replace(out, weight=out.weight.copy())
        if tint and len(out):
            out.weight *= tint_of(out.sample, out.weight.dtype)
        return out

    def trace(osg, sd, rays, t_max=None, **kw):
        result = trace0(osg, sd, rays, t_max=t_max, **kw)
        if t_max is not None:  # the shadow rays of the current wavefront
            waves[-1].shadow_t_max = t_max
            waves[-1].shadow_occluded = result.occluded
        return result

    def add(self, batch, kind_depth, result):
        if len(batch) and batch.kind[0] == golden.SHADOW:
            waves[-1].shadow = batch
        return add0(self, batch, kind_depth, result)

    with patch.object(golden, "_shade", shade), patch.object(golden, "trace", trace), \
            patch.object(golden._Recorder, "add", add):
        result = golden.render(scene, config, res=res, keep_trace=True)
    return result, waves


# ------------------------------------------------------------------------------------------------
# A case: the host stream for SC and everything SC must produce


@dataclass
class Case:
    config: MachineConfig
    images: MachineImages
    golden: golden.GoldenResult
    res: int
    host: list[list[int]] = field(default_factory=list)
    rays: list[list[int]] = field(default_factory=list)  # expected RAY messages, in order
    pixels: list[tuple[int, np.ndarray]] = field(default_factory=list)  # COL pixel values, in order
    hits: int = 0
    inside_hits: int = 0  # hits from inside the surface (SC flips the shading normal)
    bent_hits: int = 0  # hits whose shading normal is not the geometric one (patches)
    transparent_hits: int = 0  # hits on T > 0 below the depth limit (refraction or TIR)
    spawned: list[tuple[int, int]] = field(default_factory=list)  # per HIT, in order: (pixel, rays)


def _info(kind: int, depth: int) -> int:
    return int(kind) + (int(depth) << P["INFO_DEPTH_SHIFT"])


def _ray(wf, pixel, kind, depth, o, d, t_min, t_max, w) -> list[int]:
    dt = wf.float_type
    return encode_message(wf, "os", P["TAG_RAY"], [int(pixel), _info(kind, depth), *o, *d, dt(t_min),
                                                   dt(t_max), *w])


@lru_cache(maxsize=None)
def build_case(spec: str, precision: str = "fp32", res: int = 8, min_weight: float = 0.0,
               tint: bool = False) -> Case:
    config = MachineConfig()
    config.precision = precision
    config.render.min_weight = min_weight
    scene = parse_nff(INLINE[spec], spec) if spec in INLINE else load_scene(spec)
    images = build_images(scene, config)
    result, waves = golden_waves(scene, config, res, tint)
    wf = word_format(precision)
    dt = wf.float_type
    sd = build_shape_data(scene, precision)
    lum = golden.Luminance.of(scene, dt)
    lum_ptr = images.layout.luminance_pointer
    case = Case(images.config, images, result, res)
    for wv in waves:
        b, h, tr = wv.batch, wv.h, wv.tr
        for i in np.flatnonzero(tr.prim < 0):  # misses: SC adds w x background
            case.host.append(encode_message(wf, "sc", P["TAG_MISS"], [int(b.sample[i]), *b.weight[:, i]]))
            case.pixels.append((int(b.sample[i]), b.weight[:, i] * lum.background))
        d = b.d[:, h]
        t = tr.t[h]
        p = b.o[:, h] + t * d  # golden's P, bit for bit
        ng, ns = surface_normals(sd, tr.prim[h], p, tr.fan[h], tr.b1[h], tr.b2[h])
        # spawned rays leave from P +- delta*Ng (docs/golden.md, "Secondary-ray origins")
        front, back = golden.offset_vectors(p, t, ng, golden.dot(d, ng) > 0, golden.offset_scale(dt),
                                            golden.scene_epsilon(images.layout.grid, config, dt))
        which = {(int(b.sample[i]), q[:, j].tobytes()): j for q in (front, back) for j, i in enumerate(h)}
        assert len(which) == 2 * len(h), "two hits of one wavefront share a pixel and a point"
        spawned: list[list[list[int]]] = [[] for _ in h]
        if wv.shadow is not None:  # by light, then by hit: appending keeps each hit's light order
            s = wv.shadow
            for k in range(len(s)):
                j = which[(int(s.sample[k]), s.o[:, k].tobytes())]
                spawned[j].append(_ray(wf, s.sample[k], golden.SHADOW, s.depth, s.o[:, k], s.d[:, k],
                                       s.t_min[k], wv.shadow_t_max[k], s.weight[:, k]))
        out = wv.out
        for k in range(len(out)):  # reflection rays, then refraction rays
            j = which[(int(out.sample[k]), out.o[:, k].tobytes())]
            spawned[j].append(_ray(wf, out.sample[k], out.kind[k], out.depth, out.o[:, k], out.d[:, k],
                                   out.t_min[k], np.inf, out.weight[:, k]))
        for j, i in enumerate(h):
            prim = int(tr.prim[i])
            fields = [int(b.sample[i]), _info(b.kind[i], b.depth), *b.o[:, i], *b.d[:, i], *b.weight[:, i],
                      tr.t[i], *ng[:, j], *ns[:, j], int(lum_ptr[prim]), prim]
            case.host.append(encode_message(wf, "sc", P["TAG_HIT"], fields))
            case.rays.extend(spawned[j])
            case.spawned.append((int(b.sample[i]), len(spawned[j])))
        case.hits += len(h)
        case.inside_hits += int(np.count_nonzero(golden.dot(d, ng) > 0))
        case.bent_hits += int(np.count_nonzero(np.any(ng != ns, axis=0)))
        if b.depth < config.render.max_depth:
            case.transparent_hits += int(np.count_nonzero(lum.t[scene.material[tr.prim[h]]] > 0))
        if wv.shadow is not None:  # the unoccluded shadow rays come back from OS as COLOR
            s = wv.shadow
            for k in np.flatnonzero(~wv.shadow_occluded):
                fields = [int(s.sample[k]), *s.weight[:, k]]
                case.host.append(encode_message(wf, "sc", P["TAG_COLOR"], fields))
                case.pixels.append((int(s.sample[k]), s.weight[:, k]))
    return case


def assemble_sc(case: Case, generic: bool = False, serial: bool = False):
    """The kernel for the case's scene: its symbols, or every HAS_* = 1 (render --generic);
    `serial`: -D SERIAL_TREES=1 (a SHADED to OS after each hit's rays)."""
    defines = dict(case.images.symbols)
    if generic:
        defines.update({k: 1 for k in defines if k.startswith("HAS_")})
    if serial:
        defines["SERIAL_TREES"] = 1
    return assemble_file(KERNELS / "sc.s", proc="sc", defines=defines)


def bench_config(config: MachineConfig) -> MachineConfig:
    """The bench's OS stub forwards the host stream before it drains the ring and blocks in
    `send` when the ring is full, so with a long host stream SC's RAY messages back up into OS's
    receive FIFO (64 words: ~4 rays) until the ring deadlocks. Deep FIFOs hold every answer;
    they change timing only, never what SC computes."""
    config = copy.deepcopy(config)
    config.ring.fifo_depth = 1 << 16
    return config


@dataclass
class Outcome:
    rays: list[list[int]]
    frame: np.ndarray
    ids: np.ndarray
    counts: dict[str, int]
    cycles: int


def run_sc(case: Case, generic: bool = False, serial: bool = False, engine: str = "reference") -> Outcome:
    program = assemble_sc(case, generic, serial)
    case.images.check_programs({"sc": program})
    image = case.images.memory_image()
    image.frame = (case.res, case.res)
    run = run_stage("sc", program, case.host, bench_config(case.config), image, engine=engine)
    assert run.result.status == "finished", run.result
    assert not run.received["ic"], "SC sent something to IC"
    wf = word_format(case.config.precision)
    local = run.memory("sc", "local")
    counts = {}
    for name in COUNTERS:
        section, addr = program.labels[f"count_{name}"]
        assert section == "data"
        counts[name] = wf.to_int(local[addr])
    return Outcome(run.received["os"], run.frame.copy(), run.ids.copy(), counts, run.result.cycles)


# ------------------------------------------------------------------------------------------------
# Checks


def _describe(wf, msg: list[int]) -> str:
    if not msg:
        return "(none)"
    h = parse_header(msg[0])
    parts = [f"hdr tag {h.tag} len {h.length} dest {h.dest} cls {h.cls}"]
    for name, w in zip(RAY_FIELDS, msg[1:]):
        parts.append(f"{name}={wf.to_int(w) if name in ('pixel', 'info') else wf.to_float(w)!r}"
                     f"[{w:#x}]")
    return " ".join(parts)


def check_rays(case: Case, got: list[list[int]]) -> None:
    wf = word_format(case.config.precision)
    for k, (g, e) in enumerate(zip(got, case.rays)):
        if g != e:
            pytest.fail(f"RAY message {k} of {len(case.rays)} differs\n  got      {_describe(wf, g)}\n"
                        f"  expected {_describe(wf, e)}")
    assert len(got) == len(case.rays), \
        f"SC sent {len(got)} RAY messages, the golden model spawned {len(case.rays)}"


def expected_frame(case: Case) -> np.ndarray:
    """COL adds each pixel message into a float64 frame in arrival order: SC keeps the host order."""
    frame = np.zeros((case.res, case.res, 3), np.float64)
    for pixel, value in case.pixels:
        y, x = divmod(pixel, case.res)
        for c in range(3):
            frame[y, x, c] += float(value[c])
    return frame


def check_all(case: Case, out: Outcome) -> None:
    check_rays(case, out.rays)
    counts = {k: case.golden.rays[k] for k in COUNTERS}
    assert out.counts == counts
    np.testing.assert_array_equal(out.ids, case.golden.hit_ids)
    np.testing.assert_array_equal(out.frame, expected_frame(case))
    # and the frame is the golden image (summed in another order and precision)
    np.testing.assert_allclose(out.frame, case.golden.image.astype(np.float64), rtol=1e-5, atol=1e-6)


CASES = [  # (scene, precision, resolution, min_weight, tint): what each is there for
    ("balls:2", "fp32", 8, 0.0, True),  # three lights, mirror spheres: reflection
    ("mount:2", "fp32", 10, 0.0, True),  # glass spheres: refraction, hits from inside
    ("tetra:3", "fp32", 10, 0.0, False),  # no mirrors, no glass: neither is assembled
    ("rings:2", "fp32", 8, 0.0, False),  # cylinders, three lights, reflection, untinted
    (str(SCENES / "total_internal_reflection.nff"), "fp32", 6, 0.0, True),  # every refraction is TIR
    ("glass_room", "fp32", 6, 0.0, True),  # refraction and TIR in one scene, coloured light
    ("patches", "fp32", 8, 0.0, True),  # shading normal != geometric normal
    ("no_lights", "fp32", 8, 0.0, True),  # NLIGHTS = 0
    ("mount:2", "fp64", 8, 0.0, True),
    ("mount:2", "fp32", 8, 0.75, False),  # render.min_weight drops reflections and deep refractions
]


def _case_id(c) -> str:
    return f"{Path(c[0]).stem}-{c[1]}-{c[2]}px" + ("-mw" if c[3] else "") + ("-tint" if c[4] else "")


@pytest.mark.parametrize("spec,precision,res,min_weight,tint", CASES, ids=[_case_id(c) for c in CASES])
def test_sc_matches_the_golden_shading(spec, precision, res, min_weight, tint, engine_name):
    case = build_case(spec, precision, res, min_weight, tint)
    assert case.hits and case.rays, "the case exercises nothing"
    check_all(case, run_sc(case, engine=engine_name))


def test_the_cases_exercise_every_branch():
    """Each case reaches what it is there for (or the bit-for-bit test proves little)."""
    cases = {}
    for c in CASES:
        key = Path(c[0]).stem + ("-fp64" if c[1] == "fp64" else "") + ("-mw" if c[3] else "")
        cases[key] = build_case(*c)
    rays = {k: c.golden.rays for k, c in cases.items()}
    assert rays["balls:2"]["reflection"] > 0 and rays["balls:2"]["refraction"] == 0
    assert rays["mount:2"]["refraction"] > 0 and rays["mount:2"]["reflection"] > 0
    assert rays["mount:2-fp64"]["refraction"] > 0
    assert rays["tetra:3"]["reflection"] == rays["tetra:3"]["refraction"] == 0 < rays["tetra:3"]["shadow"]
    assert rays["rings:2"]["reflection"] > 0
    tir = cases["total_internal_reflection"]
    assert tir.golden.rays["reflection"] > 0 and tir.golden.rays["refraction"] == 0 < tir.transparent_hits
    room = cases["glass_room"]
    assert 0 < room.golden.rays["refraction"] < room.transparent_hits  # refraction and some TIR
    assert all(cases[k].inside_hits > 0 for k in ("mount:2", "mount:2-fp64", "glass_room"))
    assert cases["patches"].bent_hits > 0
    assert cases["no_lights"].images.symbols["NLIGHTS"] == 0
    assert rays["no_lights"]["shadow"] == 0 < rays["no_lights"]["refraction"]
    for k, c in cases.items():  # hits everywhere; misses and lit shadow rays wherever light gets out
        tags = {parse_header(m[0]).tag for m in c.host}
        sealed = k == "total_internal_reflection"  # the eye sits inside a closed glass ball
        assert P["TAG_HIT"] in tags and (P["TAG_MISS"] in tags or sealed), k
        assert P["TAG_COLOR"] in tags or sealed or k == "no_lights", k
    mw = cases["mount:2-mw"].golden.rays
    unlimited = build_case("mount:2", "fp32", 8).golden.rays
    assert mw["reflection"] == 0 < mw["refraction"] < unlimited["refraction"]
    # tinted weights reach SC: some HIT carries three different weight components
    hits = [m for m in cases["balls:2"].host if parse_header(m[0]).tag == P["TAG_HIT"]]
    assert any(len({m[9], m[10], m[11]}) == 3 for m in hits)


def test_specialised_and_generic_kernels_agree(engine_name):
    for spec in ("tetra:3", "balls:2"):
        case = build_case(spec, "fp32", 8)
        special, generic = assemble_sc(case), assemble_sc(case, generic=True)
        assert len(generic.bundles) > len(special.bundles)
        a, b = run_sc(case, engine=engine_name), run_sc(case, generic=True, engine=engine_name)
        check_all(case, a)
        assert a.rays == b.rays and a.counts == b.counts
        np.testing.assert_array_equal(a.frame, b.frame)
        np.testing.assert_array_equal(a.ids, b.ids)
        assert b.cycles > 0


def test_tetra_assembles_no_reflection_or_refraction():
    case = build_case("tetra:3", "fp32", 10)
    assert case.images.symbols["HAS_REFLECTION"] == 0 == case.images.symbols["HAS_REFRACTION"]
    labels = set(assemble_sc(case).labels)
    assert not labels & {"reflection", "refraction"}
    assert {"reflection", "refraction"} <= set(assemble_sc(case, generic=True).labels)


def test_unknown_messages_are_skipped(engine_name):
    """A message SC does not know is drained by its length; COLOR and MISS around it still work."""
    case = build_case("tetra:3", "fp32", 10)
    wf = word_format("fp32")
    host = [encode_message(wf, "sc", P["TAG_COLOR"], [3, np.float32(0.25), np.float32(0.5), np.float32(2.0)]),
            encode_message(wf, "sc", 12, [1, 2, np.float32(3.0)]),
            encode_message(wf, "sc", 13, []),
            encode_message(wf, "sc", P["TAG_MISS"], [5, np.float32(1.0), np.float32(0.5), np.float32(0.25)])]
    small = dataclasses.replace(case, host=host)
    out = run_sc(small, engine=engine_name)
    assert out.rays == [] and out.counts == dict.fromkeys(COUNTERS, 0)
    bg = golden.Luminance.of(load_scene("tetra:3"), np.float32).background
    expected = np.zeros_like(out.frame)
    expected[0, 3] = [0.25, 0.5, 2.0]
    expected[0, 5] = np.float32([1.0, 0.5, 0.25]) * bg
    np.testing.assert_array_equal(out.frame, expected)


# ------------------------------------------------------------------------------------------------
# Serial mode (-D SERIAL_TREES=1): SHADED after each hit's rays

SERIAL_CASES = [CASES[1], CASES[2], CASES[4], CASES[7], CASES[9]]  # mount, tetra, TIR, no lights, min_weight


@pytest.mark.parametrize("spec,precision,res,min_weight,tint", SERIAL_CASES,
                         ids=[_case_id(c) for c in SERIAL_CASES])
def test_serial_mode_sends_shaded_after_each_hits_rays(spec, precision, res, min_weight, tint,
                                                       engine_name):
    """Every HIT, whichever way its shading ends (no light faced, depth limit, T = 0, total
    internal reflection, min_weight cut, no mirrors or glass assembled), is followed on the ring
    to OS by exactly its spawned RAYs, then SHADED (its pixel); nothing else changes."""
    case = build_case(spec, precision, res, min_weight, tint)
    out = run_sc(case, serial=True, engine=engine_name)
    wf = word_format(precision)
    rays, k = [], 0
    for pixel, n in case.spawned:
        got = out.rays[k:k + n + 1]
        assert len(got) == n + 1, f"hit of pixel {pixel}: {len(got)} messages, expected {n} RAYs + SHADED"
        assert all(parse_header(m[0]).tag == P["TAG_RAY"] for m in got[:n])
        h = parse_header(got[n][0])
        assert (h.tag, h.length, h.dest, h.cls) == (P["TAG_SHADED"], P["LEN_SHADED"], 0, P["CLS_WORK"])
        assert got[n] == [P["HDR_SHADED"], wf.from_int(pixel)], f"hit of pixel {pixel}: SHADED"
        rays += got[:n]
        k += n + 1
    assert k == len(out.rays), "messages to OS after the last SHADED"
    check_all(case, dataclasses.replace(out, rays=rays))  # the rays, counters, ids and frame of normal mode


def test_serial_mode_exits_are_all_exercised():
    """The serial cases reach every way out of `hit`: a hit with no ray at all, the depth limit,
    T = 0 (no refraction), total internal reflection, the min_weight cut of a refraction."""
    by_id = {_case_id(c): build_case(*c) for c in SERIAL_CASES}
    assert any(n == 0 for c in by_id.values() for _, n in c.spawned)
    mount = by_id[_case_id(CASES[1])]
    assert mount.golden.rays["refraction"] > 0 and mount.transparent_hits < mount.hits
    tir = by_id[_case_id(CASES[4])]  # (every refraction is TIR)
    assert tir.transparent_hits > tir.golden.rays["refraction"]
    mw = by_id[_case_id(CASES[9])]
    assert mw.golden.rays["refraction"] < build_case("mount:2", "fp32", 8).golden.rays["refraction"]
    depth_limited = [c for c in by_id.values()
                     if c.golden.trace_depth is not None and c.golden.trace_depth.max() >= c.config.render.max_depth]
    assert depth_limited, "no case reaches the depth limit"
