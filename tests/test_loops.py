"""Loops as a writer sees them (asm/loops.py): natural loops by dominators, nested into a tree,
one name everywhere — in `report annotate`, `report bounds`, `asm --bounds` and `info loop`."""

from __future__ import annotations

import json

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.loops import Flow, innermost, natural_loops, program_loops
from netsushisen.kernels import KERNELS

DOT = KERNELS / "examples" / "dot_ic.s"
PAIRS = KERNELS / "examples" / "pairs.json"


def _flow(edges: dict[int, tuple[str, int]], n: int) -> list[Flow]:
    return [Flow(edges[pc][1], edges[pc][0]) if pc in edges else Flow(None, "") for pc in range(n)]


def test_nested_loops_form_a_tree_and_a_jump_into_a_body_is_no_loop():
    # 0; outer 1..6 (latch 6 -> 1) holds inner 2..4 (latch 4 -> 2); 7 jumps into 9..10's middle,
    # whose back edge 10 -> 9 is then no natural loop (9 does not dominate 10); 11 halts
    flow = _flow({4: ("branch", 2), 6: ("branch", 1), 7: ("branch", 10), 8: ("jump", 9),
                  10: ("branch", 9), 11: ("halt", None)}, 12)
    loops = natural_loops(flow, {1: "outer", 2: "inner", 9: "odd"})
    assert [(lp.name, lp.body, lp.parent, lp.depth) for lp in loops] == [
        ("outer", (1, 2, 3, 4, 5, 6), None, 1), ("inner", (2, 3, 4), 0, 2)]
    assert innermost(loops, 3).name == "inner" and innermost(loops, 5).name == "outer"
    assert innermost(loops, 9) is None
    # without the entry into the middle, 9..10 is a loop of its own
    del_goto = _flow({4: ("branch", 2), 6: ("branch", 1), 8: ("jump", 9), 10: ("branch", 9),
                      11: ("halt", None)}, 12)
    assert [lp.name for lp in natural_loops(del_goto, {1: "outer", 2: "inner", 9: "odd"})] == \
        ["outer", "odd", "inner"]


def test_a_jr_goes_where_li_points_its_register():
    prog = assemble_text("""
.proc ic
start:  li r5, body
        li r1, 3
body:   addi r1, r1, -1
        beqz r1, out
        jr r5
out:    halt
""")
    loops = program_loops(prog)
    assert [(lp.name, lp.body) for lp in loops] == [("body", (2, 3, 4))]


def test_the_pipelined_loop_keeps_its_source_label():
    """The kernel of a pipelined loop starts after its guard, which holds the label: the loop
    is still `loop`, and its fallback `loop+N`."""
    prog = assemble_text(DOT.read_text(), filename=str(DOT), defines={"N": 8})
    names = [lp.name for lp in program_loops(prog)]
    assert names[0] == "loop" and names[1].startswith("loop+") and len(names) == 2


def test_one_name_everywhere_and_only_loops_that_ran(cli, tmp_path, engine_name):
    stats = tmp_path / "dot.json"
    assert cli("run", "--ic", DOT, "--image", PAIRS, "--json", stats, "-q", "--engine",
               engine_name)[0] == 0

    def rows(*argv) -> dict[str, list[dict]]:
        code, out, err = cli("report", *argv, "--format", "json")
        assert code == 0, err
        return {s["key"]: s["rows"] for s in json.loads(out)["sections"]}

    annotate = rows("annotate", stats)
    assert [(r["loop"], r["iterations"]) for r in annotate["loops"]] == [("loop", 32)]
    lp = annotate["loops"][0]
    assert lp["cycles/iter"] == pytest.approx(lp["cycles"] / 32) and lp["bound"] > 0
    assert {r["loop"] for r in annotate["bundles"] if r["share"] > 0.2} == {"loop"}
    # the fallback never ran (64 pairs: the guard took the pipelined loop): --all shows it
    every = rows("annotate", stats, "--all")["loops"]
    assert [r["loop"] for r in every] == ["loop", "loop+15"] and every[1]["iterations"] == 0
    bounds = rows("bounds", stats)
    assert [r["loop"] for r in bounds["loops"]] == ["loop"] and bounds["loops"][0]["runs"] == 32
    assert [r["loop"] for r in rows("bounds", stats, "--all")["loops"]] == ["loop", "loop+15"]
    # the hot path: blocks by cycles, excess = cycles − bound × runs
    hot = annotate["hot"]
    assert [r["cycles"] for r in hot] == sorted((r["cycles"] for r in hot), reverse=True)
    for r in hot:
        assert r["excess"] == r["cycles"] - r["bound"] * r["runs"]
    assert sum(r["share"] for r in hot) == pytest.approx(1.0, abs=0.01)


def test_info_loop_names_the_innermost_loop_or_none(cli, tmp_path):
    script = tmp_path / "cmds.txt"
    script.write_text("info loop loop+6\ninfo loop 0\ninfo loop loop+16\n")
    code, out, err = cli("debug", "--ic", DOT, "--image", PAIRS, "--batch", script,
                         "--no-screen")
    assert code == 0, err
    assert "loop loop (header 8 <loop+5>, pcs 8-15) of pe0.ic" in out
    assert "pe0.ic pc 0 <0> is not in a loop" in out or "pc 0 " in out and "not in a loop" in out
    assert "loop loop+15 (header 18 <loop+15>, pcs 18-21)" in out
