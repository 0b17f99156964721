"""`report annotate`, `report diff`, the stall glossary and the plots, on statistics from real
runs of both engines (`run`) and of `render`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from netsushisen.reports.glossary import CAUSES, explain, glossary_markdown, lookup

DOCS = Path(__file__).resolve().parents[1] / "docs"

# three iterations; `fadd` waits for `fmul` (latency L: L - 1 operand stalls each), the taken
# `bnez` costs the branch penalty (1) twice
LOOP = """
.proc ic
start:  li r1, 3
loop:   { fmul r2, r2, r2 ; addi r1, r1, -1 }
        fadd r3, r2, r2
        bnez r1, loop
        halt
"""


def section(cli, *argv) -> dict[str, list[dict]]:
    code, out, err = cli("report", *argv, "--format", "json")
    assert code == 0, err
    return {s["key"]: s["rows"] for s in json.loads(out)["sections"]}


@pytest.fixture
def loop_run(cli, tmp_path, engine_name):
    """Statistics of LOOP run with `--set`s, on the engine under test."""
    src = tmp_path / "loop.s"
    src.write_text(LOOP)

    def run(name: str, *sets: str) -> Path:
        out = tmp_path / f"{name}.json"
        argv = ["run", "--ic", src, "--json", out, "-q", "--engine", engine_name]
        for s in sets:
            argv += ["--set", s]
        code, _, err = cli(*argv)
        assert code == 0, err
        return out

    return run


def test_statistics_carry_the_listing(loop_run):
    stats = json.loads(loop_run("a").read_text())
    listing = stats["programs"]["ic"]["listing"]
    assert listing["label"] == ["start", "loop", "loop+1", "loop+2", "loop+3"]
    assert listing["text"][1] == "fmul r2, r2, r2 ; addi r1, r1, -1"
    assert listing["ops"] == [1, 2, 1, 1, 1]
    assert listing["target"] == [None, None, None, 1, None]
    assert listing["source"][2] == "loop.s:5"


def test_annotate_counts_each_bundle(cli, loop_run):
    rows = section(cli, "annotate", loop_run("a"), "--order", "program")["bundles"]
    by_pc = {r["pc"]: r for r in rows}
    assert [r["pc"] for r in rows] == [0, 1, 2, 3, 4]  # program order, every bundle
    cycles = 19  # 9 bundles in the loop + 2 others, 3 × 2 operand stalls, 2 branch stalls
    assert by_pc[2]["issued"] == 3 and by_pc[2]["stall cycles"] == 6
    assert by_pc[2]["stalls by cause"] == "operand:fmul 6"
    assert by_pc[3]["stalls by cause"] == "branch 2"
    assert by_pc[2]["share"] == pytest.approx(9 / cycles)
    assert by_pc[1]["fill"] == pytest.approx(2 / 4) and by_pc[2]["fill"] == pytest.approx(1 / 4)
    assert sum(r["issued"] + r["stall cycles"] for r in rows) == cycles
    hot = section(cli, "annotate", loop_run("a"), "--top", "2")["bundles"]
    assert [r["pc"] for r in hot] == [2, 3]  # hottest first: 9 cycles, then 5


def test_loop_summary_and_its_dominant_stall_flips(cli, loop_run):
    slow = section(cli, "annotate", loop_run("slow"), "--table", "loops")["loops"]
    assert len(slow) == 1
    lp = slow[0]
    assert (lp["loop"], lp["parent"], lp["pcs"], lp["iterations"], lp["cycles"]) == \
        ("loop", None, "1-3", 3, 17)
    assert lp["cycles/iter"] == pytest.approx(17 / 3) and lp["bound"] >= 3
    assert lp["static ILP"] == pytest.approx(4 / 3) and lp["dynamic ILP"] == pytest.approx(12 / 17)
    assert lp["dominant stall"] == f"operand:fmul {100 * 6 / 17:.1f}%"
    # a one-cycle fmul has no operand stall: the taken branch dominates
    fast = section(cli, "annotate", loop_run("fast", "ic.latency.fmul=1"), "--table", "loops")["loops"]
    assert fast[0]["cycles"] == 11 and fast[0]["dominant stall"] == f"branch {100 * 2 / 11:.1f}%"


def test_diff_of_two_runs_differing_in_one_latency(cli, loop_run):
    a, b = loop_run("a"), loop_run("b", "ic.latency.fmul=6")
    d = section(cli, "diff", a, b)
    assert d["inputs"] == [{"field": "config.ic.latency.fmul", "A": "3 (default)", "B": 6}]
    m = {(r["processor"], r["metric"]): r for r in d["processors"]}
    # 5 operand stalls per iteration instead of 2, three iterations: +9 cycles, nothing else
    assert m[("(run)", "cycles")]["change"] == 9
    assert (m[("pe0.ic", "cycles")]["A"], m[("pe0.ic", "cycles")]["B"]) == (19, 28)
    assert m[("pe0.ic", "cycles")]["relative"] == pytest.approx(9 / 19)
    assert m[("pe0.ic", "stall operand:fmul")]["change"] == 9
    assert m[("pe0.ic", "stall branch")]["change"] == 0
    assert m[("pe0.ic", "bundles")]["change"] == 0 and m[("pe0.ic", "static ILP")]["change"] == 0
    assert m[("pe0.ic", "dynamic ILP")]["change"] == pytest.approx(14 / 28 - 14 / 19)  # 14 ops
    changed = section(cli, "diff", a, b, "--changed")["processors"]
    assert {r["metric"] for r in changed} == {"cycles", "dynamic ILP", "stall cycles",
                                              "stall operand:fmul"}
    # the same run twice: no input differs, no figure changes
    same = section(cli, "diff", a, a, "--changed")
    assert same["inputs"] == [] and same["processors"] == [] and same["memory"] == []


@pytest.fixture(scope="module")
def render_pair(tmp_path_factory) -> tuple[Path, Path]:
    from netsushisen.cli import main

    d = tmp_path_factory.mktemp("r")
    out = []
    for name, sets in (("a", []), ("b", ["--set", "ic.latency.fmul=8"])):
        assert main(["render", "tetra", "--res", "4", "-o",
                     str(d / f"{name}.png"), "--json", str(d / f"{name}.json"), "--quiet"] + sets) == 0
        out.append(d / f"{name}.json")
    return out[0], out[1]


def test_diff_of_render_outputs(cli, render_pair):
    a, b = render_pair
    d = section(cli, "diff", a, b)
    fields = [(r["field"], r["B"]) for r in d["inputs"]]
    # the latency, and IC's program: its .sched regions are scheduled for the configuration
    assert fields[0] == ("config.ic.latency.fmul", 8)
    assert all(f.startswith("programs.ic.") for f, _ in fields[1:])
    sa, sb = (json.loads(p.read_text()) for p in render_pair)
    run = next(r for r in d["processors"] if r["processor"] == "(run)")
    assert run["change"] == sb["run"]["cycles"] - sa["run"]["cycles"] > 0
    fmul = next(r for r in d["processors"] if r["processor"] == "pe0.ic"
                and r["metric"] == "stall operand:fmul")
    assert fmul["change"] > 0
    regions = {(r["region"], r["metric"]) for r in d["memory"] if r["processor"] == "pe0.ic"}
    assert ("all", "ρ") in regions and ("all", "t") in regions
    for fmt in ("table", "md", "csv"):
        extra = ["--table", "processors"] if fmt == "csv" else []
        code, out, err = cli("report", "diff", a, b, "--format", fmt, *extra)
        assert code == 0 and "operand:fmul" in out, err


def test_annotate_on_render_output(cli, render_pair):
    d = section(cli, "annotate", render_pair[0], "--proc", "ic", "--top", "5")
    assert {r["processor"] for r in d["bundles"]} == {"pe0.ic"} and len(d["bundles"]) == 5
    cycles = [r["issued"] + r["stall cycles"] for r in d["bundles"]]
    assert cycles == sorted(cycles, reverse=True) and all(r["bundle"] for r in d["bundles"])
    assert any(r["loop"] for r in d["loops"])
    code, out, err = cli("report", "annotate", render_pair[0], "--proc", "pe7.ic")
    assert code == 1 and "pe0.os, pe0.ic, pe0.sc" in err or "pe0.ic" in err


def test_annotate_without_a_listing(cli, render_pair, tmp_path):
    data = json.loads(render_pair[0].read_text())
    for p in data["programs"].values():
        if p:
            p.pop("listing")
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data))
    code, out, err = cli("report", "annotate", old, "--format", "json")
    assert code == 0, err
    rows = json.loads(out)["sections"][0]
    assert rows["rows"] and all(r["bundle"] is None for r in rows["rows"])
    assert "no program listing" in rows["caption"]


def test_every_cause_the_engines_charge_is_in_the_one_table(render_pair):
    from netsushisen.emulator.compiled.state import CAUSES as ENGINE_CAUSES
    from netsushisen.isa.stalls import HOLD_CAUSES, concrete_causes

    charged = {c for c in ENGINE_CAUSES if c not in ("", "halted")}
    assert charged == set(concrete_causes())
    # what the reference engine charged in a real run is in the table too
    stats = json.loads(render_pair[0].read_text())
    seen = {c for p in stats["processors"].values() if p for c in p["stalls"]}
    assert seen and all(lookup(c) is not None for c in seen), [c for c in seen if lookup(c) is None]
    assert HOLD_CAUSES == {"local", "resident", "cache_hit", "cache_miss", "branch"}
    assert lookup("no_such_cause") is None and "does not know" in explain("no_such_cause")
    assert lookup("operand:no_such_op") is None and lookup("fifo_full:nowhere") is None
    assert explain("operand:fdiv").count("`fdiv`") == 1 and "<m>" not in explain("operand:fdiv")


def test_glossary_doc_is_generated_from_the_table(cli):
    assert (DOCS / "stalls.md").read_text() == glossary_markdown(), \
        "docs/stalls.md is stale: run `netsushisen report stalls --explain --format md -o docs/stalls.md`"
    code, out, _ = cli("report", "stalls", "--explain", "--format", "json")
    rows = json.loads(out)["sections"][0]["rows"]
    assert [r["cause"] for r in rows] == [c.name for c in CAUSES]


def test_stalls_explain_covers_the_run(cli, render_pair):
    d = section(cli, "stalls", render_pair[0], "--explain")
    charged = {r["cause"] for r in d["causes"] if r["cause"] != "(issued)"}
    assert {r["cause"] for r in d["glossary"]} == charged
    ring = next(r for r in d["glossary"] if r["cause"] == "fifo_empty:ring")
    assert ring["rule"] == "T8" and "`ring`" in ring["meaning"]
    code, out, err = cli("report", "stalls")
    assert code == 1 and "--explain" in err


@pytest.mark.parametrize("kind", ["stalls", "annotate"])
def test_plots(cli, render_pair, tmp_path, kind):
    png = tmp_path / f"{kind}.png"
    code, out, err = cli("report", kind, render_pair[0], "--plot", png)
    assert code == 0 and f"plot -> {png}" in err and out
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    code, _, err = cli("report", kind, render_pair[0], "--plot", tmp_path / "x.txt")
    assert code == 1 and "x.txt" in err and len(err.strip().splitlines()) == 1
    code, _, err = cli("report", kind, render_pair[0], "--plot", tmp_path / "no" / "x.png")
    assert code == 1 and "does not exist" in err


def test_a_cause_has_one_colour_in_every_plot(render_pair):
    """Both plots draw a cause in the table's colour, whatever else the plot shows (the old
    palettes coloured causes by their rank in each plot, so `operand:fmul` changed colour)."""
    import matplotlib.pyplot as plt

    from netsushisen.isa.stalls import ISSUED_COLOUR, OTHER_COLOUR, colour
    from netsushisen.reports.stall_plots import annotate_figure, legend_colours, stalls_figure

    stats = json.loads(render_pair[1].read_text())
    plots = []
    for fig in (stalls_figure(stats), annotate_figure(stats, "pe0.ic"),
                annotate_figure(stats, "pe0.sc")):
        plots.append(legend_colours(fig))
        plt.close(fig)
    for legend in plots:
        causes = [c for c in legend if c not in ("issued", "other")]
        assert len(causes) >= 3 and legend["issued"] == ISSUED_COLOUR
        assert all(legend[c] == colour(c) for c in causes), legend
        assert len({legend[c] for c in causes}) == len(causes), legend  # told apart in a plot
        assert legend.get("other", OTHER_COLOUR) == OTHER_COLOUR
    shared = set(plots[0]) & set(plots[1]) & set(plots[2]) - {"issued", "other"}
    assert shared and all(len({p[c] for p in plots}) == 1 for c in shared)
    # a family's parameters are shades of its colour, told apart
    assert colour("operand:fmul") != colour("operand:fadd")
    assert colour("operand:") == lookup("operand:fmul").colour


def test_summary_names_static_and_dynamic_ilp(render_pair):
    from netsushisen.reports.summary import summary_tables

    text = summary_tables(json.loads(render_pair[0].read_text()), width=120)
    assert "dynamic ILP" in text and "static ILP" in text and "ops/bundle" not in text
