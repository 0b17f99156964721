"""Issue 46, Why 3: statistics and object files that once crashed reports (exit 70) are refused
on load with one located line naming the number (isa/numbers.py): a 100,000-digit integer,
`1e999999`, NaN, a count of 10^400, a flat dump whose names are not a tree."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator import stats as run_stats
from netsushisen.emulator.machine import Machine
from netsushisen.isa import numbers
from netsushisen.isa.config import load_config

PROGRAM = ".proc ic\nstart:  addi r1, r0, 3\n        { fadd r4, r3, r3 ; fmul r5, r3, r3 }\n        halt\n"


@pytest.fixture(scope="module")
def stats_text() -> str:
    m = Machine(load_config(), {"ic": assemble_text(PROGRAM, proc="ic")}, None)
    m.run(max_cycles=1000)
    return run_stats.dumps(run_stats.collect(m))


BIG = "1" + "0" * 100_000


def _poisoned(stats_text: str, raw: str) -> tuple[str, str]:
    """The statistics text with one stall count replaced by `raw` (JSON text), and that
    count's path."""
    doc = json.loads(stats_text)
    key = "branch"
    doc["processors"]["pe0.ic"]["stalls"][key] = "@@"
    return json.dumps(doc).replace('"@@"', raw), f"processors.pe0.ic.stalls.{key}"


@pytest.mark.parametrize("raw, problem", [
    (BIG, numbers.OUT_OF_RANGE), ("-" + BIG, numbers.OUT_OF_RANGE),
    ("1e999999", numbers.NOT_FINITE), ("NaN", numbers.NOT_FINITE),
    ("-Infinity", numbers.NOT_FINITE), (str(10 ** 400), numbers.OUT_OF_RANGE),
    (str(1 << 64), numbers.OUT_OF_RANGE),
])
@pytest.mark.parametrize("report", ["flat", "ilp", "stalls", "annotate", "memory", "diff",
                                    "bounds"])
def test_a_number_past_its_range_is_one_located_line(cli, tmp_path, stats_text, raw, problem,
                                                     report):
    text, where = _poisoned(stats_text, raw)
    bad = tmp_path / "stats.json"
    bad.write_text(text)
    good = tmp_path / "good.json"
    good.write_text(stats_text)
    args = [good, bad] if report == "diff" else [bad]
    code, out, err = cli("report", report, *args)
    assert code == 1 and "Traceback" not in err and "internal error" not in err
    assert err.strip() == f"{bad}: error: {where}: {problem}"


def test_the_largest_64_bit_numbers_still_read(cli, tmp_path, stats_text):
    text, _ = _poisoned(stats_text, str((1 << 64) - 1))
    path = tmp_path / "stats.json"
    path.write_text(text)
    code, out, err = cli("report", "flat", path)
    assert code == 0, err and str((1 << 64) - 1) in out.replace(",", "")


def test_cycles_of_10_to_the_400_in_diff(cli, tmp_path, stats_text):
    doc = json.loads(stats_text)
    doc["cycles"] = "@@"
    bad = tmp_path / "b.json"
    bad.write_text(json.dumps(doc).replace('"@@"', str(10 ** 400)))
    good = tmp_path / "a.json"
    good.write_text(stats_text)
    code, out, err = cli("report", "diff", good, bad)
    assert code == 1 and err.strip() == f"{bad}: error: cycles: {numbers.OUT_OF_RANGE}"


@pytest.fixture
def flat_text(cli, tmp_path, stats_text) -> str:
    path = tmp_path / "s.json"
    path.write_text(stats_text)
    code, out, err = cli("report", "flat", path)
    assert code == 0, err
    return out


@pytest.mark.parametrize("value, problem", [
    (BIG, numbers.OUT_OF_RANGE), ("1e999999", numbers.NOT_FINITE), ("nan", numbers.NOT_FINITE),
    ("-inf", numbers.NOT_FINITE)])
def test_a_flat_dump_number_past_its_range(cli, tmp_path, flat_text, value, problem):
    lines = flat_text.splitlines()
    n, name = len(lines), "pe0.ic.stalls.branch"
    lines.append(f"{name} {value}")
    path = tmp_path / "stats.txt"
    path.write_text("\n".join(lines) + "\n")
    code, out, err = cli("report", "stalls", path)
    assert code == 1 and err.strip() == f"{path}:{n + 1}: error: {name}: {problem}"


@pytest.mark.parametrize("extra, message", [
    (["processors 5", "processors.pe0.ic.cycles.sub 3"],
     "processors.pe0.ic.cycles.sub: 'processors' is a value, not a group of statistics"),
    (["processors.pe0.ic.cycles.sub 3", "processors 5"],
     "processors: 'processors' is a group of statistics, not a value"),
    (["dis.messages_per_pe.x 1"], "dis.messages_per_pe: a list's entries are named by"),
])
def test_a_flat_dump_whose_names_are_not_a_tree(cli, tmp_path, flat_text, extra, message):
    from netsushisen.api import load_stats
    from netsushisen.isa.errors import NetsushisenError

    lines = [] if extra[0].startswith("processors") else flat_text.splitlines()
    path = tmp_path / "stats.txt"
    path.write_text("\n".join(lines + extra) + "\n")
    code, out, err = cli("report", "ilp", path)
    assert code == 1 and "Traceback" not in err and message in err and len(err.splitlines()) == 1
    with pytest.raises(NetsushisenError, match=re.escape(message)):
        load_stats(path)


@pytest.mark.parametrize("raw, problem", [(BIG, numbers.OUT_OF_RANGE),
                                          ("-" + BIG, numbers.OUT_OF_RANGE),
                                          ("1e999999", "malformed content")])
@pytest.mark.parametrize("command", ["disasm", "run"])
def test_an_object_file_number_past_its_range(cli, tmp_path, raw, problem, command):
    program = assemble_text(PROGRAM, proc="ic")
    doc = program.to_json()
    doc["bundles"][0][0][1] = "@@"
    path = tmp_path / "ic.o"
    path.write_text(json.dumps(doc).replace('"@@"', raw))
    args = ["disasm", path] if command == "disasm" else ["run", "--ic", path, "--engine",
                                                         "reference"]
    code, out, err = cli(*args)
    assert code == 1 and "Traceback" not in err
    assert err.strip().startswith(f"{path}: error: bad object file: ")
    assert problem in err and len(err.strip().splitlines()) == 1


def test_numbers_parse_bounds_digits_before_conversion():
    assert numbers.integer(str((1 << 64) - 1)) == (1 << 64) - 1
    assert numbers.integer("-" + str(1 << 63)) == -(1 << 63)
    assert isinstance(numbers.integer("-" + str((1 << 63) + 1)), numbers.Unreadable)
    assert numbers.integer("0" * 50 + "7") == 7
    assert isinstance(numbers.integer("9" * 5000), numbers.Unreadable)
    assert numbers.first_problem({"a": [1, {"b": float("nan")}]}) == ("a[1].b", numbers.NOT_FINITE)
    assert numbers.first_problem({"a": [1, 2.5, True, None, "x"]}) is None
