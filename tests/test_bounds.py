"""Static bounds (asm/bounds.py, asm/optimum.py) and `report bounds` / `asm --bounds`.

The two examples are docs/scheduling.md's, "Bounds", worked by hand there; the numbers pinned
here are those. Default timing: fmul 3, fadd 2, int ALU 1, ldr t_r = 1, taken-branch penalty 1.
"""

from __future__ import annotations

import json
import random

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.bounds import (Region, program_bounds, program_from_listing, region_bounds,
                                    written_cycles)
from netsushisen.asm.optimum import optimum_schedule
from netsushisen.emulator.harness import run_machine
from netsushisen.emulator.stats import program_listing
from netsushisen.isa.config import MachineConfig, load_config

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
    src = ".proc ic\n ldg r1, [r2]\n ldg r3, [r2 + 1]\n fadd r4, r1, r3\n halt\n"
    assert bounds_of(src)["block", "0"].dead == 2
    b = bounds_of(src, "ic_memory.t_c=4")["block", "0"]
    assert (b.dead, b.units) == (6, 9)  # ldg, ldg, halt on 1 int unit + 6 held
    assert (b.written, b.optimum) == (10, 9)  # ldg c0, ldg c4, fadd c8, halt c9 | { fadd ; halt }


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
    assert b.optimum_text == f"≤ {b.optimum} (not proven)"
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


@pytest.mark.parametrize("seed", range(6))
def test_written_and_list_timing_equal_the_emulator(seed):
    """The static timing of a straight block (and of its list schedule) is the reference
    engine's cycle count, under random latencies; and bound <= optimum <= every schedule."""
    rng = random.Random(seed)
    proc = ["ic", "os", "sc"][seed % 3]
    sets = [f"{proc}.latency.fmul={rng.randint(1, 6)}", f"{proc}.latency.fadd={rng.randint(1, 4)}",
            f"{proc}.latency.fdiv={rng.randint(2, 14)}"]
    config = load_config(None, sets)
    program = assemble_text(random_block(rng, 14, proc))
    whole = Region("block", 0, len(program.bundles) - 1)
    b = region_bounds(program, whole, config)

    def emulated(p) -> int:
        e = run_machine("reference", config, {proc: p}, max_cycles=10_000)
        return e.statistics()["processors"][f"pe0.{proc}"]["cycles"]

    assert emulated(program) == b.written
    from netsushisen.asm.bounds import region_graph
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


def test_optimum_schedule_is_feasible_on_the_machine():
    """CP-SAT's schedule, bundled and run, takes its length on the reference engine."""
    program = assemble_text(SUMSQ)
    config = MachineConfig()
    from netsushisen.asm.bounds import region_graph, value_reads

    ops, g = region_graph(program, Region("block", 0, 5), config)
    best = optimum_schedule(g, value_reads(ops), program.processor, config)
    assert best.proven and best.length == 8
    by_cycle: dict[int, list] = {}
    for op, t in zip(g.ops, best.starts):
        by_cycle.setdefault(t, []).append(op)
    text = ".proc ic\n" + "".join("{ " + " ; ".join(op.format() for op in by_cycle[t]) + " }\n"
                                  for t in sorted(by_cycle)) + "halt\n"
    e = run_machine("reference", config, {"ic": assemble_text(text)}, max_cycles=1000)
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
    assert loop["stalls per run"] == "operand:fmul 2.00, branch 0.90"
    blocks = {r["block"]: r for r in rows["blocks"]}
    assert blocks["start"]["optimum"] == "2" and blocks["start"]["runs"] == 1


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
