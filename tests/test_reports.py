"""`netsushisen report ilp|stalls|memory STATS.json`: numbers from a real run, the four formats,
80-column tables, and one located line for bad input."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator import stats as run_stats
from netsushisen.emulator.machine import Machine
from netsushisen.isa.config import load_config
from netsushisen.isa.images import image_from_json

MISS_KERNELS = Path(__file__).with_name("kernels_miss")

IC_PROGRAM = """
.proc ic
start:  ldg r1, [r0 + 0]        # miss (list)
        ldg r1, [r0 + 1]        # hit  (list)
        ldg r2, [r0 + 16]       # miss (shape 5)
        ldr r3, [r0 + 0]        # resident (shape 5)
loop:   { fadd r4, r3, r3 ; fmul r5, r3, r3 ; fsub r6, r3, r3 }
        ldg r2, [r0 + 17]       # hit (shape)
        halt
"""


@pytest.fixture(scope="module")
def ic_stats(tmp_path_factory) -> Path:
    image = {"icgm": [0.5] * 64, "ic.resident": [1.0] * 8,
             "regions": {"ic.global": [[0, 16, "primitive_list", None], [16, 17, "shape_data", 5],
                                       [17, 32, "shape_data", None]],
                         "ic.resident": [[0, 1, "shape_data", 5]]}}
    m = Machine(load_config(), {"ic": assemble_text(IC_PROGRAM, proc="ic")}, image_from_json(image))
    m.run(max_cycles=1000)
    path = tmp_path_factory.mktemp("s") / "ic.json"
    path.write_text(run_stats.dumps(run_stats.collect(m)))
    return path


@pytest.fixture(scope="module")
def render_stats(tmp_path_factory) -> Path:
    from netsushisen.cli import main

    d = tmp_path_factory.mktemp("r")
    code = main(["render", "tetra:1", "--res", "3", "--kernels", str(MISS_KERNELS), "-o", str(d / "i.png"),
                 "--json", str(d / "s.json"), "--quiet"])
    assert code == 0
    return d / "s.json"


def rows(cli, kind: str, path: Path, key: str) -> list[dict]:
    code, out, err = cli("report", kind, path, "--format", "json")
    assert code == 0, err
    data = json.loads(out)
    return next(s for s in data["sections"] if s["key"] == key)["rows"]


def test_memory_report_gives_rho_mu_and_t(cli, ic_stats):
    r = {(x["processor"], x["region"]): x for x in rows(cli, "memory", ic_stats, "regions")}
    shape = r[("pe0.ic", "shape_data")]
    # shape data: 1 resident, 2 cache (1 miss, 1 hit): rho 1/3, mu 1/2, t = (1 + 2 + 8) / 3
    assert shape["loads"] == 3 and shape["resident"] == 1 and shape["cache"] == 2
    assert shape["ρ"] == pytest.approx(1 / 3) and shape["μ"] == pytest.approx(0.5)
    assert shape["t"] == pytest.approx(11 / 3) and shape["t model"] == pytest.approx((1 / 3 + 2 / 3 * 5))
    lst = r[("pe0.ic", "primitive_list")]
    assert lst["ρ"] == 0 and lst["μ"] == pytest.approx(0.5) and lst["t"] == pytest.approx(5)
    allr = r[("pe0.ic", "all")]
    assert allr["loads"] == 5 and allr["t"] == pytest.approx((1 + 2 * 2 + 2 * 8) / 5)


def test_ilp_report(cli, ic_stats):
    procs = {x["processor"]: x for x in rows(cli, "ilp", ic_stats, "processors")}
    ic = procs["pe0.ic"]
    assert ic["bundles"] == 7 and ic["ops"] == 9
    assert ic["dynamic ILP"] == pytest.approx(9 / ic["cycles"]) and ic["static ILP"] == pytest.approx(9 / 7)
    fill = {(x["processor"], x["unit"]): x for x in rows(cli, "ilp", ic_stats, "slot_fill")}
    assert fill[("pe0.ic", "fp")]["static fill"] == pytest.approx(3 / (7 * 3))
    assert fill[("pe0.ic", "fp")]["dynamic fill"] == pytest.approx(3 / (ic["cycles"] * 3))
    ports = {x["processor"]: x for x in rows(cli, "ilp", ic_stats, "register_ports")}
    assert ports["pe0.ic"]["max W"] == 3
    hot = rows(cli, "ilp", ic_stats, "hot_locations")
    # the two misses (the issue cycle + 7 held cycles each; ties by PC), then the two hits
    assert [(x["location"], x["cycles"]) for x in hot[:2]] == [("start", 8), ("start+2", 8)]
    assert sum(x["cycles"] for x in hot) <= ic["cycles"]


def test_stall_report_shares_add_up(cli, ic_stats):
    causes = [x for x in rows(cli, "stalls", ic_stats, "causes") if x["processor"] == "pe0.ic"]
    assert sum(x["of cycles"] for x in causes) == pytest.approx(1.0)
    by = {x["cause"]: x["cycles"] for x in causes}
    assert by["cache_miss"] == 14 and by["cache_hit"] == 2 and by["(issued)"] == 7
    locs = rows(cli, "stalls", ic_stats, "locations")
    assert {(x["location"], x["cause"]) for x in locs} >= {("start", "cache_miss"), ("start+2", "cache_miss")}


@pytest.mark.parametrize("kind", ["ilp", "stalls", "memory", "annotate"])
@pytest.mark.parametrize("fmt", ["table", "json", "md"])
def test_every_format(cli, render_stats, kind, fmt, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    code, out, err = cli("report", kind, render_stats, "--format", fmt)
    assert code == 0, err
    if fmt == "table":
        assert max(len(line) for line in out.splitlines()) <= 80
        assert "pe0.sc" in out
    elif fmt == "json":
        assert json.loads(out)["report"] == kind
    else:
        assert out.startswith("### ") and "|---" in out


def read_csv_strictly(text: str) -> list[dict]:
    """What pandas.read_csv needs to read a file as it is: one header row first, no comment or
    blank lines, every row as long as the header."""
    lines = text.splitlines()
    assert lines and all(line.strip() and not line.startswith("#") for line in lines)
    table = list(csv.reader(io.StringIO(text)))
    assert all(len(r) == len(table[0]) for r in table)
    return [dict(zip(table[0], r)) for r in table[1:]]


@pytest.mark.parametrize("kind", ["ilp", "stalls", "memory", "annotate"])
def test_csv_is_one_table_per_file(cli, render_stats, kind, tmp_path):
    code, out, err = cli("report", kind, render_stats, "--format", "json")
    keys = [s["key"] for s in json.loads(out)["sections"]]
    # several tables: CSV to standard output must choose one
    code, out, err = cli("report", kind, render_stats, "--format", "csv")
    assert code == 1 and out == "" and "--table NAME" in err and len(err.strip().splitlines()) == 1
    # -o DIR: one file per table, each readable as it is
    code, out, err = cli("report", kind, render_stats, "--format", "csv", "-o", tmp_path / kind)
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / kind).iterdir()) == sorted(f"{kind}_{k}.csv" for k in keys)
    for k in keys:
        read_csv_strictly((tmp_path / kind / f"{kind}_{k}.csv").read_text())
    # --table NAME: that table alone, to standard output
    code, out, err = cli("report", kind, render_stats, "--format", "csv", "--table", keys[0])
    assert code == 0 and out == (tmp_path / kind / f"{kind}_{keys[0]}.csv").read_text()
    read_csv_strictly(out)


def test_csv_reads_with_pandas(cli, render_stats):
    import pandas as pd  # a dependency (pyproject.toml): never skipped

    code, out, _ = cli("report", "stalls", render_stats, "--format", "csv", "--table", "causes")
    frame = pd.read_csv(io.StringIO(out))
    assert list(frame.columns) == ["processor", "cause", "cycles", "of cycles", "of stalls"]
    assert frame["cycles"].dtype.kind == "i"


def test_unknown_table_lists_the_tables(cli, render_stats):
    code, out, err = cli("report", "stalls", render_stats, "--table", "nope")
    assert code == 1 and "causes, locations" in err


def test_tables_fit_the_terminal_and_never_split_words(cli, render_stats, monkeypatch):
    words = set()
    code, out, _ = cli("report", "annotate", render_stats, "--format", "json", "--top", "8")
    for s in json.loads(out)["sections"]:
        for row in s["rows"]:
            for v in row.values():
                if isinstance(v, str):
                    words |= set(v.split())
    for width in (80, 140):
        monkeypatch.setenv("COLUMNS", str(width))
        code, out, _ = cli("report", "annotate", render_stats, "--top", "8")
        lines = out.splitlines()
        assert max(len(line) for line in lines) <= width
        tokens = {t for line in lines for t in line.split()}
        assert words <= tokens, sorted(words - tokens)[:5]  # every word whole on one line
    wide = max(len(line) for line in cli("report", "annotate", render_stats, "--top", "8")[1].splitlines())
    monkeypatch.setenv("COLUMNS", "80")
    narrow = max(len(line) for line in cli("report", "annotate", render_stats, "--top", "8")[1].splitlines())
    assert wide > narrow  # a wider terminal gets wider tables
    # a width below the longest words: the table grows to hold them instead of cutting one
    code, out, _ = cli("report", "annotate", render_stats, "--top", "8", "--width", "30")
    assert code == 0 and words <= {t for line in out.splitlines() for t in line.split()}


def test_column_widths_shrink_widest_first_and_stop_at_words():
    from netsushisen.reports.tables import column_widths

    assert column_widths([10, 30, 5], [3, 6, 5], 45) == [10, 30, 5]          # fits
    assert column_widths([10, 30, 5], [3, 6, 5], 30) == [10, 15, 5]          # widest gives
    assert column_widths([10, 30, 5], [8, 20, 5], 20) == [8, 20, 5]          # never below words
    # a header wider than its cells wraps first
    assert column_widths([12, 20], [6, 4], 28, body=[4, 20]) == [8, 20]


def test_output_file(cli, render_stats, tmp_path):
    code, out, _ = cli("report", "stalls", render_stats, "-o", tmp_path / "s.md", "--format", "md")
    assert code == 0 and out == "" and "fifo_empty" in (tmp_path / "s.md").read_text()


def test_old_statistics_without_static_ilp(cli, render_stats, tmp_path):
    data = json.loads(render_stats.read_text())
    for p in data["programs"].values():
        if p:
            p.pop("static_ilp", None)
            p["source"] = str(tmp_path / "gone.s")
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data))
    procs = rows(cli, "ilp", old, "processors")
    assert all(x["static ILP"] is None for x in procs)


@pytest.mark.parametrize("content, message", [
    (None, "no such statistics file"),
    ("{\"schema\": ", "not valid JSON"),
    ("[1, 2]", "not a netsushisen-stats statistics file"),
    ('{"schema": {"name": "netsushisen-stats", "version": 9}}', "schema version 9"),
    ('{"schema": {"name": "netsushisen-stats", "version": 1}, "config": {}, "memory": {}}',
     "'processors' is missing"),
    ('{"schema": {"name": "netsushisen-stats", "version": 1}, "config": {}, "memory": {},'
     ' "processors": {"pe0.ic": {"ops": 1}}}', "malformed statistics: missing field"),
])
def test_bad_input_is_one_located_line(cli, tmp_path, content, message):
    path = tmp_path / "s.json"
    if content is not None:
        path.write_text(content)
    code, out, err = cli("report", "ilp", path)
    assert code == 1 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(str(path)) and message in lines[0]
