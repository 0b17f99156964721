"""Limits on the inputs that size work (issue 30, item 1; isa/limits.py): the
assembler's total expansion and expression size, sweep specs, NFF primitive counts, deep
TOML / JSON and files that are not regular files are each refused before the work, in one line
naming the limit."""

from __future__ import annotations

from pathlib import Path

import pytest

from netsushisen.isa import limits
from netsushisen.asm.assembler import assemble_text
from netsushisen.cli import main
from netsushisen.isa.errors import NetsushisenError


def _asm_error(text: str) -> str:
    with pytest.raises(NetsushisenError) as err:
        assemble_text(".proc os\n" + text + "\n    halt\n")
    return err.value.diagnostics[0].message


def test_nested_rept_is_limited_in_total_not_per_level():
    msg = _asm_error(".rept 65536\n.rept 65536\n nop\n.endr\n.endr")
    assert "more than 1,048,576 statements (limits.MAX_EXPANDED_LINES" in msg
    assemble_text(".proc os\n.rept 4\n.rept 4\n nop\n.endr\n.endr\n halt\n")  # small: fine


def test_macros_invoking_macros_are_counted_before_they_expand():
    lines = [".macro m0", "  nop", ".endm"]
    for k in range(1, 41):
        lines += [f".macro m{k}", f"  m{k - 1}", f"  m{k - 1}", ".endm"]
    assert "limits.MAX_EXPANDED_LINES" in _asm_error("\n".join(lines + ["  m40"]))
    assert len(assemble_text(".proc os\n" + "\n".join(lines + ["  m3", " halt"])).bundles) == 9


def test_a_doubling_macro_argument_stops_at_the_statement_limit():
    lines = [".macro d0 x", "  .equ q, \\x", ".endm"]
    for k in range(1, 40):
        lines += [f".macro d{k} x", f"  d{k - 1} \\x\\x", ".endm"]
    assert "limits.MAX_STATEMENT_CHARS" in _asm_error("\n".join(lines + ["  d39 1"]))


def test_expression_size_depth_and_integer_width():
    assert "limits.MAX_STATEMENT_CHARS" in _asm_error(".equ z, " + "+".join(["1"] * 40000))
    assert "limits.MAX_EXPRESSION_DEPTH" in _asm_error(".equ z, " + "+".join(["1"] * 300))
    assert assemble_text(".proc os\n.equ z, " + "+".join(["1"] * 200) + "\n halt\n")
    squares = [".equ a0, 3"] + [f".equ a{k}, a{k - 1}*a{k - 1}" for k in range(1, 40)]
    assert "limits.MAX_CONSTANT_BITS" in _asm_error("\n".join(squares))


def _spec(tmp_path: Path, body: str) -> str:
    path = tmp_path / "s.toml"
    path.write_text('scenes = ["tetra"]\n' + body)
    return str(path)


@pytest.mark.parametrize("body, message", [
    ("[vary]\n" + "".join(f'"{f}" = [1,2,3,4,5,6,7,8,9,10]\n' for f in (
        "ic_memory.t_g", "ic_memory.t_r", "ic_memory.t_c", "sc_memory.t_g", "sc_memory.t_r",
        "sc_memory.t_c", "ring.link_latency", "ring.fifo_depth", "os.taken_branch_penalty")),
     "1,000,000,000 points"),
    ('[vary]\n"ic_memory.t_g" = {start = 1, stop = 1e15, step = 1}\n', "a range of 1,000,000,000,000,000"),
    ('[vary]\nx = [2, 3]\n[derive]\n"ic_memory.t_c" = "x ** 99999999999"\n', "limits.MAX_CONSTANT_BITS"),
    ('[vary]\nx = [[1, 2]]\n[derive]\n"ic_memory.t_c" = "x * 1000000000"\n', "not a number"),
    ('[vary]\nx = [2.5]\n[derive]\n"ic_memory.t_c" = "x ** 99999999999"\n', "too large"),
])
def test_sweep_specs_that_would_not_end_are_refused(tmp_path, capsys, body, message):
    assert main(["sweep", _spec(tmp_path, body), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "out").exists()


def test_files_that_are_not_regular_files_are_refused(capsys):
    for argv in (["render", "/dev/zero"], ["config", "--check", "/dev/zero"],
                 ["disasm", "/dev/zero"], ["report", "ilp", "/dev/zero"]):
        assert main(argv) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "is not a regular file" in err[0], (argv, err)


def test_scenes_with_too_many_primitives_are_refused(tmp_path, monkeypatch, capsys):
    head = ("v\nfrom 0 0 -10\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\n"
            "b 0 0 0\nl 1 1 1\nf 1 0 0 0.5 0.5 0 0 0\n")
    scene = tmp_path / "many.nff"
    scene.write_text(head + "s 0 0 0 1\n" * 5)
    monkeypatch.setattr(limits, "MAX_PRIMITIVES", 4)
    assert main(["golden", str(scene), "--res", "2"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == f"{scene}: error: 5 primitives, more than 4 (limits.MAX_PRIMITIVES: the host's grid and databases)"
    monkeypatch.setattr(limits, "MAX_PRIMITIVES", 5)
    assert main(["golden", str(scene), "--res", "2"]) == 0


def test_deeply_nested_toml_and_json_are_one_line(tmp_path, capsys):
    (tmp_path / "deep.toml").write_text("a = " + "[" * 50000 + "]" * 50000 + "\n")
    (tmp_path / "deep.o").write_text("[" * 50000 + "]" * 50000)
    (tmp_path / "deep.json").write_text('{"a": ' + "[" * 50000 + "]" * 50000 + "}")
    (tmp_path / "spec.toml").write_text("a = " + "[" * 50000 + "]" * 50000 + "\n")
    for argv in (["config", "--check", str(tmp_path / "deep.toml")], ["disasm", str(tmp_path / "deep.o")],
                 ["report", "ilp", str(tmp_path / "deep.json")], ["sweep", str(tmp_path / "spec.toml")]):
        assert main(argv) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "error:" in err[0] and "internal" not in err[0], (argv, err)


def test_coincident_primitives_are_refused_by_the_grid_pairs_they_imply(tmp_path, capsys):
    """20,000 coincident spheres (220 KB) asked the grid builder for 300 M pairs (3.2 GB)."""
    head = ("v\nfrom 0 0 -10\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\n"
            "b 0 0 0\nl 1 1 1\nf 1 0 0 0.5 0.5 0 0 0\n")
    scene = tmp_path / "same.nff"
    scene.write_text(head + "s 0 0 0 1\n" * 20000)
    assert main(["golden", str(scene), "--res", "2"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "limits.MAX_GRID_CANDIDATES" in err[0], err


@pytest.mark.parametrize("sets", [["grid.top_resolution=256"],
                                  ["grid.top_resolution=256", "grid.sub_resolution=256",
                                   "grid.subdivide_threshold=0"]])
def test_a_grid_at_its_maximum_is_refused_from_the_configuration(tmp_path, capsys, sets):
    """issue 46 Why 7: refused after 19-53 s of building the grid; the README promises a
    refusal within a second (here: before any grid work, the process's imports aside)."""
    import time

    args = ["render", "tetra", "--res", "2", "-o", str(tmp_path / "t.png")]
    for s in sets:
        args += ["--set", s]
    start = time.monotonic()
    assert main(args) == 1
    assert time.monotonic() - start < 5
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "grid.top_resolution 256 is 16,777,216 top voxels" in err[0], err
    assert "do not fit os.local_words = 65536" in err[0] and not (tmp_path / "t.png").exists()
