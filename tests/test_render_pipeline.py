"""The render pipeline (host -> images -> kernels -> machine -> frame) with stand-in kernels
that send every eye ray to the background: what arrives in the frame buffer is exactly
background x weight, wherever the pipeline could have lost or misplaced a pixel."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import Luminance
from netsushisen.host.images import read_png
from netsushisen.host.rays import primary_rays
from netsushisen.isa.config import load_config
from netsushisen.isa.ring import parse_header
from netsushisen.isa.words import FP32, FP64
from netsushisen.kernels import protocol
from netsushisen.pipeline import eye_ray_messages, render

MISS_KERNELS = Path(__file__).with_name("kernels_miss")


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_eye_ray_messages_carry_the_golden_eye_rays(precision):
    scene = load_scene("balls:1")
    wf = FP32 if precision == "fp32" else FP64
    words = eye_ray_messages(scene, 3, False, wf).reshape(9, 14)
    p = protocol()
    eye = primary_rays(scene.camera, 3, False, precision)
    for i in range(9):
        assert parse_header(int(words[i, 0])).tag == p["TAG_RAY"]
        assert wf.to_int(words[i, 1]) == i and wf.to_int(words[i, 2]) == 4  # eye, depth 1
        floats = [wf.to_float(w) for w in words[i, 3:]]
        assert floats[0:3] == list(np.asarray(eye.origin, wf.float_type))
        assert floats[3:6] == list(eye.direction[:, i])
        assert floats[6] == eye.t_min and floats[7] == np.inf and floats[8:] == [1, 1, 1]


@pytest.mark.parametrize("corners,pes", [(False, 1), (True, 2)])
def test_pipeline_puts_every_sample_in_its_pixel(corners, pes):
    scene = load_scene("balls:1")
    config = load_config(None, [f"pes={pes}"])
    r = render(scene, config, res=4, corners=corners, kernel_dir=MISS_KERNELS)
    assert r.run.status == "finished"
    bg = Luminance.of(scene, np.float32).background
    side = 5 if corners else 4
    assert r.rays["eye"] == side * side and r.rays["eye_hits"] == 0
    assert np.array_equal(r.image, np.broadcast_to(bg, (4, 4, 3)))
    assert (r.hit_ids == -1).all() and r.visible_primitives == 0
    assert r.stats["col"]["pixel_messages"] == side * side
    assert len([k for k in r.stats["processors"] if k.endswith(".os")]) == pes


def test_render_command_writes_image_ids_and_json(tmp_path, cli):
    out, ids, js = tmp_path / "i.png", tmp_path / "ids.npy", tmp_path / "s.json"
    code, stdout, err = cli("render", "tetra:1", "--res", "3", "--kernels", MISS_KERNELS,
                            "-o", out, "--ids", ids, "--json", js)
    assert code == 0, err
    assert read_png(out).shape == (3, 3, 3) and np.load(ids).shape == (3, 3)
    stats = json.loads(js.read_text())
    assert stats["rays"]["eye"] == 9 and len(stats["image_sha256"]) == 64
    assert "pe0.os" in stats["processors"] and "ILP and stalls" in stdout


def test_a_kernel_error_comes_back_located(tmp_path, cli):
    for f in MISS_KERNELS.glob("*.s"):
        (tmp_path / f.name).write_text(f.read_text())
    (tmp_path / "sc.s").write_text(".proc sc\n.include \"protocol.inc\"\n  fadd r1, r2\n  halt\n")
    code, _, err = cli("render", "tetra:1", "--res", "2", "--kernels", tmp_path, "-o", tmp_path / "x.png")
    assert code == 1 and "Traceback" not in err
    assert "sc.s:3:3: error: 'fadd' takes 3 operands" in err


def test_bundled_kernels_are_assembled_once_per_symbols_and_scheduler_view(tmp_path):
    """pipeline._bundled_kernels: equal symbols and configuration give the same programs (one
    assembly); a configuration the scheduler reads differently reschedules; a folder of one's own
    is assembled afresh every time (its files may change between runs)."""
    from netsushisen.kernels import KERNELS
    from netsushisen.pipeline import prepare
    config = load_config(None, [])
    a, b = (prepare("tetra:3", config, res=4).programs for _ in range(2))
    assert a is b
    slow = prepare("tetra:3", load_config(None, ["ic.latency.fmul=6"]), res=4).programs
    assert slow is not a and slow["ic"].bundles != a["ic"].bundles
    for f in KERNELS.glob("*.[si]*"):
        (tmp_path / f.name).write_text(f.read_text())
    own = [prepare("tetra:3", config, res=4, kernel_dir=tmp_path).programs for _ in range(2)]
    assert own[0] is not own[1] and own[0]["ic"].bundles == a["ic"].bundles
