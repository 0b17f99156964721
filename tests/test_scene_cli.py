"""`netsushisen scene ...`: Table-1 output as a table and as JSON, NFF export, and bad input giving
exit 1 with a located message and never a traceback."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from netsushisen.cli import main
from netsushisen.host.catalog import load_scene
from netsushisen.host.grid import build_grid
from netsushisen.host.nff import read_nff

VIEW = "v\nfrom 0 0 -5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 4 4\n"
HEADER = VIEW + "f 1 1 1 1 0 1 0 1\n"
TABLE1_KEYS = {"primitives", "polygons", "spheres", "cones", "cylinders", "lights",
               "reflective", "transparent"}


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


# luminance data: the material records, then the scene block of 9 + 6·L words (docs/databases.md)
@pytest.mark.parametrize("spec, expected, shape_lum", [
    ("tetra", dict(primitives=4096, polygons=4096, spheres=0, cones=0, cylinders=0, lights=1,
                   reflective=False, transparent=False), (245760, 92)),
    ("balls", dict(primitives=7382, polygons=1, spheres=7381, cones=0, cylinders=0, lights=3,
                   reflective=True, transparent=False), (236264, 172)),
    ("mount", dict(primitives=8196, polygons=8192, spheres=4, cones=0, cylinders=0, lights=1,
                   reflective=True, transparent=True), (491648, 124)),
    ("rings", dict(primitives=8401, polygons=1, spheres=4200, cones=0, cylinders=4200, lights=3,
                   reflective=True, transparent=False), (336072, 332)),
])
def test_info_json_table1(capsys, spec, expected, shape_lum):
    code, out, err = run(["scene", "info", spec, "--json"], capsys)
    assert code == 0 and err == ""
    data = json.loads(out)
    assert {k: data[k] for k in TABLE1_KEYS} == expected
    assert set(data) - TABLE1_KEYS == {"database_bytes"}
    # fp32 words: shape and luminance data depend on the scene only (docs/databases.md), the
    # voxel data and lists on the grid: 16-word header + grid words, null word + 2-word cells
    grid = build_grid(load_scene(spec))
    assert data["database_bytes"] == {
        "voxel_data": 4 * (16 + grid.words), "primitive_list": 4 * (1 + 2 * len(grid.leaf_prims)),
        "shape_data": shape_lum[0], "luminance_data": shape_lum[1]}


def test_info_table_from_file_fits_80_columns(capsys, shared_spd):
    code, out, err = run(["scene", "info", str(shared_spd / "sample.nff")], capsys)
    assert code == 0 and err == ""
    assert "scene sample" in out and "881" in out and "p 16, pp 864" in out
    assert max(len(line) for line in out.splitlines()) <= 80


def test_info_json_counts_patches_as_polygons(capsys, shared_spd):
    code, out, _ = run(["scene", "info", str(shared_spd / "teapot.nff"), "--json"], capsys)
    assert code == 0 and json.loads(out)["polygons"] == 9264


def test_nff_export_to_file_and_stdout(capsys, tmp_path):
    target = tmp_path / "balls1.nff"
    code, out, err = run(["scene", "nff", "balls:1", "-o", str(target)], capsys)
    assert code == 0 and out == "" and err == ""
    scene = read_nff(target)
    assert (scene.n_primitives, len(scene.light_position)) == (11, 3)
    code, out, _ = run(["scene", "nff", "rings:1"], capsys)
    assert code == 0 and out.startswith("b 0.078 0.361 0.753\nv\nfrom ")
    assert out.count("\nc ") == 30 and out.count("\ns ") == 30


def test_list(capsys):
    code, out, _ = run(["scene", "list"], capsys)
    assert code == 0 and [line.split()[0] for line in out.splitlines()] == \
        ["tetra", "balls", "mount", "rings", "shells", "tree", "lattice"]


# Every bad-input kind through the command line: (file content, "file:line:" expected or None for
# whole-file errors, message fragment).
BAD_FILES = {
    "truncated": (HEADER + "s 0 0 0\n", 9, "needs 4 numbers"),
    "non-number": (HEADER + "s 0 0 x 1\n", 9, "expected a number"),
    "bad count 2": (HEADER + "p 2\n0 0 0\n1 0 0\n", 9, "at least 3 vertices"),
    "bad count -1": (HEADER + "p -1\n", 9, "at least 3 vertices"),
    "bad count x": (HEADER + "p x\n", 9, "must be an integer"),
    "missing view": ("f 1 1 1 1 0 1 0 1\ns 0 0 0 1\n", None, "no view block"),
    "unknown keyword": (HEADER + "t 1 2 3\n", 9, "unknown record keyword 't'"),
    "nan": (HEADER + "s 0 0 0 NaN\n", 9, "not a finite number"),
    "inf": (HEADER + "s 0 0 0 inf\n", 9, "not a finite number"),
    "object before f": (VIEW + "s 0 0 0 1\n", 8, "before any material"),
    "empty": ("", None, "empty scene file"),
    "binary": (b"\x00\x01\xfe\xff\x89PNG" * 10, 1, "not valid UTF-8"),
    "non-utf8": (HEADER.encode() + b"# caf\xe9\n", 9, "not valid UTF-8"),
}


@pytest.mark.parametrize("name", list(BAD_FILES))
def test_bad_scene_file_exit_1_located(capsys, tmp_path, name):
    content, line, fragment = BAD_FILES[name]
    path = tmp_path / "bad.nff"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    code, out, err = run(["scene", "info", str(path)], capsys)
    assert code == 1 and out == ""
    first = err.splitlines()[0]
    prefix = f"{path}:{line}:" if line is not None else f"{path}: error:"
    assert first.startswith(prefix) and "error:" in first and fragment in first
    assert "Traceback" not in err


@pytest.mark.parametrize("argv, fragment", [
    (["scene", "info", "teapot"], "built-in scenes: tetra[:SIZE], balls[:SIZE]"),
    (["scene", "info", "mount:9"], "size factor for 'mount' must be between 1 and 7"),
    (["scene", "nff", "tetra:1", "-o", "/nonexistent-dir/x.nff"], "cannot write NFF file"),
])
def test_bad_specs(capsys, argv, fragment):
    code, out, err = run(argv, capsys)
    assert code == 1 and fragment in err and "Traceback" not in err


def test_subprocess_bad_and_good(tmp_path):
    bad = tmp_path / "bad.nff"
    bad.write_text(HEADER + "p 3\n0 0 0\n1 0 0\n")
    proc = subprocess.run([sys.executable, "-m", "netsushisen.cli", "scene", "info", str(bad)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith(f"{bad}:9:1: error: polygon record 'p' with 3 vertices needs 9")
    proc = subprocess.run([sys.executable, "-m", "netsushisen.cli", "scene", "info", "tetra:2",
                           "--json"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and json.loads(proc.stdout)["primitives"] == 16
