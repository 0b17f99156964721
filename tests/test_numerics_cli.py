"""`netsushisen numerics`: the stability report of one scene and of the built-in catalog."""

from __future__ import annotations

import json
import os
import signal
import time

import numpy as np
import pytest

from netsushisen import cluster, numerics
from netsushisen.host.images import decode_png

STABLE = """v
from 0 0 -5
at 0 0 0
up 0 1 0
angle 40
hither 0
resolution 8 8
l 0 5 -5
f 1 0.2 0.2 1 0 1 0 0
s 1 0 0 1
p 4
-3 -3 2
-3 3 2
3 3 2
3 -3 2
"""

# the same kind of scene far from the origin, at coordinates fp32 cannot hold: the spheres
# round onto other centres in fp32, so the hits differ from fp64's on many pixels
UNSTABLE = STABLE.replace("from 0 0 -5", "from 1000000.3 1000000.3 999995.3").replace(
    "at 0 0 0", "at 1000000.3 1000000.3 1000000.3").replace("l 0 5 -5", "l 1000000 1000005 999995").replace(
    "s 1 0 0 1", "".join(f"s {1000000.3 + 0.021 * i} 1000000.31 1000000.3 0.013\n" for i in range(-6, 7))) \
    .replace("angle 40", "angle 2")


def test_scene_report_writes_the_map_and_the_largest_translation(cli, tmp_path):
    path = tmp_path / "stable.nff"
    path.write_text(STABLE)
    code, out, err = cli("numerics", path, "--res", 8, "--out", tmp_path / "o")
    assert code == 0, err
    data = json.loads((tmp_path / "o" / "numerics.json").read_text())
    assert data["pixels"] == 64 and data["hit_differs"] == 0 and data["stable"] is True
    assert data["shadow_rays"] > 0 and data["blocked_only_fp32"] == 0
    # integer coordinates: exact in fp32 up to 2^24, the translations stay stable a long way
    assert data["largest_stable_translation"] >= 1e3
    assert f"largest stable translation: {data['largest_stable_translation']:g}" in out
    img = decode_png((tmp_path / "o" / "numerics_map.png").read_bytes())
    assert img.shape == (8, 8, 3) and not img.any()


def test_scene_report_exits_1_with_the_reason(cli, tmp_path):
    path = tmp_path / "far.nff"
    path.write_text(UNSTABLE)
    code, out, err = cli("numerics", path, "--res", 12, "--out", tmp_path / "o")
    data = json.loads((tmp_path / "o" / "numerics.json").read_text())
    assert code == 1 and data["hit_differs"] > 0.001 * 144
    assert "unstable: " in err and "hit another primitive in fp32 than in fp64" in err
    img = decode_png((tmp_path / "o" / "numerics_map.png").read_bytes())
    assert (img == 255).all(axis=2).sum() == data["hit_differs"]  # white = another primitive


def test_catalog_prints_one_row_per_case_and_path(cli, tmp_path, monkeypatch):
    cases = [c for c in numerics.CATALOG if c.name in ("grazing_sphere", "shared_edge_fan")]
    monkeypatch.setattr(numerics, "CATALOG", cases)
    code, out, err = cli("numerics", "--res", 4, "--engine", "compiled", "--out", tmp_path / "c")
    assert code == 0, err
    rows = [ln for ln in out.splitlines() if ln.startswith(("grazing_sphere", "shared_edge_fan"))]
    assert len(rows) == 6 and all(r.endswith("stable") for r in rows)
    assert {r.split()[1] for r in rows} == {"golden-fp32", "golden-fp64", "emulator-compiled"}
    md = (tmp_path / "c" / "catalog.md").read_text()
    assert md.count("| stable |") == 6


def test_catalog_exit_1_when_a_case_breaks(cli, tmp_path, monkeypatch):
    """A case whose path disagrees with the oracle makes the command fail with the reason."""
    monkeypatch.setattr(cluster, "IN_PROCESS", True)  # the patched run_path runs in the workers
    cases = [c for c in numerics.CATALOG if c.name == "shared_edge_fan"]
    monkeypatch.setattr(numerics, "CATALOG", cases)
    real = numerics.run_path

    def cracked(scene, path, res, sets=()):
        r = real(scene, path, res, sets)
        if path == numerics.GOLDEN64:
            r.hit_ids = np.where(np.arange(r.hit_ids.size) == r.hit_ids.size // 2, -1, r.hit_ids)
        return r

    monkeypatch.setattr(numerics, "run_path", cracked)
    code, out, err = cli("numerics", "--res", 5, "--engine", "compiled", "--out", tmp_path / "c")
    assert code == 1
    assert "unstable: shared_edge_fan on golden-fp64: 1 eye rays hit what the oracle does not allow" in err


@pytest.mark.parametrize("argv, message", [
    (["--res", "0"], "--res"),
    (["--set", "precision=fp64"], "--config / --set apply to a SCENE"),
    (["no_such_scene.nff"], "no_such_scene"),
])
def test_bad_input_is_one_line_and_exit_1(cli, tmp_path, argv, message):
    code, out, err = cli("numerics", *argv, "--out", tmp_path / "x")
    assert code != 0 and message in err and "Traceback" not in err


def test_spd_scene_report(cli, tmp_path):
    """An SPD scene: the map and the largest stable translation are written."""
    code, out, err = cli("numerics", "tetra:1", "--res", 6, "--out", tmp_path / "t")
    assert code in (0, 1)
    data = json.loads((tmp_path / "t" / "numerics.json").read_text())
    assert data["scene"].startswith("tetra") and data["complete"] is True
    assert data["translations"] and data["translations"][0]["by"] == 1.0
    assert "largest stable translation:" in out
    assert decode_png((tmp_path / "t" / "numerics_map.png").read_bytes()).shape == (6, 6, 3)


def test_interrupt_keeps_what_was_measured(cli, tmp_path, monkeypatch):
    """Ctrl-C during the translations: fp32 against fp64 and the translations done are written,
    exit 130. (One worker thread in this process takes the runs in order: the third sends the
    Ctrl-C and waits; the two before it have finished.)"""
    path = tmp_path / "stable.nff"
    path.write_text(STABLE)
    monkeypatch.setattr(cluster, "IN_PROCESS", True)
    real = numerics.compare_precisions
    calls = []

    def stop_on_third(*a, **kw):
        calls.append(1)
        if len(calls) == 3:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        return real(*a, **kw)

    monkeypatch.setattr(numerics, "compare_precisions", stop_on_third)
    code, out, err = cli("numerics", path, "--res", 6, "--out", tmp_path / "o", "--workers", 1)
    data = json.loads((tmp_path / "o" / "numerics.json").read_text())
    assert code == 130 and data["complete"] is False and len(data["translations"]) == 1
    assert "interrupted" in err
