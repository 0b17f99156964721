"""Tests written to kill mutants that survived tools/mutate.py in host/ (docs/mutation.md):
each checks a fact worked out from the layout's definition, not the code's own table."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from netsushisen.host.databases import build_images

sys.path.insert(0, str(Path(__file__).parent))
from test_databases import config, mixed, shuffled  # noqa: E402


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
