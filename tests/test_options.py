"""The option layer the commands share (netsushisen/options.py): one -D parser, one --set, one
resolution check, one --engine, the same for every command that takes them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from netsushisen.asm.objects import Program
from netsushisen.emulator.engine import DEFAULT_ENGINE, engine_names
from netsushisen.isa.errors import NetsushisenError
from netsushisen.options import MAX_RES, parse_define

MISS_KERNELS = Path(__file__).with_name("kernels_miss")

PROGRAM = """.proc ic
.data
value: .word X
.text
    halt
"""


@pytest.fixture
def program(tmp_path) -> Path:
    path = tmp_path / "p.s"
    path.write_text(PROGRAM)
    return path


@pytest.mark.parametrize("item, value", [("X", 1), ("X=1<<4", 16), ("X=0x10", 16), ("X=-3", -3),
                                         ("X=(2+3)*4", 20), ("X=1.5", 1.5)])
def test_one_define_parser(item, value):
    assert parse_define(item) == ("X", value)


@pytest.mark.parametrize("item, message", [("1X=2", "expected NAME"), ("X=Y+1", "undefined symbol 'Y'"),
                                           ("X=1 +", "constant expression")])
def test_define_errors(item, message):
    with pytest.raises(NetsushisenError, match=message):
        parse_define(item)


def test_run_takes_the_defines_asm_takes(tmp_path, cli, program):
    obj, stats = tmp_path / "p.o", tmp_path / "s.json"
    code, _, err = cli("asm", program, "-D", "X=1<<4", "-o", obj)
    assert code == 0, err
    assert Program.load(obj).defines["X"] == 16
    code, _, err = cli("run", "--ic", program, "-D", "X=1<<4", "--json", stats, "-q")
    assert code == 0, err
    assert json.loads(stats.read_text())["programs"]["ic"]["defines"]["X"] == 16
    for command in (["asm", program, "-o", obj], ["run", "--ic", program, "-q"]):
        code, _, err = cli(*command, "-D", "X=Y")
        assert code == 1 and "-D 'X=Y': undefined symbol 'Y'" in err


@pytest.fixture
def no_work(monkeypatch):
    """Any scene loading, host work or machine building fails the test: a rejected option must
    be rejected before anything is allocated."""
    from netsushisen import pipeline as render
    from netsushisen import paper
    from netsushisen.commands import golden
    from netsushisen.emulator import engine

    def forbidden(*args, **kwargs):
        raise AssertionError("work started before the options were checked")

    for module, name in ((render, "prepare"), (golden, "load_scene"), (golden, "render"),
                         (paper, "load_scene"), (paper, "analyse_scene"), (engine, "Machine")):
        monkeypatch.setattr(module, name, forbidden)


def _one_line_error(cli, *argv) -> str:
    code, out, err = cli(*argv)
    assert code == 1 and out == "" and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    prefix = f"netsushisen {argv[0]}: "  # the convention: the command names itself
    line = err.strip()
    return line[len(prefix):] if line.startswith(prefix + "error: ") else line


def test_resolution_out_of_range_is_one_line_before_any_work(cli, tmp_path, no_work):
    big = [_one_line_error(cli, "render", "tetra", "--res", "99999", "-o", tmp_path / "t.png"),
           _one_line_error(cli, "paper", "--res", "99999", "--out", tmp_path / "p", "--quiet"),
           _one_line_error(cli, "golden", "tetra", "--res", "99999")]
    zero = [_one_line_error(cli, "render", "tetra", "--res", "0", "-o", tmp_path / "t.png"),
            _one_line_error(cli, "golden", "tetra", "--res", "0"),
            _one_line_error(cli, "paper", "--res", "0", "--out", tmp_path / "p", "--quiet"),
            _one_line_error(cli, "debug", "tetra", "--res", "0")]
    assert len(set(big)) == 1 and len(set(zero)) == 1
    assert big[0] == zero[0].replace("--res 0", "--res 99999")
    assert f"1 to {MAX_RES:,}" in big[0]
    assert not (tmp_path / "p").exists() and not (tmp_path / "t.png").exists()


def test_unknown_engine_is_one_line_naming_the_engines(cli, tmp_path, program, no_work):
    errors = [_one_line_error(cli, "render", "tetra", "--engine", "nosuch", "-o", tmp_path / "t.png"),
              _one_line_error(cli, "run", "--ic", program, "--engine", "nosuch"),
              _one_line_error(cli, "paper", "--engine", "nosuch", "--out", tmp_path / "p", "--quiet")]
    assert len(set(errors)) == 1
    assert "unknown engine 'nosuch'" in errors[0]
    assert all(name in errors[0] for name in engine_names())


def test_the_default_engine_is_accepted_by_render_run_and_paper(cli, tmp_path, program):
    assert DEFAULT_ENGINE == ("compiled" if "compiled" in engine_names() else "reference")
    code, out, err = cli("render", "tetra:1", "--res", "2", "--kernels", MISS_KERNELS, "--engine",
                         "reference", "-o", tmp_path / "t.png", "--quiet")
    assert code == 0, err
    code, out, err = cli("run", "--ic", program, "-D", "X=1", "--engine", "reference", "-q")
    assert code == 0, err
    code, out, err = cli("paper", "--res", "4", "--scenes", "tetra:1", "--engine", "reference",
                         "--out", tmp_path / "p", "--quiet")
    assert code == 0, err
    assert "--engine reference" in (tmp_path / "p" / "report.md").read_text()


def test_set_is_one_option_everywhere(cli, tmp_path):
    """--set (and its shorthands) reach the configuration of every command that builds one."""
    code, out, _ = cli("config", "--set", "ring.fifo_depth=40")
    assert code == 0 and "fifo_depth = 40" in out
    for argv in (["golden", "tetra:1", "--res", "2"], ["render", "tetra:1", "--res", "2", "-o", tmp_path / "t.png"],
                 ["paper", "--res", "2", "--out", tmp_path / "p", "--quiet"],
                 ["run", "--ic", "x.s"], ["debug", "tetra:1"], ["config"]):
        code, _, err = cli(*argv, "--set", "ring.nosuch=1")
        assert code == 1 and "unknown configuration field 'ring.nosuch'" in err, argv


# ---------------------------------------------------------------------------------------------
# Limits before work (isa/limits.py)


def test_too_many_pes_or_too_large_an_image_is_one_line_before_any_work(cli, tmp_path, no_work,
                                                                        program, monkeypatch):
    """On a host with 16 GiB free, 100,000 PEs (~2.5 MiB each even on the reference engine), an
    8192² render (~1 KiB an eye ray) or a 3000² golden image (~3 KiB an eye ray) are refused at
    once, naming the limit, with nothing written."""
    from netsushisen.isa import limits

    monkeypatch.setattr(limits, "available_bytes", lambda: 16 * limits.GiB)
    pes = [_one_line_error(cli, "render", "tetra", "--pes", "100000", "-o", tmp_path / "t.png"),
           _one_line_error(cli, "run", "--ic", program, "--pes", "100000"),
           _one_line_error(cli, "debug", "tetra", "--set", "pes=100000"),
           _one_line_error(cli, "paper", "--set", "pes=100000", "--out", tmp_path / "p", "--quiet"),
           _one_line_error(cli, "accuracy", "tetra", "--set", "pes=100000", "--out", tmp_path / "a")]
    assert len(set(pes)) == 1 and "100,000 PEs needs about" in pes[0]
    assert "of host memory, more than the" in pes[0]
    big = _one_line_error(cli, "render", "tetra", "--res", "8192", "-o", tmp_path / "t.png")
    assert big.startswith("error: a 8192×8192 image needs about 64.2 GiB")
    if "compiled" in engine_names():  # ~9.5 MiB a PE on the compiled engine, 2.5 on the reference
        err = _one_line_error(cli, "render", "tetra", "--pes", "2000", "--engine", "compiled",
                              "-o", tmp_path / "t.png")
        assert "render tetra 32×32 on 2,000 PEs needs about 20.3 GiB" in err
    assert "golden tetra 3000×3000 needs" in _one_line_error(cli, "golden", "tetra", "--res", "3000")
    assert _one_line_error(cli, "debug", "tetra", "--res", "8192").startswith(
        "error: a 8192×8192 image needs about 64.2 GiB of host memory, more than the 16.0 GiB")
    assert not any(tmp_path.glob("*.png")) and not (tmp_path / "p").exists()


def test_sizes_past_the_machine_s_words_are_refused(cli, tmp_path, no_work):
    """Addresses and the pixel index are 32-bit signed words: a memory of more than 2^31 words
    or a frame of 46,341² samples cannot exist on the machine."""
    err = _one_line_error(cli, "render", "tetra", "--set", "os.local_words=3000000000",
                          "-o", tmp_path / "t.png")
    assert "os.local_words 3,000,000,000 is more than a memory can address" in err
    err = _one_line_error(cli, "golden", "tetra", "--set", "ic_memory.resident_bytes=9000000000")
    assert "ic_memory.resident_bytes" in err and "2,147,483,648 words" in err
    err = _one_line_error(cli, "render", "tetra", "--res", str(MAX_RES), "--corners")
    assert "image needs about" in err  # legal for the machine, not for this host
    err = _one_line_error(cli, "render", "tetra", "--res", str(MAX_RES + 1))
    assert "32-bit word" in err


def test_deep_fifos_count_against_host_memory(cli, tmp_path, no_work):
    """The compiled engine allocates every FIFO at the deepest's capacity: 2^20 words (the
    field's limit, limits.MAX_FIFO_WORDS) is ~470 MB for one PE's 56 FIFOs, so 1,000 PEs need
    ~460 GB; past the limit the field itself is refused."""
    err = _one_line_error(cli, "render", "tetra", "--res", "2", "--engine", "compiled", "--pes",
                          "1000", "--set", "ring.fifo_depth=1048576", "-o", tmp_path / "t.png")
    assert "needs about" in err and "GiB of host memory" in err
    err = _one_line_error(cli, "render", "tetra", "--res", "2", "--engine", "compiled",
                          "--set", "ring.fifo_depth=1000000000", "-o", tmp_path / "t.png")
    assert "ring.fifo_depth must be at most 1,048,576, got 1,000,000,000" in err


def test_large_runs_announce_their_size(monkeypatch):
    from netsushisen.isa import limits
    from netsushisen.isa.config import MachineConfig

    lines: list[str] = []
    monkeypatch.setattr(limits, "available_bytes", lambda: 64 * limits.GiB)
    small = limits.render_footprint("render tetra 32×32", MachineConfig(), 32, "compiled")
    limits.check_host(small, announce=lines.append)
    assert lines == [] and not small.large
    big = limits.render_footprint("render tetra 1024×1024", MachineConfig(), 1024, "compiled")
    limits.check_host(big, quiet=True, announce=lines.append)
    assert lines == []
    limits.check_host(big, announce=lines.append)
    assert lines == ["render tetra 1024×1024: 1,048,576 eye rays, about 1.2 GiB of host memory "
                     "of 64.0 GiB available"]
    many = MachineConfig(pes=200)
    assert limits.machine_bytes(many, "compiled") > limits.machine_bytes(many, "reference")
    assert limits.render_footprint("x", many, 2, "compiled").large
    monkeypatch.setattr(limits, "available_bytes", lambda: limits.GiB)
    with pytest.raises(NetsushisenError, match="more than the 1.0 GiB available"):
        limits.check_host(big, announce=lines.append)


def test_render_never_overwrites_an_image_it_was_not_told_to(cli, tmp_path, monkeypatch):
    """The default SCENE.png, then SCENE-1.png, SCENE-2.png: an earlier image is never lost;
    -o names the file to write (over) exactly; golden writes an image only where -o says."""
    monkeypatch.chdir(tmp_path)
    argv = ["render", "tetra:1", "--res", "2", "--kernels", MISS_KERNELS, "--engine",
            "reference", "--quiet"]
    (tmp_path / "tetra.png").write_bytes(b"an earlier image")
    for _ in range(2):
        code, _, err = cli(*argv)
        assert code == 0, err
    assert (tmp_path / "tetra.png").read_bytes() == b"an earlier image"
    assert (tmp_path / "tetra-1.png").stat().st_size > 0 and (tmp_path / "tetra-2.png").exists()
    code, _, err = cli(*argv, "-o", "tetra.png")
    assert code == 0 and (tmp_path / "tetra.png").read_bytes() != b"an earlier image"
    assert not (tmp_path / "tetra-3.png").exists()
    code, _, err = cli("golden", "tetra:1", "--res", "2")
    assert code == 0 and sorted(p.name for p in tmp_path.iterdir()) == [
        "tetra-1.png", "tetra-2.png", "tetra.png"]
    err = _one_line_error(cli, *argv, "-o", tmp_path / "no" / "t.png")
    assert err.endswith(f"cannot write here: no folder '{tmp_path / 'no'}'")


def test_set_into_a_value_is_one_line(cli):
    """`--set precision.foo=1`: precision is a value, not a table (was a TypeError)."""
    code, _, err = cli("run", "--set", "precision.foo=1")
    assert code == 1 and "precision is a value, not a table" in err
    assert "Traceback" not in err and "internal error" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("setting, message", [
    ("max_cycles=-5", "max_cycles must be at least 0, got -5 (allowed 0.."),
    ("grid.top_resolution=-1", "grid.top_resolution must be at least 0, got -1"),
    ("grid.top_resolution=100000", "grid.top_resolution must be at most 256, got 100,000 "
                                   "(allowed 0..256 voxels a side"),
    ("render.epsilon=nan", "render.epsilon must be a finite number (allowed 0..1"),
    ("render.min_weight=-inf", "render.min_weight must be a finite number (allowed 0..1"),
    ("ic_memory.t_g=2000000000", "ic_memory.t_g must be at most 4,096, got 2,000,000,000"),
    ("ic.latency.fmul=1000000000", "ic.latency.fmul must be at most 4,096"),
    ("ic.latency.fmul=0", "ic.latency.fmul must be at least 1, got 0"),
    ("render.max_depth=100000000", "render.max_depth must be at most 64"),
    ("ring.deadlock_cycles=0", "ring.deadlock_cycles must be at least 1"),
    ("os.taken_branch_penalty=-1", "os.taken_branch_penalty must be at least 0"),
])
def test_fields_outside_their_range_are_refused_with_the_range(setting, message, capsys):
    """issue 30 items 1 and 7: negative, zero, NaN, infinite and oversized values of fields that
    size memory or time are refused (limits.FIELD_LIMITS), the allowed range in the line."""
    from netsushisen.cli import main

    assert main(["config", "--set", setting]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert main(["config", "--set", setting.split("=")[0] + "=" + _at_limit(setting)]) == 0


def _at_limit(setting: str) -> str:
    """A legal value of the field: its bound nearest the refused one."""
    from netsushisen.isa import limits

    path, value = setting.split("=")
    low, high, _ = limits.FIELD_LIMITS.get(path, limits.FIELD_LIMITS["ring.link_latency"])
    return str(high if value.lstrip("+").replace(".", "").isdigit() and float(value) > high
               else low)
