"""Tests written to kill mutants that survived tools/mutate.py in emulator/ (docs/mutation.md).
Expected cycles are worked out by hand in the comments (`cN`: the cycle a bundle issues), as in
tests/test_emulator_timing.py; every test runs on every engine."""

from __future__ import annotations

import dataclasses

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import load_config
from netsushisen.isa.images import image_from_json
from netsushisen.isa.ring import DEST_SHIFT, DESTS


def run(engine, sets=(), **sources):
    programs = {proc: assemble_text(src, proc=proc) for proc, src in sources.items()}
    e = run_machine(engine, load_config(None, list(sets)), programs, max_cycles=5_000)
    return e, e.result()


# room then poll, each with latency 3 and its result used at once: the results are due at
# issue + 3, so each use waits 2 cycles. Issued at an even cycle (c2, c6), a due cycle computed
# as c XOR 3 would be in the past (c1, c5) and nothing would wait.
POLL_ROOM = """
    nop                 # c0
    nop                 # c1
    room r3, ring       # c2: r3 due at 5
    add r4, r3, r3      # c3, c4 stall operand:room; c5 issue
    poll r1, ring       # c6: r1 due at 9
    add r2, r1, r1      # c7, c8 stall operand:poll; c9 issue
    halt                # c10
"""


def test_poll_and_room_results_wait_for_their_latency(engine_name):
    m, r = run(engine_name, ["os.latency.poll=3", "os.latency.room=3"], os=POLL_ROOM)
    os_ = ProcessorView(m, "pe0.os")
    assert r.status == "halted"
    assert os_.stalls == {"operand:room": 2, "operand:poll": 2} and os_.cycles == 11
    assert os_.raw(3) == load_config(None, []).ring.fifo_depth and os_.raw(1) == 0


def test_summary_names_pe_count_and_orders_equal_stalls_by_name(engine_name):
    # two stall causes of 2 cycles each, operand:room first in time: the summary lists the most
    # frequent causes first and breaks the tie by name (poll before room)
    sets = ["os.latency.poll=3", "os.latency.room=3"]
    m, _ = run(engine_name, sets, os=POLL_ROOM)
    lines = m.summary().splitlines()
    assert lines[0].startswith("status halted, ") and lines[0].endswith(" cycles, 1 PE")
    os_line = next(line for line in lines if line.lstrip().startswith("pe0.os:"))
    assert os_line.endswith("4 stall cycles [operand:poll 2, operand:room 2]")
    m, _ = run(engine_name, sets + ["pes=2"], os=POLL_ROOM)
    assert m.summary().splitlines()[0].endswith(" cycles, 2 PEs")


def test_col_header_on_the_ring_fault_names_the_header_not_a_later_word(engine_name):
    # c2 send header, c3 send 99: at c3 SC's CMU finds the header poppable with the payload
    # already queued behind it; the fault must quote the header
    header = (DESTS["col"] << DEST_SHIFT) | 1
    _, r = run(engine_name, sc=f"""
        li r1, {header}
        li r2, 99
        send ring, r1
        send ring, r2
        halt
    """)
    assert r.status == "fault"
    assert f"message header {header:#x} for COL sent on the ring" in r.error.format()


def test_a_hand_edited_program_is_rejected_before_the_run(engine_name):
    # an object file edited by hand: li's destination register set to r99 (IC has fewer)
    program = assemble_text("li r1, 1\nhalt\n", proc="ic")
    (op,) = program.bundles[0]
    bad = dataclasses.replace(program, bundles=[(dataclasses.replace(op, args=(99, 1)),),
                                                *program.bundles[1:]])
    with pytest.raises(NetsushisenError) as err:
        run_machine(engine_name, load_config(None, []), {"ic": bad}, max_cycles=100).result()
    assert "bundle 0: li: no register r99" in err.value.format()


def test_sc_reads_its_own_global_and_resident_memory(engine_name):
    # SC, like IC, has a global memory behind a cache and a resident memory (OS has neither)
    programs = {"sc": assemble_text("ldg r1, [r0 + 2]\nldr r2, [r0 + 1]\nhalt\n", proc="sc")}
    image = image_from_json({"scgm": [0.5, 1.5, 2.5, 3.5], "sc.resident": [7.0, 7.25]})
    m = run_machine(engine_name, load_config(None, []), programs, image, max_cycles=1_000)
    sc = ProcessorView(m, "pe0.sc")
    assert m.result().status == "halted"
    assert (sc.float(1), sc.float(2)) == (2.5, 7.25)


ONE_MESSAGE = {"os": "li r1, (DEST_IC << HDR_DEST_SHIFT) | 1\nsend ring, r1\nsend ring, r1\nhalt\n",
               "ic": "recv r1, ring\nrecv r2, ring\nhalt\n"}


def test_statistics_list_only_the_pool_channels_a_run_used(engine_name):
    # with the buffer pool each link has one channel per class; a 2-word OS -> IC message uses
    # class 0 of link os-ic only: that channel is listed, no unused channel is
    m, r = run(engine_name, **ONE_MESSAGE)
    links = {k: v["words"] for k, v in m.statistics()["fifos"].items() if ".link." in k}
    assert r.status == "halted" and links == {"pe0.link.os-ic.0": 2}
    # without the pool every link is listed, used or not
    m, _ = run(engine_name, ["ring.buffer_pool=false"], **ONE_MESSAGE)
    links = {k: v["words"] for k, v in m.statistics()["fifos"].items() if ".link." in k}
    assert sorted(links.values()) == [0, 0, 2]


def test_unsent_report_quotes_the_header_still_in_the_send_fifo(engine_name):
    # OS sends a whole 2-word message (length 2, dest ic), then the header and one of the two
    # payload words of a second one, and halts. A 1-word link with latency 8 holds the first
    # message's tail, so the second header (1 << 8 | 2 = 0x102) is still in OS's send FIFO.
    src = """
        li r1, (DEST_IC << HDR_DEST_SHIFT) | 2
        send ring, r1
        send ring, r0
        send ring, r0
        send ring, r1
        send ring, r0
        halt
    """
    _, r = run(engine_name, ["ring.link_buffer_words=1", "ring.link_latency=8"], os=src)
    assert r.status == "deadlock"
    assert ("pe0.os: halted at pc 6, with 1 word of its message on `ring` never sent; "
            "header 0x102 (dest ic, length 2) still in FIFO pe0.send.os") in r.error.format()


def _race(engine, ic_nops: int, sc_nops: int) -> int:
    """IC (through SC's CMU) and SC both send a 1-word message to OS; the payload OS gets first."""
    def sender(nops: int, payload: int) -> str:
        return ("nop\n" * nops + "li r1, (DEST_OS << HDR_DEST_SHIFT) | 1\n"
                f"li r2, {payload}\nsend ring, r1\nsend ring, r2\nhalt\n")
    m, r = run(engine, ["ring.buffer_pool=false"], ic=sender(ic_nops, 11), sc=sender(sc_nops, 22),
               os="recv r1, ring\nrecv r2, ring\nrecv r3, ring\nrecv r4, ring\nhalt\n")
    assert r.status == "halted"
    return ProcessorView(m, "pe0.os").raw(2)


def test_cmu_round_robin_starts_at_input_cycle_mod_n(engine_name):
    # SC's CMU has two inputs: 0 = SC's send FIFO, 1 = the link from IC. IC's header, sent at
    # c(2 + ic_nops), reaches SC's CMU at c(4 + ic_nops); SC's own, sent at c(2 + sc_nops), is
    # poppable at c(3 + sc_nops). When both wait in the same cycle c, input c mod 2 goes first.
    assert _race(engine_name, 0, 1) == 22   # both at c4: input 0 (SC's own message) first
    assert _race(engine_name, 1, 2) == 11   # both at c5: input 1 (IC's, on the link) first
    assert _race(engine_name, 1, 3) == 11   # IC's alone at c5, SC's at c6


def test_statistics_listing_names_the_source_lines_of_each_bundle():
    """`programs.<stage>.listing.lines`: a bundle's distinct source lines, the file named when
    it changes (a scheduled bundle gathers several lines; a macro's body lives in another file)."""
    from netsushisen.asm.objects import SourceLoc
    from netsushisen.emulator.stats import program_listing

    p = assemble_text("{ li r1, 1 ; li r2, 2 }\nhalt\n", proc="os", filename="k/a.s")
    p.op_sources = [(SourceLoc("k/a.s", 4), SourceLoc("k/a.s", 4), SourceLoc("k/a.s", 2),
                     SourceLoc("k/b.inc", 9), SourceLoc("k/b.inc", 7)), (SourceLoc("k/a.s", 5),)]
    assert program_listing(p)["lines"] == ["a.s:4, 2, b.inc:9, 7", "a.s:5"]
    p.op_sources = p.op_sources[:1]
    assert program_listing(p)["lines"] == ["a.s:4, 2, b.inc:9, 7", None]
