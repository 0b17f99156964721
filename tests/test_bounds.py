"""Static bounds (asm/bounds.py, asm/optimum.py) and `report bounds` / `asm --bounds`.

The two examples are docs/scheduling.md's, "Bounds", worked by hand there; the numbers pinned
here are those. Default timing: fmul 3, fadd 2, int ALU 1, ldr t_r = 1, taken-branch penalty 1.
"""

from __future__ import annotations

import json
import os
import random

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.bounds import (Region, program_bounds, program_from_listing, region_bounds,
                                    written_cycles)
from netsushisen.asm.optimum import optimum_schedule
from netsushisen.emulator.harness import run_machine
from netsushisen.emulator.stats import program_listing
from netsushisen.asm.objects import Op
from netsushisen.isa.config import MachineConfig, load_config

OPCODES_HALT = Op("halt")
SEEDS = int(os.environ.get("BOUNDS_SEEDS", "6"))
"""Random blocks checked against the emulator (`BOUNDS_SEEDS=80` for a longer look)."""

# Example 1 (docs/scheduling.md): a loop accumulating r1·r2 into r6, r4 times
LOOP = """
.proc ic
start:
    lf r1, 1.0
    lf r2, 2.0
    li r3, 0
    li r4, 10
loop:
    fmul r5, r1, r2
    fadd r6, r6, r5
    addi r3, r3, 1
    bne  r3, r4, loop
    halt
"""

# Example 2 (docs/scheduling.md): a block, r1² + r3² from resident memory into local memory
SUMSQ = """
.proc ic
sumsq:
    ldr  r1, [r10]
    fmul r2, r1, r1
    ldr  r3, [r10 + 1]
    fmul r4, r3, r3
    fadd r5, r2, r4
    st   r5, [r11]
done:
    halt
"""


def bounds_of(source: str, *sets: str, **kw) -> dict:
    program = assemble_text(source)
    config = load_config(None, list(sets))
    return {(b.kind, b.label): b for b in program_bounds(program, config, **kw)}


def test_example_loop_is_bound_by_the_units():
    b = bounds_of(LOOP)["loop", "loop"]
    assert (b.start, b.end, b.ops_by_unit) == (4, 7, {"fp": 2, "int": 2})
    assert (b.slots, b.dead, b.units) == (2, 1, 3)  # addi + bne on 1 int unit; back edge 1
    assert (b.reads, b.writes, b.ports) == (7, 3, 3)  # ceil(7/6) + 1
    assert b.recurrence == 2  # fadd r6 -> fadd r6: latency 2, distance 1
    assert b.critical_path == 4  # fmul 0 -> fadd 3 -> bne 3, + 1
    assert (b.bound, b.binding) == (3, "units")
    assert b.written == 7  # fmul c0, fadd c3, addi c4, bne c5, penalty c6


def test_a_recurrence_through_local_memory():
    # ld -> fadd (1) -> st (fadd 5) -> the next iteration's ld (a store before a load: 1)
    src = ".proc ic\nloop:\n ld r1, [0]\n fadd r1, r1, r3\n st r1, [0]\n bnez r4, loop\n halt\n"
    b = bounds_of(src, "ic.latency.fadd=5", optimum_ops=0)["loop", "loop"]
    assert (b.recurrence, b.units, b.bound, b.binding) == (7, 4, 7, "recurrence")


def test_recurrence_mii_is_the_largest_cycle_ratio():
    """Against the definition on random graphs: the least II ≥ 1 for which no cycle has
    Σ latency > II · Σ distance (every cycle's ratio by brute force over simple cycles)."""
    import itertools

    from netsushisen.asm.bounds import recurrence_mii
    from netsushisen.asm.dependences import Edge

    rng = random.Random(3)
    for _ in range(300):
        n = rng.randint(1, 5)
        edges = []
        for _ in range(rng.randint(0, 9)):
            a, b = rng.randrange(n), rng.randrange(n)
            d = rng.choice([0, 0, 1, 2]) if b > a else rng.choice([1, 2])
            edges.append(Edge(a, b, rng.randint(0, 6), d, "true"))
        best = 1  # every simple cycle: a sequence of distinct nodes, the best edge per step
        for size in range(1, n + 1):
            for nodes in itertools.permutations(range(n), size):
                steps = list(zip(nodes, nodes[1:] + nodes[:1]))
                choices = [[e for e in edges if (e.src, e.dst) == st] for st in steps]
                for pick in itertools.product(*choices):
                    lat, dist = sum(e.latency for e in pick), sum(e.distance for e in pick)
                    if dist:
                        best = max(best, -(-lat // dist))
        assert recurrence_mii(n, edges) == best, edges


def test_a_slower_fadd_makes_the_loop_recurrence_bound():
    b = bounds_of(LOOP, "ic.latency.fadd=4")["loop", "loop"]
    assert b.recurrence == 4 and b.units == 3
    assert (b.bound, b.binding) == (4, "recurrence")
    assert b.written == 7  # the fadd's result is not read again within the iteration


def test_example_block_optimum_between_bound_and_written():
    got = bounds_of(SUMSQ)
    b = got["block", "sumsq"]
    assert (b.units, b.ports, b.critical_path) == (3, 2, 7)
    assert (b.bound, b.binding) == (7, "path")
    assert b.written == 9  # ldr c0, fmul c1, ldr c2, fmul c3, fadd c6, st c8
    assert b.list_scheduled == 8
    assert (b.optimum, b.optimum_proven, b.optimum_text) == (8, True, "8")
    assert got["block", "done"].optimum == 1


def test_a_faster_fmul_shortens_the_block():
    b = bounds_of(SUMSQ, "ic.latency.fmul=1")["block", "sumsq"]
    # path: ldr 0 -> fmul 1 -> fadd 2 -> st 4, + 1 = 5; but one int unit puts the second ldr
    # at 1 at best: its fmul 2, fadd 3, st 5 -> optimum 6
    assert (b.critical_path, b.bound, b.optimum, b.optimum_proven) == (5, 5, 6, True)


def test_load_holds_count_as_dead_cycles():
    # ldg counts as a hit: t_c = 2 holds issue 1 cycle, t_c = 4 holds 3
    src = ".proc ic\n ldg r1, [r2]\n ldg r3, [r2 + 1]\n fadd r4, r1, r3\ndone: halt\n"
    assert bounds_of(src)["block", "0"].dead == 2
    b = bounds_of(src, "ic_memory.t_c=4")["block", "0"]
    assert (b.dead, b.units) == (6, 8)  # ldg, ldg on 1 int unit + 6 held
    assert (b.written, b.optimum) == (9, 9)  # ldg c0, ldg c4, fadd c8
    # a load in the halt's bundle holds nothing: the processor stops (T9)
    b = bounds_of(src.replace("done: halt", " halt"), "ic_memory.t_c=4")["block", "0"]
    assert (b.dead, b.units, b.written, b.optimum) == (3, 6, 10, 9)  # { fadd ; halt } c8


def test_an_unpipelined_unit_bounds_a_loop_not_a_block():
    src = ".proc ic\nloop:\n fdiv r1, r2, r3\n fdiv r4, r2, r3\n fdiv r5, r2, r3\n fdiv r6, r2, r3\n bnez r7, loop\n"
    got = bounds_of(src, optimum_ops=0)
    loop, block = got["loop", "loop"], got["block", "loop"]
    assert loop.busy == 16  # 4 × 12 on 3 units, every iteration
    assert block.busy == 13  # one unit runs two: the 4th fdiv issues at 12 at the earliest


def test_optimum_not_proven_is_an_upper_bound():
    """36 FP operations over 40 registers: the read ports make it hard to prove in 0.05 s of
    CP-SAT's deterministic time (the same answer on every machine)."""
    rng = random.Random(1)
    lines = [".proc ic"] + [f"    {rng.choice(['fadd', 'fmul', 'fsub', 'fmin'])} r{rng.randint(1, 40)}, "
                            f"r{rng.randint(1, 40)}, r{rng.randint(1, 40)}" for _ in range(36)]
    program = assemble_text("\n".join(lines) + "\n")
    whole = Region("block", 0, len(program.bundles) - 1)
    b = region_bounds(program, whole, MachineConfig(), seconds=0.05)
    assert not b.optimum_proven
    assert b.optimum_text.startswith(f"best {b.optimum}, bound ")
    assert b.optimum_text.endswith("within 0.05 deterministic s")
    assert b.bound <= b.optimum <= min(b.written, b.list_scheduled)
    again = region_bounds(program, whole, MachineConfig(), seconds=0.05)
    assert (again.optimum, again.optimum_proven) == (b.optimum, False)  # deterministic


# ---------------------------------------------------------------------------------------------
# The timing model against the emulator, and the bounds against every schedule of a block

MNEMONICS = {"int": ["add", "sub", "mul", "addi", "slt", "ld", "st"],
             "fp": ["fadd", "fsub", "fmul", "fdiv", "fsqrt", "fmin", "itof"]}


def random_block(rng: random.Random, n: int, proc: str) -> str:
    """n random operations on r1..r8 (one a line), local memory words 0..3, then halt."""
    lines = [f".proc {proc}"]
    for _ in range(n):
        m = rng.choice(MNEMONICS[rng.choice(["int", "fp"])])
        r = [f"r{rng.randint(1, 8)}" for _ in range(3)]
        if m in ("ld", "st"):
            lines.append(f"    {m} {r[0]}, [{rng.randint(0, 3)}]")
        elif m == "addi":
            lines.append(f"    addi {r[0]}, {r[1]}, {rng.randint(-3, 3)}")
        elif m in ("fsqrt", "itof"):
            lines.append(f"    {m} {r[0]}, {r[1]}")
        else:
            lines.append(f"    {m} {r[0]}, {r[1]}, {r[2]}")
    return "\n".join(lines + ["    halt", ""])


@pytest.mark.parametrize("seed", range(SEEDS))
def test_written_and_list_timing_equal_the_emulator(seed):
    """The static timing of a straight block (and of its list schedule) is the reference
    engine's cycle count, under random latencies; and bound <= optimum <= every schedule."""
    rng = random.Random(seed)
    proc = ["ic", "os", "sc"][seed % 3]
    sets = [f"{proc}.latency.fmul={rng.randint(1, 6)}", f"{proc}.latency.fadd={rng.randint(1, 4)}",
            f"{proc}.latency.fdiv={rng.randint(2, 14)}",
            f"os.latency.ld={rng.randint(1, 3)}" if proc == "os" else
            f"{proc}_memory.t_r={rng.randint(1, 3)}"]
    config = load_config(None, sets)
    program = assemble_text(random_block(rng, 14, proc))
    whole = Region("block", 0, len(program.bundles) - 1)
    b = region_bounds(program, whole, config)

    def emulated(p) -> int:
        e = run_machine("reference", config, {proc: p}, max_cycles=10_000)
        return e.statistics()["processors"][f"pe0.{proc}"]["cycles"]

    assert emulated(program) == b.written
    from netsushisen.asm.bounds import region_graph, value_reads
    from netsushisen.asm.scheduler import list_schedule

    _, g = region_graph(program, whole, config)
    scheduled = [tuple(g.ops[i] for i in grp) for grp in list_schedule(g.ops, program.processor,
                                                                      config, g)]
    listed = assemble_text(f".proc {proc}\n" + "".join(
        "{ " + " ; ".join(op.format() for op in grp) + " }\n" for grp in scheduled))
    assert emulated(listed) == b.list_scheduled == written_cycles(
        program.processor, scheduled, config, loop=False)
    assert b.optimum_proven
    assert b.bound <= b.optimum <= min(b.written, b.list_scheduled)
    # CP-SAT's schedule, bundled, runs in exactly its length: the model is not looser than
    # the machine
    ops, _ = region_graph(program, whole, config)
    best = optimum_schedule(g, value_reads(ops), program.processor, config)
    assert best.length == b.optimum
    assert emulated(bundled(proc, g.ops, best.starts, g.holds)) == best.length


def bundled(proc: str, ops, starts, holds) -> "Program":
    """Operations placed at issue cycles, as a program of bundles: an empty bundle in each empty
    cycle that no load holds (left out, the interlocks would issue some bundles earlier, and an
    earlier result can collide with a later one at the write ports)."""
    by_cycle: dict[int, list] = {}
    held_until = 0
    for op, t, h in sorted(zip(ops, starts, holds), key=lambda x: x[1]):
        by_cycle.setdefault(t, []).append(op)
    for op, t, h in zip(ops, starts, holds):
        held_until = max(held_until, t + h)
    lines, free = [], 0
    for t in range(max(by_cycle) + 1):
        if t in by_cycle:
            lines.append("{ " + " ; ".join(op.format() for op in by_cycle[t]) + " }")
            free = t + max(h for op, s, h in zip(ops, starts, holds) if s == t)
        elif t >= free:
            lines.append("{ }")
    return assemble_text(f".proc {proc}\n" + "\n".join(lines) + "\n")


@pytest.mark.parametrize("seed", range(SEEDS))
def test_loop_written_is_the_emulators_steady_state(seed):
    """A loop's `written` (cycles per iteration in the steady state) is what one more iteration
    costs on the reference engine, and no bound exceeds it."""
    rng = random.Random(seed)
    proc = ["ic", "os", "sc"][seed % 3]
    config = load_config(None, [f"{proc}.latency.fmul={rng.randint(1, 6)}",
                                f"{proc}.latency.fdiv={rng.randint(2, 14)}"])
    body = random_block(rng, rng.randint(2, 8), proc).splitlines()[1:-1]  # no .proc, no halt

    def source(n: int) -> str:
        return "\n".join([f".proc {proc}", f"    li r20, {n}", "loop:", *body,
                          "    addi r20, r20, -1", "    bnez r20, loop", "    halt", ""])

    def cycles(n: int) -> int:
        e = run_machine("reference", config, {proc: assemble_text(source(n))}, max_cycles=100_000)
        return e.statistics()["processors"][f"pe0.{proc}"]["cycles"]

    b = next(x for x in program_bounds(assemble_text(source(8)), config, optimum_ops=0)
             if x.kind == "loop")
    assert cycles(9) - cycles(8) == b.written
    assert b.bound <= b.written


def test_optimum_schedule_is_feasible_on_the_machine():
    """CP-SAT's schedule, bundled and run, takes its length on the reference engine."""
    program = assemble_text(SUMSQ)
    config = MachineConfig()
    from netsushisen.asm.bounds import region_graph, value_reads

    ops, g = region_graph(program, Region("block", 0, 5), config)
    best = optimum_schedule(g, value_reads(ops), program.processor, config)
    assert best.proven and best.length == 8
    e = run_machine("reference", config, {"ic": bundled("ic", list(g.ops) + [OPCODES_HALT],
                                                        list(best.starts) + [8],
                                                        list(g.holds) + [1])},
                    max_cycles=1000)
    assert e.statistics()["processors"]["pe0.ic"]["cycles"] == 8 + 1  # + the halt


# ---------------------------------------------------------------------------------------------
# Statistics: the program back from the listing, and the report


def test_program_from_listing_reassembles_the_program():
    src = """
.proc ic
top: { lf r1, nan ; addi r2, r2, 1 ; lf r3, -inf }
mid: bne r2, r4, mid+2
     { beqz r2, top ; fadd r5, r1, r3 }
     j mid
     halt
"""
    program = assemble_text(src)
    back = program_from_listing(program_listing(program), "ic")
    assert back.same_program(program)


def test_report_bounds_joins_the_run(cli, tmp_path, engine_name):
    src = tmp_path / "loop.s"
    src.write_text(LOOP)
    stats = tmp_path / "s.json"
    code, _, err = cli("run", "--ic", src, "--json", stats, "-q", "--engine", engine_name)
    assert code == 0, err
    code, out, err = cli("report", "bounds", stats, "--format", "json")
    assert code == 0, err
    rows = {s["key"]: s["rows"] for s in json.loads(out)["sections"]}
    (loop,) = rows["loops"]
    assert (loop["processor"], loop["loop"], loop["bound"], loop["by"], loop["written"]) == \
        ("pe0.ic", "loop", 3, "units", 7)
    # 10 iterations: 4 bundles each, fadd waits 2 on fmul, 9 taken back edges
    assert (loop["runs"], loop["achieved"], loop["issued"]) == (10, 6.9, 4.0)
    assert loop["units run"] == 2.0  # addi + bne on the one int unit, every iteration
    assert loop["stalls per run"] == "operand:fmul 2.00, branch 0.90"
    blocks = {r["block"]: r for r in rows["blocks"]}
    assert blocks["start"]["optimum"] == "2" and blocks["start"]["runs"] == 1


@pytest.fixture(scope="module")
def render_stats(tmp_path_factory):
    from netsushisen.cli import main

    d = tmp_path_factory.mktemp("bounds")
    assert main(["render", "tetra", "--res", "4", "-o", str(d / "t.png"), "--json",
                 str(d / "t.json"), "--quiet"]) == 0
    return d / "t.json"


@pytest.mark.slow
def test_report_bounds_has_every_loop_annotate_finds(cli, render_stats):
    def rows(kind: str, *argv) -> dict:
        code, out, err = cli("report", kind, render_stats, "--format", "json", *argv)
        assert code == 0, err
        return {s["key"]: s["rows"] for s in json.loads(out)["sections"]}

    annotated = {(r["processor"], r["pcs"]) for r in rows("annotate")["loops"] if r["bundles"]}
    got = rows("bounds", "--optimum-ops", "0", "--top", "3")
    assert {(r["processor"], r["pcs"]) for r in got["loops"]} == annotated
    assert any(p.endswith(".ic") for p, _ in annotated)
    for r in got["loops"]:
        assert r["bound"] <= r["written"] and r["achieved"] is not None or r["runs"] == 0
    blocks = got["blocks"]
    assert len({r["processor"] for r in blocks}) == 3 and len(blocks) == 9  # 3 hottest each
    heat = [r["achieved"] * r["runs"] for r in blocks if r["processor"] == "pe0.ic"]
    assert heat == sorted(heat, reverse=True)


def test_report_bounds_fits_80_columns(cli, tmp_path):
    """Too wide for the terminal, a table is printed as its column groups, one under the other."""
    src = tmp_path / "loop.s"
    src.write_text(LOOP)
    stats = tmp_path / "s.json"
    assert cli("run", "--ic", src, "--json", stats, "-q", "--engine", "reference")[0] == 0
    code, out, err = cli("report", "bounds", stats, "--width", "80")
    assert code == 0, err
    assert max(len(line) for line in out.splitlines()) <= 80
    rules = [line for line in out.splitlines() if line.startswith("─")]
    # loops in two groups, blocks in three (their hot-path share and excess last), the floor
    assert len(rules) == 6 and "operand:fmul 2.00" in out
    code, wide, _ = cli("report", "bounds", stats, "--width", "200")
    assert code == 0 and max(len(line) for line in wide.splitlines()) > 80
    assert len([line for line in wide.splitlines() if line.startswith("─")]) == 3


def test_report_bounds_needs_the_listing(cli, tmp_path):
    src = tmp_path / "loop.s"
    src.write_text(LOOP)
    stats = tmp_path / "s.json"
    assert cli("run", "--ic", src, "--json", stats, "-q", "--engine", "reference")[0] == 0
    data = json.loads(stats.read_text())
    data["programs"]["ic"].pop("listing")
    stats.write_text(json.dumps(data))
    code, out, err = cli("report", "bounds", stats)
    assert code == 1 and out == ""
    assert err.count("\n") == 1 and "carry no program listing" in err


@pytest.mark.parametrize("spoil, says", [
    (lambda d: d["programs"]["ic"]["listing"]["text"].__setitem__(5, "fadd r6, r6"),
     "listing does not assemble again: 'fadd' takes 3 operands"),
    (lambda d: d["config"]["ic"]["latency"].__setitem__("fadd", 0),
     "configuration: ic.latency.fadd must be at least 1, got 0"),
])
def test_report_bounds_on_spoilt_statistics(cli, tmp_path, spoil, says):
    src = tmp_path / "loop.s"
    src.write_text(LOOP)
    stats = tmp_path / "s.json"
    assert cli("run", "--ic", src, "--json", stats, "-q", "--engine", "reference")[0] == 0
    data = json.loads(stats.read_text())
    spoil(data)
    stats.write_text(json.dumps(data))
    code, out, err = cli("report", "bounds", stats)
    assert code == 1 and out == "" and err.count("\n") == 1 and says in err


def test_asm_bounds_of_a_scenes_kernels(cli):
    code, out, err = cli("asm", "--bounds", "--scene", "tetra", "--proc", "ic", "--res", "4",
                         "--optimum-ops", "0", "--format", "json")
    assert code == 0, err
    loops = {r["loop"]: r for s in json.loads(out)["sections"] if s["key"] == "loops"
             for r in s["rows"]}
    assert "cell_loop" in loops  # IC's walk of a voxel's primitive list
    assert all(r["bound"] <= r["written"] for r in loops.values())


def test_asm_bounds_for_the_configured_machine(cli, tmp_path):
    src = tmp_path / "loop.s"
    src.write_text(LOOP)

    def loop_row(*sets: str) -> dict:
        code, out, err = cli("asm", "--bounds", src, "--optimum-ops", "0", "--format", "json",
                             *[x for s in sets for x in ("--set", s)])
        assert code == 0, err
        return next(s for s in json.loads(out)["sections"] if s["key"] == "loops")["rows"][0]

    assert (loop_row()["bound"], loop_row()["by"]) == (3, "units")
    assert (loop_row("ic.latency.fadd=4")["bound"], loop_row("ic.latency.fadd=4")["by"]) == (4, "rec")


def test_asm_bounds_from_a_source(cli, tmp_path):
    src = tmp_path / "sumsq.s"
    src.write_text(SUMSQ)
    code, out, err = cli("asm", "--bounds", src, "--format", "json")
    assert code == 0, err
    rows = {r["block"]: r for s in json.loads(out)["sections"] if s["key"] == "blocks"
            for r in s["rows"]}
    assert (rows["sumsq"]["bound"], rows["sumsq"]["written"], rows["sumsq"]["list"],
            rows["sumsq"]["optimum"]) == (7, 9, 8, "8")
    code, out, _ = cli("asm", "--bounds", src, "--optimum-ops", "0", "--format", "json")
    assert code == 0 and all(r["optimum"] is None for s in json.loads(out)["sections"]
                             for r in s["rows"])
    code, _, err = cli("asm", "--bounds", src, "--optimum-ops", "-1")
    assert code == 1 and err.count("\n") == 1
    assert not list(tmp_path.glob("*.o"))  # --bounds is an analysis: no object file


def test_recurrence_mii_of_a_large_loop_takes_little_work(monkeypatch):
    """`report bounds` of a small run spent 17 s in an all-pairs closure over every carried
    edge's head, per II tried. A 3,000-operation loop with 1,000 carried
    edges (one long recurrence, the rest short) needs a handful of longest-path searches of a
    few passes each (O(V·E) relaxations at most), well within seconds, and gets the long
    recurrence's ratio."""
    from netsushisen.asm import bounds, recurrence
    from netsushisen.asm.dependences import Edge

    rng = random.Random(46)
    n = 3000
    edges = [Edge(i, i + 1, 2, 0, "true") for i in range(n - 1)]  # the long chain: 2 a step
    edges.append(Edge(n - 1, 0, 2, 3, "true"))  # closed over 3 iterations: 2n / 3 = 2,000
    for _ in range(1000):
        a = rng.randrange(n - 5)
        edges.append(Edge(a + rng.randint(1, 4), a, rng.randint(1, 9), 1, "true"))
    calls = []
    real = recurrence.positive_cycle

    def counted(size, inner, ii):
        calls.append(len(inner))
        return real(size, inner, ii)
    monkeypatch.setattr(recurrence, "positive_cycle", counted)
    import time

    started = time.monotonic()
    assert bounds.recurrence_mii(n, edges) == 2000
    assert time.monotonic() - started < 5  # the closure took 23 s on this loop (0.05 s now)
    assert len(calls) <= 2 * 20  # a binary search over at most 2^20 IIs, often shortened
    assert sum(calls) <= len(calls) * len(edges)
