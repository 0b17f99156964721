"""The CMU ring: FIFO empty/full stalls, link latency, forwarding through a CMU, wormhole
channels, the buffer pool and the deadlock detector (emulator/cmu.py, machine.py).

Path of one word from a send to a receive one hop away (FIFO delay 1, link latency L):
send in c -> send FIFO, poppable c+1 -> link, at the next CMU at c+1+L -> receive FIFO,
poppable c+2+L. Each extra hop (forwarding) adds L.

The machine tests run once per engine (`engine_name`, tests/conftest.py) and read stalls,
registers and FIFO counters (statistics `fifos`) through the engine interface; the Fifo unit
test uses the reference engine's class directly.
"""

from __future__ import annotations

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.cmu import Fifo
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.isa.config import load_config


def run(engine, sets=(), **sources):
    programs = {proc: assemble_text(src, proc=proc) for proc, src in sources.items()}
    e = run_machine(engine, load_config(None, list(sets)), programs, max_cycles=5_000)
    return e, e.result()


def proc(e, name, pe=0):
    return ProcessorView(e, f"pe{pe}.{name}")


def test_fifo_rule_free_slots_count_from_cycle_start():
    f = Fifo("t", capacity=2, delay=1)
    f.push(0, 10)
    f.push(0, 11)
    assert f.free(0) == 0 and not f.ready(0) and f.ready(1)
    assert f.pop(1) == 10
    assert f.free(1) == 0  # the slot freed in cycle 1 is reusable from cycle 2
    assert f.free(2) == 1
    f.push(2, 12)
    assert f.peak == 2 and f.visible(2) == 1 and f.visible(3) == 2


FORWARD_IC = """
    li r1, (1 << HDR_CLS_SHIFT) | ({dest} << HDR_DEST_SHIFT) | 1    # c0
    li r2, 42                                                       # c1
    send ring, r1                                                   # c2
    send ring, r2                                                   # c3
    halt
"""
RECEIVE_2 = """
    recv r1, ring
    recv r2, ring
    halt
"""


@pytest.mark.parametrize("latency", [1, 3])
def test_forwarding_ic_to_os_through_sc_costs_one_more_link(latency, engine_name):
    sets = [f"ring.link_latency={latency}"]
    # direct IC -> SC: header sent at c2 is received at 2 + 2 + L
    m, _ = run(engine_name, sets, ic=FORWARD_IC.format(dest="DEST_SC"), sc=RECEIVE_2)
    sc = proc(m, "sc")
    assert sc.stalls == {"fifo_empty:ring": 4 + latency}
    assert sc.raw(2) == 42 and sc.cycles == 4 + latency + 3
    # IC -> OS crosses SC's CMU: 2 + 2 + 2L; SC runs its own program meanwhile, untouched
    m, _ = run(engine_name, sets, ic=FORWARD_IC.format(dest="DEST_OS"), os=RECEIVE_2, sc="halt")
    os_ = proc(m, "os")
    assert os_.stalls == {"fifo_empty:ring": 4 + 2 * latency}
    assert os_.raw(1) == (1 << 10) | 1 and os_.raw(2) == 42
    assert proc(m, "sc").bundles == 1  # just its halt
    assert m.statistics()["fifos"]["pe0.send.sc"]["words"] == 0  # SC's send FIFO never used


def test_fifo_full_stall_and_backpressure(engine_name):
    # fifo_depth 2, link buffer 2, L = 1: OS streams a 7-word message to IC, which only starts
    # receiving at c13. Six words fit on the way (2 in recv.ic, 2 in the link, 2 in send.os):
    # sends at c1..c6, the 7th stalls from c7. IC pops word 0 at 13; that slot is reused at 14
    # (link -> recv.ic), the link slot at 15 (send.os -> link), the send FIFO slot at 16: the 7th
    # send issues at 16 (fifo_full c7..c15 = 9 cycles), halt at 17.
    m, r = run(engine_name, ["ring.fifo_depth=2", "ring.link_buffer_words=2"],
               os="""
        li r1, (DEST_IC << HDR_DEST_SHIFT) | 6    # c0
        send ring, r1                              # c1
        send ring, r0
        send ring, r0
        send ring, r0
        send ring, r0
        send ring, r0                              # c6
        send ring, r0                              # c16
        halt                                       # c17
    """, ic="""
        fdiv r1, r0, r0     # c0: r1 at 12
        fadd r2, r1, r1     # c12
        recv r3, ring       # c13 .. one word per cycle .. c19
        recv r3, ring
        recv r3, ring
        recv r3, ring
        recv r3, ring
        recv r3, ring
        recv r3, ring
        halt                # c20
    """)
    os_, ic = proc(m, "os"), proc(m, "ic")
    assert r.status == "halted"
    assert os_.stalls == {"fifo_full:ring": 9} and os_.stalls_by_pc == {7: {"fifo_full:ring": 9}}
    assert os_.cycles == 18
    assert ic.stalls == {"operand:fdiv": 11} and ic.cycles == 21
    fifos = m.statistics()["fifos"]
    assert fifos["pe0.send.os"]["peak"] == 2 and fifos["pe0.recv.ic"]["peak"] == 2
    assert fifos["pe0.link.os-ic.0"]["peak"] == 2  # class 0's channel of the buffer pool


def test_poll_counts_visible_words(engine_name):
    m, _ = run(engine_name, ic="""
        li r1, (DEST_OS << HDR_DEST_SHIFT) | 2
        send ring, r1
        send ring, r1
        send ring, r1
        halt
    """, os="""
        poll r1, ring       # c0: nothing yet
        div r5, r0, r0      # c1: wait until everything has arrived
        add r5, r5, r5      # c13
        { poll r2, ring ; recv r3, ring }   # c14: poll sees 3 words (before the pop)
        poll r4, ring       # c15: 2 left
        halt
    """)
    os_ = proc(m, "os")
    assert (os_.raw(1), os_.raw(2), os_.raw(4)) == (0, 3, 2)


def test_message_to_self_goes_round_the_ring(engine_name):
    # OS -> OS: three links (L = 1): sent at c1, received at 1 + 2 + 3 = 6
    m, _ = run(engine_name, os="""
        li r1, (DEST_OS << HDR_DEST_SHIFT) | 0    # c0
        send ring, r1                              # c1
        recv r2, ring                              # c2..c5 fifo_empty; c6
        halt                                       # c7
    """)
    os_ = proc(m, "os")
    assert os_.stalls == {"fifo_empty:ring": 4} and os_.cycles == 8


def test_sc_header_for_col_on_the_ring_is_a_fault(engine_name):
    m, r = run(engine_name, sc="""
        li r1, (DEST_COL << HDR_DEST_SHIFT) | 0
        send ring, r1
        halt
    """)
    assert r.status == "fault" and "COL sent on the ring" in r.error.format()


# --- wormhole channels, the buffer pool and deadlock ----------------------------------------
#
# SC starts a 2-word message to IC (class 1) but stops after its first payload word to wait for
# OS's message (class 0). SC's message holds the SC->OS and OS->IC channels it has reached.
# Buffer pool off: OS's message needs the same OS->IC channel -> nobody can move: deadlock.
# Buffer pool on: classes 0 and 1 have separate channels; OS's message passes and all finish.

DEADLOCK_SC = """
    li r1, (1 << HDR_CLS_SHIFT) | (DEST_IC << HDR_DEST_SHIFT) | 2
    send ring, r1
    li r2, 11
    send ring, r2
wait_os:
    recv r3, ring       # OS's header
    recv r4, ring
    send ring, r4       # the tail of the message to IC
    halt
"""
DEADLOCK_OS = """
    li r5, 10
delay:
    addi r5, r5, -1
    bnez r5, delay
    li r1, (0 << HDR_CLS_SHIFT) | (DEST_SC << HDR_DEST_SHIFT) | 1
    send ring, r1
    li r2, 22
    send ring, r2
    halt
"""
DEADLOCK_IC = """
    recv r1, ring
    recv r2, ring
tail:
    recv r3, ring
    halt
"""


def test_deadlock_without_buffer_pool_is_detected_and_reported(engine_name):
    m, r = run(engine_name, ["ring.buffer_pool=false", "ring.deadlock_cycles=50"],
               os=DEADLOCK_OS, ic=DEADLOCK_IC, sc=DEADLOCK_SC)
    assert r.status == "deadlock" and r.exit_code == 3
    text = r.error.format()
    assert "deadlock in pe0" in text
    assert "pe0.ic: pc 2 (tail): waiting on fifo_empty:ring" in text
    assert "pe0.sc: pc 4 (wait_os): waiting on fifo_empty:ring" in text
    assert "pe0.os: pc 8 (delay+7): halted" in text
    assert "FIFO pe0.send.os: 2/64 words" in text
    assert "pe0.link.os-ic held by a message from pe0.link.sc-os" in text
    # detected exactly deadlock_cycles after the last progress
    assert "no progress for 50 cycles" in text


def test_same_traffic_completes_with_the_buffer_pool(engine_name):
    m, r = run(engine_name, ["ring.buffer_pool=true", "ring.deadlock_cycles=50"],
               os=DEADLOCK_OS, ic=DEADLOCK_IC, sc=DEADLOCK_SC)
    assert r.status == "halted"
    ic = proc(m, "ic")
    assert (ic.raw(2), ic.raw(3)) == (11, 22)


def test_idle_pe_waiting_for_work_is_not_a_deadlock(engine_name):
    # IC waits forever on an empty FIFO, nothing in flight: quiescence ends the run normally
    m, r = run(engine_name, ["ring.deadlock_cycles=5"], ic="recv r1, ring\nhalt")
    assert r.status == "finished" and r.exit_code == 0
