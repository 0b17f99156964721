"""The run's floor (issue 40, item 3): `report bounds` ends with a per-processor floor table and
`Results.table("floor")` gives it; the numbers of a hand-made run computed by hand, and a change
of the run that moves the bottleneck from IC to OS (reports/floor.py, docs/scheduling.md)."""

from __future__ import annotations

import json

import pytest

IC = """
.proc ic
    li r1, 0
    li r2, 10
loop: { fadd r3, r4, r5 ; fmul r6, r4, r5 ; addi r1, r1, 1 }
    { fadd r8, r4, r5 ; fsub r7, r4, r5 ; bne r1, r2, loop }
    halt
"""
OS = """
.proc os
    li r1, 0
    li r2, N
loop: { addi r1, r1, 1 ; fadd r3, r4, r5 }
    { bne r1, r2, loop }
    halt
"""


def _floor(cli, tmp_path, n: int, engine: str) -> dict[str, dict]:
    (tmp_path / "ic.s").write_text(IC)
    (tmp_path / "os.s").write_text(OS)
    stats = tmp_path / f"s{n}.json"
    code, _, err = cli("run", "--ic", tmp_path / "ic.s", "--os", tmp_path / "os.s", "-D", f"N={n}",
                       "--json", stats, "-q", "--engine", engine)
    assert code == 0, err
    code, out, err = cli("report", "bounds", stats, "--format", "json")
    assert code == 0, err
    (floor,) = [s for s in json.loads(out)["sections"] if s["key"] == "floor"]
    return {r["processor"]: r for r in floor["rows"]}


def test_the_floor_of_a_hand_made_run(cli, tmp_path, engine_name):
    rows = _floor(cli, tmp_path, 3, engine_name)
    ic, os_ = rows["pe0.ic"], rows["pe0.os"]
    # IC: 2 li + 10 addi + 10 bne + halt = 23 integer operations on its one integer unit;
    # 40 FP operations on 3 units (14 cycles); reads 110 on 6 ports, writes 52 on 3: 23 rules.
    # 23 bundles and 9 taken back edges (1 cycle each).
    assert (ic["cycles"], ic["work bound"], ic["unit/port bound"], ic["memory holds"]) == (32, 23, 23, 0)
    assert ic["gap"] == pytest.approx(32 / 23)
    # OS, N = 3: 2 li + 3 addi + 3 bne + halt = 9 integer operations on 2 units: 5 cycles;
    # 9 bundles + 2 taken back edges = 11 cycles, then halted for the 21 IC still runs
    assert (os_["cycles"], os_["work bound"], os_["starved"]) == (11, 5, 21)
    assert (ic["starved"], ic["bottleneck"], os_["bottleneck"]) == (0, "yes", "")


def test_a_longer_os_loop_moves_the_bottleneck(cli, tmp_path, engine_name):
    rows = _floor(cli, tmp_path, 30, engine_name)
    ic, os_ = rows["pe0.ic"], rows["pe0.os"]
    # OS: 63 integer operations (32 cycles on 2 units); 63 bundles + 29 back edges = 92 cycles
    assert (os_["cycles"], os_["work bound"], os_["starved"]) == (92, 32, 0)
    assert (ic["starved"], ic["bottleneck"], os_["bottleneck"]) == (92 - 23 - 9, "", "yes")


def test_results_table_floor(cli, tmp_path):
    import netsushisen as nss

    (tmp_path / "ic.s").write_text(IC)
    stats = tmp_path / "s.json"
    assert cli("run", "--ic", tmp_path / "ic.s", "--json", stats, "-q", "--engine", "reference")[0] == 0
    table = nss.load_stats(stats).table("floor")
    assert list(table["processor"]) == ["pe0.ic"]
    assert int(table["work bound"].iloc[0]) == 23 and table["bottleneck"].iloc[0] == "yes"


@pytest.mark.slow
def test_rings_work_bound_is_the_hand_computed_one(tmp_path):
    """Issue 40: rings 32x32, IC: 3.41 M cycles by hand (FP operations executed ÷ 3 + the cache
    misses' 7-cycle holds beyond a hit's)."""
    from netsushisen.cli import main
    from netsushisen.reports.floor import floor_sections

    stats = tmp_path / "rings.json"
    assert main(["render", "rings", "--res", "32", "-o", str(tmp_path / "r.png"), "--json",
                 str(stats), "--quiet"]) == 0
    doc = json.loads(stats.read_text())
    (section,) = floor_sections(doc)
    rows = {r[0]: dict(zip(section.columns, r)) for r in section.rows}
    assert rows["pe0.ic"]["work bound"] == pytest.approx(3.41e6, rel=0.10)
    assert rows["pe0.ic"]["bottleneck"] == "yes"
