"""Tests written to kill mutants that survived tools/mutate.py in host/ (docs/mutation.md):
databases, grid, shapes and traversal. Each checks a value worked out by hand from the rule it
pins (comments show the working) or against brute force, never the code's own tables."""

from __future__ import annotations

import numpy as np
from test_databases import config, mixed, shuffled  # tests/ is on sys.path (conftest.py)

from netsushisen.host.databases import build_images


def _extent(regions) -> tuple[int, int]:
    """(first address, end) of ranges that must tile one block with no gap or overlap."""
    regions = sorted(regions, key=lambda r: r.start)
    for a, b in zip(regions, regions[1:]):
        assert a.end == b.start, (a, b)
    return regions[0].start, regions[-1].end


def test_region_maps_tile_each_placed_image_exactly():
    # sc_base = 260 shares a bit with the 20-word scene block (260 & 20 = 4), so an end computed
    # as base ^ size or base * size differs from base + size
    sc = mixed()
    img = build_images(sc, config(resident_share=0.3), priorities=shuffled(sc.n_primitives),
                       sc_base=260)
    lay, regions = img.layout, img.regions
    assert _extent(regions["os.local"]) == (lay.os_base, lay.os_base + len(img.os_local))
    assert _extent(regions["ic.global"]) == (0, len(img.icgm))
    assert _extent(regions["ic.resident"]) == (0, len(img.ic_resident))
    assert _extent(regions["sc.local"]) == (260, 260 + len(img.sc_local))
    assert _extent(regions["sc.global"]) == (0, len(img.scgm))
    # IC's database is the list and every record: what ICGM and the resident memory hold
    assert lay.primitive_database_words == len(img.icgm) + len(img.ic_resident)
    assert img.icgm[0] == 0  # the null word before the first list cell


def test_top_level_takes_at_most_half_the_os_budget():
    # 1000 primitives want ~1000 top voxels; a 128-word budget caps the top level at 128 // 2 =
    # 64 voxels (1 word each): a unit cube gets 4 x 4 x 4. Nothing is subdivided (counts 0).
    from netsushisen.host.grid import WORDS_PER_VOXEL, choose_resolutions
    from netsushisen.isa.config import MachineConfig

    assert WORDS_PER_VOXEL == 1
    top, sub = choose_resolutions(np.ones(3), 1000, MachineConfig().grid, 128,
                                  lambda res: np.zeros(int(np.prod(res)), np.int64))
    assert top.tolist() == [4, 4, 4] and not sub.any()


CLUSTER = """v
from 0 0 -10
at 0 0 0
up 0 1 0
angle 45
hither 1
resolution 4 4
f 1 1 1 1 0 0 0 0
s -1 -1 -1 0.1
s 0.8 0.8 0.8 0.1
s 0.9 0.7 0.9 0.05
s 0.7 0.9 0.8 0.05
"""


def test_only_the_crowded_top_voxel_is_subdivided():
    # a 2 x 2 x 2 top level over [-1.1, 0.95]^3 (about): one sphere in voxel (0,0,0), three in
    # voxel (1,1,1) = flat index (1*2 + 1)*2 + 1 = 7; threshold 2 divides voxel 7 alone
    from netsushisen.host.grid import build_grid
    from netsushisen.host.nff import parse_nff
    from netsushisen.isa.config import load_config

    cfg = load_config(None, ["grid.top_resolution=2", "grid.subdivide_threshold=2"])
    g = build_grid(parse_nff(CLUSTER, "cluster.nff"), cfg)
    assert g.res.tolist() == [2, 2, 2]
    assert np.flatnonzero(g.top_sub >= 0).tolist() == [7]
    assert g.top_leaf[0] >= 0 and (g.top_leaf[1:7] == -1).all()  # voxel 0 one leaf, 1..6 empty


def test_a_cone_without_axis_gets_a_defined_axis_and_no_slope():
    # the NFF reader rejects base == apex, but the scene builder (SPD generators) does not: such
    # a cone must still get finite shape data, +z axis, length 0 and slope 0 (never 0/0 = NaN)
    from netsushisen.host.nff_builder import SceneBuilder
    from netsushisen.host.shapes import build_shape_data

    b = SceneBuilder()
    b.set_camera((0, 0, -10), (0, 0, 0), (0, 1, 0), 45, 1, (4, 4))
    b.set_material(1, 1, 1, 1, 0, 0, 0, 0)
    b.add_cone(0, 0, 2, 1.0, 0, 3, 2, 0.5)   # axis (0, 3, 0): unit (0, 1, 0), slope -0.5/3
    b.add_cone(1, 2, 3, 1.0, 1, 2, 3, 0.5)   # no axis
    sd = build_shape_data(b.build("degenerate"), "fp64")
    assert sd.cone_axis.tolist() == [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    assert sd.cone_length.tolist() == [3.0, 0.0]
    assert sd.cone_slope.tolist() == [-0.5 / 3, 0.0]


# --- host/shapes.py: expected values worked out by hand (fp64) --------------------------------

def _shapes(body: str):
    """A scene of `body` records under tests/test_shapes.py's view."""
    from test_shapes import scene
    return scene(body)


def test_newell_normal_when_the_first_corner_is_degenerate():
    # polygon 1 starts at vertex 4 and its first three vertices are collinear: (v1-v0) x (v2-v1)
    # = 0, so the normal is Newell's: for the square (0,0) (2,0) (2,2) (0,2) with a vertex in the
    # middle of its first edge, n_z = sum (x_i - x_j)(y_i + y_j) = (2 - 0)(2 + 2) = 8 -> +z
    from test_shapes import GLASS, polygon_text

    from netsushisen.host.shapes import build_shape_data

    square = [(0.0, 5.0, 0.0), (1.0, 5.0, 0.0), (1.0, 6.0, 0.0), (0.0, 6.0, 0.0)]
    degenerate = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0), (2.0, 2.0, 0.0), (0.0, 2.0, 0.0)]
    sd = build_shape_data(_shapes(GLASS + polygon_text(square) + polygon_text(degenerate)), "fp64")
    assert sd.poly_normal.reshape(-1, 3).tolist() == [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]


def test_triangle_barycentrics_and_patch_shading_normal_in_the_second_fan_triangle():
    from test_shapes import GLASS, hits, polygon_text

    from netsushisen.host.rays import normalize
    from netsushisen.host.shapes import build_shape_data, surface_normals

    # triangle (0,0) (1,0) (0,1) at z = 0, hit at (0.25, 0.5): b1 = 0.25 (weight of v1), b2 = 0.5
    sc = _shapes(GLASS + polygon_text([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]))
    h, _ = hits(sc, "fp64", [[0.25, 0.5, -5.0]], [[0.0, 0.0, 1.0]], [0])
    assert h.t.tolist() == [5.0] and h.fan.tolist() == [0]
    assert np.allclose([h.b1[0], h.b2[0]], [0.25, 0.5], rtol=0, atol=1e-12)
    # patch square v0..v3 = (0,0) (1,0) (1,1) (0,1), vertex normals n0..n3; the point (0.25, 0.75)
    # lies in fan triangle 1 = (v0, v2, v3) with weights b0 = 0.25, b1 = x = 0.25 (v2),
    # b2 = y - x = 0.5 (v3): shading normal = normalise(0.25 n0 + 0.25 n2 + 0.5 n3)
    n = [(0.0, 0.0, -1.0), (1.0, 0.0, -1.0), (0.0, 1.0, -1.0), (-1.0, 0.0, -1.0)]
    corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    text = "pp 4\n" + "".join(f"{x} {y} 0 {a} {b} {c}\n" for (x, y), (a, b, c) in zip(corners, n))
    sc = _shapes(GLASS + text)
    h, d = hits(sc, "fp64", [[0.25, 0.75, -5.0]], [[0.0, 0.0, 1.0]], [0])
    assert h.fan.tolist() == [1] and h.t.tolist() == [5.0]
    sd = build_shape_data(sc, "fp64")
    p = np.array([[0.25], [0.75], [0.0]])
    _, ns = surface_normals(sd, np.array([0]), p, h.fan, h.b1, h.b2)
    want = 0.25 * np.array(n[0]) + 0.25 * np.array(n[2]) + 0.5 * np.array(n[3])
    assert np.allclose(ns[:, 0], want / np.linalg.norm(want), rtol=0, atol=1e-12)


def test_a_two_sided_cone_is_hit_from_inside_by_its_second_root():
    # cone from (0,0,0) radius 1 to (0,0,1) radius 0.5: r(z) = 1 - 0.5 z. A ray from (0,0,0.5)
    # along +x leaves it at x = r(0.5) = 0.75: the roots are -0.75 (behind) and 0.75. Two-sided
    # (glass): hit at 0.75; one-sided: that root is a back face, no hit.
    from test_shapes import GLASS, OPAQUE, hits

    for material, want in ((GLASS, 0.75), (OPAQUE, np.inf)):
        h, _ = hits(_shapes(material + "c 0 0 0 1 0 0 1 0.5\n"), "fp64", [[0.0, 0.0, 0.5]],
                    [[1.0, 0.0, 0.0]], [0])
        assert np.allclose(h.t, [want], rtol=1e-12), material


# --- host/traversal.py ---------------------------------------------------------------------------

def test_grid_traversal_finds_the_brute_force_closest_hit_through_sub_grids():
    # rings:2 gets 8 x 5 x 8 top voxels (so a y/z or x/y mix-up in a voxel index shows) and
    # sub-grids wherever a voxel holds more than 2 primitives; the truth is every ray tested
    # against every primitive, the closest hit kept
    from netsushisen.host.catalog import load_scene
    from netsushisen.host.grid import build_grid
    from netsushisen.host.shapes import build_shape_data, ic_rays, intersect
    from netsushisen.host.traversal import OSGrid, trace
    from netsushisen.isa.config import load_config

    sc = load_scene("rings:2")
    grid = build_grid(sc, load_config(None, ["grid.subdivide_threshold=2"]))
    assert grid.res[1] not in (grid.res[0], grid.res[2]) and len(grid.sub_res) > 0
    sd = build_shape_data(sc, "fp64")
    rng = np.random.default_rng(18)
    n = 300
    o = grid.lo + rng.uniform(-0.2, 1.2, size=(n, 3)) * (grid.hi - grid.lo)
    aim = grid.lo + rng.uniform(0.2, 0.8, size=(n, 3)) * (grid.hi - grid.lo)
    d = (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True)
    rays = ic_rays(np.ascontiguousarray(o.T), np.ascontiguousarray(d.T), np.zeros(n))
    tr = trace(OSGrid.of(grid, np.float64), sd, rays)
    pairs_r = np.repeat(np.arange(n), sc.n_primitives)
    pairs_p = np.tile(np.arange(sc.n_primitives), n)
    t = intersect(sd, rays, pairs_r, pairs_p).t.reshape(n, sc.n_primitives)
    best = t.min(axis=1)
    hit = np.isfinite(best)
    assert hit.sum() > n // 4                 # the test sees many hits, not just misses
    assert np.array_equal(tr.t, best)
    assert np.array_equal(tr.prim[hit], t.argmin(axis=1)[hit]) and (tr.prim[~hit] == -1).all()


def test_a_shadow_ray_tests_a_leaf_only_up_to_its_first_occluder():
    # one voxel holding spheres 0 and 1 (listed in that order); a shadow ray through sphere 0
    # only: IC tests sphere 0, finds the occluder and stops (refs [1, 0]); a shadow ray crossing
    # the voxel between them (x = 2.5, along y) tests both (refs [1, 1])
    from netsushisen.host.grid import build_grid
    from netsushisen.host.shapes import build_shape_data, ic_rays
    from netsushisen.host.traversal import OSGrid, trace
    from netsushisen.isa.config import load_config

    sc = _shapes("f 1 1 1 1 0 1 0 1\ns 0 0 0 1\ns 5 0 0 1\n")
    grid = build_grid(sc, load_config(None, ["grid.top_resolution=1",
                                             "grid.subdivide_threshold=10"]))
    sd = build_shape_data(sc, "fp64")
    for o, d, occluded, refs in (((-3.0, 0.0, 0.0), (1.0, 0.0, 0.0), True, [1, 0]),
                                 ((2.5, -3.0, 0.0), (0.0, 1.0, 0.0), False, [1, 1])):
        rays = ic_rays(np.array(o)[:, None], np.array(d)[:, None], np.zeros(1))
        tr = trace(OSGrid.of(grid, np.float64), sd, rays, t_max=np.array([100.0]), keep_refs=True)
        assert tr.occluded.tolist() == [occluded]
        assert tr.ref_counts.tolist() == refs, o


def test_a_shadow_ray_stops_walking_at_the_light():
    # spheres at x = 0 and x = 5 (radius 1), 2 x 2 x 2 top voxels split at x = 2.5. A shadow ray
    # from (1.5, 0.5, 0.5) along +x to a light 0.5 away (x = 2.0) tests sphere 0 in its first
    # voxel and ends there: sphere 1, in the next voxel, is never tested. To a light 5 away the
    # ray goes on into that voxel and sphere 1 (entered at x = 5 - sqrt(0.5)) occludes it.
    from netsushisen.host.grid import build_grid
    from netsushisen.host.shapes import build_shape_data, ic_rays
    from netsushisen.host.traversal import OSGrid, trace
    from netsushisen.isa.config import load_config

    sc = _shapes("f 1 1 1 1 0 1 0 1\ns 0 0 0 1\ns 5 0 0 1\n")
    grid = build_grid(sc, load_config(None, ["grid.top_resolution=2",
                                             "grid.subdivide_threshold=10"]))
    sd = build_shape_data(sc, "fp64")
    rays = ic_rays(np.array([[1.5], [0.5], [0.5]]), np.array([[1.0], [0.0], [0.0]]), np.zeros(1))
    for t_max, occluded, refs in ((0.5, False, [1, 0]), (5.0, True, [1, 1])):
        tr = trace(OSGrid.of(grid, np.float64), sd, rays, t_max=np.array([t_max]), keep_refs=True)
        assert tr.occluded.tolist() == [occluded]
        assert tr.ref_counts.tolist() == refs, t_max



def test_a_two_sided_cylinder_seen_from_inside_is_open_at_its_ends():
    # cylinder along z from 0 to L = 1, radius 1, glass (two-sided). From (0,0,0.5) the ray
    # along +x leaves through the side at t = 1 (z = 0.5); along (1,0,1)/sqrt(2) it would meet
    # the infinite cylinder at z = 1.5 > L, beyond the open end: no hit. In the base plane
    # (from the origin along +x, z = 0 exactly all the way) it meets the rim, which is surface.
    from test_shapes import GLASS, hits

    sc = _shapes(GLASS + "c 0 0 0 1 0 0 1 1\n")
    h, _ = hits(sc, "fp64", [[0.0, 0.0, 0.5], [0.0, 0.0, 0.5], [0.0, 0.0, 0.0]],
                [[1.0, 0.0, 0.0], [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]], [0, 0, 0])
    assert h.t.tolist() == [1.0, np.inf, 1.0]
