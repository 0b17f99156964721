"""The golden renderer: grid results equal a brute-force nearest-hit search, ray counts, the IC
reference trace, corners, both precisions, the PNG writer/reader and the `golden` command."""

from __future__ import annotations

import json
import struct
import zlib

import numpy as np
import pytest

from netsushisen.cli import main
from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import EYE, REFLECTION, REFRACTION, SHADOW, render
from netsushisen.host.images import decode_png, encode_png, read_png, write_png
from netsushisen.host.nff import parse_nff
from netsushisen.host.rays import primary_rays
from netsushisen.host.shapes import build_shape_data, ic_rays, intersect
from netsushisen.isa.config import load_config


def brute_force_ids(scene, precision, res):
    """Nearest counting hit over ALL primitives (no grid), first id on equal t."""
    sd = build_shape_data(scene, precision)
    pr = primary_rays(scene.camera, res, precision=precision)
    n = pr.direction.shape[1]
    rays = ic_rays(np.repeat(pr.origin[:, None], n, 1), pr.direction, np.full(n, pr.t_min, sd.dtype))
    best, best_t = np.full(n, -1), np.full(n, np.inf, sd.dtype)
    prims = np.arange(scene.n_primitives)
    for lo in range(0, len(prims), 1024):
        p = prims[lo:lo + 1024]
        t = intersect(sd, rays, np.repeat(np.arange(n), len(p)), np.tile(p, n)).t.reshape(n, len(p))
        j = np.argmin(t, axis=1)
        tv = t[np.arange(n), j]
        better = tv < best_t
        best_t[better], best[better] = tv[better], p[j[better]]
    return best.reshape(res, res)


@pytest.mark.parametrize("spec", ["tetra", "balls", "mount", "rings", "tree:4"])
@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_grid_hits_equal_brute_force(spec, precision):
    sc = load_scene(spec)
    r = render(sc, load_config(None, [f"precision={precision}", "render.max_depth=1"]), res=12)
    assert np.array_equal(r.hit_ids, brute_force_ids(sc, precision, 12))


def test_concave_gears_hits_equal_brute_force(shared_spd):
    sc = load_scene(str(shared_spd / "gears.nff"))
    r = render(sc, load_config(None, ["render.max_depth=1"]), res=12)
    assert np.array_equal(r.hit_ids, brute_force_ids(sc, "fp32", 12))


def test_precisions_agree_on_almost_every_pixel():
    sc = load_scene("mount:3")
    a = render(sc, load_config(None, ["precision=fp32"]), res=24)
    b = render(sc, load_config(None, ["precision=fp64"]), res=24)
    assert (a.hit_ids == b.hit_ids).mean() > 0.99
    assert np.abs(a.image.astype(np.float64) - b.image).mean() < 0.01


def test_ray_counts_and_reference_trace_are_consistent():
    sc = load_scene("mount:3")
    r = render(sc, res=12, keep_trace=True)
    n_rays = len(r.trace_kind)
    assert (r.trace_kind == EYE).sum() == 144  # the trace holds one eye ray per pixel
    for kind, name in ((REFLECTION, "reflection"), (REFRACTION, "refraction"), (SHADOW, "shadow")):
        assert (r.trace_kind == kind).sum() == r.rays[name]
    assert r.rays["eye_hits"] == (r.hit_ids >= 0).sum()
    assert len(r.trace_ray_offsets) == n_rays + 1 and r.trace_ray_offsets[-1] == len(r.trace_prims)
    assert np.array_equal(np.bincount(r.trace_prims, minlength=sc.n_primitives), r.references)
    # depth-first order: pixels ascending, each tree starts with its eye ray
    eyes = np.flatnonzero(r.trace_kind == EYE)
    assert np.array_equal(r.trace_pixel[eyes], np.arange(144))
    assert np.all(np.diff(r.trace_pixel) >= 0)
    assert r.trace_depth.min() == 1 and r.trace_depth.max() <= 5
    # within a tree: after a surface ray come its shadow rays, then its reflection subtree
    for i in range(n_rays - 1):
        if r.trace_kind[i] == REFLECTION and r.trace_kind[i + 1] == SHADOW:
            assert r.trace_depth[i + 1] == r.trace_depth[i]


def test_shadow_rays_stop_at_the_first_occluder_in_list_order():
    text = """v
from 0 -5 3
at 0 0 0
up 0 0 1
angle 40
hither 0
resolution 4 4
l 0 0 10
f 1 1 1 1 0 1 0 1
p 4
-4 -4 0
4 -4 0
4 4 0
-4 4 0
s 0 0 2 0.5
s 0 0 4 0.5
"""
    sc = parse_nff(text, filename="stack.nff")
    cfg = load_config(None, ["grid.top_resolution=1", "grid.subdivide_threshold=10"])
    r = render(sc, cfg, res=31, keep_trace=True)
    lists = [r.trace_prims[r.trace_ray_offsets[i]:r.trace_ray_offsets[i + 1]].tolist()
             for i in range(len(r.trace_kind))]
    shadow = [lst for lst, k in zip(lists, r.trace_kind) if k == SHADOW]
    assert [0, 1] in shadow  # blocked by sphere 1: sphere 2 is never tested
    assert all(lst in ([0, 1], [0, 1, 2], [0]) or lst[:1] == [0] for lst in shadow)
    assert all(lst == [0, 1, 2] for lst, k in zip(lists, r.trace_kind) if k == EYE)


def test_visible_primitives_of_a_scene_worked_out_by_hand():
    # looking down +z from the origin: sphere 0 in front, sphere 1 hidden right behind it,
    # sphere 2 off to the side in view, sphere 3 behind the eye, sphere 4 outside the view
    text = """v
from 0 0 0
at 0 0 1
up 0 1 0
angle 40
hither 0.1
resolution 16 16
l 0 5 -5
f 1 1 1 1 0 1 0 1
s 0 0 10 2
s 0 0 14 1
s 2.5 0 10 0.6
s 0 0 -10 3
s 40 0 10 1
"""
    r = render(parse_nff(text, filename="hidden.nff"), res=16)
    assert r.visible_primitives == 2
    assert sorted(np.unique(r.hit_ids[r.hit_ids >= 0]).tolist()) == [0, 2]
    assert r.rays["eye_hits"] == (r.hit_ids >= 0).sum()
    # the centre pixel sees sphere 0, a corner pixel sees nothing
    assert r.hit_ids[8, 8] == 0 and r.hit_ids[0, 0] == -1


def test_corners_give_n_plus_one_squared_eye_rays():
    sc = load_scene("balls:1")
    r = render(sc, res=8, corners=True)
    assert r.rays["eye"] == 81 and r.hit_ids.shape == (9, 9) and r.image.shape == (8, 8, 3)
    assert r.image_u8.dtype == np.uint8


def test_depth_one_spawns_no_secondary_rays():
    r = render(load_scene("balls:1"), load_config(None, ["render.max_depth=1"]), res=8)
    assert r.rays["reflection"] == 0 and r.rays["refraction"] == 0 and r.rays["shadow"] > 0


def test_png_round_trip(tmp_path):
    img = np.random.default_rng(0).integers(0, 256, size=(7, 5, 3), dtype=np.uint8)
    write_png(tmp_path / "a.png", img)
    assert np.array_equal(read_png(tmp_path / "a.png"), img)
    grey = img[:, :, 0]
    assert np.array_equal(decode_png(encode_png(grey))[:, :, 0], grey)


def test_png_reader_handles_every_row_filter():
    img = np.random.default_rng(1).integers(0, 256, size=(5, 4, 3), dtype=np.uint8).astype(int)
    h, w, c = img.shape
    rows, prev = [], np.zeros(w * c, int)
    for y in range(h):
        f = y % 5
        line = img[y].reshape(-1)
        left = np.concatenate([np.zeros(c, int), line[:-c]])
        upleft = np.concatenate([np.zeros(c, int), prev[:-c]])
        if f == 0:
            pred = 0 * line
        elif f == 1:
            pred = left
        elif f == 2:
            pred = prev
        elif f == 3:
            pred = (left + prev) // 2
        else:
            p = left + prev - upleft
            pa, pb, pc = abs(p - left), abs(p - prev), abs(p - upleft)
            pred = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, prev, upleft))
        rows.append(bytes([f]) + bytes(((line - pred) & 0xFF).tolist()))
        prev = line

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(b"".join(rows))) + chunk(b"IEND", b""))
    assert np.array_equal(decode_png(png), img.astype(np.uint8))


def test_golden_command_writes_outputs(tmp_path, capsys):
    out, ids, js = tmp_path / "t.png", tmp_path / "ids.npy", tmp_path / "s.json"
    rc = main(["golden", "tetra:2", "--res", "8", "--precision", "fp64", "--depth", "2",
               "-o", str(out), "--ids", str(ids), "--json", str(js)])
    assert rc == 0
    stats = json.loads(js.read_text())
    assert set(stats) >= {"primitives", "visible_primitives", "rays", "references", "seconds"}
    assert set(stats["rays"]) == {"eye", "eye_hits", "reflection", "refraction", "shadow"}
    assert stats["rays"]["eye"] == 64 and stats["primitives"] == 16
    assert read_png(out).shape == (8, 8, 3) and np.load(ids).shape == (8, 8)
    assert "rays/s" in capsys.readouterr().out


@pytest.mark.parametrize("argv, needle", [
    (["golden", "no_such_scene"], "cannot load scene"),
    (["golden", "tetra:1", "--set", "grid.nope=1"], "unknown configuration field"),
    (["golden", "tetra:1", "--res", "0"], "--res"),
])
def test_golden_command_bad_input(argv, needle, capsys):
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err


SHARED_FILES = ["balls", "gears", "jacks", "lattice", "mount", "nurbtst", "rings", "sample", "shells",
                "sombrero", "teapot", "tetra", "tree"]


@pytest.mark.parametrize("name", SHARED_FILES)
def test_every_shared_file_renders(shared_spd, name):
    """Concave gears, teapot's patches, tree's cones, ...: each file renders to a finite image in
    which eye rays hit primitives of the kinds the file has."""
    sc = load_scene(str(shared_spd / f"{name}.nff"))
    r = render(sc, load_config(None, []), res=12)
    assert np.isfinite(r.image).all()
    hit = r.hit_ids[r.hit_ids >= 0]
    assert 0 < len(hit) and hit.max() < sc.n_primitives
    assert 1 <= r.visible_primitives <= min(144, sc.n_primitives)
