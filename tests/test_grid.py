"""Two-level grid: overlap tests against sampling, membership, sizing, and the DDA against a
brute-force slab test of every voxel."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.host.catalog import load_scene
from netsushisen.host.grid import build_grid, cone_box, sphere_box, triangle_box
from netsushisen.host.rays import normalize
from netsushisen.host.shapes import build_shape_data, ic_rays
from netsushisen.host.traversal import OSGrid, trace
from netsushisen.isa.config import load_config

RNG = np.random.default_rng(2024)


def random_boxes(n, scale=1.0):
    lo = RNG.uniform(-1.5, 1.2, size=(n, 3)) * scale
    return lo, lo + RNG.uniform(0.05, 0.8, size=(n, 3)) * scale


def in_box(points, lo, hi):
    """(n_boxes, n_points): point strictly inside box."""
    return np.all((points[None] > lo[:, None]) & (points[None] < hi[:, None]), axis=2)


def test_triangle_box_is_exact_against_sampling():
    for _ in range(10):
        tri = RNG.uniform(-1, 1, size=(3, 3))
        lo, hi = random_boxes(200)
        got = triangle_box(np.repeat(tri[None], 200, 0), lo, hi)
        u, v = RNG.uniform(size=(2, 6000))
        flip = u + v > 1
        u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
        pts = tri[0] + u[:, None] * (tri[1] - tri[0]) + v[:, None] * (tri[2] - tri[0])
        sampled = in_box(pts, lo, hi).any(axis=1)
        assert np.all(got[sampled])  # conservative
        # tight: a box said to overlap is near some sample
        grown = in_box(pts, lo - 0.03, hi + 0.03).any(axis=1)
        assert np.all(grown[got])


def test_sphere_box_touches_surface_only():
    c, r = np.array([0.1, -0.2, 0.05]), 0.7
    lo, hi = random_boxes(400)
    got = sphere_box(np.tile([*c, r], (400, 1)), lo, hi)
    dirs = normalize(RNG.normal(size=(3, 15000))).T
    pts = c + r * dirs
    sampled = in_box(pts, lo, hi).any(axis=1)
    assert np.all(got[sampled])
    grown = in_box(pts, lo - 0.03, hi + 0.03).any(axis=1)
    assert np.all(grown[got])
    inner = sphere_box(np.array([[0, 0, 0, 1.0]]), np.array([[-0.1] * 3]), np.array([[0.1] * 3]))
    assert not inner[0]  # a box strictly inside does not touch the surface


@pytest.mark.parametrize("r1", [0.3, 0.05])
def test_cone_box_is_conservative_and_tight(r1):
    base, apex, r0 = np.array([-0.5, 0.2, -0.4]), np.array([0.6, -0.3, 0.7]), 0.3
    lo, hi = random_boxes(400)
    got = cone_box(np.tile([*base, r0, *apex, r1], (400, 1)), lo, hi)
    axis = apex - base
    a = axis / np.linalg.norm(axis)
    e1 = np.cross(a, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    s, phi = RNG.uniform(size=(2, 15000))
    rad = r0 + s * (r1 - r0)
    pts = base + s[:, None] * axis + rad[:, None] * (np.cos(2 * np.pi * phi)[:, None] * e1
                                                     + np.sin(2 * np.pi * phi)[:, None] * e2)
    sampled = in_box(pts, lo, hi).any(axis=1)
    assert np.all(got[sampled])
    grown = in_box(pts, lo - 0.05, hi + 0.05).any(axis=1)
    assert grown[got].mean() > 0.97  # tight up to the capsule ends


def leaf_of_points(grid, pts):
    """Leaf id holding each float64 point (exact float64 voxel arithmetic)."""
    i = np.clip(np.floor((pts - grid.lo) / grid.cell).astype(int), 0, grid.res - 1)
    flat = (i[:, 2] * grid.res[1] + i[:, 1]) * grid.res[0] + i[:, 0]
    leaf = grid.top_leaf[flat].astype(np.int64)
    sub = grid.top_sub[flat]
    s = sub[sub >= 0]
    j = np.clip(np.floor((pts[sub >= 0] - grid.sub_lo[s]) / grid.sub_cell[s]).astype(int), 0, grid.sub_res[s] - 1)
    r = grid.sub_res[s]
    leaf[sub >= 0] = grid.sub_leaf[grid.sub_offset[s] + (j[:, 2] * r[:, 1] + j[:, 1]) * r[:, 0] + j[:, 0]]
    return leaf


@pytest.mark.parametrize("spec", ["mount:3", "rings:2", "balls:2"])
def test_every_surface_point_is_listed_in_its_leaf(spec):
    sc = load_scene(spec)
    grid = build_grid(sc, load_config(None, ["grid.subdivide_threshold=4"]))
    assert len(grid.sub_res) > 0
    members = {(int(lf), int(p)) for lf in range(grid.n_leaves)
               for p in grid.leaf_prims[grid.leaf_offsets[lf]:grid.leaf_offsets[lf + 1]]}
    for lf in range(grid.n_leaves):
        lst = grid.leaf_prims[grid.leaf_offsets[lf]:grid.leaf_offsets[lf + 1]]
        assert np.all(np.diff(lst) > 0)  # ascending primitive ids
    pts, owner = [], []
    sp = sc.spheres
    for j in range(len(sc.kind)):
        k, li = sc.kind[j], sc.local_index[j]
        if k == 1:
            dirs = normalize(RNG.normal(size=(3, 30))).T
            pts.append(sp.center[li] + sp.radius[li] * dirs)
        elif k == 0:
            s0 = sc.polygons.start[li]
            v = sc.polygons.vertices[s0:s0 + 3]
            u, w = RNG.uniform(size=(2, 10))
            m = u + w > 1
            u[m], w[m] = 1 - u[m], 1 - w[m]
            pts.append(v[0] + u[:, None] * (v[1] - v[0]) + w[:, None] * (v[2] - v[0]))
        else:
            c = sc.cones
            t = RNG.uniform(size=20)
            a = c.apex[li] - c.base[li]
            e = np.cross(a, [0.3, 0.5, 0.7])
            e /= np.linalg.norm(e)
            f = np.cross(a / np.linalg.norm(a), e)
            ang = RNG.uniform(0, 2 * np.pi, size=20)
            ring = np.cos(ang)[:, None] * e + np.sin(ang)[:, None] * f
            pts.append(c.base[li] + t[:, None] * a + c.base_radius[li] * ring)
        owner.append(np.full(len(pts[-1]), j))
    pts, owner = np.concatenate(pts), np.concatenate(owner)
    leaf = leaf_of_points(grid, pts)
    assert np.all(leaf >= 0)
    missing = [(int(lf), int(p)) for lf, p in zip(leaf, owner) if (int(lf), int(p)) not in members]
    assert not missing


def test_sizing_fits_os_memory_and_respects_fixed_resolutions():
    sc = load_scene("mount:4")
    for words in (1 << 16, 6000, 2000):
        g = build_grid(sc, load_config(None, [f"os.local_words={words}"]))
        assert g.words <= words
    g = build_grid(sc, load_config(None, ["grid.top_resolution=7", "grid.sub_resolution=3",
                                          "grid.subdivide_threshold=20"]))
    assert list(g.res) == [7, 7, 7] and np.all(g.sub_res == 3)
    big = g.top_sub >= 0
    assert big.sum() == len(g.sub_res) and np.all(g.top_leaf[big] == -1)


def slab(lo, hi, o, d):
    """float64 [t0, t1] of a ray (unit d) inside boxes lo/hi (k, 3)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        a, b = (lo - o) * inv, (hi - o) * inv
    t0 = np.where(d == 0, np.where((o >= lo) & (o <= hi), -np.inf, np.inf), np.minimum(a, b))
    t1 = np.where(d == 0, np.where((o >= lo) & (o <= hi), np.inf, -np.inf), np.maximum(a, b))
    return t0.max(axis=1), t1.min(axis=1)


def visit_rays(grid, n):
    lo, hi = grid.lo, grid.hi
    size = hi - lo
    o = lo + RNG.uniform(-0.3, 1.3, size=(n, 3)) * size
    d = RNG.normal(size=(n, 3))
    k = n // 3
    # axis-parallel rays, some with -0.0 components and origins exactly on voxel boundaries
    axis = RNG.integers(0, 3, size=k)
    d[:k] = 0.0
    d[np.arange(k), axis] = RNG.choice([-1.0, 1.0], size=k)
    d[:k:2][d[:k:2] == 0] = -0.0
    cells = RNG.integers(0, grid.res, size=(k, 3))
    on = lo + cells * grid.cell
    pick = RNG.uniform(size=(k, 3)) < 0.5
    o[:k] = np.where(pick, on, o[:k])
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_dda_visits_exactly_the_voxels_the_segment_crosses(precision):
    sc = load_scene("mount:3")
    grid = build_grid(sc, load_config(None, ["grid.subdivide_threshold=6", "grid.top_resolution=6"]))
    osg = OSGrid.of(grid, np.float32 if precision == "fp32" else np.float64)
    sd = build_shape_data(sc, precision)
    dt = sd.dtype
    o, d = visit_rays(grid, 300)
    # use the rounded rays as the truth so both sides see the same line
    o = o.astype(dt).astype(np.float64)
    d = d.astype(dt).astype(np.float64)
    rays = ic_rays(np.ascontiguousarray(o.T.astype(dt)), np.ascontiguousarray(d.T.astype(dt)),
                   np.zeros(len(o), dt))
    # move every primitive far away so that no test hits and every ray walks its whole path
    for name in ("poly_vertices", "sph_center", "cone_base"):
        setattr(sd, name, getattr(sd, name) + dt(1e6))
    tr = trace(osg, sd, rays, keep_visits=True)
    assert np.all(tr.prim == -1)
    res, cell = grid.res, grid.cell
    idx = np.stack(np.meshgrid(*[np.arange(r) for r in res], indexing="ij"), -1).reshape(-1, 3)
    flat = (idx[:, 2] * res[1] + idx[:, 1]) * res[0] + idx[:, 0]
    box_lo, box_hi = grid.lo + idx * cell, grid.lo + (idx + 1) * cell
    tol = 1e-5 * float(cell.max())
    checked = 0
    for i in range(len(o)):
        # must: the box shrunk by tol is crossed; may: the box grown by tol is touched
        t0, t1 = slab(box_lo + tol, box_hi - tol, o[i], d[i])
        must = set(flat[(t1 - np.maximum(t0, 0.0)) > 0].tolist())
        t0, t1 = slab(box_lo - tol, box_hi + tol, o[i], d[i])
        may = set(flat[(t1 - np.maximum(t0, 0.0)) >= 0].tolist())
        got = set(tr.visits[tr.visits[:, 0] == i, 1].tolist())
        assert must <= got <= may, (i, o[i], d[i], must - got, got - may)
        checked += 1
        # sub level: every sub-voxel crossed inside a divided top voxel is visited
        v = tr.visits[(tr.visits[:, 0] == i) & (tr.visits[:, 2] >= 0)]
        for top in set(v[:, 1].tolist()):
            s = grid.top_sub[top]
            r = grid.sub_res[s]
            sidx = np.stack(np.meshgrid(*[np.arange(x) for x in r], indexing="ij"), -1).reshape(-1, 3)
            sflat = (sidx[:, 2] * r[1] + sidx[:, 1]) * r[0] + sidx[:, 0]
            blo, bhi = grid.sub_lo[s] + sidx * grid.sub_cell[s], grid.sub_lo[s] + (sidx + 1) * grid.sub_cell[s]
            # sub-voxels are clipped to the part of the path inside this top voxel
            u0, u1 = slab(box_lo[flat == top] + tol, box_hi[flat == top] - tol, o[i], d[i])
            s0, s1 = slab(blo + tol, bhi - tol, o[i], d[i])
            smust = set(sflat[(np.minimum(s1, u1) - np.maximum(np.maximum(s0, u0), 0.0)) > 0].tolist())
            s0, s1 = slab(blo - tol, bhi + tol, o[i], d[i])
            smay = set(sflat[(s1 - np.maximum(s0, 0.0)) >= 0].tolist())
            sgot = set(v[v[:, 1] == top, 2].tolist())
            assert smust <= sgot <= smay
    assert checked == len(o)


def test_grid_memory_does_not_grow_with_the_distance_from_the_origin():
    """tetra moved by 3e4: fp32's pad (64u × 3e4 ≈ 0.11 on an extent of 2) used to list every
    triangle in the hundreds of voxels it touches only through the pad — 1.07 M list entries and
    a 1.1 GB peak (5.6 GB at 1e5, numerics tetra --res 8); voxels at least MIN_CELL_PADS pads
    wide keep the entries near the primitives' count and the peak small, at any translation."""
    import tracemalloc

    from netsushisen.host.grid import MIN_CELL_PADS
    from netsushisen.numerics import translate_scene

    base = load_scene("tetra")
    for by in (3e4, 1e6):
        scene = translate_scene(base, by)
        tracemalloc.start()
        try:
            g = build_grid(scene, load_config(None, []))
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert g.stats()["list_entries"] <= 8 * scene.n_primitives
        assert peak < 300 * 2**20, f"moved by {by:g}: {peak / 2**20:.0f} MiB"
        assert np.all(g.cell >= MIN_CELL_PADS * g.pad) or np.all(g.res == 1)
    untranslated = build_grid(base, load_config(None, []))  # ordinary scenes keep their grid
    assert untranslated.stats()["list_entries"] == 49636 and len(untranslated.sub_res) == 812
