"""The hard numerical cases, each in fp32 and fp64, on the tiny scenes in tests/scenes/ (kept for
the kernel writers): grazing tangent rays, shared edges and vertices, a far tiny sphere,
axis-parallel rays on voxel boundaries, self-intersection of secondary rays, total internal
reflection. Also: fp32 stays fp32 (no silent float64 promotion).

Then issue 13's catalog (netsushisen/numerics.py): every case on golden fp32, golden fp64 and
the machine (both engines), judged against the brute-force float64 oracle; the translated scenes
(1e3..1e6); randomised re-intersection from points on spheres, cylinders and triangles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netsushisen import numerics
from netsushisen.host import golden
from netsushisen.host.golden import render
from netsushisen.host.grid import build_grid
from netsushisen.host.nff import parse_nff, read_nff
from netsushisen.host.oracle import offset_bound
from netsushisen.host.rays import primary_rays
from netsushisen.host.shapes import build_shape_data, ic_rays, intersect, surface_normals
from netsushisen.host.traversal import OSGrid, trace
from netsushisen.isa.config import load_config

SCENES = Path(__file__).parent / "scenes"
PRECISIONS = ["fp32", "fp64"]


def config(precision, *extra):
    return load_config(None, [f"precision={precision}", *extra])


def trace_rays(scene, precision, o, d, t_min=0.0, cfg=None, **kw):
    dt = np.float32 if precision == "fp32" else np.float64
    grid = build_grid(scene, cfg or config(precision))
    sd = build_shape_data(scene, precision)
    o = np.ascontiguousarray(np.asarray(o, np.float64).T.astype(dt))
    d = np.asarray(d, np.float64)
    d = np.ascontiguousarray((d / np.linalg.norm(d, axis=1, keepdims=True)).T.astype(dt))
    return trace(OSGrid.of(grid, dt), sd, ic_rays(o, d, np.full(o.shape[1], t_min, dt)), **kw), grid


@pytest.mark.parametrize("precision", PRECISIONS)
def test_grazing_ray_tangent_to_sphere(precision):
    sc = read_nff(SCENES / "grazing_sphere.nff")  # sphere centre (1,0,0) r=1; x=0 is tangent
    tr, _ = trace_rays(sc, precision, [[0, 0, -5], [-1e-3, 0, -5], [1e-3, 0, -5]], [[0, 0, 1]] * 3)
    assert tr.prim[0] == 0 and tr.t[0] == 5.0  # disc = 0 exactly: a hit at the tangent point
    assert tr.prim[1] == -1 and tr.prim[2] == 0
    r = render(sc, config(precision), res=5)
    assert r.hit_ids[2, 2] == 0 and r.hit_ids[2, 1] == -1
    assert np.isfinite(r.image).all()


@pytest.mark.parametrize("precision", PRECISIONS)
def test_shared_edges_and_vertex_hit_exactly_one_triangle(precision):
    sc = read_nff(SCENES / "shared_edge.nff")  # 8 triangles fanned around the origin
    r = render(sc, config(precision), res=5)
    inner = r.hit_ids[1:4, 1:4]
    assert np.all(inner >= 0)  # no cracks: the central ray passes exactly through the shared vertex
    # a fine set of rays along the spokes and through the vertex from many directions
    s = np.linspace(-1.5, 1.5, 13)
    pts = np.concatenate([np.column_stack([s, 0 * s]), np.column_stack([0 * s, s]),
                          np.column_stack([s, s]), np.column_stack([s, -s])])
    o = np.column_stack([pts, np.full(len(pts), -4.0)])
    for d in ([0, 0, 1], [0.2, 0.1, 1], [-0.3, 0.25, 1]):
        oo = o - 4.0 * np.array([d[0], d[1], 0.0])
        tr, _ = trace_rays(sc, precision, oo, [d] * len(oo), keep_refs=True)
        assert np.all(tr.prim >= 0), pts[tr.prim < 0]
        # exactly one claimant per ray: test every primitive for every ray
        sd = build_shape_data(sc, precision)
        dt = sd.dtype
        dd = np.tile(np.asarray(d, np.float64) / np.linalg.norm(d), (len(oo), 1))
        rays = ic_rays(np.ascontiguousarray(oo.T.astype(dt)), np.ascontiguousarray(dd.T.astype(dt)),
                       np.zeros(len(oo), dt))
        ri = np.repeat(np.arange(len(oo)), 8)
        h = intersect(sd, rays, ri, np.tile(np.arange(8), len(oo)))
        assert np.all(np.isfinite(h.t).reshape(-1, 8).sum(axis=1) == 1)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_far_tiny_sphere_is_hit_where_expected(precision):
    sc = read_nff(SCENES / "far_tiny_sphere.nff")  # r = 1e-3 at distance 1e4
    off = np.array([[0, 0], [9e-4, 0], [0, -9e-4], [6e-4, 6e-4], [1.1e-3, 0], [8e-4, 8e-4], [0, 1.2e-3]])
    d = np.column_stack([off, np.full(len(off), 1e4)])
    tr, _ = trace_rays(sc, precision, np.zeros((len(off), 3)), d)
    assert list(tr.prim) == [0, 0, 0, 0, -1, -1, -1]
    assert tr.t[0] == pytest.approx(1e4 - 1e-3, rel=1e-7)
    r = render(sc, config(precision), res=5)
    assert (r.hit_ids >= 0).sum() == 21  # all but the four corner samples (|offset| = 1.23e-3)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_axis_parallel_rays_through_voxel_boundaries(precision):
    sc = read_nff(SCENES / "axis_parallel.nff")  # 3x3 spheres on integer points, a back wall
    cfg = config(precision, "grid.top_resolution=6", "grid.subdivide_threshold=1", "grid.sub_resolution=2")
    grid = build_grid(sc, cfg)
    b = grid.lo + np.arange(7)[:, None] * grid.cell  # boundary coordinates per axis
    o, d = [], []
    for x in b[:, 0]:
        for y in b[:, 1]:
            o.append([x, y, -10.0])
            d.append([0.0, 0.0, 1.0])
            o.append([x, -10.0, 0.0])
            d.append([-0.0, 1.0, -0.0])
    tr, _ = trace_rays(sc, precision, o, d, cfg=cfg, keep_visits=True)
    hit = tr.prim >= 0
    assert np.isfinite(tr.t[hit]).all() and not np.isnan(tr.t).any()
    # a ray down the z axis through x=y=0 must hit sphere 4 (centre 0,0,0) at t = 9.5
    zero = np.flatnonzero((np.abs(np.asarray(o)[:, 0]) < 1e-12) & (np.abs(np.asarray(o)[:, 1]) < 1e-12))
    for i in zero:
        assert tr.prim[i] == 4 and tr.t[i] == pytest.approx(9.5)
    assert np.all(tr.visits[:, 1] >= 0) and np.all(tr.visits[:, 1] < 216)
    r = render(sc, config(precision), res=9)
    assert r.hit_ids[4, 4] == 4 and np.isfinite(r.image).all()


MIRRORS = """v
from 0 0 -5
at 0 0 0
up 0 1 0
angle 50
hither 0
resolution 8 8
l 3 4 -6
l -3 2 -6
"""


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("body", [
    "f 1 1 1 0.5 0.5 20 0 1\ns 0 0 0 1.5\n",  # mirror sphere alone
    "f 1 1 1 0.5 0.5 20 0 1\np 4\n-3 -3 0\n-3 3 0\n3 3 0\n3 -3 0\n",  # mirror square alone
    "f 1 1 1 0.5 0.5 20 0 1\np 4\n-3 -3 0.3\n-3 3 0.3\n3 3 0.3\n3 -3 0.3\nc 0 -1 -1 0.4 0 1 -1 0.4\n",
])
def test_no_self_intersection_of_secondary_rays(precision, body):
    sc = parse_nff(MIRRORS + body, filename="mirrors.nff")
    r = render(sc, config(precision), res=24, keep_trace=True)
    # every reflection ray leaves the convex mirror it starts on: a second bounce would need another
    # object in front; alone, each mirror hit spawns exactly one reflection ray that escapes
    if sc.n_primitives == 1:
        assert r.rays["reflection"] == r.rays["eye_hits"]
    # no shadow ray is blocked by the surface it starts on: nothing lies between a lone mirror
    # and the lights, so every surface point facing a light is lit
    kinds = r.trace_kind
    assert (kinds == 1).sum() == r.rays["reflection"]
    assert np.isfinite(r.image).all()
    # shadow rays from the hit points toward every light the surface faces are never blocked by
    # the surface they start on (t_min = epsilon x scene size, as SC sets it)
    dt = np.float32 if precision == "fp32" else np.float64
    pr = primary_rays(sc.camera, 24, precision=precision)
    n = pr.direction.shape[1]
    o = np.repeat(pr.origin[:, None].astype(np.float64), n, 1).T
    tr, grid = trace_rays(sc, precision, o, pr.direction.T.astype(np.float64))
    hit = np.flatnonzero(tr.prim >= 0)
    p = (pr.origin[:, None] + tr.t[hit] * pr.direction[:, hit]).T.astype(np.float64)
    eps = float(dt(1e-4 * float(np.max(grid.hi - grid.lo))))
    for light in sc.light_position:
        to = light - p
        dist = np.linalg.norm(to, axis=1)
        st, _ = trace_rays(sc, precision, p, to, t_min=eps, t_max=dist.astype(dt))
        if sc.n_primitives == 1:  # a lone convex mirror: its points facing a light see it
            faces = _faces(sc, p, to)
            assert faces.sum() > 10 and not st.occluded[faces].any()


def _faces(sc, p, to):
    """Surface points whose outward normal has a positive component toward the light."""
    if sc.kind[0] == 1:
        n = p - sc.spheres.center[0]
    else:
        n = np.tile([0.0, 0.0, -1.0], (len(p), 1))
    return np.einsum("ij,ij->i", n, to) > 0


@pytest.mark.parametrize("precision", PRECISIONS)
def test_glass_sphere_refraction_rays_reach_the_far_wall(precision):
    sc = parse_nff(MIRRORS + "f 1 1 1 0.1 0.1 20 0.9 1.5\ns 0 0 0 1.5\n", filename="glass.nff")
    r = render(sc, config(precision, "render.max_depth=2"), res=16)
    # depth 2 rays: one reflection (escapes) and one refraction (hits the far wall) per eye hit
    assert r.rays["reflection"] == r.rays["eye_hits"] == r.rays["refraction"]
    r3 = render(sc, config(precision, "render.max_depth=3"), res=16)
    # at depth 3 every internal refraction ray hit the far wall, and spawned both kinds again
    # (unless total internal reflection cut the refraction ray)
    assert r3.rays["reflection"] == 2 * r.rays["eye_hits"]


@pytest.mark.parametrize("precision", PRECISIONS)
def test_total_internal_reflection_spawns_reflection_but_no_refraction(precision):
    sc = read_nff(SCENES / "total_internal_reflection.nff")  # eye inside a glass sphere, 64 deg incidence
    r = render(sc, config(precision), res=1)
    assert r.rays["eye_hits"] == 1
    assert r.rays["refraction"] == 0 and r.rays["reflection"] == 4  # depths 2..5, all TIR
    # from the centre every incidence is normal: no TIR, both rays at every depth
    sc2 = parse_nff(MIRRORS.replace("from 0 0 -5", "from 0 0 0").replace("at 0 0 0", "at 0 0 1")
                    .replace("resolution 8 8", "resolution 1 1") + "f 1 1 1 0.1 0.1 100 0.9 1.5\ns 0 0 0 1\n",
                    filename="centre.nff")
    r2 = render(sc2, config(precision), res=1)
    assert r2.rays["refraction"] == 4 and r2.rays["reflection"] == 4


@pytest.mark.parametrize("precision", PRECISIONS)
def test_precision_is_kept_end_to_end(precision):
    dt = np.float32 if precision == "fp32" else np.float64
    sc = parse_nff(MIRRORS + "f 1 1 1 0.1 0.1 20 0.9 1.5\ns 0 0 0 1.5\n", filename="glass.nff")
    pr = primary_rays(sc.camera, 4, corners=True, precision=precision)
    assert pr.direction.dtype == dt and pr.origin.dtype == dt and pr.direction.shape == (3, 25)
    sd = build_shape_data(sc, precision)
    assert sd.sph_r2.dtype == dt and sd.poly_vertices.dtype == dt
    r = render(sc, config(precision), res=4, corners=True)
    assert r.image.dtype == dt and r.hit_ids.shape == (5, 5)


# ------------------------------------------------------------------------------------------------
# The catalog (issue 13): every hard case on golden fp32, golden fp64 and the machine, judged
# against the brute-force float64 oracle (host/oracle.py) with its tolerance rule.

CASES = {c.name: c for c in numerics.CATALOG}


def _verdict(case, path, res=None):
    (v,) = numerics.run_catalog([path], [case], res=res)
    return v


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("name", list(CASES))
def test_catalog_on_the_golden_model(name, precision):
    v = _verdict(CASES[name], f"golden-{precision}")
    assert v.rays > 0
    assert v.stable, f"{name} golden {precision}: {v.reason()}"
    if CASES[name].shadows and name not in ("tiny_triangle_far",):
        assert v.shadow_rays > 0  # the shadow-ray judgement is not vacuous


MACHINE_RES = {"reference": 3}
"""The machine renders each case at this size on the slow engines (6 or the case's own on the rest)."""
LIGHT = ("far_tiny_sphere", "grazing_sphere", "shared_edge_fan", "axis_parallel", "origin_on_grid_face")
"""Cases whose [reference] run stays in the default suite; the others are `heavy` (their [reference]
run is under -m slow by tests/conftest.py's rule, [compiled] runs every case by default, and
tests/test_engine_identity.py holds the two engines to identical outputs)."""


def _machine_case(name, engine_name):
    """The machine equals golden fp32 bit for bit (hit ids, 8-bit image, ray counts) and its hits
    pass the oracle; translated cases keep the untranslated scene's hit ids."""
    v = _verdict(CASES[name], f"emulator-{engine_name}", res=MACHINE_RES.get(engine_name, 6))
    assert v.rays > 0
    assert v.stable, f"{name} on {engine_name}: {v.reason()}"


@pytest.mark.parametrize("name", LIGHT)
def test_catalog_on_the_machine(name, engine_name):
    _machine_case(name, engine_name)


@pytest.mark.heavy
@pytest.mark.parametrize("name", [n for n in CASES if n not in LIGHT])
def test_catalog_on_the_machine_heavy(name, engine_name):
    _machine_case(name, engine_name)


@pytest.mark.parametrize("translation", numerics.TRANSLATIONS)
def test_translated_scenes_keep_hit_ids_and_no_shadow_acne(translation):
    """The issue's scene moved by 1e3..1e6: hit ids equal the untranslated scene's, and no shadow
    ray the oracle calls free is blocked, in golden fp32 (the machine: test above)."""
    case = CASES[f"translated_{translation:.0e}".replace("+0", "")]
    plain = numerics.run_path(numerics.Case("plain", "", numerics.MIXED).scene(), "golden-fp32", case.res)
    moved = numerics.run_path(case.scene(), "golden-fp32", case.res)
    assert np.array_equal(plain.hit_ids, moved.hit_ids)
    v = numerics.judge(case.scene(), moved, case.res, "fp32")
    assert v.shadow_rays > 100 and v.wrongly_blocked == 0 and v.wrongly_lit == 0, v.reason()


def test_the_judge_catches_a_crack_and_acne():
    """The verdicts can fail: a hit id turned into background on a shared edge is a wrong hit;
    a shadow ray of a lit floor pixel marked blocked is a wrongly blocked shadow ray."""
    case = CASES["shared_edge_fan"]
    sc = case.scene()
    r = numerics.run_path(sc, "golden-fp32", case.res)
    centre = (case.res * case.res) // 2  # the ray through the shared vertex
    assert r.hit_ids[centre] >= 0
    r.hit_ids[centre] = -1
    assert numerics.judge(sc, r, case.res, "fp32", shadows=False).wrong_hits == 1
    case = CASES["self_intersection"]
    sc = case.scene()
    r = numerics.run_path(sc, "golden-fp32", case.res)
    v0 = numerics.judge(sc, r, case.res, "fp32")
    lit = np.flatnonzero(~r.shadows["blocked"] & (r.shadows["prim"] == 0))[:3]
    r.shadows["blocked"][lit] = True
    v1 = numerics.judge(sc, r, case.res, "fp32")
    assert v0.wrongly_blocked == 0 and 1 <= v1.wrongly_blocked <= 3


# ------------------------------------------------------------------------------------------------
# Randomised re-intersection (pbrt-v4's manner): random magnitudes for positions and sizes; a ray
# leaving a surface point from the offset origin never hits that surface again.

def _one(nff_body):
    return parse_nff("v\nfrom 0 0 -1\nat 0 0 0\nup 0 1 0\nangle 30\nhither 0\nresolution 1 1\n"
                     "f 1 1 1 1 0 1 0.5 1.5\n" + nff_body, filename="one.nff")


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def _reintersect(sc, o, target, out_dir, precision):
    """Shoot from o at `target` on the surface; from the hit, leave along out_dir (flipped to the
    side the ray came from) from the front offset origin; return (hit?, t of the re-hit)."""
    dt = np.float32 if precision == "fp32" else np.float64
    grid = build_grid(sc, config(precision))
    sd = build_shape_data(sc, precision)
    o32 = np.asarray(o, np.float64).astype(dt)[:, None]
    d32 = _unit(np.asarray(target, np.float64) - o).astype(dt)[:, None]
    h = intersect(sd, ic_rays(o32, d32, np.zeros(1, dt)), np.zeros(1, int), np.zeros(1, int))
    if not np.isfinite(h.t[0]):
        return False, None
    t = h.t
    p = o32 + t * d32
    ng, _ = surface_normals(sd, np.zeros(1, int), p, h.fan, h.b1, h.b2)
    inside = golden.dot(d32, ng) > 0
    front, _ = golden.offset_vectors(p, t, ng, inside, golden.offset_scale(dt),
                                     golden.scene_epsilon(grid, None, dt))
    facing = np.where(inside, -ng, ng)[:, 0].astype(np.float64)
    w = _unit(out_dir)
    if w @ facing < 0:
        w = w - 2 * (w @ facing) * facing  # mirror into the hemisphere the ray came from
    w32 = _unit(w).astype(dt)[:, None]
    h2 = intersect(sd, ic_rays(front, w32, np.zeros(1, dt)), np.zeros(1, int), np.zeros(1, int))
    return True, h2.t[0]


_exp = st.floats(-3, 5)
_vec = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=60, deadline=None)
@given(c_exp=_exp, r_exp=st.floats(-2, 3), cdir=_vec, pdir=_vec, odir=_vec, o_exp=st.floats(0, 1),
       out=_vec, precision=st.sampled_from(PRECISIONS))
def test_random_sphere_reintersection(c_exp, r_exp, cdir, pdir, odir, o_exp, out, precision):
    centre = _unit(cdir) * 10.0 ** c_exp
    r = 10.0 ** r_exp
    sc = _one(f"s {float(centre[0])!r} {float(centre[1])!r} {float(centre[2])!r} {r!r}\n")
    target = centre + r * _unit(pdir)
    o = target + _unit(odir) * r * 10.0 ** (o_exp + 0.5)  # an outside eye
    if np.linalg.norm(o - centre) <= r * 1.01 or _unit(odir) @ _unit(pdir) < 0.2:
        return
    hit, t2 = _reintersect(sc, o, target, out, precision)
    assert not hit or not np.isfinite(t2), (t2,)


@settings(max_examples=60, deadline=None)
@given(c_exp=_exp, r_exp=st.floats(-2, 3), l_exp=st.floats(-1, 1), cdir=_vec, adir=_vec, s=st.floats(0.05, 0.95),
       ang=st.floats(0, 6.28), odir=_vec, out=_vec, precision=st.sampled_from(PRECISIONS))
def test_random_cylinder_reintersection(c_exp, r_exp, l_exp, cdir, adir, s, ang, odir, out, precision):
    base = _unit(cdir) * 10.0 ** c_exp
    r = 10.0 ** r_exp
    a = _unit(adir)
    apex = base + a * r * 10.0 ** l_exp
    ends = [repr(float(x)) for x in (*base, r, *apex, r)]
    sc = _one("c " + " ".join(ends) + "\n")
    e1 = _unit(np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0]))
    e2 = np.cross(a, e1)
    radial = np.cos(ang) * e1 + np.sin(ang) * e2
    target = base + s * (apex - base) + r * radial
    o = target + (radial + 0.5 * _unit(odir)) * r * 3  # outside, looking at the outer wall
    if (o - target) @ radial < 0.5 * r:
        return
    hit, t2 = _reintersect(sc, o, target, out, precision)
    assert not hit or not np.isfinite(t2), (t2,)


@settings(max_examples=60, deadline=None)
@given(c_exp=_exp, s_exp=st.floats(-3, 3), cdir=_vec, v1=_vec, v2=_vec, v3=_vec, b=st.tuples(
    st.floats(0.05, 0.9), st.floats(0.05, 0.9)), odir=_vec, out=_vec, precision=st.sampled_from(PRECISIONS))
def test_random_triangle_reintersection(c_exp, s_exp, cdir, v1, v2, v3, b, odir, out, precision):
    centre = _unit(cdir) * 10.0 ** c_exp
    size = 10.0 ** s_exp
    vs = [centre + size * np.asarray(v) for v in (v1, v2, v3)]
    n = np.cross(vs[1] - vs[0], vs[2] - vs[1])
    if np.linalg.norm(n) < 1e-2 * size * size or b[0] + b[1] > 0.95:
        return
    n = _unit(n)
    sc = _one("p 3\n" + "".join(f"{float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n" for v in vs))
    target = vs[0] + b[0] * (vs[1] - vs[0]) + b[1] * (vs[2] - vs[0])
    w = _unit(odir)
    if abs(w @ n) < 0.05:
        return
    o = target + w * size * 3
    hit, t2 = _reintersect(sc, o, target, out, precision)
    assert not hit or not np.isfinite(t2), (t2,)


def test_catalog_scenes_are_what_they_claim():
    """The eye of origin_on_grid_face lies exactly on fp32 voxel boundaries of its own grid;
    axis_parallel's eye rays have exactly-zero and -0.0 components; the translated scenes' eye
    rays are bit-identical to the untranslated ones."""
    sc = CASES["origin_on_grid_face"].scene()
    g = build_grid(sc, config("fp32"))
    osg = OSGrid.of(g, np.float32)
    for axis in (0, 1):
        faces = osg.lo[axis] + np.arange(g.res[axis] + 1).astype(np.float32) * osg.cell[axis]
        assert np.float32(sc.camera.eye[axis]) in faces
    d = primary_rays(CASES["axis_parallel"].scene().camera, CASES["axis_parallel"].res, precision="fp32").direction
    zero = d == 0
    assert zero.any() and np.signbit(d[zero]).any() and (~np.signbit(d[zero])).any()
    plain = primary_rays(numerics.Case("p", "", numerics.MIXED).scene().camera, 16, precision="fp32")
    for t in numerics.TRANSLATIONS:
        moved = primary_rays(numerics.Case("m", "", numerics.MIXED, translate=t).scene().camera, 16, precision="fp32")
        assert np.array_equal(plain.direction, moved.direction)
        assert np.array_equal(moved.origin.astype(np.float64) - t, plain.origin.astype(np.float64))


# ------------------------------------------------------------------------------------------------
# Offsets from error bounds (issue 29): delta = (sum |P_a Ng_a| + t) x 2.125u + 64u x S per hit.


def _blanket_delta(p, t, ng, k_rel, k_abs):
    """The offset before issue 29: (max|P_a| + t) x 4u + k_abs, whatever k_rel says."""
    dt = p.dtype.type
    a = np.abs(p)
    return (np.maximum(np.maximum(a[0], a[1]), a[2]) + t) * dt(4 * float(np.finfo(dt).eps) / 2) + k_abs


@settings(max_examples=200, deadline=None)
@given(p_exp=st.floats(-3, 7), pdir=_vec, ndir=_vec, t_exp=st.floats(-3, 4), inside=st.booleans(),
       precision=st.sampled_from(PRECISIONS))
def test_offset_covers_the_rounding_of_p_and_stays_below_the_blanket(p_exp, pdir, ndir, t_exp, inside, precision):
    """Along the normal, the front origin sits above P by at least P's own rounding bound
    u x (sum |P_a Ng_a| + t) — after the rounding of P + delta*Ng itself — and delta never exceeds
    the blanket offset it replaced."""
    dt = np.float32 if precision == "fp32" else np.float64
    u = float(np.finfo(dt).eps) / 2
    p = (10.0 ** p_exp * _unit(pdir)).astype(dt)[:, None]
    ng = _unit(ndir).astype(dt)[:, None]
    t = np.array([10.0 ** t_exp], dt)
    k_abs = dt(64 * u)
    front, back = golden.offset_vectors(p, t, ng, np.array([inside]), golden.offset_scale(dt), k_abs)
    nf = (-ng if inside else ng)[:, 0].astype(np.float64)
    p64 = p[:, 0].astype(np.float64)
    need = u * (np.abs(p64) @ np.abs(ng[:, 0].astype(np.float64)) + float(t[0]))
    assert (front[:, 0].astype(np.float64) - p64) @ nf > need
    assert (p64 - back[:, 0].astype(np.float64)) @ nf > need
    delta = golden.offset_delta(p, t, ng, golden.offset_scale(dt), k_abs)
    assert delta[0] <= _blanket_delta(p, t, ng, None, k_abs)[0]


@pytest.mark.parametrize("translation", sorted(numerics.CONTACT_GAPS))
def test_contact_shadow_leaks_with_the_blanket_offset_not_with_the_bound(translation, monkeypatch):
    """A plate a few units in the last place above a floor moved by 1e4..1e6, lit at a low angle:
    with the per-hit bound no shadow ray the judge can decide is wrong, and the shadow is there;
    with the blanket offset the shadow rays start on or above the plate and light the floor under
    its shadow (the judge, from the path's own hit points, calls them wrongly unblocked)."""
    case = CASES[f"contact_shadow_{translation:.0e}".replace("+0", "")]
    sc = case.scene()
    gap = numerics.CONTACT_GAPS[translation]
    floor = np.full((1, 3), translation)  # the plate lies above the bound the judge forgives
    bound = offset_bound(floor, np.array([[0.0, 1.0, 0.0]]), np.array([10.0]), 16.0, "fp32")[0]
    assert bound < gap < 4 * 2.0 ** -24 * translation
    r = numerics.run_path(sc, "golden-fp32", case.res)
    v = numerics.judge(sc, r, case.res, "fp32")
    assert v.shadow_rays > 100 and v.wrongly_lit == 0 and v.wrongly_blocked == 0, v.reason()
    assert r.shadows["blocked"].sum() > 20
    monkeypatch.setattr(golden, "offset_delta", _blanket_delta)
    old = numerics.run_path(sc, "golden-fp32", case.res)
    assert not old.shadows["blocked"].any()
    assert numerics.judge(sc, old, case.res, "fp32").wrongly_lit >= 5


def test_a_moved_scene_keeps_offsets_below_six_digits():
    """`translate_scene` reads the moved scene back through the NFF reader; written with `%g`
    (six digits) a plate 0.0234 above a floor at 1e5 would land on the floor."""
    from netsushisen.host.nff import format_nff, parse_nff
    from netsushisen.numerics import translate_scene

    text = ("b 0 0 0\nv\nfrom 0 3 -8\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\nresolution 8 8\n"
                         "l 0 5 -5\nf 0.8 0.8 0.8 0.8 0 1 0 0\n"
                         "p 4\n-4 0 -4\n-4 0 4\n4 0 4\n4 0 -4\np 4\n-1 0.0234 -1\n-1 0.0234 1\n1 0.0234 1\n1 0.0234 -1\n")
    scene = parse_nff(text, "plate.nff")
    moved = translate_scene(scene, 1e5)
    assert np.array_equal(moved.polygons.vertices, scene.polygons.vertices + 1e5)
    assert "100000.0234" in format_nff(moved, exact=True)
    assert "100000.0234" not in format_nff(moved)  # the SPD's own six digits stay the default
