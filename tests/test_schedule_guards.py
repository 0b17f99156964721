"""Three rules of the scheduler that an independent audit could break without a project test
failing (issue 40, item 4): results landing per cycle within the write ports, a `.temps`
register the loop itself uses, loads kept below a superblock's side exits. Each test here fails
when its rule is planted wrong (write ports per completion cycle off by one; the `.temps` clash
check dropped; loads made speculable)."""

from __future__ import annotations

from collections import Counter

from netsushisen.asm.assembler import Assembler, assemble_text
from netsushisen.asm.dependences import result_latency
from netsushisen.asm.objects import Op
from netsushisen.asm.scheduler import issue_times
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import PROCESSORS


def test_results_landing_in_one_cycle_fit_the_write_ports():
    """IC: fmul (3 cycles), fadd (2) and integer operations (1), all independent: a greedy
    packing lands four results in one cycle unless completions are counted per cycle."""
    proc, config = PROCESSORS["ic"], MachineConfig()
    ops = []
    for k in range(6):
        ops += [Op("fmul", (10 + k, 1, 2)), Op("fadd", (20 + k, 1, 2)), Op("addi", (30 + k, 1, k))]
    cycles = issue_times(ops, proc, config)
    landing = Counter(t + result_latency(op, proc, config) for op, t in zip(ops, cycles))
    assert max(landing.values()) <= proc.write_ports
    assert max(Counter(cycles).values()) >= 2  # packed: the rule, not a serial order, decides


LOOP = """
.proc ic
.data
xs: .float 1.0, 2.0, 3.0, 4.0, 5.0, 6.0
.text
.sched
.temps r40-r47
        li r1, 0
        li r2, 6
        lf r3, 0.0
.pipeline
loop:   ld r4, [r1 + xs]
        fmul r5, r4, r4
        fadd r3, r3, r5
        addi r1, r1, 1
        blt r1, r2, loop
        halt
.endsched
"""


def test_a_temps_register_the_loop_uses_stops_pipelining():
    asm = Assembler("ic")
    asm.assemble_text(LOOP.replace("r5", "r41"), "t.s")
    (report,) = asm.pipeline_reports
    assert report.reason == ".temps r41 is used by the loop"
    ok = Assembler("ic")
    ok.assemble_text(LOOP, "t.s")
    assert ok.pipeline_reports[0].reason == ""


SUPERBLOCK = """
.proc ic
.sched
.deadout r40-r47
        flt r2, r5, r6
        bnez r2, out
        ld r40, [r3 + 4]
        fadd r41, r40, r40
        st r41, [r3]
        halt
.endsched
out:    halt
"""


def test_loads_stay_below_a_side_exit():
    """The exit waits for its compare, the integer unit is free before it: a load allowed above
    the exit would take it."""
    def where(src: str) -> dict[str, int]:
        program = assemble_text(src, "ic")
        return {op.mnemonic: pc for pc, bundle in enumerate(program.bundles) for op in bundle}

    assert where(SUPERBLOCK)["ld"] > where(SUPERBLOCK)["bnez"]
    # an integer operation into a .deadout register does rise above it (the rule is the load's)
    risen = where(SUPERBLOCK.replace("ld r40, [r3 + 4]", "li r40, 4"))
    assert risen["li"] < risen["bnez"]
