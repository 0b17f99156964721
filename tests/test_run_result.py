"""`run --regs`, `run --mem`, `run --json`'s `final` and `run/debug --no-schedule`: a program's
result without the debugger (emulator/final.py), the same on every engine."""

from __future__ import annotations

import json
import re

import pytest

from netsushisen.cli import main
from netsushisen.kernels import KERNELS

DOT = str(KERNELS / "examples" / "dot_ic.s")
PAIRS = str(KERNELS / "examples" / "pairs.json")

STORE = """
.proc ic
.reg total = r5
.data
out:    .word 0, 0, 0, 0, 0
.text
        li r1, 7
        st r1, [out + 1]
        lf total, 2.5
        st total, [out + 3]
        li r2, -3
        halt
"""


def _sum_line(out: str) -> str:
    return next(line for line in out.splitlines() if line.strip().startswith("sum/r10"))


def test_regs_give_the_dot_products_sum_scheduled_and_serial(capsys, engine_name):
    """The shipped docs/scheduling.md example: 64 pairs, the sum by name as a float, the same
    scheduled and serial while the cycles differ."""
    base = ["run", "--ic", DOT, "--image", PAIRS, "--regs", "--engine", engine_name]
    assert main(base) == 0
    scheduled = capsys.readouterr().out
    assert main(base + ["--no-schedule"]) == 0
    serial = capsys.readouterr().out
    assert _sum_line(scheduled) == _sum_line(serial)
    assert _sum_line(scheduled).split()[1:] == ["1155923968", "0x44e60000", "1840.0"]
    cycles = [int(re.search(r"halted, (\d+) cycles", o).group(1)) for o in (scheduled, serial)]
    assert cycles[0] < 0.6 * cycles[1]


def test_mem_prints_words_in_each_format(tmp_path, capsys, engine_name):
    src = tmp_path / "store.s"
    src.write_text(STORE)
    assert main(["run", "--ic", str(src), "-q", "--engine", engine_name, "--regs",
                 "--mem", "ic.local:0:4", "--mem", "ic.local:out:5d", "--mem",
                 "pe0.ic.local:3:1f"]) == 0
    out = capsys.readouterr().out.splitlines()
    words = [line for line in out if line.startswith("ic.local[")]
    assert words[:4] == ["ic.local[0]:  0x00000000            0  0.0",
                         "ic.local[1]:  0x00000007            7  9.80908925027372e-45",
                         "ic.local[2]:  0x00000000            0  0.0",
                         "ic.local[3]:  0x40200000   1075838976  2.5"]
    assert words[4].split() == ["ic.local[0]:", "0", "7", "0", "1075838976"]
    assert words[5].split() == ["ic.local[4]:", "0"]
    assert words[6].split() == ["ic.local[3]:", "2.5"]
    regs = {line.split()[0]: line.split()[1:] for line in out if line.startswith("  ")}
    assert regs["total/r5"] == ["1075838976", "0x40200000", "2.5"]
    assert regs["r2"][:2] == ["-3", "0xfffffffd"]
    assert "r3" not in regs  # zero and unnamed


def test_json_holds_final_registers_and_memory(tmp_path, capsys, engine_name):
    out = tmp_path / "s.json"
    assert main(["run", "--ic", DOT, "--image", PAIRS, "--json", str(out), "-q",
                 "--mem", "ic.resident:2:2", "--engine", engine_name]) == 0
    shown = capsys.readouterr().out  # --mem prints, and no --regs: no registers
    assert shown.startswith("ic.resident[2]:  0x40000000") and "registers" not in shown
    final = json.loads(out.read_text())["final"]
    regs = {r["name"]: r for r in final["registers"]["pe0.ic"]}
    assert regs["sum"] == {"reg": "r10", "name": "sum", "int": 1155923968, "hex": "0x44e60000",
                           "float": 1840.0}
    assert final["memory"] == [{"request": "ic.resident:2:2", "processor": "pe0.ic",
                                "space": "resident", "address": 2,
                                "words": [{"int": 1073741824, "hex": "0x40000000", "float": 2.0},
                                          {"int": 1061158912, "hex": "0x3f400000",
                                           "float": 0.75}]}]


@pytest.mark.parametrize("request_text, message", [
    ("ic.locl:0", "expected [peN.]PROC.MEMORY:ADDR[:N[F]]"),
    ("ic.local:0:4q", "expected [peN.]PROC.MEMORY:ADDR[:N[F]]"),
    ("ic.local:70000:2", "address 70000 is past the memory's end"),
    ("ic.local:nothere", "no data label 'nothere'"),
    ("pe3.ic.local:0", "no processor pe3.ic"),
    ("os.resident:0", "no resident memory"),
])
def test_bad_mem_requests_are_one_line_before_the_run(request_text, message, capsys):
    assert main(["run", "--ic", DOT, "--image", PAIRS, "--mem", request_text,
                 "--engine", "reference"]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""  # refused before the run: no summary
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in captured.err


def test_debug_no_schedule_runs_the_serial_form(capsys):
    base = ["debug", "--ic", DOT, "--image", PAIRS, "--no-screen", "--batch", "-"]
    cycles = []
    for extra in ([], ["--no-schedule"]):
        import io
        import sys
        stdin, sys.stdin = sys.stdin, io.StringIO("continue\nprint sum\n")
        try:
            assert main(base + extra) == 0
        finally:
            sys.stdin = stdin
        out = capsys.readouterr().out
        assert "float 1840.0" in out
        cycles.append(int(re.search(r"run ended at cycle (\d+)", out).group(1)))
    assert cycles[0] < 0.6 * cycles[1]
    assert main(["debug", "tetra", "--no-schedule", "--batch", "-"]) == 1
    assert "--no-schedule is for programs given as files" in capsys.readouterr().err
