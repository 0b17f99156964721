"""Resident pre-pass (docs/databases.md "Pre-pass"): coarse resolution, priorities from
reference counts, the resident fill, and the images built from it."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import RESIDENT, build_images, plan_layout
from netsushisen.host.golden import render
from netsushisen.host.prepass import coarse_resolution, priorities_from_counts, run_prepass
from netsushisen.isa.config import MachineConfig


def test_coarse_resolution_is_the_share_of_eye_rays():
    assert coarse_resolution(512, 0.01) == 51  # the paper's 1 %: 100 x 100 for 1000 x 1000
    assert coarse_resolution(1000, 0.01) == 100
    assert coarse_resolution(64, 1.0) == 64
    assert coarse_resolution(8, 0.0001) == 1  # at least one


def test_priorities_rank_counts_descending_ties_by_id():
    counts = np.array([5, 0, 9, 5, 0, 1])
    assert priorities_from_counts(counts).tolist() == [2, 5, 1, 3, 6, 4]


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_prepass_priorities_fill_and_images(precision):
    sc = load_scene("balls:3")
    cfg = MachineConfig(precision=precision)
    cfg.ic_memory.resident_share = 0.2
    cfg.prepass.share = 0.04
    pre = run_prepass(sc, cfg, res=100)
    n = sc.n_primitives
    assert pre.resolution == 20 and pre.eye_rays == 400
    assert np.array_equal(np.sort(pre.priorities), np.arange(1, n + 1))
    # the counts are the coarse golden render's, all ray kinds
    golden = render(sc, cfg, res=20)
    assert np.array_equal(pre.references, golden.references)
    order = np.argsort(pre.priorities)  # by priority
    c = pre.references[order]
    assert np.all(np.diff(c) <= 0)
    ties = np.diff(c) == 0
    assert np.all(np.diff(order)[ties] > 0)  # equal counts: ascending id
    # balls:3 has unreferenced primitives: last, in id order
    assert pre.references[order[-1]] == 0 and np.all(np.diff(order[c == 0]) > 0)
    # resident fill: records in priority order while they fit
    lay = plan_layout(sc, cfg, pre.priorities)
    wb = cfg.word_bytes
    size = lay.record_size[order]
    m = pre.resident_count
    assert 0 < m < n and pre.resident_bytes == size[:m].sum() * wb <= pre.capacity_bytes
    assert size[:m + 1].sum() * wb > pre.capacity_bytes
    assert pre.capacity_bytes == int(0.2 * lay.primitive_database_words) * wb
    img = build_images(sc, cfg, priorities=pre.priorities)
    assert img.layout.resident_count == m and len(img.ic_resident) * wb == pre.resident_bytes
    assert np.array_equal(img.layout.record_space == RESIDENT, pre.priorities <= m)
    assert img.symbols["RESIDENT_M"] == m
    s = pre.summary()
    assert s["resident_count"] == m and 0 < s["resident_reference_share"] <= 1


def test_prepass_at_the_papers_resolution():
    sc = load_scene("mount")
    cfg = MachineConfig()
    cfg.ic_memory.resident_share = 0.3
    pre = run_prepass(sc, cfg, res=512)
    assert pre.resolution == 51 and pre.eye_rays == 51 * 51
    assert pre.resident_bytes <= pre.capacity_bytes
    # skewed references (paper, Fig. 3): the resident 30 % take well over 30 % of the tests
    assert pre.summary()["resident_reference_share"] > 0.5
    # nothing fits: M = 0, all records global
    cfg.ic_memory.resident_share = 0.0
    none = run_prepass(sc, cfg, res=64)
    assert none.resident_count == 0 and none.resident_bytes == 0


def test_a_draw_permutes_only_ties_and_jitters_eye_rays_within_their_pixels():
    """`paper --draws`: a seed reorders only primitives with equal counts (the records' order the
    paper leaves open) and moves each eye ray by less than half a pixel, the same for the same
    seed; without a seed nothing changes."""
    from netsushisen.host.rays import primary_rays, screen_coordinates

    counts = np.array([5, 0, 9, 5, 0, 1, 5, 0])
    orders = {tuple(priorities_from_counts(counts, seed).tolist()) for seed in range(20)}
    assert len(orders) > 1
    for p in orders:
        p = np.array(p)
        assert all(p[i] < p[j] for i in range(8) for j in range(8) if counts[i] > counts[j])
    cam = load_scene("tetra:1").camera
    exact = primary_rays(cam, 8)
    a, b = primary_rays(cam, 8, jitter=3), primary_rays(cam, 8, jitter=3)
    assert np.array_equal(a.direction, b.direction)
    assert not np.array_equal(a.direction, exact.direction)
    assert np.array_equal(primary_rays(cam, 8, jitter=None).direction, exact.direction)
    step = np.diff(screen_coordinates(8, cam.angle))[0]
    # on the image plane at distance 1 along the view: x/z and y/z differ by < half a step
    from netsushisen.host.rays import camera_basis

    f, r, u = camera_basis(cam)
    for d in (a, exact):
        d.plane = np.stack([(d.direction.T @ r) / (d.direction.T @ f),
                            (d.direction.T @ u) / (d.direction.T @ f)])
    assert np.max(np.abs(a.plane - exact.plane)) < step / 2 + 1e-6
