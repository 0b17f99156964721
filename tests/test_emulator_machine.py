"""The whole machine: DIS, COL and the frame buffer, several PEs, statistics, determinism,
snapshot/restore and per-cycle events.

The behaviour tests run once per engine (`engine_name`, tests/conftest.py) and read the frame,
the id buffer, statistics and registers through the engine interface. Snapshot/restore, the
tracer and per-cycle events are the reference engine's (the debugger's) own machinery: those
tests build a reference `Machine` directly."""

from __future__ import annotations

import io

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator import stats
from netsushisen.emulator.engine import make_engine
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.isa.images import image_from_json
from netsushisen.emulator.machine import Machine
from netsushisen.emulator.trace import Tracer
from netsushisen.isa.config import load_config

# OS takes (header, pixel) messages from the host and passes the pixel to SC; SC sends COL the
# pixel message (pixel, R = pixel, G = B = 0.5). Neither halts: the run ends by quiescence.
OS_SRC = """
loop:   recv r1, host
        recv r2, host
        li r3, (DEST_SC << HDR_DEST_SHIFT) | 1
        send ring, r3
        send ring, r2
        j loop
"""
SC_SRC = """
        lf r4, 0.5
        li r5, (DEST_COL << HDR_DEST_SHIFT) | 4
loop:   recv r1, ring
        recv r2, ring
        itof r3, r2
        send col, r5
        send col, r2
        send col, r3
        send col, r4
        send col, r4
        j loop
"""
N_PIXELS = 6


def image(n=N_PIXELS):
    host = []
    for i in range(n):
        host += [{"header": {"length": 1, "dest": "os"}}, i]
    return image_from_json({"host": host, "frame": {"width": 3, "height": 2}})


def programs():
    return {"os": assemble_text(OS_SRC, proc="os"), "sc": assemble_text(SC_SRC, proc="sc")}


def machine(sets=()):
    """A reference Machine (for the snapshot, trace and event tests)."""
    return Machine(load_config(None, list(sets)), programs(), image())


def engine(engine_name, sets=()):
    return make_engine(engine_name, load_config(None, list(sets)), programs(), image())


def expected_frame():
    f = np.zeros((2, 3, 3))
    for i in range(N_PIXELS):
        f[i // 3, i % 3] = (i, 0.5, 0.5)
    return f


def test_dis_col_frame_buffer_one_pe(engine_name):
    m = engine(engine_name)
    r = m.run(max_cycles=5000)
    assert r.status == "finished" and r.exit_code == 0
    assert np.array_equal(m.frame, expected_frame())
    s = m.statistics()
    assert s["col"]["pixel_messages"] == N_PIXELS and s["dis"]["messages_per_pe"] == [N_PIXELS]


def test_static_distribution_interleaves_over_pes(engine_name):
    m = engine(engine_name, ["pes=2"])
    assert m.run(max_cycles=5000).status == "finished"
    s = m.statistics()
    assert s["dis"]["messages_per_pe"] == [3, 3]
    assert s["processors"]["pe0.sc"]["ops_by_mnemonic"]["itof"] == 3
    assert np.array_equal(m.frame, expected_frame())


def test_dynamic_distribution_hands_out_every_message(engine_name):
    m = engine(engine_name, ["pes=3", "distribution=dynamic"])
    assert m.run(max_cycles=5000).status == "finished"
    assigned = m.statistics()["dis"]["messages_per_pe"]
    assert sum(assigned) == N_PIXELS and min(assigned) >= 1
    assert np.array_equal(m.frame, expected_frame())


# OS spins `work` iterations per ray; even rays are heavy (40), odd ones free. Static
# interleaving gives PE0 every heavy ray; dynamic hands a ray only to a PE whose host FIFO is
# empty, so PE1 (finishing its light rays fast) takes more of them and the run is shorter.
OS_WORK = """
loop:   recv r1, host
        recv r2, host
        recv r6, host
spin:   beqz r6, done
        addi r6, r6, -1
        j spin
done:   li r3, (DEST_SC << HDR_DEST_SHIFT) | 1
        send ring, r3
        send ring, r2
        j loop
"""


def test_dynamic_distribution_balances_uneven_work(engine_name):
    host = []
    for i in range(8):
        host += [{"header": {"length": 2, "dest": "os"}}, i, 40 if i % 2 == 0 else 0]
    img = {"host": host, "frame": {"width": 4, "height": 2}}
    runs = {}
    for mode in ("static", "dynamic"):
        m = run_machine(engine_name, load_config(None, ["pes=2", f"distribution={mode}"]),
                        {"os": assemble_text(OS_WORK, proc="os"),
                         "sc": assemble_text(SC_SRC, proc="sc")},
                        image_from_json(img), max_cycles=20_000)
        r, s = m.result(), m.statistics()
        assert r.status == "finished" and s["col"]["pixel_messages"] == 8
        runs[mode] = (r.cycles, s["dis"]["messages_per_pe"])
    assert runs["static"][1] == [4, 4]
    assert runs["dynamic"][1][1] > runs["dynamic"][1][0]
    assert runs["dynamic"][0] < runs["static"][0]


def test_statistics_are_deterministic_and_complete(engine_name):
    a = stats.dumps(_ran(engine(engine_name, ["pes=2"])).statistics())
    b = stats.dumps(_ran(engine(engine_name, ["pes=2"])).statistics())
    assert a == b
    s = _ran(engine(engine_name, ["pes=2"])).statistics()
    assert s["schema"] == {"name": "netsushisen-stats", "version": 1}
    assert s["config"]["pes"] == 2 and s["config"]["ring"]["buffer_pool"] is True
    assert set(s["processors"]) == {f"pe{i}.{p}" for i in range(2) for p in ("os", "ic", "sc")}
    for name, p in s["processors"].items():
        assert p["cycles"] == p["bundles"] + p["stall_cycles"], name
    assert s["processors"]["pe1.ic"]["present"] is False
    assert s["memory"]["pe0.sc"]["cache"]["accesses"] == 0
    assert s["fifos"]["pe0.col"]["words"] == 15 and s["fifos"]["pe0.col"]["peak"] >= 1
    assert s["run"]["status"] == "finished" and s["col"]["pixel_messages"] == N_PIXELS
    assert s["processors"]["pe0.os"]["stalls_by_pc"]["0"] == {
        "label": "loop", "stalls": {"fifo_empty:host": s["processors"]["pe0.os"]["stalls"]["fifo_empty:host"]}}


def _ran(m):
    m.run(max_cycles=5000)
    return m


def test_snapshot_restore_reproduces_the_run_exactly():
    m = machine(["pes=2"])
    for _ in range(25):
        m.step()
    snap = m.snapshot()
    out1 = io.StringIO()
    m.tracer = Tracer(out1)
    m.run(max_cycles=5000)
    first = stats.dumps(stats.collect(m))
    frame = m.col.frame.copy()
    m.restore(snap)
    assert m.cycle == 25 and m.status is None
    out2 = io.StringIO()
    m.tracer = Tracer(out2)
    m.run(max_cycles=5000)
    assert stats.dumps(stats.collect(m)) == first
    assert out1.getvalue() == out2.getvalue() and out1.getvalue()
    assert np.array_equal(m.col.frame, frame)
    # the snapshot is still usable (restore copies it)
    m.restore(snap)
    assert m.cycle == 25


def test_events_record_register_writes_and_cache_sets():
    prog = assemble_text("""
        li r1, 7
        ldg r2, [r1]
        halt
    """, proc="ic")
    m = Machine(load_config(None, ["ic_memory.cache_bytes=256"]), {"ic": prog},
                image_from_json({"icgm": list(range(64))}))
    m.record_events()
    ic = m.pes[0].cores["ic"]
    seen = []
    while m.step() is None:
        seen.append((m.cycle - 1, list(ic.events)))
        ic.events.clear()
    assert (1, [("reg", "pe0.ic", 1, 7), ("load", "pe0.ic", "global", 7, 0)]) in seen


def test_trace_filter_and_cycle_range():
    m = machine(["pes=2"])
    out = io.StringIO()
    m.tracer = Tracer(out, "pe1.sc", "5:8")
    m.run(max_cycles=5000)
    lines = out.getvalue().splitlines()
    assert len(lines) == 3
    assert all(" pe1.sc " in line for line in lines)
    assert [int(line.split()[0]) for line in lines] == [5, 6, 7]


def test_col_rejects_a_malformed_pixel_message(engine_name):
    sc = assemble_text("""
        li r1, (DEST_COL << HDR_DEST_SHIFT) | 3
        send col, r1
        halt
    """, proc="sc")
    r = run_machine(engine_name, load_config(), {"sc": sc}, image(), max_cycles=100).result()
    assert r.status == "fault" and "COL takes pixel messages" in r.error.format()


def test_incomplete_pixel_message_at_quiescence_is_reported(engine_name):
    sc = assemble_text("""
        li r1, (DEST_COL << HDR_DEST_SHIFT) | 4
        send col, r1
        send col, r0
        recv r2, ring       # waits forever; nothing else can ever arrive
    """, proc="sc")
    r = run_machine(engine_name, load_config(), {"sc": sc}, image(0), max_cycles=1000).result()
    assert r.status == "deadlock" and r.exit_code == 3
    assert "COL holds an incomplete pixel message" in r.error.format()
    assert "from pe0: 2 of 5 words received" in r.error.format()


def test_pixel_outside_the_frame_is_a_fault(engine_name):
    sc = assemble_text("""
        li r1, (DEST_COL << HDR_DEST_SHIFT) | 4
        li r2, 6
        send col, r1
        send col, r2
        send col, r0
        send col, r0
        send col, r0
        halt
    """, proc="sc")
    r = run_machine(engine_name, load_config(), {"sc": sc}, image(0), max_cycles=100).result()
    assert r.status == "fault" and "pixel 6 outside the 3x2 frame" in r.error.format()


ID_SC_SRC = """
        li r5, (DEST_COL << HDR_DEST_SHIFT) | 2
loop:   recv r1, ring
        recv r2, ring
        addi r3, r2, 100
        send col, r5
        send col, r2
        send col, r3
        j loop
"""


def test_col_id_messages_fill_the_hit_id_buffer(engine_name):
    # SC sends (pixel, 100 + pixel) as ID messages for pixels 0..3 of a 3x2 frame; the rest stay -1
    m = run_machine(engine_name, load_config(None, []),
                    {"os": assemble_text(OS_SRC, proc="os"),
                     "sc": assemble_text(ID_SC_SRC, proc="sc")},
                    image(4), max_cycles=5000)
    assert m.status == "finished"
    assert m.ids.tolist() == [[100, 101, 102], [103, -1, -1]]
    assert not m.frame.any()


WAIT_OS_SRC = """
# OS serves two FIFOs: it sleeps in `wait` until the host or the ring has a word
loop:   wait
        poll r6, host
        bnez r6, host_msg
        recv r1, ring            # never reached here: only host words arrive
        j loop
host_msg:
        recv r1, host
        recv r2, host
        li r3, (DEST_SC << HDR_DEST_SHIFT) | 1
        send ring, r3
        send ring, r2
        j loop
"""


def test_wait_sleeps_until_a_fifo_has_a_word_and_counts_as_idle(engine_name):
    m = run_machine(engine_name, load_config(None, []),
                    {"os": assemble_text(WAIT_OS_SRC, proc="os"),
                     "sc": assemble_text(SC_SRC, proc="sc")},
                    image(), max_cycles=5000)
    r = m.result()
    assert r.status == "finished"  # quiescence is reached with OS asleep in `wait`
    assert np.array_equal(m.frame, expected_frame())
    stalls = m.statistics()["processors"]["pe0.os"]["stalls"]
    assert stalls.get("fifo_empty:any", 0) > 0


ROOM_OS_SRC = """
# `room` tells how many words the send FIFO can still take: send only whole messages
        li r3, (DEST_SC << HDR_DEST_SHIFT) | 1
        room r7, ring            # all free at the start
loop:   recv r1, host
        recv r2, host
        send ring, r3
        send ring, r2
        j loop
"""


def test_room_reports_free_send_fifo_words(engine_name):
    m = run_machine(engine_name, load_config(None, ["ring.fifo_depth=16"]),
                    {"os": assemble_text(ROOM_OS_SRC, proc="os"),
                     "sc": assemble_text(SC_SRC, proc="sc")},
                    image(), max_cycles=5000)
    assert m.status == "finished"
    assert ProcessorView(m, "pe0.os").raw(7) == 16
    with pytest.raises(Exception) as exc:  # room names a send FIFO: host is a receive FIFO
        assemble_text("room r1, host\n halt\n", proc="os")
    assert "expected a FIFO port of OS: ring" in str(exc.value)


# -- no pixel or message is lost silently (machine.py, end of a run) ---------------------------


def test_sc_halting_in_the_middle_of_a_pixel_message_is_a_deadlock(engine_name):
    # the header and 2 of the 4 words reach COL, then SC halts: the pixel can never complete
    sc = assemble_text("""
        li r1, (DEST_COL << HDR_DEST_SHIFT) | 4
        li r2, 5
        send col, r1
        send col, r2
        send col, r0
        halt
    """, proc="sc")
    m = run_machine(engine_name, load_config(), {"sc": sc}, image(0), max_cycles=1000)
    r = m.result()
    assert (r.status, r.exit_code) == ("deadlock", 3)
    text = r.error.format()
    assert "every PE is idle but COL holds an incomplete pixel message" in text
    assert "from pe0: 3 of 5 words received" in text
    assert not m.frame.any()


def test_sc_halting_after_a_whole_pixel_message_halts(engine_name):
    # the control: the same pixel sent whole ends `halted` with the pixel in the frame
    sc = assemble_text("""
        li r1, (DEST_COL << HDR_DEST_SHIFT) | 4
        li r2, 5
        lf r3, 0.25
        send col, r1
        send col, r2
        send col, r3
        send col, r3
        send col, r3
        halt
    """, proc="sc")
    m = run_machine(engine_name, load_config(), {"sc": sc}, image(0), max_cycles=1000)
    r = m.result()
    assert (r.status, r.exit_code) == ("halted", 0)
    want = np.zeros((2, 3, 3))
    want[1, 2] = 0.25  # pixel 5 = (x 2, y 1) of the 3x2 frame
    assert np.array_equal(m.frame, want)


RING_HALF = """
        li r1, (DEST_IC << HDR_DEST_SHIFT) | 3     # a 3-word message to IC
        li r2, 7
        send ring, r1
        send ring, r2
        halt                                      # 2 of its words never sent
"""


def test_a_processor_halting_in_the_middle_of_a_ring_message_is_a_deadlock(engine_name):
    os_ = assemble_text(RING_HALF, proc="os")
    r = run_machine(engine_name, load_config(), {"os": os_}, image(0), max_cycles=1000).result()
    assert (r.status, r.exit_code) == ("deadlock", 3)
    text = r.error.format()
    assert "a message was left incomplete" in text
    assert "pe0.os" in text and "halted at pc 4, with 2 words of its message on `ring` never sent" in text


def test_a_ring_message_cut_short_in_pe1_is_located_there(engine_name):
    # each PE's OS sends a 2-word message to SC with as many payload words as its host message
    # says: pe0 is told 2 (whole), pe1 is told 1 (one word short)
    os_ = assemble_text("""
        recv r1, host
        recv r2, host                             # payload words to send
        li r3, (DEST_SC << HDR_DEST_SHIFT) | 2
        send ring, r3
loop:   beqz r2, done
        send ring, r2
        addi r2, r2, -1
        j loop
done:   halt
    """, proc="os")
    img = image_from_json({"host": [{"header": {"length": 1, "dest": "os"}}, 2,
                                    {"header": {"length": 1, "dest": "os"}}, 1],
                           "frame": {"width": 3, "height": 2}})
    r = run_machine(engine_name, load_config(None, ["pes=2"]), {"os": os_}, img,
                    max_cycles=1000).result()
    assert (r.status, r.exit_code) == ("deadlock", 3)
    notes = [d.message for d in r.error.diagnostics[1:]]
    senders = [n for n in notes if "never sent" in n]
    assert len(senders) == 1 and senders[0].startswith("  pe1.os: ") \
        and "halted at pc 8 (done), with 1 word of its message on `ring` never sent" in senders[0], notes


def test_a_processor_waiting_in_the_middle_of_a_ring_message_is_a_deadlock(engine_name):
    # IC sends 1 of 2 payload words to OS and waits forever; OS has taken what came and waits
    # for the rest: every processor waits on an empty FIFO (formerly `finished`, exit 0)
    ic = assemble_text("""
        li r1, (DEST_OS << HDR_DEST_SHIFT) | 2
        li r2, 9
        send ring, r1
        send ring, r2
        recv r5, ring
        halt
    """, proc="ic")
    os_ = assemble_text("""
        recv r1, ring
        recv r2, ring
        recv r3, ring                             # never comes
        halt
    """, proc="os")
    m = run_machine(engine_name, load_config(), {"os": os_, "ic": ic}, image(0),
                    max_cycles=20_000)
    r = m.result()
    assert (r.status, r.exit_code) == ("deadlock", 3)
    text = r.error.format()
    assert "pe0.ic" in text and "waiting on" in text \
        and "with 1 word of its message on `ring` never sent" in text, text
    assert ProcessorView(m, "pe0.os").int(2) == 9


def test_a_whole_ring_message_left_in_flight_still_halts(engine_name):
    # the control: a processor that sends its message whole and halts loses nothing it could
    # have finished; words still travelling when every processor has halted are counted
    # (left_in_flight), the run ends `halted`
    os_ = assemble_text(RING_HALF.replace("halt ", "send ring, r2\n        send ring, r2\n"
                                          "        halt "), proc="os")
    m = run_machine(engine_name, load_config(), {"os": os_}, image(0), max_cycles=1000)
    r = m.result()
    assert (r.status, r.exit_code) == ("halted", 0), r.error
