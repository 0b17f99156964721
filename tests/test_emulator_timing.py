"""The core's timing rules (emulator/core.py T1–T10), each pinned by an exact cycle count.

Every expected count is worked out by hand in the comments: `cN` is the cycle a bundle issues
in; a processor's `cycles` is its halt cycle + 1. Default timing unless a test says otherwise:
fadd/fsub 2, fmul 3, fdiv 12 (unpipelined), int ALU 1, mul 3, taken-branch penalty 1.
Each test runs once per engine (`engine_name`, tests/conftest.py) and reads statistics and
registers through the engine interface only.
"""

from __future__ import annotations

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.isa.config import load_config


def run(engine, sets=(), **sources):
    programs = {proc: assemble_text(src, proc=proc) for proc, src in sources.items()}
    e = run_machine(engine, load_config(None, list(sets)), programs, max_cycles=10_000)
    return e, e.result()


def core(e, proc="ic", pe=0):
    return ProcessorView(e, f"pe{pe}.{proc}")


def check_invariant(e):
    for name, p in e.statistics()["processors"].items():
        assert p["cycles"] == p["bundles"] + sum(p["stalls"].values()), name


def test_latency_chain(engine_name):
    m, r = run(engine_name, ic="""
        lf r1, 2.0          # c0        r1 ready at 1
        fmul r2, r1, r1     # c1        r2 ready at 1 + 3 = 4
        fadd r3, r2, r1     # c2, c3 stall operand:fmul; c4 issue, r3 ready at 6
        fadd r4, r3, r3     # c5 stall operand:fadd; c6 issue
        halt                # c7
    """)
    ic = core(m)
    assert r.status == "halted"
    assert ic.cycles == 8 and ic.bundles == 5
    assert ic.stalls == {"operand:fmul": 2, "operand:fadd": 1}
    assert ic.stalls_by_pc == {2: {"operand:fmul": 2}, 3: {"operand:fadd": 1}}
    assert ic.float(4) == 12.0
    check_invariant(m)


def test_bundle_sees_none_of_its_own_results(engine_name):
    # c0: both ops read r1 = 0 at issue; r2 = 0 + 1, not 5 + 1; no stall (nothing pending before)
    m, _ = run(engine_name, os="""
        { addi r1, r0, 5 ; addi r2, r1, 1 }
        halt
    """)
    os_ = core(m, "os")
    assert (os_.raw(1), os_.raw(2)) == (5, 1)
    assert os_.cycles == 2 and os_.stalls == {}


def test_operand_stall_charges_the_source_ready_last(engine_name):
    m, _ = run(engine_name, ic="""
        lf r1, 1.0                              # c0
        { fmul r2, r1, r1 ; fadd r3, r1, r1 }   # c1: r2 ready at 4, r3 at 3
        fadd r4, r2, r3                         # c2, c3 stalled; r2 binds both cycles
        halt                                    # c5
    """)
    ic = core(m)
    assert ic.stalls == {"operand:fmul": 2}
    assert ic.cycles == 6


def test_waw_interlock(engine_name):
    m, _ = run(engine_name, ic="""
        lf r1, 1.0          # c0
        fdiv r2, r1, r1     # c1: r2 ready at 13
        lf r2, 5.0          # c2..c12 stall waw:fdiv (11 cycles); c13 issue, r2 = 5.0 at 14
        halt                # c14
    """)
    ic = core(m)
    assert ic.stalls == {"waw:fdiv": 11}
    assert ic.cycles == 15
    assert ic.float(2) == 5.0  # the later write wins


def test_unpipelined_divider_keeps_its_unit_busy(engine_name):
    m, _ = run(engine_name, ic="""
        lf r1, 1.0                                          # c0
        { fdiv r2, r1, r1 ; fdiv r3, r1, r1 ; fdiv r4, r1, r1 }  # c1: all 3 FP units busy to 13
        addi r6, r0, 1                                      # c2: the integer unit is free
        fadd r5, r1, r1                                     # c3..c12 unit_busy:fdiv (10); c13
        halt                                                # c14
    """)
    ic = core(m)
    assert ic.stalls == {"unit_busy:fdiv": 10}
    assert ic.cycles == 15


def test_pipelined_units_accept_one_op_per_cycle(engine_name):
    m, _ = run(engine_name, ic="""
        lf r1, 1.0                                          # c0
        { fmul r2, r1, r1 ; fmul r3, r1, r1 ; fmul r4, r1, r1 }  # c1
        { fmul r5, r1, r1 ; fmul r6, r1, r1 ; fmul r7, r1, r1 }  # c2: no unit stall
        halt                                                # c3
    """)
    ic = core(m)
    assert ic.stalls == {} and ic.cycles == 4


def test_sequential_sc_divider_blocks_everything(engine_name):
    m, _ = run(engine_name, sc="""
        fdiv r1, r0, r0     # c0: the one 'gen' unit busy until 12
        addi r2, r0, 1      # c1..c11 unit_busy:fdiv (11); c12
        halt                # c13
    """)
    sc = core(m, "sc")
    assert sc.stalls == {"unit_busy:fdiv": 11} and sc.cycles == 14


def test_write_port_conflict_sc(engine_name):
    m, _ = run(engine_name, sc="""
        lf r1, 1.0          # c0: writes at 1
        fadd r2, r1, r1     # c1: writes at 3
        addi r3, r0, 7      # c2 would write at 3 too: SC has 1 write port -> stall; c3 (writes 4)
        halt                # c4
    """)
    sc = core(m, "sc")
    assert sc.stalls == {"write_port": 1}
    assert sc.stalls_by_pc == {2: {"write_port": 1}}
    assert sc.cycles == 5 and sc.raw(3) == 7


def test_write_port_conflict_ic_counts_per_completion_cycle(engine_name):
    m, _ = run(engine_name, ic="""
        lf r1, 1.0                                          # c0
        { fmul r2, r1, r1 ; fmul r3, r1, r1 ; fmul r4, r1, r1 }  # c1: 3 writes at 4
        { fadd r5, r1, r1 ; addi r6, r0, 1 }                # c2: fadd at 4 -> 4 writes; stall
                                                            # c3: addi at 4 -> stall again
                                                            # c4: writes at 6 and 5 -> issue
        halt                                                # c5
    """)
    ic = core(m)
    assert ic.stalls == {"write_port": 2} and ic.cycles == 6


def test_taken_branch_penalty(engine_name):
    src = """
        li r1, 3            # c0
    loop:
        addi r1, r1, -1     # c1, c4, c7
        bnez r1, loop       # c2 taken (c3 branch), c5 taken (c6 branch), c8 not taken
        halt                # c9
    """
    m, _ = run(engine_name, os=src)
    os_ = core(m, "os")
    assert os_.cycles == 10 and os_.bundles == 8
    assert os_.stalls == {"branch": 2} and os_.stalls_by_pc == {2: {"branch": 2}}
    # penalty 3: each taken branch costs 3 stall cycles: 10 + 2 * 2 = 14
    m, _ = run(engine_name, sets=["os.taken_branch_penalty=3"], os=src)
    assert core(m, "os").cycles == 14 and core(m, "os").stalls == {"branch": 6}
    # penalty 0: a taken branch costs nothing extra
    m, _ = run(engine_name, sets=["os.taken_branch_penalty=0"], os=src)
    assert core(m, "os").cycles == 8 and core(m, "os").stalls == {}


def test_call_and_ret(engine_name):
    m, _ = run(engine_name, ic="""
        call f              # c0: lr = 1 (ready at 1); taken: c1 branch
        halt                # c4
    f:  ret                 # c2: jumps to lr = 1; c3 branch
    """)
    ic = core(m)
    assert ic.cycles == 5 and ic.stalls == {"branch": 2}
    assert ic.raw(63) == 1


def test_latency_override_from_config(engine_name):
    src = """
        lf r1, 1.0          # c0
        fdiv r2, r1, r1     # c1: ready at 1 + L
        fadd r3, r2, r2     # c(1 + L)
        halt                # c(2 + L)
    """
    m, _ = run(engine_name, ic=src)
    assert core(m).cycles == 15  # L = 12
    m, _ = run(engine_name, sets=["ic.latency.fdiv=20"], ic=src)
    assert core(m).cycles == 23 and core(m).stalls == {"operand:fdiv": 19}


def test_r0_is_zero_and_never_pending(engine_name):
    m, _ = run(engine_name, ic="""
        addi r0, r0, 5      # c0: the write vanishes
        fdiv r0, r0, r0     # c1: no scoreboard entry for r0
        addi r1, r0, 1      # c2: reads 0, no stall (the FP unit is busy, not the int unit)
        halt
    """)
    ic = core(m)
    assert ic.raw(0) == 0 and ic.raw(1) == 1 and ic.stalls == {}


def test_stall_priority_operand_before_fifo(engine_name):
    # OS waits on both a pending `mul` and an empty ring FIFO: operand is charged first.
    # IC's header (length 0) is sent at c0 and reaches OS via SC's CMU: send FIFO ready at 1,
    # link IC->SC ready at 2, link SC->OS ready at 3, OS's receive FIFO ready at 4.
    m, _ = run(engine_name,
        os="""
        li r1, 5                            # c0
        mul r2, r1, r1                      # c1: ready at 4
        { recv r3, ring ; add r4, r2, r2 }  # c2, c3 operand:mul; c4 issue (header visible at 4)
        halt                                # c5
        """,
        ic="""
        send ring, r0                       # header 0: length 0, dest OS
        halt
        """)
    os_ = core(m, "os")
    assert os_.stalls == {"operand:mul": 2} and os_.cycles == 6
    # ... and when the word comes later, the remaining cycles are fifo_empty
    m, _ = run(engine_name,
        os="""
        li r1, 5                            # c0
        mul r2, r1, r1                      # c1
        { recv r3, ring ; add r4, r2, r2 }  # c2, c3 operand:mul; c4, c5 fifo_empty:ring; c6
        halt                                # c7
        """,
        ic="""
        nop                                 # c0
        nop                                 # c1
        send ring, r0                       # c2: visible to OS at 2 + 4 = 6
        halt
        """)
    os_ = core(m, "os")
    assert os_.stalls == {"operand:mul": 2, "fifo_empty:ring": 2} and os_.cycles == 8
    check_invariant(m)


def test_load_and_taken_branch_in_one_bundle_charge_memory_first(engine_name):
    src = """
        { ld r1, [r0] ; beqz r0, target }   # c0: ld holds to c3 (os.latency.ld = 3), taken
        nop
    target:
        halt
    """
    # penalty 2: issue again at max(0 + 3, 0 + 1 + 2) = 3; c1, c2 are `local`
    m, _ = run(engine_name, sets=["os.latency.ld=3", "os.taken_branch_penalty=2"], os=src)
    os_ = core(m, "os")
    assert os_.stalls == {"local": 2} and os_.cycles == 4
    # penalty 4: issue at 5; c1, c2 `local`, then c3, c4 `branch`, all charged to pc 0
    m, _ = run(engine_name, sets=["os.latency.ld=3", "os.taken_branch_penalty=4"], os=src)
    os_ = core(m, "os")
    assert os_.stalls == {"local": 2, "branch": 2} and os_.cycles == 6
    assert os_.stalls_by_pc == {0: {"local": 2, "branch": 2}}
