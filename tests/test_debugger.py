"""`netsushisen debug`: driven with --batch (what a user sees), and the session's exact reverse
execution (full canonical state dumps compared).

Expected cycles are worked out from docs/timing.md in the comments (`cN` = the cycle a bundle
issues in; default timing: int ALU 1, fadd 2, fmul 3, taken-branch penalty 1, IC local t_r 1).
A breakpoint stops after the cycle in which its bundle issues.
"""

from __future__ import annotations

import io
import json
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.debugger.session import ProgramsFactory, Session
from netsushisen.debugger.state import STATE_KEYS, dump_differences, state_dump
from netsushisen.emulator.machine import Machine
from netsushisen.isa.config import load_config
from netsushisen.isa.images import image_from_json

PROJECT = Path(__file__).resolve().parents[1]

# The timing.md example (section 1, T10), with a label on the fourth bundle.
CHAIN = """
.proc ic
start:  lf r1, 2.0          # c0
        fmul r2, r1, r1     # c1        r2 ready at 4
        fadd r3, r2, r1     # c2, c3 stall operand:fmul; c4 issue, r3 ready at 6
target: fadd r4, r3, r3     # c5 stall operand:fadd; c6 issue
        halt                # c7 -> 8 cycles
"""

# A counted loop: li c0, lf c1; per iteration: loop cK, st cK+1, bnez cK+2 (taken: cK+3 is a
# branch stall), so loop issues in c2, c6, c10; then st c11, bnez c12 (not taken), done c13
# (ld t_r = 1), halt c14 -> the run ends after 15 cycles.
LOOP = """
.proc ic
.data
counter: .word 0
table:   .float 1.5, 2.5, 3.5
.text
start:  li r9, 3
        lf r1, 1.5
loop:   { addi r9, r9, -1 ; fadd r2, r2, r1 }
        st r9, [counter]
        bnez r9, loop
done:   { ld r3, [table + 1] ; fmul r4, r1, r1 }
        halt
"""

# A three-stage pipeline: DIS -> OS -> IC (ldg through the cache, ldr resident) -> SC -> COL.
OS_PIPE = """
.proc os
loop:   recv r1, host
        recv r2, host
        li r3, (DEST_IC << HDR_DEST_SHIFT) | 1
        send ring, r3
        send ring, r2
        j loop
"""
IC_PIPE = """
.proc ic
loop:   recv r1, ring
        recv r2, ring
        slli r3, r2, 2
        ldg r4, [r3 + 1]
        ldr r5, [r2]
        fadd r6, r4, r5
        li r7, (DEST_SC << HDR_DEST_SHIFT) | (1 << HDR_CLS_SHIFT) | 2
        send ring, r7
        send ring, r2
        send ring, r6
        j loop
"""
SC_PIPE = """
.proc sc
        li r5, (DEST_COL << HDR_DEST_SHIFT) | 4
        lf r8, 0.5
loop:   recv r1, ring
        recv r2, ring
        recv r3, ring
        itof r4, r2
        send col, r5
        send col, r2
        send col, r3
        send col, r4
        send col, r8
        j loop
"""


def pipe_image() -> dict:
    host = []
    for i in range(6):
        host += [{"header": {"length": 1, "dest": "os"}}, i]
    return {"host": host, "frame": {"width": 3, "height": 2},
            "icgm": [float(i) for i in range(32)], "ic.resident": [0.25 * i for i in range(6)]}


@pytest.fixture
def files(tmp_path):
    for name, src in (("chain", CHAIN), ("loop", LOOP), ("os", OS_PIPE), ("ic", IC_PIPE),
                      ("sc", SC_PIPE)):
        (tmp_path / f"{name}.s").write_text(src)
    (tmp_path / "image.json").write_text(json.dumps(pipe_image()))
    return tmp_path


@pytest.fixture
def debug(cli, files):
    """Run `netsushisen debug ARGS --batch` on a list of commands: (exit code, stdout)."""

    def run(commands: list[str], *args, screen: bool = False):
        script = files / "commands.txt"
        script.write_text("\n".join(commands) + "\n")
        extra = [] if screen else ["--no-screen"]
        code, out, err = cli("debug", *[str(a) for a in args], "--batch", str(script), *extra)
        assert "Traceback" not in out + err
        return code, out

    return run


def pipe_session(pes: int = 2, **kw) -> Session:
    programs = {s: assemble_text(src, proc=s) for s, src in
                (("os", OS_PIPE), ("ic", IC_PIPE), ("sc", SC_PIPE))}
    factory = ProgramsFactory(load_config(None, [f"pes={pes}"]), programs,
                              image_from_json(pipe_image()))
    return Session(factory, **kw)


def loop_session(**kw) -> Session:
    factory = ProgramsFactory(load_config(None, []), {"ic": assemble_text(LOOP)})
    return Session(factory, **kw)


def lines_with(out: str, text: str) -> list[str]:
    return [line for line in out.splitlines() if text in line]


def listing_rows(out: str, mark: str) -> list[list[str]]:
    """Rows of the listing panel whose marker column starts with `mark` (=>, !>, ->)."""
    rows = []
    for line in out.splitlines():
        cells = line.strip("│ ").split()
        if cells and cells[0].startswith(mark) and "│" in line:
            rows.append(cells)
    return rows


# ---------------------------------------------------------------------------------------------
# Breakpoints, watchpoints, until, set


def test_breakpoint_on_a_label_stops_in_the_cycle_the_bundle_issues(debug, files):
    code, out = debug(["break target", "continue", "print r3", "print f:r3"],
                      "--program", files / "chain.s", screen=True)
    assert code == 0
    assert "breakpoint 1: pe0.ic issued pc 3 (target) in cycle 6" in out
    assert "last cycle 6 (7 cycles run)" in out  # the screen's header
    # the listing marks the issuing bundle, with every slot of the IC VLIW shown
    row = listing_rows(out, "=>")[0]
    assert row[:3] == ["=>B1", "3", "target"] and "fadd r4, r3, r3" in " ".join(row)
    assert all(slot in out for slot in ("int0", "fp0", "fp1", "fp2"))
    assert "f:r3 = 6.0" in out  # fadd r3 = 4.0 + 2.0, written at the start of cycle 6
    assert "\x1b[" not in out  # no colour codes when not a terminal


def test_the_screen_shows_the_stall_reason_and_the_scoreboard(debug, files):
    # after c3: fadd r3 (pc 2) waits for fmul's r2 (ready at 4)
    code, out = debug(["cycle 4"], "--program", files / "chain.s", screen=True)
    assert "last cycle 3 (4 cycles run)" in out
    assert "stall operand:fmul at pc 2 (start+2)" in out
    assert listing_rows(out, "!>")[0][:2] == ["!>", "2"]
    pending = lines_with(out, "fmul pc 1")[0]
    assert "r2" in pending and " 4 " in pending and "4.0" in pending


def test_conditional_breakpoint(debug, files):
    # loop issues in c2 (r9 = 3), c6 (2), c10 (1); the condition sees the registers the bundle read
    code, out = debug(["break loop if r9 == 1", "continue", "print r9", "info break"],
                      "--program", files / "loop.s")
    assert "breakpoint 1: pe0.ic issued pc 2 (loop) in cycle 10 [r9 == 1]" in out
    assert "r9 = 1  (0x00000001" in out
    assert "hit 1 time" in out
    # a float condition, true from the second iteration (r2 = 1.5 written at c4)
    code, out = debug(["break loop if f:r2 > 1.0", "continue"], "--program", files / "loop.s")
    assert "in cycle 6 [f:r2 > 1.0]" in out


def test_watchpoint_fires_on_the_write_with_old_and_new_values(debug, files):
    code, out = debug(["watch r9", "watch local[counter]", "continue", "continue", "delete 1",
                       "continue"], "--program", files / "loop.s")
    # li r9 issued c0, written at the start of c1; addi issued c2 (latency 1), written in c3
    assert "watchpoint 1: pe0.ic.r9: 0 -> 3 in cycle 1 (li at pc 0 (start), issued in cycle 0)" in out
    assert "watchpoint 1: pe0.ic.r9: 3 -> 2 in cycle 3 (addi at pc 2 (loop), issued in cycle 2)" in out
    # st issues in c3 too (stores write at issue): the same stop reports both; then c7
    assert "watchpoint 2: pe0.ic.local[0]: 0 -> 2 in cycle 3 (st at pc 3 (loop+1))" in out
    assert "watchpoint 2: pe0.ic.local[0]: 2 -> 1 in cycle 7 (st at pc 3 (loop+1))" in out
    assert "r9: 2 -> 1" not in out  # deleted before c7


def test_set_changes_what_follows(debug, files):
    code, out = debug(["continue"], "--program", files / "loop.s")
    assert "run ended at cycle 15: halted" in out
    # after c1 r9 = 3 is in the register; set it to 1: one iteration: loop c2, st c3, bnez c4
    # (not taken), done c5, halt c6 -> 7 cycles
    code, out = debug(["cycle 2", "set r9 = 1", "continue", "print local[counter]",
                       "print f:r2"], "--program", files / "loop.s")
    assert "r9 = 1 (was 3)" in out
    assert "run ended at cycle 7: halted" in out
    assert "local[0] = 0  (0x00000000" in out
    assert "f:r2 = 1.5" in out
    # a result in flight overwrites a set register: li (c0) writes r9 in c1
    code, out = debug(["cycle", "set r9 = 7", "cycle", "print r9"], "--program", files / "loop.s")
    assert "note: r9 has a li result in flight (written in cycle 1)" in out
    assert "r9 = 3  (" in out


def test_set_floats_memory_and_pc(debug, files):
    code, out = debug(["cycle 2", "set r6 = 1.5f", "print f:r6", "set f:r7 = 2", "print f:r7",
                       "set x:r8 = 0x40490fdb", "print f:r8", "set *local[10] = 7",
                       "print local[10]", "set *table = 0.25", "print f:local[table]",
                       "set pc = done", "stepi", "print r3"],
                      "--program", files / "loop.s")
    assert code == 0
    assert "f:r6 = 1.5" in out and "f:r7 = 2.0" in out and "f:r8 = 3.1415927" in out
    assert "local[10] = 7  (0x00000007" in out
    assert "f:local[1] = 0.25" in out
    assert "issued pc 5 (done)" in out  # stepi after `set pc = done`


def test_until_a_label_and_until_out_of_a_loop(debug, files):
    code, out = debug(["until done", "print cycle"], "--program", files / "loop.s")
    assert "until: pe0.ic issued pc 5 (done) in cycle 13" in out
    assert "cycle = 14" in out
    # `until` without a location leaves the loop: stopped after bnez (pc 4, c4), it runs to
    # the first bundle issued past pc 4: loop c6, st c7, bnez c8, loop c10, ... done c13
    code, out = debug(["break loop", "continue", "delete", "stepi 2", "until"],
                      "--program", files / "loop.s")
    assert "[cycle 4] pe0.ic issued pc 4 (loop+2): bnez r9, loop" in out
    assert "[cycle 13] pe0.ic issued pc 5 (done)" in out


def test_stepi_and_next_count_bundles_of_the_viewed_processor(debug, files):
    src = """
.proc sc
        li r1, 1        # c0
        call sub        # c1 (taken: c2 is a branch stall)
        li r3, 3        # c6
        halt            # c7
sub:    addi r2, r1, 1  # c3
        ret             # c4 (taken: c5 stall)
"""
    (files / "call.s").write_text(src)
    code, out = debug(["stepi", "next", "stepi", "reverse-stepi 2", "stepi 2"],
                      "--program", files / "call.s")
    assert "[cycle 0] pe0.sc issued pc 0: li r1, 1" in out
    assert "[cycle 6] pe0.sc issued pc 2: li r3, 3" in out  # next: call with its subroutine
    assert "[cycle 7] pe0.sc issued pc 3, halted: halt" in out
    assert "run ended at cycle 8: halted" in out
    # back two bundles of SC: before halt (c7) and li (c6) is ret, issued in c4
    assert "[cycle 4] pe0.sc issued pc 5 (sub+1): ret" in out
    assert out.count("run ended at cycle 8: halted") == 2  # stepi 2: li (c6), halt (c7)


def test_print_and_x(debug, files):
    img = files / "img.json"
    img.write_text(json.dumps({"icgm": [float(i) / 4 for i in range(8)]}))
    code, out = debug(["cycle 3", "print r9", "print r9 * 2 + 1", "print loop", "print/x 255",
                       "print f:r1 + 0.25", "print table", "print icgm[table + 2]",
                       "print f:icgm[table + 2]", "x/3f local[table]", "x/4 icgm 4",
                       "x/2d local 1", "print/x r1"],
                      "--program", files / "loop.s", "--image", img)
    assert code == 0
    assert "r9 = 3  (0x00000003, float 4e-45)" in out
    assert "r9 * 2 + 1 = 7" in out
    assert "loop = 2  (code address: loop)" in out
    assert "255 = 0xff" in out
    assert "f:r1 + 0.25 = 1.75" in out
    assert "table = 1" in out
    assert "icgm[3] = 1061158912  (0x3f400000, float 0.75)" in out
    assert "f:icgm[3] = 0.75" in out
    rows = [line.split() for line in out.splitlines()]
    assert ["local[1]:", "1.5", "2.5", "3.5"] in rows
    assert ["icgm[4]:", "0x3f800000", "0x3fa00000", "0x3fc00000", "0x3fe00000"] in rows
    assert ["local[1]:", "1069547520", "1075838976"] in rows
    assert "r1 = 0x3fc00000" in out


def test_bad_commands_give_one_line_errors_and_the_session_goes_on(debug, files):
    bad = ["bogus", "print r99", "print (1 +", "print nosuch", "break nowhere", "x/8q local 0",
           "set r0 = 1", "set *icgm[0] = 1", "step -1", "info nothing", "watch icgm[0]",
           "print local[70000]", "pe 3", "proc xx", "delete 9", "print 1/0", "re"]
    (files / "img.json").write_text(json.dumps({"icgm": [1, 2, 3]}))
    code, out = debug(bad + ["cycle", "print r9"], "--program", files / "loop.s", "--image",
                      files / "img.json")
    errors = lines_with(out, "error: ")
    assert len(errors) == len(bad)
    assert "error: unknown command 'bogus'" in out
    assert "error: no register r99" in out
    assert "error: unknown name 'nosuch'" in out
    assert "error: ambiguous command 're'" in out
    assert "icgm memory is read-only" in out
    assert "[cycle 0] pe0.ic issued pc 0 (start)" in out  # the session still works
    assert "r9 = 0" in out
    assert code == 1  # a batch with failed commands exits 1


def test_the_end_of_the_run_is_shown_and_the_session_stays_open(debug, files):
    (files / "fault.s").write_text(".proc ic\n li r1, 70000\n ld r2, [r1]\n halt\n")
    code, out = debug(["continue", "print r1", "cycle", "info stats"],
                      "--program", files / "fault.s")
    assert "run ended at cycle 2: fault (run-time fault)" in out
    assert "local memory address 70000 is outside" in out
    assert "r1 = 70000" in out
    assert "nothing more to run" in out
    # deadlock: OS sends forever, nobody receives
    (files / "flood.s").write_text(".proc os\nloop: send ring, r1\n j loop\n")
    code, out = debug(["continue", "info fifo"], "--program", files / "flood.s",
                      "--set", "ring.deadlock_cycles=50")
    assert "run ended at cycle 470: deadlock" in out and "no progress for 50 cycles" in out
    assert ["send.os", "64/64"] in [line.split()[:2] for line in out.splitlines()]


def test_reverse_step_and_continue_in_batch(debug, files):
    code, out = debug(["cycle 9", "info state", "cycle 30", "reverse-cycle 30", "info state",
                       "break loop", "continue", "continue", "continue", "reverse-continue",
                       "print cycle"],
                      "--os", files / "os.s", "--ic", files / "ic.s", "--sc", files / "sc.s",
                      "--image", files / "image.json", "--checkpoint-interval", "8", "--proc",
                      "sc")
    digests = [line.split(": ")[1] for line in lines_with(out, "state digest after 9 cycles")]
    assert len(digests) == 2 and digests[0] == digests[1]
    hits = lines_with(out, "breakpoint 1: pe0.sc issued pc 2 (loop) in cycle")
    cycles = [int(h.rsplit(" ", 1)[1]) for h in hits]
    assert len(cycles) == 4 and cycles[3] == cycles[1]  # reverse-continue: the previous hit
    assert f"cycle = {cycles[1] + 1}" in out


def test_help_trace_disassemble_views(debug, files):
    code, out = debug(["help", "help break", "trace on", "cycle 2", "trace off", "disassemble loop",
                       "proc ic", "pe 1", "info registers", "info cache", "info checkpoints"],
                      "--os", files / "os.s", "--ic", files / "ic.s", "--sc", files / "sc.s",
                      "--image", files / "image.json", "--pes", "2")
    assert code == 0
    assert "reverse-continue" in out and "break LOCATION [if CONDITION]" in out
    assert "aliases: b" in out
    first = [line.split() for line in lines_with(out, "pe0.os ") if line[:8].strip().isdigit()][0]
    assert first[:4] == ["0", "pe0.os", "0", "loop"] and first[-1] == "fifo_empty:host"
    assert "pe0.os: bundles 0..5" in out and "recv r1, host" in out
    assert "registers pe1.ic" in out
    assert "cache: 128 sets x 64 B" in out
    assert "checkpoints, every 2048 cycles" in out


def test_enter_repeats_the_last_command():
    from netsushisen.debugger.commands import Commands

    s = loop_session()
    cmds = Commands(s)
    cmds.execute("cycle 3")
    cmds.execute("", repeat_empty=True)
    assert s.machine.cycle == 6
    cmds.execute("")  # a batch's empty line does nothing
    assert s.machine.cycle == 6


def test_commands_from_stdin(cli, files, monkeypatch):
    monkeypatch.setattr(sys, "stdin", io.StringIO("break done\ncontinue\nquit\nstep\n"))
    code, out, err = cli("debug", "--program", files / "loop.s", "--batch", "-", "--no-screen")
    assert code == 0 and "issued pc 5 (done) in cycle 13" in out
    assert "(nss) step" not in out  # quit ends the batch


def test_source_and_commands_file(cli, files):
    setup = files / "setup.txt"
    setup.write_text("# set up\nbreak done\n")
    (files / "run.txt").write_text(f"continue\nsource {setup}\ninfo break\nsource nowhere.txt\n")
    code, out, err = cli("debug", "--program", files / "loop.s", "-x", setup,
                         "--batch", files / "run.txt", "--no-screen")
    assert "breakpoint 1: pe0.ic issued pc 5 (done) in cycle 13" in out  # set by -x
    assert "breakpoint 2 at ic pc 5 (done)" in out  # by `source`
    assert "error: nowhere.txt: No such file or directory" in out
    assert code == 1


def test_scene_mode(cli, files):
    # the scene's host work (grid, pre-pass, images, eye rays) with our own small kernels in
    # place of the bundled ones: they do not understand the scene's messages, so the run may
    # fault, which the session shows and replays exactly
    script = files / "scene.txt"
    script.write_text("cycle 40\ninfo state\nreverse-cycle 20\ncycle 20\ninfo state\nrestart\n"
                      "cycle 40\ninfo state\n")
    code, out, err = cli("debug", "tetra:1", "--res", "2", "--os", files / "os.s", "--ic",
                         files / "ic.s", "--sc", files / "sc.s", "--batch", script, "--no-screen")
    assert code == 0, err
    assert "netsushisen debug: scene tetra" in out
    digests = [line.split("cycles: ")[1] for line in lines_with(out, "state digest after")]
    assert len(digests) == 3 and len(set(digests)) == 1


def test_scene_and_program_options_do_not_mix(cli, files):
    code, out, err = cli("debug", "tetra", "--program", files / "loop.s")
    assert code == 1 and "scene mode builds its own programs" in err
    code, out, err = cli("debug", "--program", files / "loop.s", "--res", "8")
    assert code == 1 and "are for scene mode" in err


def test_program_options_are_those_of_run(cli, files):
    code, out, err = cli("debug", "--program", files / "loop.s", "--program", files / "loop.s")
    assert code == 1 and "a second IC program" in err
    code, out, err = cli("debug")
    assert code == 1 and "nothing to debug" in err


# ---------------------------------------------------------------------------------------------
# Reverse execution is exact


def test_state_keys_match_the_machine_snapshot():
    m = Machine(load_config(None, []), {"ic": assemble_text(LOOP)})
    assert set(m.snapshot()) == set(STATE_KEYS)


def test_state_dump_sees_every_kind_of_state():
    s = pipe_session(pes=1)
    s.step(40)
    base = state_dump(s.machine)

    def pe():  # looked up each time: going back installs new objects
        return s.machine.pes[0]

    edits = [
        lambda: pe().cores["ic"].regs.__setitem__(5, 1),
        lambda: pe().memories["os"].local.words.__setitem__(100, 1),
        lambda: pe().memories["ic"].cache.tags.__setitem__(3, 7),
        lambda: pe().ring.send["os"].q.append((99, 1)),
        lambda: setattr(s.machine, "cycle", 41),
        lambda: pe().cores["sc"].pending.setdefault(99, []).append((3, 3)),
    ]
    for edit in edits:
        s.goto_cycle(40)
        assert state_dump(s.machine) == base
        edit()
        assert state_dump(s.machine) != base


def test_reverse_step_returns_exactly_to_the_earlier_state():
    # small checkpoint interval and capacity: stepping back crosses checkpoints, replays, and
    # the interval doubles while the run goes on
    s = pipe_session(pes=2, checkpoint_interval=8, max_checkpoints=3)
    rng = random.Random(7)
    seen = {0: state_dump(s.machine)}
    while not s.ended:
        n = rng.randint(1, 11)
        before = state_dump(s.machine)
        at = s.machine.cycle
        s.step(n)
        moved = s.machine.cycle - at
        seen[s.machine.cycle] = state_dump(s.machine)
        if s.ended:
            break
        s.reverse_step(moved)
        assert s.machine.cycle == at
        diff = dump_differences(state_dump(s.machine), before)
        assert not diff, diff
        s.step(moved)
        assert state_dump(s.machine) == seen[s.machine.cycle]
    assert s.interval > 8  # thinned
    assert len([c for c in s.checkpoints.values() if not c.pinned]) <= 3
    # every recorded state, revisited in reverse order, from the end of the run
    for c in sorted(seen, reverse=True):
        s.goto_cycle(c)
        assert state_dump(s.machine) == seen[c], c


def test_replay_matches_a_fresh_machine():
    s = pipe_session(pes=2, checkpoint_interval=16)
    s.step(45)
    s.reverse_step(13)
    m = s.factory.build()
    m.record_events(True)
    for _ in range(32):
        m.step()
        for core in m.cores:
            core.events.clear()
    assert state_dump(m) == state_dump(s.machine)


def test_reverse_step_is_exact_while_the_deadlock_detector_counts():
    # OS floods the ring and nobody receives: after the FIFOs fill, cycles without progress
    # are counted (machine.no_progress) until the deadlock report
    src = ".proc os\nloop: send ring, r1\n j loop\n"
    factory = ProgramsFactory(load_config(None, ["ring.deadlock_cycles=300"]),
                              {"os": assemble_text(src)})
    s = Session(factory, checkpoint_interval=64)
    s.step(500)
    assert s.machine.no_progress[0] > 0
    before = state_dump(s.machine)
    s.step(77)
    assert s.machine.no_progress[0] > 77
    s.reverse_step(77)
    assert state_dump(s.machine) == before
    s.cont()
    assert s.machine.status == "deadlock"
    end = state_dump(s.machine)
    s.reverse_step(200)
    s.cont()
    assert state_dump(s.machine) == end


def test_reverse_continue_returns_to_the_previous_breakpoint_exactly():
    s = loop_session(checkpoint_interval=4)
    s.add_breakpoint("loop")
    states = []
    for _ in range(3):  # hits in c2, c6, c10
        stop = s.cont()
        states.append((s.machine.cycle, state_dump(s.machine)))
        assert stop.hits
    stop = s.reverse_continue()
    assert "in cycle 6" in stop.messages[0]
    assert (s.machine.cycle, state_dump(s.machine)) == states[1]
    stop = s.reverse_continue()
    assert (s.machine.cycle, state_dump(s.machine)) == states[0]
    stop = s.reverse_continue()
    assert s.machine.cycle == 0 and "back at cycle 0" in stop.messages[0]
    assert s.breakpoints[1].hits == 3  # replays do not count hits


def test_reverse_continue_finds_a_watchpoint_and_reverse_stepi():
    s = loop_session(checkpoint_interval=4)
    s.add_watchpoint("local[counter]")
    s.cont()
    s.cont()  # st in c3, c7
    assert s.machine.cycle == 8
    s.delete()
    s.cont()  # to the end
    s.add_watchpoint("local[counter]")
    stop = s.reverse_continue()  # the last store: c11
    assert s.machine.cycle == 12 and "1 -> 0 in cycle 11" in stop.messages[0]
    s.reverse_stepi(2)  # back over st (c11) and loop (c10): after bnez in c8
    assert s.machine.cycle == 9 and s.core.last_pc == 4


def test_an_edit_is_part_of_history():
    s = loop_session(checkpoint_interval=4)
    s.step(2)  # r9 = 3 written at the start of c1
    assert s.machine.pes[0].cores["ic"].regs[9] == 3
    s.set_place(s.context().place("r9"), 1)
    after_edit = state_dump(s.machine)
    s.cont()
    assert s.machine.cycle == 7  # one iteration only
    end = state_dump(s.machine)
    s.goto_cycle(2)
    assert state_dump(s.machine) == after_edit
    s.reverse_step(1)  # before the edit
    assert s.machine.pes[0].cores["ic"].regs[9] == 0
    s.step(1)  # stepping forward over the edit re-applies it
    assert state_dump(s.machine) == after_edit
    s.reverse_step(2)
    s.cont()
    assert state_dump(s.machine) == end


# ---------------------------------------------------------------------------------------------
# --fast-forward: the compiled engine runs there, the session steps the reference engine on


@pytest.fixture
def compiled():
    from netsushisen.emulator.engine import engine_names

    assert "compiled" in engine_names(), "the compiled engine does not import (numba is a dependency)"


def pipe_args(files):
    return ["--os", files / "os.s", "--ic", files / "ic.s", "--sc", files / "sc.s",
            "--image", files / "image.json", "--pes", "2"]


def digests(out: str) -> list[str]:
    return [line.split(": ")[1] for line in lines_with(out, "state digest after")]


def test_fast_forward_to_a_cycle_is_the_state_stepping_reaches(debug, files, compiled):
    shown = ["info state", "print pc", "print f:r6", "info registers", "info scoreboard",
             "info fifo", "cycle 9", "info state", "print r2"]
    code, ff = debug(shown, *pipe_args(files), "--proc", "ic", "--fast-forward", "40")
    assert code == 0 and "fast-forward: cycle 40 reached with the compiled engine" in ff
    code, ref = debug(["cycle 40", *shown], *pipe_args(files), "--proc", "ic")
    assert code == 0
    assert digests(ff) == digests(ref) and len(digests(ff)) == 2
    assert "state digest after 40 cycles" in ff and "state digest after 49 cycles" in ff

    def answers(out):  # what the commands print, without the `*` marks of the first stop
        out = out[out.index("(nss) info state"):]
        return [line.replace("*", " ") for line in out.splitlines()]

    assert answers(ff) == answers(ref)
    # the whole canonical state, at the hand-off and after stepping on (a breakpoint on the way)
    programs = {s: assemble_text(src, proc=s) for s, src in
                (("os", OS_PIPE), ("ic", IC_PIPE), ("sc", SC_PIPE))}
    factory = ProgramsFactory(load_config(None, ["pes=2"]), programs,
                              image_from_json(pipe_image()))
    for n in (1, 33, 61):
        fast = Session(factory, fast_forward=str(n), checkpoint_interval=8)
        slow = pipe_session(pes=2, checkpoint_interval=8)
        slow.step(n)
        assert fast.machine.cycle == n and fast.origin == n
        diff = dump_differences(state_dump(fast.machine), state_dump(slow.machine))
        assert not diff, diff
        for s in (fast, slow):
            s.add_breakpoint("ic.loop+9")
            s.cont()
        assert fast.machine.cycle == slow.machine.cycle
        assert state_dump(fast.machine) == state_dump(slow.machine)


def test_fast_forward_in_scene_mode(cli, files, compiled):
    # the scene's machine (RenderSetup.engine("compiled")) with the small kernels of
    # test_scene_mode: the same state as the reference engine stepped there
    script = files / "scene.txt"
    scene = ["tetra:1", "--res", "2", "--os", files / "os.s", "--ic", files / "ic.s", "--sc",
             files / "sc.s", "--batch", script, "--no-screen"]
    script.write_text("info state\nstep 7\ninfo state\n")
    code, ff, err = cli("debug", *scene, "--fast-forward", "33")
    assert code == 0, err
    script.write_text("cycle 33\ninfo state\nstep 7\ninfo state\n")
    code, ref, err = cli("debug", *scene)
    assert code == 0, err
    assert digests(ff) == digests(ref) and len(digests(ff)) == 2


def test_fast_forward_to_a_label_stops_with_the_pc_at_it(debug, files, compiled):
    code, out = debug(["screen", "print pc", "print cycle", "stepi", "print pc"],
                      *pipe_args(files), "--fast-forward", "ic:loop+5", screen=True)
    assert code == 0
    assert "fast-forward: pe0.ic pc 5 (loop+5) reached after " in out
    assert "viewing pe0.ic" in out  # the processor fast-forwarded is the one viewed
    assert listing_rows(out, "->")[0][1] == "5"  # the next bundle: the label's
    assert "pc = 5 (loop+5)" in out and "pc = 6 (loop+6)" in out
    assert "*IC  issued pc 5 (loop+5)" in out  # stepi issues it
    # the same place as stepping the reference engine gets to: PC first at loop+5
    at = int(out.split("cycle = ")[1].split()[0])
    assert f"reached after {at} cycles" in out
    s = pipe_session(pes=2, pe=0, stage="ic")
    s.until("loop+4")
    while s.core.pc != 5:
        s.step()
    assert s.machine.cycle == at
    ff = Session(s.factory, fast_forward="pe0.ic.loop+5")
    assert state_dump(ff.machine) == state_dump(s.machine)
    # unqualified: the processor of --pe/--proc; `*ADDRESS`; another PE; PROC.LABEL
    code, out = debug(["print pc"], *pipe_args(files), "--pe", "1", "--proc", "sc",
                      "--fast-forward", "*4")
    assert code == 0 and "pe1.sc pc 4 (loop+2) reached" in out and "pc = 4 (loop+2)" in out
    code, out = debug(["print pc"], *pipe_args(files), "--fast-forward", "pe1.ic.loop")
    assert code == 0 and "viewing pe1.ic" in out and "pc = 0 (loop)" in out
    # every program starts at 0: a label there is reached when the processor comes back to it
    cycle = int(out.split("reached after ")[1].split()[0])
    assert cycle > 10 and "(nss) print pc" in out


def test_reverse_execution_stops_at_the_fast_forward_point(debug, files, compiled):
    code, out = debug(["info state", "reverse-cycle", "cycle 30", "info state", "reverse-cycle 10",
                       "cycle 10", "info state", "reverse-cycle 100", "info state", "break loop+9",
                       "continue", "continue", "reverse-continue", "reverse-continue",
                       "reverse-continue", "print cycle", "cycle 5", "restart", "info state",
                       "info checkpoints"],
                      *pipe_args(files), "--proc", "ic", "--fast-forward", "40",
                      "--checkpoint-interval", "8")
    assert code == 0
    d = digests(out)
    assert d[0] == d[3] == d[4] and d[1] == d[2] and d[0] != d[1]
    assert ("no more reverse-execution history: it starts at cycle 40, where --fast-forward "
            "handed the machine over") in out
    assert "no more reverse-execution history: back at cycle 40" in out
    assert ("no more reverse-execution history: no breakpoint or watchpoint fired since cycle "
            "40") in out
    assert "restarted: cycle 40, where --fast-forward handed over" in out
    assert "pinned by edits or the start: 40 (the history starts at cycle 40" in out
    # in the session: going back lands exactly on the hand-off state
    s = loop_session(fast_forward="5", checkpoint_interval=4)
    handoff = state_dump(s.machine)
    s.step(6)
    stop = s.reverse_step(8)
    assert s.machine.cycle == 5 and state_dump(s.machine) == handoff
    assert "no more reverse-execution history" in stop.messages[0]
    stop = s.reverse_stepi()
    assert "it starts at cycle 5" in stop.messages[0] and s.machine.cycle == 5


def test_fast_forward_errors_and_a_run_that_ends_first(debug, cli, files, compiled):
    for target, message in (("nope", "error: --fast-forward nope: unknown name 'nope'"),
                            ("ic:nope", "error: --fast-forward ic:nope: unknown name 'nope'"),
                            ("os:loop", "OS has no program"),
                            ("pe3.ic:loop", "no PE 3 (the machine has 1)"),
                            ("-5", "a cycle is at least 0")):
        code, out, err = cli("debug", "--program", files / "loop.s", "--fast-forward", target,
                             "--batch", "-")
        assert code == 1 and message in err, (target, err)
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    # the run ends (halts after 15 cycles) first: a note, and the session starts at the end
    code, out = debug(["info state", "cycle", "reverse-cycle"], "--program", files / "loop.s",
                      "--fast-forward", "1000")
    assert code == 0
    assert ("fast-forward: the run ended at cycle 15 (halted) before reaching cycle 1000: the "
            "session starts at the end of the run") in out
    assert "state digest after 15 cycles" in out and "nothing more to run" in out
    code, out = debug(["info state"], "--program", files / "loop.s", "--max-cycles", "10",
                      "--fast-forward", "done")
    assert code == 0 and "ended at cycle 10 (max_cycles) before reaching pe0.ic pc 5 (done)" in out


# ---------------------------------------------------------------------------------------------
# A real terminal (tmux)


@pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed "
                    "(apt-get install tmux); the batch tests cover the commands")
@pytest.mark.parametrize("size", ["80x24", "120x40", "200x60"])
def test_interactive_session_in_tmux(tmp_path, size):
    out = tmp_path / "screen.txt"
    # the interpreter running the tests, not whatever `python3`/`netsushisen` PATH finds first
    env = dict(os.environ, NETSUSHISEN_DEBUG_HISTORY="", DRIVE_QUICK="1", PYTHON=sys.executable,
               DRIVE_SIZE=size)
    r = subprocess.run(["bash", str(PROJECT / "tools" / "drive_debugger.sh"), str(out)],
                       capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    screens = out.read_text().split("===== ")
    stop = [s for s in screens if s.startswith("(nss) continue")][0]
    width, height = (int(n) for n in size.split("x"))
    lines = stop.rstrip("\n").splitlines()[1:]
    assert len(lines) <= height and max(len(line) for line in lines) <= width
    assert "netsushisen debug" in stop and "listing pe0.ic" in stop
    assert "breakpoint 1: pe0.ic issued pc" in stop
    rows = cells_of(stop)
    assert ["=>B1", "5"] in [r[:2] for r in rows]  # the PC marker with the breakpoint's
    assert [r for r in rows if r[:2] == ["addr", "label"]][0][2:6] == SLOTS["ic"]
    assert "registers pe0.ic" in stop
    assert ("fifos pe0" in stop) == (height >= 30)  # 80x24: listing and registers only
    # the register names, the current bundle's operands whole, and the command line
    assert "*shape/r4" in stop and "fadd sum/r6, shape/r4, r5" in stop
    assert "fmul r9, shape/r4, r8" in stop and lines[-1].startswith("(nss)")
    paged = [s for s in screens if s.startswith("(nss) help all")]
    assert bool(paged) == (height < 45)  # help all is paged where it does not fit
    if paged:
        assert "--Type <RET> for more, q to quit, c to continue without paging--" in paged[0]


# ---------------------------------------------------------------------------------------------
# The screen at ordinary terminal sizes (rich's recording console stands in for the terminal)

SLOTS = {"os": ["int0", "int1", "fp0", "fp1"], "ic": ["int0", "fp0", "fp1", "fp2"],
         "sc": ["gen0"]}


def capture(session, width: int, height: int, commands: list[str] = ()) -> tuple[str, object]:
    """Run commands in an interactive front end on a `width` x `height` terminal; the last
    screen as the terminal shows it (text), and the front end."""
    from rich.console import Console

    from netsushisen.debugger.frontend import FrontEnd

    console = Console(record=True, width=width, height=height, file=io.StringIO(),
                      force_terminal=True)
    front = FrontEnd(session, console, interactive=True)
    for c in commands:
        front.execute(c)
    console.export_text(clear=True)
    front.draw()
    return console.export_text(), front


def cells_of(screen: str) -> list[list[str]]:
    return [line.replace("│", " ").split() for line in screen.splitlines()]


@pytest.mark.parametrize("width,height", [(80, 24), (120, 40), (150, 50)])
@pytest.mark.parametrize("stage", ["os", "ic", "sc"])
def test_the_screen_fits_the_terminal_with_markers_and_every_slot(width, height, stage):
    from netsushisen.debugger.layout import RESERVED

    s = pipe_session(pes=1, stage=stage)
    first, second = s.machine.programs[stage].labels["loop"][1] + 3, None
    second = first + 1
    screen, _ = capture(s, width, height, ["break loop+3", "break loop+4", "continue"])
    lines = screen.rstrip("\n").split("\n")
    # one stop fits one screen: the room below is left for the stop's messages and the prompt
    assert len(lines) <= height - RESERVED, len(lines)
    assert max(len(line) for line in lines) <= width
    rows = cells_of(screen)
    head = [r for r in rows if r[:2] == ["addr", "label"]]
    n = len(SLOTS[stage])  # every slot column of the viewed processor
    assert head and head[0][2:2 + n] == SLOTS[stage] and "…" not in head[0][2 + n:3 + n]
    # the PC marker with the breakpoint it stopped at, the other breakpoint's marker, and the
    # address and label columns whole
    assert ["=>B1", str(first)] in [r[:2] for r in rows]
    assert ["->B2", str(second)] in [r[:2] for r in rows]  # the next bundle, with B2
    labels = s.machine.programs[stage].code_labels()
    shown = 0
    for r in rows:  # listing rows: [marker] address [label] slots...
        k = 0 if r and r[0].isdigit() else 1
        if len(r) > k + 1 and r[k].isdigit() and int(r[k]) in labels:
            assert r[k + 1] == labels[int(r[k])]  # the label whole
            shown += 1
    assert shown or height == 24
    assert f"listing pe0.{stage}" in screen and f"registers pe0.{stage}" in screen
    # the panels the size holds: 80x24 listing and registers; larger sizes more
    assert ("fifos pe0" in screen) == (height >= 30)


def test_operands_are_cut_never_the_orienting_columns(tmp_path):
    src = """
.proc ic
a_very_long_label_name_here:
        { st r40, [r33 + 1024] ; fmul r41, r42, r43 ; fadd r44, r42, r43 ; fsub r47, r42, r43 }
        halt
"""
    factory = ProgramsFactory(load_config(None, []), {"ic": assemble_text(src)})
    s = Session(factory)
    s.add_breakpoint("0")
    screen, _ = capture(s, 80, 24, ["cycle"])
    assert max(len(line) for line in screen.splitlines()) <= 80
    rows = cells_of(screen)
    assert [r for r in rows if r[:2] == ["addr", "label"]][0][2:6] == SLOTS["ic"]
    row = [r for r in rows if r[:3] == ["=>B1", "0", "a_very_long_lab…"]][0]
    text = " ".join(row[3:])
    assert "st r40," in text and "fmul" in text and "fadd" in text and "fsub" in text
    assert "…" in text  # the operands give way
    # the same bundle with the listing alone at 150 columns: nothing cut
    screen, _ = capture(s, 150, 50, ["layout asm"])
    assert "fsub r47, r42, r43" in screen and "st r40, [r33 + 1024]" in screen


def test_layout_chooses_the_panels():
    s = pipe_session(pes=1, stage="ic")
    screen, front = capture(s, 150, 50, ["cycle 5", "layout asm"])
    assert "listing pe0.ic" in screen and "registers" not in screen and "fifos" not in screen
    screen, front = capture(s, 80, 24, ["layout listing fifos"])
    assert "listing pe0.ic" in screen and "fifos pe0" in screen and "registers" not in screen
    screen, front = capture(s, 80, 50, ["layout full"])
    for panel in ("listing", "registers", "scoreboard", "fifos", "memory", "counters"):
        assert panel in screen
    out = front.commands.execute("layout bogus")
    assert out.failed and "no panel 'bogus'" in out.output[0].plain
    out = front.commands.execute("layout")
    assert "layout full" in out.output[0].plain


# ---------------------------------------------------------------------------------------------
# gdb's staples (batch mode). LOOP's source lines: 7 start (pc 0), 8 lf (1), 9 loop (2),
# 10 st (3), 11 bnez (4), 12 done (5), 13 halt (6); st issues in c3, c7, c11 with r9 = 2, 1, 0.


def test_tbreak_stops_once_and_is_deleted(debug, files):
    code, out = debug(["tbreak loop", "info breakpoints", "continue", "info breakpoints",
                       "continue"], "--program", files / "loop.s")
    assert code == 0
    assert "temporary breakpoint 1 at ic pc 2 (loop)" in out
    assert ["1", "breakpoint", "del", "y", "2", "ic", "loop"] in [
        line.split()[:7] for line in out.splitlines()]
    assert "temporary breakpoint 1: pe0.ic issued pc 2 (loop) in cycle 2" in out
    assert "no breakpoints or watchpoints" in out
    assert "run ended at cycle 15: halted" in out  # loop issues again in c6 and c10


def test_disable_and_enable(debug, files):
    code, out = debug(["break loop", "break loop.s:10", "disable 1", "continue", "info break",
                       "enable", "continue", "disable 1-2", "continue"],
                      "--program", files / "loop.s")
    assert code == 0
    stops = lines_with(out, "issued pc")
    assert "breakpoint 2: pe0.ic issued pc 3 (loop+1) in cycle 3" in stops[1]  # 1 disabled
    assert ["1", "breakpoint", "keep", "n", "2"] in [line.split()[:5] for line in out.splitlines()]
    assert "breakpoint 1: pe0.ic issued pc 2 (loop) in cycle 6" in out  # enabled again
    assert "run ended at cycle 15: halted" in out  # both disabled
    code, out = debug(["disable 7"], "--program", files / "loop.s")
    assert code == 1 and "error: no breakpoint or watchpoint 7" in out


def test_condition_and_removing_it(debug, files):
    code, out = debug(["break loop.s:10", "condition 1 r9 == 1", "continue", "condition 1",
                       "continue", "condition 1 nosuch", "condition 4 r1"],
                      "--program", files / "loop.s")
    assert "breakpoint 1: stop only if r9 == 1" in out
    assert "breakpoint 1: pe0.ic issued pc 3 (loop+1) in cycle 7 [r9 == 1]" in out
    assert "in cycle 3" not in out
    assert "breakpoint 1 now unconditional" in out
    assert "breakpoint 1: pe0.ic issued pc 3 (loop+1) in cycle 11" in out
    assert "error: unknown name 'nosuch'" in out and "error: no breakpoint or watchpoint 4" in out
    assert code == 1


def test_ignore_and_continue_n(debug, files):
    code, out = debug(["break loop", "ignore 1 2", "continue", "info breakpoints"],
                      "--program", files / "loop.s")
    assert "will ignore next 2 crossings of breakpoint 1" in out
    assert "breakpoint 1: pe0.ic issued pc 2 (loop) in cycle 10" in out  # c2, c6 let pass
    assert "breakpoint already hit 3 times" in out  # ignored crossings count as hits
    assert "in cycle 2" not in out and "in cycle 6" not in out
    code, out = debug(["break loop", "continue", "continue 2", "ignore 1 0"],
                      "--program", files / "loop.s")
    assert "in cycle 2" in out and "in cycle 6" not in out
    assert "will ignore next 1 crossings of breakpoint 1" in out
    assert "breakpoint 1: pe0.ic issued pc 2 (loop) in cycle 10" in out
    assert "will stop next time breakpoint 1 is reached" in out
    code, out = debug(["continue 3"], "--program", files / "loop.s")  # gdb: a note, and on
    assert "not stopped at any breakpoint; argument ignored" in out and "halted" in out


def test_display_at_every_stop(debug, files):
    code, out = debug(["display r9", "display/x local[counter]", "break loop.s:10", "continue",
                       "continue", "undisplay 1", "continue", "info display", "undisplay",
                       "info display", "display nosuch"],
                      "--program", files / "loop.s")
    assert "1: r9 = 0  (0x00000000" in out  # shown when made
    after = out[out.index("(nss) continue"):]
    assert "1: r9 = 2  (" in after and "2: local[0] = 0x00000002" in after  # c3
    assert "1: r9 = 1  (" in after and "2: local[0] = 0x00000001" in after  # c7
    last = out[out.index("(nss) undisplay 1"):]
    assert "2: local[0] = 0x00000000" in last and "1: r9 =" not in last  # c11
    assert "Auto-display expressions now in effect:" in out
    assert ["2:", "y", "/x", "local[counter]"] in [line.split() for line in out.splitlines()]
    assert "there are no auto-display expressions now" in out
    assert "error: unknown name 'nosuch'" in out


def test_list_around_the_pc_a_label_and_a_line(debug, files):
    code, out = debug(["list", "list", "list loop.s:12", "list nowhere.s:3", "break done",
                       "cycle 3", "list", "list done"], "--program", files / "loop.s")
    blocks = out.split("(nss) ")

    def shown(block):  # (line number, mark or '') per listed line
        rows = []
        for line in block.splitlines()[1:]:
            m = __import__("re").match(r"^\s*(\d+) (\S*)\s", line + " ")
            if m:
                rows.append((int(m.group(1)), line[6:12].strip()))
        return rows

    first = shown(blocks[1])
    assert [n for n, _ in first] == list(range(2, 12))  # around the PC (line 7), 10 lines
    assert dict(first)[7] == "=>"
    assert [n for n, _ in shown(blocks[2])] == [12, 13]  # Enter/list again: the next lines
    assert [n for n, _ in shown(blocks[3])] == list(range(7, 14))  # centred on line 12
    assert "error: no source file 'nowhere.s'" in blocks[4]
    around = dict(shown(blocks[7]))  # after c2: loop (line 9) issued; done has B1
    assert around[9] == "=>" and around[12] == "B1"
    assert [n for n, _ in shown(blocks[8])] == list(range(7, 14))


def test_break_file_line(debug, files):
    code, out = debug(["break loop.s:10", "break loop.s:6", "break loop.s:99", "break other.s:3",
                       "continue", "continue"], "--program", files / "loop.s")
    first = lines_with(out, "breakpoint 1 at")[0]
    assert "at ic pc 3 (loop+1): file " in first and first.endswith("loop.s:10")
    assert "breakpoint 2 at ic pc 0 (start)" in out  # line 6 has no code: the next one's
    assert "no code at or after line 99 (the last line with code is 13)" in out
    assert "error: no source file 'other.s'" in out
    assert "breakpoint 2: pe0.ic issued pc 0 (start) in cycle 0" in out
    assert "breakpoint 1: pe0.ic issued pc 3 (loop+1) in cycle 3" in out
    # ic.s:4 names the file ic.s, not `ic.` + `s:4`; the file picks the processor
    code, out = debug(["break ic.s:4", "break os.s:5", "break sc.s:10", "break ic:loop+2",
                       "break *4"], *pipe_args(files))
    assert code == 0
    assert "breakpoint 1 at ic pc 1 (loop+1)" in out
    assert "breakpoint 2 at os pc 2 (loop+2)" in out
    assert "breakpoint 3 at sc pc 7 (loop+5)" in out
    assert "breakpoint 4 at ic pc 2 (loop+2)" in out  # --fast-forward's PROC:LOCATION too
    assert "breakpoint 5 at os pc 4 (loop+4)" in out  # gdb's *ADDRESS


def test_info_breakpoints_is_gdbs_table(debug, files):
    code, out = debug(["break loop if r9 < 3", "tbreak done", "watch r9", "rwatch local[2]",
                       "awatch local[counter]", "disable 3", "continue", "continue",
                       "info breakpoints"], "--program", files / "loop.s")
    table = out[out.rindex("(nss) info breakpoints"):].splitlines()[1:]
    assert table[0].split() == ["Num", "Type", "Disp", "Enb", "Address", "What"]
    rows = [line.split() for line in table]
    assert rows[1][:7] == ["1", "breakpoint", "keep", "y", "2", "ic", "loop"]
    assert rows[1][-1].endswith("loop.s:9")
    assert table[2].strip() == "stop only if r9 < 3"
    assert table[3].strip() == "breakpoint already hit 1 time"  # c2 (r9 = 3) did not hold
    assert rows[4][:5] == ["2", "breakpoint", "del", "y", "5"]
    assert rows[5] == ["3", "watchpoint", "keep", "n", "pe0.ic.r9"]
    assert rows[6] == ["4", "read", "watchpoint", "keep", "y", "pe0.ic.local[2]"]
    assert rows[7] == ["5", "acc", "watchpoint", "keep", "y", "pe0.ic.local[0]"]
    assert table[8].strip() == "breakpoint already hit 1 time"  # st in c3


def test_read_and_access_watchpoints(debug, files):
    code, out = debug(["rwatch local[table + 1]", "awatch local[counter]", "continue",
                       "continue", "continue", "continue", "continue"],
                      "--program", files / "loop.s")
    assert code == 0
    assert "read watchpoint 1 on pe0.ic.local[2] (now 1075838976 (2.5))" in out
    for c, old, new in ((3, 0, 2), (7, 2, 1), (11, 1, 0)):  # the stores (awatch: writes)
        assert (f"acc watchpoint 2: pe0.ic.local[0]: {old} -> {new} in cycle {c} "
                "(st at pc 3 (loop+1))") in out
    assert ("read watchpoint 1: pe0.ic.local[2]: read 1075838976 (2.5) in cycle 13 "
            "(ld at pe0.ic pc 5 (done))") in out
    assert "run ended at cycle 15: halted" in out
    assert "local[0]: read" not in out  # nothing reads counter
    # global memory: a read by any PE, with the cache's verdict
    (files / "ldg.s").write_text(".proc ic\n ldg r1, [5]\n ldg r2, [5]\n ldg r3, [70]\n halt\n")
    (files / "g.json").write_text(json.dumps({"icgm": [float(i) for i in range(128)]}))
    code, out = debug(["rwatch icgm[5]", "continue", "continue", "continue", "rwatch r5",
                       "watch icgm[5]", "awatch pc"],
                      "--program", files / "ldg.s", "--image", files / "g.json", "--pes", "2")
    hits = lines_with(out, "read watchpoint 1: icgm[5]: read 1084227584 (5.0)")
    assert len(hits) == 2
    assert ("ldg at pe0.ic pc 0 (0), cache miss; ldg at pe1.ic pc 0 (0), cache miss"
            in hits[0])
    assert "ldg at pe0.ic pc 1 (1), cache hit; ldg at pe1.ic pc 1 (1), cache hit" in hits[1]
    assert "run ended" in out  # icgm[70] is not watched
    assert "error: rwatch takes a memory word" in out
    assert "read-only during a run: nothing writes it (rwatch icgm[5]" in out
    assert "error: awatch takes a memory word" in out


FINISH = """
.proc sc
        li r1, 1
        call sub          # pc 1
        li r3, 3          # pc 2: sub returns here
        halt
sub:    addi r10, lr, 0   # pc 4: keep the return address
        call leaf         # pc 5
        addi lr, r10, 0   # pc 6: leaf returns here
        ret               # pc 7
leaf:   addi r4, r1, 1    # pc 8
        ret               # pc 9
"""


def test_finish_runs_to_the_return_of_the_current_routine(debug, files):
    (files / "finish.s").write_text(FINISH)
    code, out = debug(["finish", "break leaf", "continue", "finish", "finish", "print r3",
                       "stepi", "print r3"], "--program", files / "finish.s")
    assert "error: \"finish\" not meaningful in the outermost frame" in out
    assert "run till exit from pc leaf" in out
    assert "returned: ret at pc 9 (leaf+1)" in out and "back to pc 6 (sub+2)" in out
    assert "returned: ret at pc 7 (sub+3)" in out and "back to pc 2 (sub-2)" not in out
    assert "back to pc 2 (1)" in out or "back to pc 2 (2)" in out
    # inside sub, before its call: finish runs over leaf's return to sub's own
    code, out = debug(["break sub", "continue", "finish"], "--program", files / "finish.s")
    assert "run till exit from pc sub" in out
    assert "returned: ret at pc 7 (sub+3)" in out and "ret at pc 9" not in out


def test_finish_continue_n_tbreak_display_after_the_fast_forward_hand_off(debug, files, compiled):
    """The staples after `--fast-forward` (the compiled engine's hand-off) answer as after
    stepping the reference engine there."""
    (files / "finish.s").write_text(FINISH)
    script = ["tbreak leaf", "display r4", "rwatch local[0]", "continue", "finish",
              "info breakpoints", "continue"]
    code, ff = debug(script, "--program", files / "finish.s", "--fast-forward", "3")
    code2, ref = debug(["cycle 3", *script], "--program", files / "finish.s")
    assert code == code2 == 0

    def answers(out):
        return out[out.index("(nss) tbreak"):]

    assert answers(ff) == answers(ref)
    assert "temporary breakpoint 1: pe0.sc issued pc 8 (leaf)" in ff


def test_branch_targets_print_as_labels(debug, files):
    from netsushisen.asm.disasm import disassemble
    from netsushisen.asm.listing import listing

    src = """
.proc os
        li r1, 3
        j 2
top:    addi r1, r1, -1
        addi r2, r2, 1
        bnez r1, top + 1
        beqz r1, 1
        halt
"""
    program = assemble_text(src)
    text = disassemble(program)
    assert "bnez r1, top+1" in text  # no label at 3: the nearest one before it, plus 1
    assert "beqz r1, 1" in text and "j top" in text  # before the first label: a number
    assert assemble_text(text).same_program(program)
    assert "bnez r1, top+1" in listing(program)
    (files / "targets.s").write_text(src)
    code, out = debug(["disassemble 0", "cycle 4"], "--program", files / "targets.s")
    assert "bnez r1, top+1" in out and "j top" in out
    assert "[cycle 3] pe0.os issued pc 2 (top): addi r1, r1, -1" in out  # j c1, stall c2


def test_small_fixes_info_stats_help_and_x0(debug, files):
    code, out = debug(["info stats", "cycle 3", "info stats", "help reverse-continue",
                       "x/0 local 0", "x/0 local 99999"], "--program", files / "loop.s")
    assert "status None" not in out
    assert "running, 0 cycles run, 1 PE" in out and "running, 3 cycles run, 1 PE" in out
    assert "pe0.ic memory:" in out
    help_text = out[out.index("(nss) help reverse-continue"):out.index("(nss) x/0")]
    assert help_text.count("rc") == 1 and "aliases: rc" in help_text
    assert "x/0: a count of 0 words shows nothing" in out
    assert "error: local[99999]: address outside local" in out
    code, out = debug(["continue", "info stats"], "--program", files / "loop.s")
    assert "ended: halted, 15 cycles run" in out


def test_tab_completion_by_context():
    from netsushisen.debugger.frontend import completions

    s = loop_session()
    s.add_breakpoint("loop")

    def complete(line: str) -> list[str]:  # readline's words: split at spaces, '-' and '['
        begidx = max(line.rfind(c) for c in " -[") + 1
        return completions(s, line, begidx, line[begidx:])

    assert "break" in complete("") and "reverse-step" in complete("")
    assert complete("reverse-") == ["continue", "cycle", "step", "stepi"]  # only the four
    assert complete("rev") == ["reverse-continue", "reverse-cycle", "reverse-step",
                               "reverse-stepi"]
    mem = complete("x/4 ")
    assert {"local", "icgm", "resident", "scgm", "table", "counter"} <= set(mem)
    assert "r1" not in mem and "loop" not in mem
    assert complete("break ") == ["done", "ic.", "loop", "start"]
    assert complete("info b") == ["breakpoints"]
    assert complete("disable ") == ["1"]
    assert "r9" in complete("print r") and "lr" not in complete("print r")
    assert complete("layout f") == ["fifos", "full"]


def test_program_without_proc_gets_advice_that_works(cli, files):
    (files / "noproc.s").write_text("        li r1, 1\n        halt\n")
    code, out, err = cli("debug", "--program", files / "noproc.s", "--proc", "os", "--batch", "-")
    assert code == 1 and "Traceback" not in err
    assert "give --proc" not in err
    assert "write `.proc os|ic|sc` before the first instruction" in err
    assert "give the file as --os/--ic/--sc FILE" in err
    (files / "c.txt").write_text("continue\n")
    code, out, err = cli("debug", "--os", files / "noproc.s", "--batch", files / "c.txt",
                         "--no-screen")
    assert code == 0 and "run ended at cycle 2: halted" in out
