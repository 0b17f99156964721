"""`netsushisen run` and `netsushisen config`: outputs, exit codes, located errors, no tracebacks.

The tests of what a run does (statistics, outputs, exit codes of its end) run once per engine
(`engine_name`, tests/conftest.py) with `run --engine`; the trace is the reference engine's own
(`run --trace` takes only it), and input errors are found before any engine is built."""

from __future__ import annotations

from pathlib import Path

import json

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.cli import main
from netsushisen.isa.ring import make_header

IC_SRC = """
start:
    ldg r1, [r0 + 1]
    fadd r2, r1, r1
    halt
"""


@pytest.fixture
def files(tmp_path):
    (tmp_path / "ic.s").write_text(IC_SRC)
    assemble_text(IC_SRC, proc="ic", filename="ic.s").save(tmp_path / "ic.o")
    (tmp_path / "img.json").write_text(json.dumps({"icgm": [0.5, 1.25, 2.0]}))
    return tmp_path


def test_run_source_and_object_with_statistics(files, capsys, engine_name):
    for prog in ("ic.s", "ic.o"):
        out = files / f"stats-{prog}.json"
        code = main(["run", "--ic", str(files / prog), "--image", str(files / "img.json"),
                     "--json", str(out), "--engine", engine_name])
        assert code == 0
        s = json.loads(out.read_text())
        assert s["run"]["status"] == "halted"
        # ldg miss: c0 + 7 held; fadd c8; r2 at 10 not needed; halt c9 -> 10 cycles
        assert s["processors"]["pe0.ic"]["cycles"] == 10
        assert s["processors"]["pe0.ic"]["stalls"] == {"cache_miss": 7}
        assert s["memory"]["pe0.ic"]["cache"]["misses"] == 1
    assert "pe0.ic: 10 cycles, 3 bundles" in capsys.readouterr().out


def test_statistics_files_are_byte_identical(files, engine_name):
    paths = [files / "a.json", files / "b.json"]
    for p in paths:
        assert main(["run", "--ic", str(files / "ic.s"), "--image", str(files / "img.json"),
                     "--pes", "2", "--json", str(p), "-q", "--engine", engine_name]) == 0
    assert paths[0].read_bytes() == paths[1].read_bytes()


def test_trace_filter_and_cycles(files, capsys):
    assert main(["run", "--ic", str(files / "ic.s"), "--image", str(files / "img.json"),
                 "--trace", "--trace-filter", "pe0.ic", "--cycles", "0:3", "-q"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3
    assert lines[0].split()[:4] == ["0", "pe0.ic", "0", "start"]
    assert "ldg r1, [1]" in lines[0]
    assert lines[1].endswith("stall cache_miss")


RING_DEADLOCK_DIR = Path(__file__).parent / "programs" / "ring_deadlock"
"""Three stage programs that deadlock the ring with the buffer pool off (one channel per link)."""
DL_OS, DL_IC, DL_SC = ((RING_DEADLOCK_DIR / f"{s}.s").read_text() for s in ("os", "ic", "sc"))


def test_deadlock_exit_3_with_report_and_outputs(tmp_path, capsys, engine_name):
    for name, src in (("os", DL_OS), ("ic", DL_IC), ("sc", DL_SC)):
        (tmp_path / f"{name}.s").write_text(src)
    args = ["run", "--os", str(tmp_path / "os.s"), "--ic", str(tmp_path / "ic.s"),
            "--sc", str(tmp_path / "sc.s"), "--set", "ring.deadlock_cycles=100",
            "--json", str(tmp_path / "s.json"), "--frame", str(tmp_path / "f.npy"),
            "--engine", engine_name]
    code = main(args + ["--set", "ring.buffer_pool=false"])
    err = capsys.readouterr().err
    assert code == 3
    assert "Traceback" not in err and "deadlock in pe0" in err
    assert "pe0.ic: pc 2 (tail): waiting on fifo_empty:ring" in err
    assert "pe0.sc: pc 4 (wait_os)" in err
    assert "FIFO pe0.send.os: 2/64 words" in err and "FIFO pe0.link.os-ic" in err
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["run"]["status"] == "deadlock" and "deadlock" in s["run"]["message"]
    assert s["fifos"]["pe0.send.os"]["left"] == 2
    assert np.load(tmp_path / "f.npy").shape == (0, 0, 3)
    assert main(args + ["--set", "ring.buffer_pool=true"]) == 0


def test_run_time_fault_exit_2_statistics_written(tmp_path, capsys, engine_name):
    (tmp_path / "ic.s").write_text("start: nop\n ldg r1, [r0 + 99]\n halt\n")
    code = main(["run", "--ic", str(tmp_path / "ic.s"), "--json", str(tmp_path / "s.json"),
                 "--engine", engine_name])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert "pe0.ic pc 1 (start+1) cycle 1: error: run-time fault: ICGM address 99" in err
    assert json.loads((tmp_path / "s.json").read_text())["run"]["status"] == "fault"


def test_max_cycles_exit_4(tmp_path, capsys, engine_name):
    (tmp_path / "os.s").write_text("loop: j loop\n")
    assert main(["run", "--os", str(tmp_path / "os.s"), "--max-cycles", "100", "-q",
                 "--engine", engine_name]) == 4
    assert "cycle limit reached: 100" in capsys.readouterr().err


def _err(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err
    return err


def test_bad_inputs_exit_1_with_located_messages(files, tmp_path, capsys):
    ic = str(files / "ic.s")
    assert main(["run", "--ic", str(tmp_path / "missing.o")]) == 1
    assert "missing.o: error: no such object file" in _err(capsys)
    (tmp_path / "junk.o").write_text("not json")
    assert main(["run", "--ic", str(tmp_path / "junk.o")]) == 1
    assert "junk.o: error: not a netsushisen-object file" in _err(capsys)
    (tmp_path / "bad.s").write_text("halt\n fadd r1, r2\n")
    assert main(["run", "--ic", str(tmp_path / "bad.s")]) == 1
    assert "bad.s:2:" in _err(capsys)
    assert main(["run", "--os", str(files / "ic.o")]) == 1
    assert "this is a IC program, given as --os" in _err(capsys)
    (tmp_path / "img.json").write_text('{"icgm": [1, 2,]}')
    assert main(["run", "--ic", ic, "--image", str(tmp_path / "img.json")]) == 1
    assert "img.json:1:16: error: not valid JSON" in _err(capsys)
    (tmp_path / "img2.json").write_text('{"icgm": [1, true]}')
    assert main(["run", "--ic", ic, "--image", str(tmp_path / "img2.json")]) == 1
    assert "icgm: word 1: booleans are not words" in _err(capsys)
    (tmp_path / "img3.json").write_text('{"ic.local": {"at": 70000, "words": [1]}}')
    assert main(["run", "--ic", ic, "--image", str(tmp_path / "img3.json")]) == 1
    assert "do not fit in ic.local_words" in _err(capsys)
    assert main(["run", "--ic", ic, "--set", "ring.fifo_depth=0"]) == 1
    assert "ring.fifo_depth must be at least 1" in _err(capsys)
    assert main(["run", "--ic", ic, "--set", "ring.nonsense=1"]) == 1
    assert "unknown configuration field" in _err(capsys)
    assert main(["run"]) == 1
    assert "nothing to run" in _err(capsys)
    assert main(["run", "--ic", ic, "--cycles", "x:y"]) == 1
    assert "--cycles" in _err(capsys)


def test_host_stream_must_hold_whole_messages(files, tmp_path, capsys):
    (tmp_path / "img.json").write_text(json.dumps({"host": [make_header(3, 0), 1]}))
    assert main(["run", "--ic", str(files / "ic.s"), "--image", str(tmp_path / "img.json")]) == 1
    assert "announces 3 payload words but only 1 follow" in _err(capsys)


def test_npz_image(tmp_path, capsys, engine_name):
    (tmp_path / "ic.s").write_text("ldg r1, [r0 + 2]\nldr r2, [r0]\nhalt\n")
    np.savez(tmp_path / "img.npz", **{"icgm": np.array([0.0, 1.0, 2.5], dtype=np.float32),
                                      "ic.resident": np.array([-3], dtype=np.int32),
                                      "sizes.icgm": np.array(16)})
    assert main(["run", "--ic", str(tmp_path / "ic.s"), "--image", str(tmp_path / "img.npz"),
                 "--json", str(tmp_path / "s.json"), "-q", "--engine", engine_name]) == 0
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["global_memory"]["icgm"]["words"] == 16


def test_config_dump_roundtrip_and_check(tmp_path, capsys):
    assert main(["config", "--dump", "--set", "ic_memory.t_g=16", "--set", "ic.latency.fdiv=20"]) == 0
    text = capsys.readouterr().out
    assert "t_g = 16" in text and "fdiv = 20" in text
    (tmp_path / "c.toml").write_text(text)
    assert main(["config", "--check", str(tmp_path / "c.toml")]) == 0
    assert "ok" in capsys.readouterr().out
    (tmp_path / "bad.toml").write_text("[ring]\nfifo_depth = 0\n[ic.latency]\nldg = 3\n")
    assert main(["config", "--check", str(tmp_path / "bad.toml")]) == 1
    err = _err(capsys)
    assert "bad.toml:2: error: ring.fifo_depth must be at least 1" in err
    assert "bad.toml:4: error: ic.latency.ldg: IC load times come from ic_memory" in err
    (tmp_path / "broken.toml").write_text("[ring\n")
    assert main(["config", "--check", str(tmp_path / "broken.toml")]) == 1
    assert "broken.toml:1:6: error: not valid TOML: Expected ']'" in _err(capsys)


BAD_CONFIG = """\
pes = 2
precison = "fp64"

[rnig]                  # an unknown section hides nothing after it
fifo_depth = 8

[ring]
buffer_pool = "no"
fifo_depth = 0

[ic_memory]
t_g = "8"
cache_share = 2.0
"""


def test_config_check_reports_every_error_at_its_line(tmp_path, capsys):
    (tmp_path / "bad.toml").write_text(BAD_CONFIG)
    assert main(["config", "--check", str(tmp_path / "bad.toml")]) == 1
    err = _err(capsys).splitlines()
    f = str(tmp_path / "bad.toml")
    assert err == [
        f"{f}:2: error: unknown configuration field 'precison'; did you mean 'precision'?",
        f"{f}:4: error: unknown configuration section 'rnig'; did you mean 'ring'?",
        f'{f}:8: error: ring.buffer_pool: expected true or false, got "no" (a string)',
        f"{f}:9: error: ring.fifo_depth must be at least 1, got 0 (allowed 1..1,048,576 words; "
        "the compiled engine's FIFO buffers)",
        f'{f}:12: error: ic_memory.t_g: expected a whole number, got "8" (a string)',
        f"{f}:13: error: ic_memory.cache_share must lie in 0..1, got 2.0"]
    # the same through --config of a command, before any work; a --set value is not the file's
    assert main(["render", "tetra", "--config", f, "--set", "pes=0"]) == 1
    err = _err(capsys).splitlines()
    assert len(err) == 7 and err[-1] == "netsushisen render: error: pes must be at least 1, got 0"
    # fixed, the file passes; on the command line a bool may be written yes/no
    fixed = BAD_CONFIG.replace("precison", "precision").replace("[rnig]", "[render]").replace(
        "fifo_depth = 8", "max_depth = 3").replace('"no"', "false").replace(
        "fifo_depth = 0", "fifo_depth = 32").replace('"8"', "8").replace("2.0", "0.5")
    (tmp_path / "good.toml").write_text(fixed)
    assert main(["config", "--check", str(tmp_path / "good.toml"), "--set",
                 "ring.buffer_pool=yes"]) == 0
    out = capsys.readouterr().out
    assert out.strip().endswith("good.toml: ok")


def test_unknown_set_field_suggests_the_closest(capsys):
    assert main(["config", "--set", "ring.fifo_dept=40"]) == 1
    assert "did you mean 'ring.fifo_depth'?" in _err(capsys)
    assert main(["config", "--set", "rnig.fifo_depth=40"]) == 1
    assert "did you mean 'ring'?" in _err(capsys)
    assert main(["config", "--set", "ic.latency.fdvi=40"]) == 1
    assert "ic.latency.fdvi: unknown mnemonic 'fdvi'; did you mean 'fdiv'?" in _err(capsys)


def test_object_file_that_breaks_the_checker_is_rejected(files, tmp_path, capsys):
    obj = json.loads((files / "ic.o").read_text())
    obj["bundles"][1] = [["fadd", 2, 1, 1], ["fadd", 3, 1, 1], ["fadd", 4, 1, 1],
                         ["fadd", 5, 1, 1]]
    (tmp_path / "bad.o").write_text(json.dumps(obj))
    assert main(["run", "--ic", str(tmp_path / "bad.o")]) == 1
    err = _err(capsys)
    assert "ic.s:4: error: bundle 1: slot overflow: 4 fp operations" in err


def test_image_raw_word_too_wide_for_fp32(files, tmp_path, capsys):
    (tmp_path / "img.json").write_text('{"icgm": ["0x100000000", 1.0]}')
    assert main(["run", "--ic", str(files / "ic.s"), "--image", str(tmp_path / "img.json")]) == 1
    assert "icgm: raw word 0x100000000 is wider than a 32-bit (fp32) machine word" in _err(capsys)
    assert main(["run", "--ic", str(files / "ic.s"), "--image", str(tmp_path / "img.json"),
                 "--set", "precision=fp64", "-q"]) == 0


def test_a_processor_blocked_forever_is_a_warning(tmp_path, capsys, engine_name):
    """docs/timing.md "End of run": `finished` is quiescence, so a processor still waiting on
    an empty FIFO is legal (exit 0) — but a program run by hand meant to halt: warn, naming the
    processor, its PC and the FIFO, the same on every engine."""
    (tmp_path / "ic.s").write_text("start:\n    addi r1, r0, 1\nloop:\n    recv r2, ring\n    halt\n")
    (tmp_path / "sc.s").write_text("start:\n    wait\n    halt\n")
    (tmp_path / "os.s").write_text("    halt\n")
    code = main(["run", "--ic", str(tmp_path / "ic.s"), "--sc", str(tmp_path / "sc.s"), "--os",
                 str(tmp_path / "os.s"), "--engine", engine_name, "-q", "--json",
                 str(tmp_path / "s.json")])
    assert code == 0
    assert _err(capsys).splitlines() == [
        "netsushisen run: warning: pe0.ic never halted: it waits forever at pc 1 (loop) on its "
        "empty receive FIFO 'ring'; nothing is left to send it (the run ended `finished`)",
        "netsushisen run: warning: pe0.sc never halted: it waits forever at pc 0 (start) in "
        "`wait`, with every receive FIFO empty; nothing is left to send it (the run ended "
        "`finished`)"]
    assert json.loads((tmp_path / "s.json").read_text())["run"]["status"] == "finished"
    # every processor halts: no warning
    (tmp_path / "ic.s").write_text("    halt\n")
    assert main(["run", "--ic", str(tmp_path / "ic.s"), "--engine", engine_name, "-q"]) == 0
    assert _err(capsys) == ""


def test_outputs_in_a_missing_folder_are_refused_before_the_run(tmp_path, capsys):
    (tmp_path / "ic.s").write_text("    halt\n")
    assert main(["run", "--ic", str(tmp_path / "ic.s"), "--json", str(tmp_path / "no" / "s.json")]) == 1
    assert _err(capsys).strip() == (f"{tmp_path / 'no' / 's.json'}: error: cannot write here: "
                                    f"no folder '{tmp_path / 'no'}'")


@pytest.mark.parametrize("image, message", [
    ({"sizes": {"icgm": 100_000_000_000}}, "sizes.icgm: 100,000,000,000 words; a memory holds 0 "
                                           "to 2,147,483,648 words"),
    ({"frame": {"width": 100_000, "height": 100_000}}, "frame: 100,000×100,000 samples exceed the "
                                                        "machine's frame"),
    ({"frame": {"width": -5, "height": 3}}, "frame: a -5×3 frame"),
])
def test_image_sizes_beyond_the_machine_are_one_line_before_the_run(tmp_path, capsys, monkeypatch,
                                                                    image, message):
    from netsushisen.emulator import engine

    def forbidden(*args, **kwargs):
        raise AssertionError("the machine was built before the image was checked")

    monkeypatch.setattr(engine, "Machine", forbidden)
    (tmp_path / "ic.s").write_text("    halt\n")
    (tmp_path / "img.json").write_text(json.dumps(image))
    assert main(["run", "--ic", str(tmp_path / "ic.s"), "--image", str(tmp_path / "img.json"),
                 "--engine", "reference"]) == 1
    err = _err(capsys).strip()
    assert len(err.splitlines()) == 1 and f"img.json: {message}" in err
