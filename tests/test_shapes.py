"""Shape records and ray-primitive tests: agreement with float64 references, one-sidedness,
watertight polygon edges and vertices, concave polygons, robust quadrics."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.host.nff import parse_nff
from netsushisen.host.rays import normalize
from netsushisen.host.shapes import build_shape_data, ic_rays, intersect

VIEW = "v\nfrom 0 0 -5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\nresolution 4 4\n"
OPAQUE = "f 1 1 1 1 0 1 0 1\n"
GLASS = "f 1 1 1 0 0.1 1 0.9 1.5\n"
PRECISIONS = ["fp32", "fp64"]


def scene(body: str):
    return parse_nff(VIEW + body, filename="test.nff")


def hits(sc, precision, o, d, prims, t_min=0.0):
    """t per (ray i, primitive prims[i]) for rays o, d given as (n, 3) float64 arrays."""
    sd = build_shape_data(sc, precision)
    dt = sd.dtype
    o = np.ascontiguousarray(np.asarray(o, np.float64).T.astype(dt))
    d = normalize(np.ascontiguousarray(np.asarray(d, np.float64).T.astype(dt)))
    n = o.shape[1]
    r = ic_rays(o, d, np.full(n, t_min, dt))
    return intersect(sd, r, np.arange(n), np.asarray(prims, np.int64)), d


def polygon_text(verts) -> str:
    return f"p {len(verts)}\n" + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in verts)


def winding_number(px, py, poly):
    """Float64 reference: winding number of points about a 2-D polygon (sum of angles)."""
    total = np.zeros(len(px))
    for i in range(len(poly)):
        ax, ay = poly[i][0] - px, poly[i][1] - py
        bx, by = poly[(i + 1) % len(poly)][0] - px, poly[(i + 1) % len(poly)][1] - py
        total += np.arctan2(ax * by - ay * bx, ax * bx + ay * by)
    return np.rint(total / (2 * np.pi)).astype(int)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_concave_polygon_matches_winding_reference(precision):
    # a concave "comb" polygon in the plane z = 0, counter-clockwise seen from -z (its front)
    comb = [(0, 0), (0, 3), (1, 3), (1, 1), (2, 1), (2, 3), (3, 3), (3, 0)]
    sc = scene(OPAQUE + polygon_text([(x, y, 0.0) for x, y in comb]))
    rng = np.random.default_rng(1)
    pts = rng.uniform(-0.5, 3.5, size=(4000, 2))
    o = np.column_stack([pts, np.full(len(pts), -5.0)])
    h, _ = hits(sc, precision, o, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), np.zeros(len(pts), int))
    inside = winding_number(pts[:, 0], pts[:, 1], comb) != 0
    # points within 1e-6 of an edge may go either way
    margin = np.minimum.reduce([np.abs(pts[:, 0] - v) for v in (0, 1, 2, 3)]
                               + [np.abs(pts[:, 1] - v) for v in (0, 1, 3)])
    clear = margin > 1e-6
    assert np.array_equal(np.isfinite(h.t)[clear], inside[clear])
    assert np.allclose(h.t[np.isfinite(h.t)], 5.0)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_polygon_one_sided_unless_transmitting(precision):
    tri = polygon_text([(0, 0, 0), (0, 1, 0), (1, 0, 0)])  # front faces -z
    o = [[0.2, 0.2, -1], [0.2, 0.2, 1]]
    d = [[0, 0, 1], [0, 0, -1]]
    h, _ = hits(scene(OPAQUE + tri), precision, o, d, [0, 0])
    assert np.isfinite(h.t[0]) and not np.isfinite(h.t[1])
    h, _ = hits(scene(GLASS + tri), precision, o, d, [0, 0])
    assert np.all(np.isfinite(h.t))


def heightfield(n: int, seed: int):
    rng = np.random.default_rng(seed)
    z = rng.uniform(-0.3, 0.3, size=(n + 1, n + 1))
    text = OPAQUE
    for i in range(n):
        for j in range(n):
            a, b, c, d = (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
            for tri in ((a, b, c), (a, c, d)):  # counter-clockwise from +z: front faces up
                text += polygon_text([(float(x), float(y), float(z[x, y])) for x, y in tri])
    return scene(text), z


@pytest.mark.parametrize("precision", PRECISIONS)
def test_mesh_is_watertight_on_edges_vertices_and_random_points(precision):
    sc, _ = heightfield(6, seed=3)
    n_tri = sc.n_primitives
    rng = np.random.default_rng(7)
    xs = [rng.uniform(0.01, 5.99, size=(3000, 2)),
          np.array([(i, j) for i in range(1, 6) for j in range(1, 6)], float),  # vertices
          np.array([(i + 0.5, j) for i in range(6) for j in range(1, 6)], float),  # axis edges
          np.array([(i + 0.25, j + 0.25) for i in range(6) for j in range(6)], float)]  # diagonals
    pts = np.concatenate(xs)
    for direction in ([0.0, 0.0, -1.0], [0.3, -0.2, -1.0]):
        dz = np.asarray(direction)
        o = np.column_stack([pts, np.full(len(pts), 5.0)]) - 5.0 * dz * np.array([1, 1, 0]) / -dz[2]
        ok = (pts[:, 0] > 0.3) & (pts[:, 0] < 5.7) & (pts[:, 1] > 0.3) & (pts[:, 1] < 5.7)
        o, p = o[ok], pts[ok]
        ri = np.repeat(np.arange(len(o)), n_tri)
        pi = np.tile(np.arange(n_tri), len(o))
        h, _ = hits(sc, precision, o[ri], np.tile(dz, (len(ri), 1)), pi)
        per_ray = np.isfinite(h.t).reshape(len(o), n_tri).sum(axis=1)
        assert np.all(per_ray == 1), (direction, p[per_ray != 1][:5], per_ray[per_ray != 1][:5])


@pytest.mark.parametrize("precision", PRECISIONS)
def test_ray_along_shared_edge_hits_exactly_one(precision):
    # two triangles sharing the diagonal x = y of a square; rays hit points exactly on it
    sc = scene(OPAQUE + polygon_text([(-1, -1, 0), (1, 1, 0), (1, -1, 0)])
               + polygon_text([(-1, -1, 0), (-1, 1, 0), (1, 1, 0)]))
    s = np.linspace(-0.75, 0.75, 7)
    o = np.column_stack([s, s, np.full(7, -3.0)])
    h0, _ = hits(sc, precision, o, np.tile([0, 0, 1.0], (7, 1)), np.zeros(7, int))
    h1, _ = hits(sc, precision, o, np.tile([0, 0, 1.0], (7, 1)), np.ones(7, int))
    assert np.all(np.isfinite(h0.t) ^ np.isfinite(h1.t))


@pytest.mark.parametrize("precision", PRECISIONS)
def test_patch_barycentrics(precision):
    sc = scene(OPAQUE + "pp 3\n0 0 0 0 0 -1\n0 1 0 0 0 -1\n1 0 0 0 0 -1\n")
    h, _ = hits(sc, precision, [[0.2, 0.3, -1]], [[0, 0, 1]], [0])
    # fan triangle 0 = (v0, v1, v2): b1 belongs to v1 = (0, 1, 0), b2 to v2 = (1, 0, 0)
    assert h.fan[0] == 0
    assert h.b1[0] == pytest.approx(0.3, abs=1e-6) and h.b2[0] == pytest.approx(0.2, abs=1e-6)


def sphere_reference(o, d, c, r):
    """float64 reference roots with unit d."""
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    oc = o - c
    b = (oc * d).sum(1)
    q = oc - b[:, None] * d
    disc = r * r - (q * q).sum(1)
    h = np.sqrt(np.maximum(disc, 0))
    return disc, -b - h, -b + h


@pytest.mark.parametrize("precision", PRECISIONS)
def test_sphere_against_float64_reference(precision):
    sc = scene(OPAQUE + "s 0.3 -0.2 0.1 1.5\n")
    rng = np.random.default_rng(5)
    o = rng.uniform(-6, 6, size=(3000, 3))
    target = rng.uniform(-2, 2, size=(3000, 3))
    d = target - o
    outside = np.linalg.norm(o - [0.3, -0.2, 0.1], axis=1) > 1.6
    o, d = o[outside], d[outside]
    h, _ = hits(sc, precision, o, d, np.zeros(len(o), int))
    disc, t0, _ = sphere_reference(o, d, np.array([0.3, -0.2, 0.1]), 1.5)
    clear = np.abs(disc) > 1e-3
    expect = (disc > 0) & (t0 > 0)
    assert np.array_equal(np.isfinite(h.t)[clear], expect[clear])
    both = clear & expect
    assert np.allclose(h.t[both], t0[both], rtol=1e-5)


@pytest.mark.parametrize("precision", PRECISIONS)
def test_glass_sphere_from_inside_hits_far_wall(precision):
    sc = scene(GLASS + "s 0 0 0 1\n")
    h, _ = hits(sc, precision, [[0, 0, 0], [0.5, 0, 0]], [[0, 0, 1], [1, 0, 0]], [0, 0])
    assert h.t == pytest.approx([1.0, 0.5], rel=1e-6)
    h, _ = hits(scene(OPAQUE + "s 0 0 0 1\n"), precision, [[0, 0, 0]], [[0, 0, 1]], [0])
    assert not np.isfinite(h.t[0])  # an opaque sphere is not seen from inside


def cone_reference(o, d, base, apex, r0, r1, two_sided=False):
    """float64 brute force: march t finely, find the first sign change of |wp| - r(z)."""
    ts = np.linspace(1e-4, 30, 40001)
    out = np.full(len(o), np.inf)
    axis = apex - base
    length = np.linalg.norm(axis)
    a = axis / length
    for i in range(len(o)):
        dd = d[i] / np.linalg.norm(d[i])
        p = o[i] + ts[:, None] * dd
        w = p - base
        z = w @ a
        rad = np.linalg.norm(w - z[:, None] * a, axis=1)
        f = rad - (r0 + (r1 - r0) * z / length)
        inside_h = (z >= 0) & (z <= length)
        cross = np.flatnonzero((np.sign(f[1:]) != np.sign(f[:-1])) & inside_h[1:] & inside_h[:-1])
        for j in cross:
            entering = f[j] > 0
            if entering or two_sided:
                out[i] = ts[j]
                break
    return out


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("radii", [(0.5, 0.5), (0.8, 0.2)])
def test_cylinder_and_cone_against_marching_reference(precision, radii):
    r0, r1 = radii
    base, apex = np.array([0.2, -1.0, 0.3]), np.array([-0.1, 1.2, 0.1])
    sc = scene(OPAQUE + f"c {base[0]} {base[1]} {base[2]} {r0} {apex[0]} {apex[1]} {apex[2]} {r1}\n")
    rng = np.random.default_rng(11)
    o = rng.uniform(-4, 4, size=(80, 3))
    o = o[np.linalg.norm(o, axis=1) > 2.5]
    d = rng.uniform(-0.6, 0.6, size=(len(o), 3)) - o
    h, _ = hits(sc, precision, o, d, np.zeros(len(o), int))
    ref = cone_reference(o, d, base, apex, r0, r1)
    agree = (np.isfinite(h.t) == np.isfinite(ref))
    with np.errstate(invalid="ignore"):
        close = ~np.isfinite(ref) | (np.abs(h.t - ref) < 2e-3)
    assert agree.mean() > 0.97 and np.isfinite(ref).sum() > 20
    assert np.all(close[agree & np.isfinite(ref)])


@pytest.mark.parametrize("precision", PRECISIONS)
def test_open_cylinder_inner_wall_is_a_back_face(precision):
    sc = scene(OPAQUE + "c 0 0 0 1 0 0 4 1\n")
    # looking into the open end along a slanted line: the first surface met is the inner wall
    h, _ = hits(sc, precision, [[0, 0, -2]], [[0.3, 0, 1]], [0])
    assert not np.isfinite(h.t[0])
    sc = scene(GLASS + "c 0 0 0 1 0 0 4 1\n")
    h, _ = hits(sc, precision, [[0, 0, -2]], [[0.3, 0, 1]], [0])
    assert np.isfinite(h.t[0])
