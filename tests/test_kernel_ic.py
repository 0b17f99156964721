"""kernels/ic.s on the stage bench (emulator/harness.py), bit for bit against the golden model.

For a scene we take rays as the golden model makes them — eye rays (host/rays.py) and, from the
eye hits, golden's shadow, reflection and refraction rays (host/golden.py's formulas) — and
trace them with golden's traversal (host/traversal.py `trace`, visits and references kept).
The non-empty leaves a ray visits go to IC two at a time, as OS's look-ahead sends them: one
VISIT_FIRST / VISIT message per pair, each leaf with its list pointer and golden's t_exit
(recomputed from the visited voxel indices with traversal's own `_next_crossing`); after a ray's
last leaf the second is CELL_NONE, or — when the ray ends at IC in the first — a leaf IC must not
walk. Rays are interleaved over slots so that IC serves visits of one ray while others are in
flight (slot table reloads). Then, per message:

* IC's answer to OS (NEXT / DONE, class CLS_ANSWER, the slot) is golden's outcome of its leaves;
* each HIT carries the ray as sent, golden's t, golden's geometric and shading normals at
  P = o + t*d (host/shapes.py `surface_normals`, patches from golden's fan and barycentrics),
  the luminance pointer and the primitive id — every float compared as a raw word;
* IC's loads (resident / ICGM) are exactly docs/databases.md's IC access protocol
  (host/ic_access.py) in order, so the emulator's per-primitive counters equal golden's
  references, and resident vs cache reads follow P <= M (scenes run with a resident share
  that leaves records on both sides);
* the kernel assembled for the scene's needs and the generic one (every HAS_* = 1) agree.

`test_the_bench_catches_a_wrong_kernel` runs deliberately broken copies of the kernel (one
operation changed each: tangent rays, the two tie-break paths, patch barycentrics, the cone's
entering test, the resident rule) and expects the checks to fail.

`test_ic_matches_golden` runs once per engine (`engine_name`, tests/conftest.py), reading answers,
hits and counters through the engine interface. IC's load stream is recorded by wrapping the
reference engine's `MemorySystem.load`: it is compared whenever the engine goes through it (the
reference engine always; an engine that never calls it records nothing and is checked on
everything else). The mutants run on the reference engine: they test the bench's checks, the load
stream among them.
"""

from __future__ import annotations

import functools
from collections import Counter
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_file
from netsushisen.emulator.harness import encode_message, run_stage
from netsushisen.emulator.memories import MemorySystem
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import GLOBAL, RESIDENT, build_images
from netsushisen.host.golden import EYE, REFLECTION, REFRACTION, SHADOW, Luminance, scene_epsilon
from netsushisen.host.grid import build_grid
from netsushisen.host.ic_access import ic_address_stream
from netsushisen.host.nff import parse_nff
from netsushisen.host.prepass import run_prepass
from netsushisen.host.rays import dot, dtype_of, normalize, primary_rays
from netsushisen.host.records import record_sizes
from netsushisen.host.shapes import build_shape_data, ic_rays, surface_normals
from netsushisen.host.traversal import OSGrid, _next_crossing, trace
from netsushisen.isa.config import load_config
from netsushisen.isa.ring import parse_header
from netsushisen.isa.words import word_format
from netsushisen.kernels import KERNELS, protocol
from netsushisen.paper_machine import PAPER_ORDER

PROTO = protocol()
SCENES = Path(__file__).resolve().parent / "scenes"

# A few cones (one transmitting: two-sided) and spheres, one cylinder: every root case of the cone.
CONES_NFF = """
b 0.1 0.1 0.1
v
from 0 -6 1.5
at 0 0 0.8
up 0 0 1
angle 45
hither 0.01
resolution 8 8
l 3 -4 6
l -4 -2 5
f 0.8 0.5 0.2 0.7 0.3 20 0 1
c 0 0 0 1.0  0 0 2 0.2
c 1.6 0.5 0 0.4  1.9 0.3 1.5 0.6
s -1.5 0.2 0.6 0.6
s 0.4 -1.2 0.3 0.3
f 0.3 0.6 0.9 0.5 0.2 10 0.6 1.4
c -0.6 -1.0 1.2 0.5  0.4 -0.8 2.2 0.05
s 1.0 -1.0 1.6 0.35
c -1.0 -2.2 0.2 0.3  -0.4 -2.0 1.2 0.3
f 0.8 0.8 0.3 0.6 0.3 15 0 1
c 1.1 -2.0 0 0.25  1.1 -2.0 1.0 0.25
c -1.8 1.0 0 0.3  -1.8 1.0 1.4 0.3
"""

# A small patch mesh (pp: per-vertex normals) with a quad and a concave pentagon patch.
PATCH_NFF = """
b 0 0 0
v
from 0.3 -5 3
at 0 0 0.3
up 0 0 1
angle 40
hither 0.01
resolution 8 8
l 2 -3 5
f 0.9 0.9 0.9 0.8 0.2 30 0 1
pp 3
-1 -1 0  -0.3 -0.3 0.9
1 -1 0  0.3 -0.3 0.9
0 1 0.8  0 0.4 0.9
pp 3
1 -1 0  0.3 -0.3 0.9
1.5 1 0.2  0.6 0.2 0.8
0 1 0.8  0 0.4 0.9
pp 4
-1 -1 0  -0.3 -0.3 0.9
0 1 0.8  0 0.4 0.9
-1.4 1.2 0.3  -0.5 0.3 0.8
-1.8 -0.5 -0.1  -0.7 -0.1 0.7
pp 5
-2 -2 -0.5  0 0 1
2 -2 -0.5  0 0.1 1
2 -1.3 -0.5  0.1 0 1
0 -1.7 -0.5  0 0 1
-2 -1.3 -0.5  -0.1 0 1
"""


# Quads and a concave pentagon around a shared vertex, one-sided and two-sided: the odd
# resolution puts the middle row and column of eye rays exactly on the shared edges (edge values
# exactly 0: the general loop's tie-break), the centre ray through the shared vertex.
QUADS_NFF = """
b 0 0 0
v
from 0 0 -5
at 0 0 0
up 0 1 0
angle 45
hither 0
resolution 9 9
l 1 2 -6
f 1 1 1 1 0 100000 0 0
p 4
0 0 0
0 2 0
2 2 0
2 0 0
p 4
0 0 0
2 0 0
2 -2 0
0 -2 0
f 1 1 1 1 0 100000 0.5 1.3
p 4
0 0 0
-2 0 0
-2 2 0
0 2 0
p 5
0 0 0
0 -2 0
-2 -2 0
-1 -1 0
-2 0 0
"""
QUADS4_NFF = QUADS_NFF.split("p 5")[0].replace("100000 0.5 1.3", "100000 0 0") + """p 4
0 0 0
0 -2 0
-2 -2 0
-2 0 0
"""
"""Opaque quadrilaterals only (MAX_VERTICES = 4, one-sided: IC's straight-line quad test, not the
n-gon loop), with the shared edges and vertex of QUADS_NFF."""


# ---- rays ----------------------------------------------------------------------------------------

@dataclass
class Rays:
    o: np.ndarray  # (3, n)
    d: np.ndarray
    t_min: np.ndarray
    t_max: np.ndarray
    kind: np.ndarray
    depth: np.ndarray
    pixel: np.ndarray
    w: np.ndarray  # (3, n)

    def __len__(self) -> int:
        return len(self.kind)


def _cat(parts: list[Rays]) -> Rays:
    return Rays(*(np.concatenate([getattr(p, f) for p in parts], axis=-1) for f in
                  ("o", "d", "t_min", "t_max", "kind", "depth", "pixel", "w")))


@dataclass
class Traced:
    """Golden's answer for a batch of rays: hits, and per ray the non-empty leaves visited."""

    rays: Rays
    prim: np.ndarray
    t: np.ndarray
    fan: np.ndarray
    b1: np.ndarray
    b2: np.ndarray
    occluded: np.ndarray
    visits: list = field(default_factory=list)  # per ray: [(leaf, t_exit, [prims tested])]


def golden_trace(rays: Rays, osg: OSGrid, sd, shadow: bool) -> Traced:
    dt = sd.dtype
    grid = osg.grid
    res = trace(osg, sd, ic_rays(rays.o, rays.d, rays.t_min), t_max=rays.t_max if shadow else None,
                keep_refs=True, keep_visits=True)
    out = Traced(rays, res.prim, res.t, res.fan, res.b1, res.b2, res.occluded,
                 [[] for _ in range(len(rays))])
    v = res.visits
    r, top, sub = v[:, 0], v[:, 1], v[:, 2]
    nx, ny = grid.res[0], grid.res[1]
    ti = np.stack([top % nx, (top // nx) % ny, top // (nx * ny)])
    o, d = rays.o[:, r], rays.d[:, r]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = dt(1) / d
        pos = (inv > 0) & (inv < np.inf)
        neg = (inv < 0) & (inv > -np.inf)
        t_exit, _ = _next_crossing(osg.lo[:, None], osg.cell[:, None], ti, o, inv, pos, neg, dt)
        leaf = grid.top_leaf[top].astype(np.int64)
        s_in = np.flatnonzero(sub >= 0)
        if len(s_in):
            s = grid.top_sub[top[s_in]].astype(np.int64)
            m = osg.sub_res[s].T
            fs = sub[s_in]
            si = np.stack([fs % m[0], (fs // m[0]) % m[1], fs // (m[0] * m[1])])
            tn, _ = _next_crossing(osg.sub_lo[s].T, osg.sub_cell[s].T, si, o[:, s_in], inv[:, s_in],
                                   pos[:, s_in], neg[:, s_in], dt)
            t_exit[s_in] = np.minimum(tn, t_exit[s_in])
            leaf[s_in] = grid.sub_leaf[grid.sub_offset[s] + fs]
    refs: dict[tuple[int, int], list[int]] = {}
    leaves = res.ref_leaf if res.ref_leaf is not None else np.zeros(0, np.int64)
    for rr, p, lf in zip(res.ref_ray.tolist(), res.ref_prim.tolist(), leaves.tolist()):
        refs.setdefault((rr, lf), []).append(p)
    for rr, lf, te in zip(r.tolist(), leaf.tolist(), t_exit):
        if lf >= 0:
            out.visits[rr].append((lf, te, refs[(rr, lf)]))
    return out


def hit_points(tr: Traced, sd):
    h = np.flatnonzero(tr.prim >= 0)
    p = tr.rays.o[:, h] + tr.t[h] * tr.rays.d[:, h]
    ng, ns = surface_normals(sd, tr.prim[h], p, tr.fan[h], tr.b1[h], tr.b2[h])
    return h, p, ng, ns


def secondary_rays(eye: Traced, sd, lum: Luminance, scene, eps) -> list[Rays]:
    """Golden's shadow, reflection and refraction rays of the eye hits (host/golden.py _shade)."""
    dt = sd.dtype
    h, p, ng, nsh = hit_points(eye, sd)
    if not len(h):
        return []
    d, w = eye.rays.d[:, h], eye.rays.w[:, h]
    pixel = eye.rays.pixel[h]
    inside = dot(d, ng) > 0
    nsh = np.where(inside, -nsh, nsh)
    mat = scene.material[eye.prim[h]]
    cosi = -dot(d, nsh)
    refl = normalize(d + (cosi + cosi) * nsh)
    out = []
    for li in range(len(lum.light_pos)):
        lv = lum.light_pos[li][:, None] - p
        dist = np.sqrt(dot(lv, lv))
        ld = lv / dist
        face = np.flatnonzero(dot(nsh, ld) > 0)
        n = len(face)
        out.append(Rays(p[:, face], ld[:, face], np.full(n, eps, dt), dist[face], np.full(n, SHADOW),
                        np.ones(n, np.int64), pixel[face], w[:, face]))
    r = np.flatnonzero(lum.ks[mat] > 0)
    out.append(Rays(p[:, r], refl[:, r], np.full(len(r), eps, dt), np.full(len(r), np.inf, dt),
                    np.full(len(r), REFLECTION), np.full(len(r), 2), pixel[r], w[:, r] * lum.ks[mat][r]))
    eta = np.where(inside, lum.ior[mat], lum.inv_ior[mat])
    k = dt(1) - (eta * eta) * (dt(1) - cosi * cosi)
    t = np.flatnonzero((lum.t[mat] > 0) & (k >= 0))
    if len(t):
        e, c = eta[t], cosi[t]
        tdir = normalize(e * d[:, t] + (e * c - np.sqrt(k[t])) * nsh[:, t])
        out.append(Rays(p[:, t], tdir, np.full(len(t), eps, dt), np.full(len(t), np.inf, dt),
                        np.full(len(t), REFRACTION), np.full(len(t), 2), pixel[t],
                        w[:, t] * lum.t[mat][t]))
    return out


# ---- the case: images, rays, golden's expectations ------------------------------------------------

@dataclass
class Case:
    name: str
    images: object
    sd: object
    traced: list[Traced]  # surface batches and shadow batches


# A sphere whose r^2 underflows to 0, the eye ray passing through its centre's neighbourhood:
# oc.oc (4.2e-45) is below the early rejection's lower guard EARLY_LO (1e-30), where its products
# are denormal and its margin proves nothing. Golden: disc = 0, a hit at t0 = -b; an early
# rejection without the guard: oc.oc K - b^2 = 1.4e-45 > r^2, a miss (issue 40). Below the scale
# renders accept (host/scale.py), so only the bench reaches it.
TINY_NFF = """
b 0 0 0
v
from 0 0 0
at 0.3 0.2 1
up 0 1 0
angle 30
hither 0
resolution 1 1
l 1 1 -1
f 1 1 1 1 0 0 0 1
p 4
-4 -4 6
4 -4 6
4 4 6
-4 4 6
s 2.667998894483294e-23 3.616216644534916e-23 4.5556770919054987e-23 1.1375540702937992e-23
"""

INLINE = {"cones": CONES_NFF, "patches": PATCH_NFF, "quads": QUADS_NFF, "quads4": QUADS4_NFF,
          "tiny": TINY_NFF}


@functools.lru_cache(maxsize=None)
def build_case(spec: str, precision: str = "fp32", res: int = 8, resident: float = 0.5,
               prepass: bool = False) -> Case:
    """Images with about `resident` of the shape records resident (1: all, 0: none; the
    records in priority order: ids, or a pre-pass's), and golden's rays and answers."""
    if spec in INLINE:
        scene = parse_nff(INLINE[spec], f"<{spec}>")
    else:
        scene = load_scene(str(SCENES / spec) if spec.endswith(".nff") else spec)
    config = load_config(None, [f"precision={precision}"])
    grid = build_grid(scene, config)
    sd = build_shape_data(scene, precision)
    priorities = run_prepass(scene, config, res=100, grid=grid).priorities if prepass else None
    order = np.argsort(priorities) if prepass else np.arange(scene.n_primitives)
    sizes = record_sizes(sd)[order]
    k = int(round(resident * len(sizes)))
    config.ic_memory.resident_bytes = int(sizes[:k].sum()) * word_format(precision).bytes
    images = build_images(scene, config, priorities=priorities, grid=grid)
    dt = dtype_of(precision)
    osg = OSGrid.of(grid, dt)
    lum = Luminance.of(scene, dt)
    eps = scene_epsilon(grid, config, dt)
    eye = primary_rays(scene.camera, res, False, precision)
    n = eye.direction.shape[1]
    rays = Rays(np.repeat(eye.origin[:, None], n, axis=1), eye.direction, np.full(n, eye.t_min, dt),
                np.full(n, np.inf, dt), np.full(n, EYE), np.ones(n, np.int64), np.arange(n),
                np.ones((3, n), dt))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        first = golden_trace(rays, osg, sd, shadow=False)
        sec = secondary_rays(first, sd, lum, scene, eps)
        traced = [first]
        surf = [r for r in sec if r.kind[0:1].tolist() != [SHADOW] and len(r)]
        shad = [r for r in sec if r.kind[0:1].tolist() == [SHADOW] and len(r)]
        if surf:
            traced.append(golden_trace(_cat(surf), osg, sd, shadow=False))
        if shad:
            traced.append(golden_trace(_cat(shad), osg, sd, shadow=True))
    return Case(spec, images, sd, traced)


@dataclass
class Expected:
    messages: list  # the host stream: VISIT_FIRST / VISIT messages for IC (two leaves each)
    answers: list  # (tag, slot) per message, in message order
    hits: list  # HIT payload words, in order
    stream: tuple  # (space, address) of every IC load
    refs: np.ndarray  # references per primitive


def expected(case: Case, slots: int = 3) -> Expected:
    """Messages to IC (rays interleaved over `slots` slots) and golden's answers."""
    images, sd = case.images, case.sd
    lay = images.layout
    wf = lay.wf
    dt = wf.float_type
    msgs, answers, hits, spaces, addrs = [], [], [], [], []
    refs = np.zeros(lay.n_primitives, np.int64)
    normals = {}
    for ti, tr in enumerate(case.traced):
        h, p, ng, ns = hit_points(tr, sd)
        for j, r in enumerate(h.tolist()):
            normals[(ti, r)] = (ng[:, j], ns[:, j])
    # every ray with at least one visit, interleaved in groups of `slots`; a message carries two
    # of its leaves (A, B) as OS's look-ahead sends them. B is the ray's next leaf; after its last
    # leaf, none (CELL_NONE) when the ray goes on at OS, or any leaf when it ends at IC in A
    # (here A's own list: IC must not walk it — its loads would show in the stream)
    jobs = [(ti, r) for ti, tr in enumerate(case.traced) for r in range(len(tr.rays)) if tr.visits[r]]
    for g in range(0, len(jobs), slots):
        group = jobs[g:g + slots]
        m = 0
        while True:
            live = [(k, ti, r) for k, (ti, r) in enumerate(group) if 2 * m < len(case.traced[ti].visits[r])]
            if not live:
                break
            for k, ti, r in live:
                tr = case.traced[ti]
                ray = tr.rays
                slot = (g // slots + 2 * k) % 8
                visits = tr.visits[r]
                pair = visits[2 * m:2 * m + 2]
                last = 2 * m + len(pair) == len(visits)
                hit = int(tr.prim[r]) if last and ray.kind[r] != SHADOW else -1
                at_ic = last and (hit >= 0 or (ray.kind[r] == SHADOW and tr.occluded[r]))
                cell = int(lay.leaf_cell[pair[0][0]])
                if len(pair) == 2:
                    second = [int(lay.leaf_cell[pair[1][0]]), dt(pair[1][1])]
                elif at_ic:
                    second = [cell, dt(pair[0][1])]
                else:
                    second = [PROTO["CELL_NONE"], dt(0)]
                if m == 0:
                    info = int(ray.kind[r]) + (int(ray.depth[r]) << PROTO["INFO_DEPTH_SHIFT"])
                    fields = [slot, cell, dt(pair[0][1]), int(ray.pixel[r]), info,
                              *[dt(x) for x in ray.o[:, r]], *[dt(x) for x in ray.d[:, r]],
                              dt(ray.t_min[r]), dt(ray.t_max[r]), *[dt(x) for x in ray.w[:, r]], *second]
                    msgs.append(encode_message(wf, "ic", PROTO["TAG_VISIT_FIRST"], fields))
                else:
                    msgs.append(encode_message(wf, "ic", PROTO["TAG_VISIT"],
                                               [slot, cell, dt(pair[0][1]), *second]))
                if at_ic:
                    answers.append(("DONE", slot))
                else:
                    answers.append(("NEXT", slot))
                if hit >= 0:
                    ngr, nsr = normals[(ti, r)]
                    words = [int(ray.pixel[r]), int(info_of(ray, r))]
                    words += [wf.from_float(dt(x)) for x in (*ray.o[:, r], *ray.d[:, r], *ray.w[:, r],
                                                            tr.t[r], *ngr, *nsr)]
                    words += [int(lay.luminance_pointer[hit]), hit]
                    hits.append(words)
                for q, (leaf, t_exit, prims) in enumerate(pair):
                    h = hit if last and q == len(pair) - 1 else -1
                    pr = np.asarray(prims, np.int64)
                    np.add.at(refs, pr, 1)
                    sp, ad = ic_address_stream(lay, pr, np.full(len(pr), leaf), np.array([0, len(pr)]),
                                               np.array([h]), np.array([int(tr.fan[r]) if h >= 0 else 0]))
                    spaces.append(sp)
                    addrs.append(ad)
            m += 1
    stream = (np.concatenate(spaces), np.concatenate(addrs))
    return Expected(msgs, answers, hits, stream, refs)


def info_of(ray: Rays, r: int) -> int:
    return int(ray.kind[r]) + (int(ray.depth[r]) << PROTO["INFO_DEPTH_SHIFT"])


# ---- running IC ----------------------------------------------------------------------------------

KERNEL_DIR = KERNELS


def assemble(images, generic: bool = False, paper_order: bool = False):
    defines = dict(images.symbols)
    if generic:
        defines.update({k: 1 for k in defines if k.startswith("HAS_")})
    defines["SLOTS"] = 8
    if paper_order:  # the kernel's loads are then the protocol's stream, load for load
        defines.update(PAPER_ORDER)
    return assemble_file(KERNEL_DIR / "ic.s", proc="ic", defines=defines, include_dirs=[KERNEL_DIR])


@dataclass
class Outcome:
    answers: list
    hits: list
    stream: tuple | None  # None: the engine does not go through the recorded MemorySystem.load
    paper_order: bool     # assembled in the paper's load order: the stream is the protocol's
    primitives: dict
    cycles: int
    status: str
    stats: dict


def run_ic(case: Case, exp: Expected, generic: bool = False, monkeypatch=None,
           engine: str = "reference", paper_order: bool = False) -> Outcome:
    images = case.images
    wf = images.layout.wf
    log: list[tuple[str, int]] = []
    orig = MemorySystem.load

    def load(self, space, address):
        if self.proc == "ic" and space != "local":
            log.append((space, address))
        return orig(self, space, address)

    program = assemble(images, generic, paper_order)
    monkeypatch.setattr(MemorySystem, "load", load)
    try:
        run = run_stage("ic", program, exp.messages, images.config, images.memory_image(),
                        engine=engine)
    finally:
        monkeypatch.setattr(MemorySystem, "load", orig)
    if run.result.status != "finished":
        return Outcome([], [], ([], []), paper_order, {}, run.result.cycles, run.result.status, {})
    answers, hits = [], []
    for m in run.received["os"]:
        h = parse_header(m[0])
        name = {PROTO["TAG_NEXT"]: "NEXT", PROTO["TAG_DONE"]: "DONE"}.get(h.tag, f"tag{h.tag}")
        assert h.cls == PROTO["CLS_ANSWER"] and h.length == 1, f"{name}: class {h.cls}"
        answers.append((name, wf.to_int(m[1])))
    for m in run.received["sc"]:
        h = parse_header(m[0])
        assert (h.tag, h.length, h.cls) == (PROTO["TAG_HIT"], PROTO["LEN_HIT"], PROTO["CLS_WORK"])
        words = [int(w) for w in m[1:]]
        for i in (0, 1, -2, -1):
            words[i] = wf.to_int(words[i])
        hits.append(words)
    statistics = run.statistics()
    mem = statistics["memory"]["pe0.ic"]
    prims = {int(k): v for k, v in mem.get("primitives", {}).items()}
    stats = statistics["processors"]["pe0.ic"]
    stream = None
    if engine == "reference" or log:
        space = np.array([GLOBAL if s == "global" else RESIDENT for s, _ in log], np.int8)
        addr = np.array([a for _, a in log], np.int64)
        stream = (space, addr)
    return Outcome(answers, hits, stream, paper_order, prims, run.result.cycles, "finished", stats)


def check(case: Case, exp: Expected, out: Outcome) -> None:
    assert out.status == "finished", out.status
    if out.answers != exp.answers:  # not a rewritten assert: pytest's diff of two long lists is
        # quadratic (minutes on balls:2 at 8x8 with a mutant)
        k = next((i for i, (a, b) in enumerate(zip(out.answers, exp.answers)) if a != b),
                 min(len(out.answers), len(exp.answers)))
        raise AssertionError(f"answer {k} of {len(exp.answers)} differs: "
                             f"{out.answers[k:k + 1]} against {exp.answers[k:k + 1]}"
                             f" ({len(out.answers)} answers given)")
    assert len(out.hits) == len(exp.hits)
    for k, (got, want) in enumerate(zip(out.hits, exp.hits)):
        assert got == want, f"HIT {k}: {hit_diff(got, want)}"
    if out.stream is not None and out.paper_order:
        sp, ad = exp.stream
        assert len(out.stream[0]) == len(sp), f"{len(out.stream[0])} loads, protocol says {len(sp)}"
        assert np.array_equal(out.stream[1], ad) and np.array_equal(out.stream[0], sp)
    elif out.stream is not None:  # record words: only the protocol's (some not read); cells: at least
        lay = case.images.layout
        got, want = (Counter(zip(st[0].tolist(), st[1].tolist())) for st in (out.stream, exp.stream))

        def in_lists(key) -> bool:  # a list word: ICGM below the first record
            return key[0] == GLOBAL and key[1] < lay.shape_base

        assert all(got[k] <= n for k, n in want.items() if not in_lists(k)), "a record word read too often"
        assert all(k in want or in_lists(k) for k in got), "a word the protocol does not read"
        assert all(got[k] >= n for k, n in want.items() if in_lists(k)), "a list cell not read"
    want = {p: int(n) for p, n in enumerate(exp.refs) if n}
    assert out.primitives == want


HIT_FIELDS = ["pixel", "info", "ox", "oy", "oz", "dx", "dy", "dz", "wr", "wg", "wb", "t",
              "ngx", "ngy", "ngz", "nsx", "nsy", "nsz", "lum", "id"]


def hit_diff(got, want) -> str:
    return ", ".join(f"{n}: {g:#x} != {w:#x}" for n, g, w in zip(HIT_FIELDS, got, want) if g != w)


# ---- tests -----------------------------------------------------------------------------------------

# (scene, precision, eye rays per axis, resident share of the records, pre-pass priorities)
CASES = [
    ("tetra:3", "fp32", 12, 0.5, True),        # triangles
    ("balls:2", "fp32", 8, 0.5, True),         # spheres + a quad
    ("rings:2", "fp32", 8, 0.5, False),        # cylinders, spheres, a quad
    ("cones", "fp32", 10, 0.5, False),         # cones, cylinders, spheres; two-sided ones
    ("patches", "fp32", 10, 0.5, False),       # pp patches: shading normals, fan j > 0, concave
    ("quads", "fp32", 9, 0.5, False),          # n-gons, shared edges and vertex
    ("quads4", "fp32", 9, 0.5, False),         # quads only (their own test), the same ties
    ("shared_edge.nff", "fp32", 9, 0.5, False),
    ("grazing_sphere.nff", "fp32", 9, 0.0, False),     # cache only: no ldr code assembled
    ("far_tiny_sphere.nff", "fp32", 5, 1.0, False),    # resident only: no ldg shape code
    ("balls:2", "fp64", 6, 0.5, True),
    ("cones", "fp64", 8, 0.5, False),
    ("patches", "fp64", 8, 0.5, False),
    ("quads", "fp64", 9, 0.5, False),
]
GENERIC = {"cones", "patches", "quads", "quads4", "shared_edge.nff"}


def case_id(c) -> str:
    return f"{c[0]}-{c[1]}"


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
@pytest.mark.parametrize("spec,precision,res,resident,prepass", CASES, ids=[case_id(c) for c in CASES])
def test_ic_matches_golden(spec, precision, res, resident, prepass, monkeypatch, engine_name):
    case = build_case(spec, precision, res, resident, prepass)
    exp = expected(case)
    lay = case.images.layout
    assert exp.answers and exp.hits, "no visits or no hits: the case tests nothing"
    if 0 < resident < 1:
        assert 0 < lay.resident_count < lay.n_primitives
        assert set(exp.stream[0].tolist()) == {GLOBAL, RESIDENT}, "both memories are read"
    out = run_ic(case, exp, monkeypatch=monkeypatch, engine=engine_name)
    check(case, exp, out)
    if engine_name == "reference":  # (the stream is recorded there): the paper's order, exactly
        paper = run_ic(case, exp, monkeypatch=monkeypatch, engine=engine_name, paper_order=True)
        check(case, exp, paper)
        assert (paper.answers, paper.hits) == (out.answers, out.hits)
    if spec in GENERIC and precision == "fp32":
        generic = run_ic(case, exp, generic=True, monkeypatch=monkeypatch, engine=engine_name)
        check(case, exp, generic)
        assert (generic.answers, generic.hits) == (out.answers, out.hits)


@pytest.mark.parametrize("resident", [1.0, 0.0])
def test_the_early_rejection_keeps_its_lower_guard(resident, monkeypatch, engine_name):
    """oc.oc < EARLY_LO: the sphere's early rejection must stand aside (its guard s_g1 once
    shared r40 with s_Zt, which overwrote it: the test missed this sphere)."""
    case = build_case("tiny", "fp32", 1, resident)
    exp = expected(case)
    assert exp.answers == [("DONE", 0)] and len(exp.hits) == 1, "golden hits the tiny sphere"
    check(case, exp, run_ic(case, exp, monkeypatch=monkeypatch, engine=engine_name))


def test_cases_cover_the_hard_parts():
    """The scenes above reach what they are there for (golden's side of it)."""
    seen = {}
    for spec, res, prepass in (("cones", 10, False), ("patches", 10, False), ("balls:2", 8, True)):
        case = build_case(spec, "fp32", res, 0.5, prepass)
        sd = case.sd
        for tr in case.traced:
            h = np.flatnonzero(tr.prim >= 0)
            kinds = set(sd.kind[tr.prim[h]].tolist())
            seen.setdefault(spec, set()).update(f"kind{k}" for k in kinds)
            if sd.two_sided[tr.prim[h]].any():
                seen[spec].add("two-sided hit")
            if (tr.fan[h] > 0).any():
                seen[spec].add("fan > 0")
            if tr.occluded.any():
                seen[spec].add("occluded")
            if (tr.rays.kind == REFRACTION).any() and len(h):
                seen[spec].add("refraction hit")
    assert {"kind1", "kind2", "kind3", "two-sided hit", "occluded", "refraction hit"} <= seen["cones"]
    assert {"kind0", "fan > 0"} <= seen["patches"]
    assert {"kind0", "kind1", "occluded"} <= seen["balls:2"]


# Mutations of the kernel the bench must catch (each scene is there for its case).
MUTANTS = [
    ("grazing_sphere.nff", 9, 0.0, "ic_sphere.inc",          # a tangent ray (disc = 0) hits
     "fle s_real, r0, s_disc", "flt s_real, r0, s_disc"),
    ("shared_edge.nff", 9, 0.5, "ic_polygon.inc",            # triangles: tie-break on dy / dx
     "fsel t_i01, t_y01, t_dx01, t_dy01", "fsel t_i01, t_y01, t_dy01, t_dx01"),
    ("quads", 9, 0.5, "ic_polygon.inc",                      # n-gons: tie-break of E0
     "fsel q_dy0, q_z0, q_dy0, q_e0 }", "fmov q_dy0, q_e0 }"),
    ("patches", 10, 0.5, "ic_polygon.inc",                   # patch barycentrics: b0 = (1 - b1) - b2
     "fsub ph_b0, ph_b0, ph_b2", "fadd ph_b0, ph_b0, ph_b2"),
    ("cones", 10, 0.5, "ic_cone.inc",                        # the cone's entering test
     "flt k_e0, k_e0, r0", "flt k_e0, r0, k_e0"),
    ("tetra:3", 12, 0.5, "ic.s",                              # resident when |P| <= M
     "{ li mlim, 2 * RESIDENT_M + 1 }", "{ li mlim, 2 * RESIDENT_M }"),
    ("balls:2", 8, 0.5, "ic.s",                              # early rejection with a margin the
     ".equ EARLY_K, 0.999755859375", ".equ EARLY_K, 1.25"),   #   wrong way: hits near the rim lost
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # the cylinder's early rejection
     "fadd c_q3, c_r2, c_q3", "fsub c_q3, c_r2, c_q3"),      #   with its margin the wrong way
    ("rings:2", 4, 0.5, "ic_cylinder.inc",                   # ... going on to a next cell
     "fadd c_q6, c_q3, c_thr", "fmov c_q6, c_q3"),           #   after the last one
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # ... rejecting the last cell's
     "flt c_q5, c_q3, c_q1", "flt c_q5, c_q1, c_q3"),        #   hits
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # the range rejection: zB below the
     "flt c_zlo, c_zs, c_zlo", "flt c_zlo, c_zlo, c_zs"),    #   base taken the wrong way
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # ... the far side's squares
     "flt c_mr, c_mr, c_md", "flt c_mr, c_md, c_mr"),        #   compared the wrong way
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # ... zB's verdict without the quotient
     "    flt c_dV, c_dS, c_dV", "    flt c_dV, c_dV, c_dS"),  #   (AXIAL_BEHIND) the wrong way
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # ... -s <= t_min the wrong way
     "fle c_ztm, c_ns, c_ztm", "fle c_ztm, c_ztm, c_ns"),
    ("grazing_sphere.nff", 9, 0.0, "ic_sphere.inc",          # the sphere's range rejection:
     "fle s_a0, s_U, r0", "fle s_a0, r0, s_U"),              #   t0 <= t_min the wrong way
    ("balls:2", 8, 0.5, "ic_sphere.inc",                     # ... t0 beyond L the wrong way
     "flt s_cB, s_dK, s_V2", "flt s_cB, s_V2, s_dK"),
    ("quads4", 9, 0.5, "ic_polygon.inc",                     # the quadrilateral's plane
     "fle v_qb, tres, lim", "fle v_qb, lim, tres"),          #   rejection: t <= t_exit reversed
    ("quads4", 9, 0.5, "ic_polygon.inc",                     # ... its sign rejection (beside the
     "    flt v_s0, v_sg, r0\n", "    flt v_s0, r0, v_sg\n"),  #   division) the wrong way
    ("quads4", 9, 0.5, "ic_polygon.inc",                     # quads: tie-break dy before dx
     "fsel \\i, \\b, v_w, \\i", "fsel \\i, \\b, \\i, v_w"),
    ("quads4", 9, 0.5, "ic_polygon.inc",                     # quads: the second fan triangle
     "fsel v_c3, v_n12, r0, v_n03", "fsel v_c3, v_n12, r0, v_n02"),
    ("grazing_sphere.nff", 9, 0.0, "ic_sphere.inc",          # the sphere's going on to a next
     "fsel s_Zm, s_g1, s_Zt, pinf", "fsel s_Zm, s_g1, s_r2, pinf"),  # cell after the last one
    ("grazing_sphere.nff", 9, 0.0, "ic_sphere.inc",          # ... rejecting the last cell's hits
     "flt s_eno, s_Zg, s_E", "flt s_eno, s_E, s_Zg"),
    ("rings:2", 8, 0.5, "ic.s",                              # the next cell read ahead from the
     "    fsel padr, \\more, cell, padr", "    fsel padr, \\more, padr, cell"),  # wrong cell
    ("rings:2", 8, 0.5, "ic.s",                              # ... its memory taken the wrong way
     "{ bltu padr, mlim, rec_r ; fmov shp, nshp }", "{ bgeu padr, mlim, rec_r ; fmov shp, nshp }"),
    ("balls:2", 8, 0.5, "ic.s",                              # the winner's S, kept in `winner`
     "    { st shp, [winner + 1] }", "    { st pri, [winner + 1] }"),
    ("tetra:3", 12, 0.5, "ic_polygon.inc",                   # the triangle's normal, read late:
     "\\ld r62, [shp + (POLY_NORMAL + 2)]", "\\ld r62, [shp + (POLY_NORMAL + 1)]"),  # a wrong word
    ("rings:2", 8, 0.5, "ic_cylinder.inc",                   # the cylinder's L, read late: the
     "through)\n    \\ld c_len, [shp + CYL_LENGTH]", "through)\n    \\ld c_len, [shp + CYL_R2]"),  # wrong word
]


@pytest.mark.parametrize("spec,res,resident,file,old,new", MUTANTS, ids=[f"{m[0]}:{m[3]}" for m in MUTANTS])
def test_the_bench_catches_a_wrong_kernel(spec, res, resident, file, old, new, tmp_path, monkeypatch):
    for f in list(KERNELS.glob("ic*")) + [KERNELS / "protocol.inc"]:
        (tmp_path / f.name).write_text(f.read_text())
    src = (tmp_path / file).read_text()
    assert src.count(old) == 1, f"mutation target not found once in {file}: {old}"
    (tmp_path / file).write_text(src.replace(old, new))
    case = build_case(spec, "fp32", res, resident, spec == "tetra:3")   # as in CASES
    exp = expected(case)
    monkeypatch.setattr(sys.modules[__name__], "KERNEL_DIR", tmp_path)
    out = run_ic(case, exp, monkeypatch=monkeypatch)
    with pytest.raises(AssertionError):
        check(case, exp, out)
