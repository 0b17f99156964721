"""The debugger as a kernel writer uses it: `.reg` names everywhere a register shows or is
taken (listing, print, display, watch, info registers, conditions, trace, timeline), scoped as
the assembler scopes them, carried by the object file (`disasm --names`, `--listing`); a usable
80x24 screen (the current bundle whole, the help index, gdb's pager, line mode below).

NAMED's timing (docs/timing.md): li c0, lf c1, loop c2/c6/c10 (taken bnez: a branch stall),
st c3/c7/c11, bnez c4/c8/c12, done c13, halt c14. `acc` is r2 up to `done` and r3 from there.
"""

from __future__ import annotations

import re

import json

import pytest
from rich.text import Text

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.disasm import disassemble
from netsushisen.asm.listing import listing
from netsushisen.asm.objects import Program
from netsushisen.asm.regnames import register_names

NAMED = """
.proc ic
.data
counter: .word 0
.text
.reg cnt = r9
.reg acc = r2
start:  li cnt, 3
        lf r1, 1.5
loop:   { addi cnt, cnt, -1 ; fadd acc, acc, r1 }
        st cnt, [counter]
        bnez cnt, loop
.unreg acc             # ended, then bound again: acc is r3 from here
.reg acc = r3
done:   { ld acc, [counter] ; fmul r4, r1, r1 }
        halt
"""


@pytest.fixture
def named(tmp_path):
    (tmp_path / "named.s").write_text(NAMED)
    return tmp_path / "named.s"


@pytest.fixture
def debug(cli, tmp_path):
    def run(commands: list[str], *args, screen: bool = False):
        script = tmp_path / "commands.txt"
        script.write_text("\n".join(commands) + "\n")
        extra = [] if screen else ["--no-screen"]
        code, out, err = cli("debug", *[str(a) for a in args], "--batch", str(script), *extra)
        assert "Traceback" not in out + err
        return code, out

    return run


# ---------------------------------------------------------------------------------------------
# The assembler's name table


def test_a_redefined_reg_name_means_its_latest_register_before_each_bundle():
    p = assemble_text(NAMED)
    assert p.bundles[2][1].args[0] == 2  # fadd acc: r2 before the redefinition
    assert p.bundles[5][0].args[0] == 3  # ld acc: r3 after it
    scopes = [(r.name, r.reg, r.start, r.end) for r in p.reg_names]
    assert scopes == [("cnt", 9, 0, 7), ("acc", 2, 0, 5), ("acc", 3, 5, 7)]
    names = register_names(p)
    assert names.register("acc", 4) == 2 and names.register("acc", 5) == 3
    assert names.label(2, 1) == "acc/r2" and names.label(2, 5) == "r2"
    assert names.label(3, 6) == "acc/r3"


def test_several_names_of_one_register_show_the_one_the_source_used():
    p = assemble_text("""
.proc sc
.reg a = r5
.reg b = r5
        li a, 1
        addi b, b, 1
        li r6, 2
        halt
""")
    names = register_names(p)
    assert names.names(0)[5] == "a"  # the bundle's own line says a
    assert names.names(1)[5] == "b"
    assert names.names(2)[5] == "b"  # the nearest line before that names r5


def test_the_object_file_carries_the_names_and_loads_without_them(tmp_path):
    p = assemble_text(NAMED)
    p.save(tmp_path / "n.o")
    q = Program.load(tmp_path / "n.o")
    assert q.reg_names == p.reg_names and q.same_program(p)
    obj = json.loads((tmp_path / "n.o").read_text())
    assert obj["version"] == 1 and "reg_names" in obj
    del obj["reg_names"]  # an object file from before the name table
    (tmp_path / "old.o").write_text(json.dumps(obj))
    old = Program.load(tmp_path / "old.o")
    assert old.reg_names == [] and old.same_program(p)
    assert "r2" in disassemble(old, names=True)


def test_disasm_names_reassembles_identically_and_listing_shows_names(cli, tmp_path):
    p = assemble_text(NAMED)
    text = disassemble(p, names=True)
    assert ".reg acc = r3" in text and "fadd acc, acc, r1" in text and "ld acc, [0]" in text
    again = assemble_text(text)
    assert again.same_program(p) and again.reg_names == p.reg_names
    assert "fadd r2, r2, r1" in disassemble(p)  # without --names: registers as themselves
    p.save(tmp_path / "n.o")
    code, out, _ = cli("disasm", "--names", tmp_path / "n.o")
    assert code == 0 and out == text
    rows = listing(p).splitlines()
    assert any("fadd acc/r2, acc/r2, r1" in r for r in rows)
    assert any("ld acc/r3, [0]" in r for r in rows)
    assert ";   acc = r3  5..6" in rows


def test_the_kernels_disassemble_with_names_to_themselves():
    from netsushisen.asm.assembler import assemble_file
    from netsushisen.pipeline import KERNELS

    p = assemble_file(KERNELS / "sc.s", proc="sc", defines=_sc_defines(),
                      include_dirs=[KERNELS])
    assert p.reg_names
    again = assemble_text(disassemble(p, names=True), proc="sc")
    assert again.same_program(p)


def _sc_defines() -> dict:
    from netsushisen.isa.config import MachineConfig
    from netsushisen.pipeline import kernel_inputs

    return kernel_inputs("tetra", MachineConfig(), res=2).defines


# ---------------------------------------------------------------------------------------------
# The debugger


def test_print_display_watch_info_registers_and_conditions_take_names(debug, named):
    code, out = debug(["print acc", "display cnt", "watch cnt", "continue",
                       "info registers cnt acc", "print f:acc", "print cnt * 2 + 1",
                       "delete", "break loop if cnt == 1", "continue", "print cnt",
                       "break done", "continue", "print acc", "print r2",
                       "info registers acc"], "--program", named)
    assert code == 0, out
    assert "acc/r2 = 0" in out
    assert "1: cnt/r9 = 0" in out
    assert "watchpoint 1 on pe0.ic.cnt/r9 (now 0)" in out
    assert "watchpoint 1: pe0.ic.cnt/r9: 0 -> 3 in cycle 1 (li at pc 0 (start)" in out
    assert "*cnt/r9     3" in out and " acc/r2     0" in out
    assert "f:acc/r2 = 0.0" in out and "cnt * 2 + 1 = 7" in out
    # loop issues in c2, c6, c10 reading cnt = 3, 2, 1
    assert "breakpoint 2: pe0.ic issued pc 2 (loop) in cycle 10 [cnt == 1]" in out
    after = out.split("(nss) break done")[1]
    assert "acc/r3 = 0" in after  # past the redefinition: acc is r3
    assert "r2 = 1083179008  (0x40900000, float 4.5)" in after  # 3 x 1.5; no name here
    assert "acc/r3" in after.split("(nss) info registers acc")[1]


def test_names_in_the_listing_trace_and_on_an_object_file(debug, cli, named, tmp_path):
    code, out = debug(["break loop", "continue", "trace on", "stepi 2"], "--program", named,
                      "--width", "100", screen=True)
    assert code == 0
    assert "addi cnt/r9, cnt/r9, -1" in out and "fadd acc/r2, acc/r2, r1" in out
    assert "ld acc/r3, [0]" in out
    assert "loop+1               st cnt/r9, [0]" in out.split("(nss) stepi 2")[1]  # the trace
    cli("asm", named, "-o", tmp_path / "named.o")
    code, out = debug(["print cnt", "until done", "print acc"], "--program", tmp_path / "named.o")
    assert code == 0 and "cnt/r9 = 0" in out and "acc/r3 = " in out
    code, out, _ = cli("run", "--ic", tmp_path / "named.o", "--trace")
    assert "addi cnt/r9, cnt/r9, -1 ; fadd acc/r2, acc/r2, r1" in out


def test_names_in_the_timeline(cli, named, tmp_path):
    code, out, err = cli("run", "--ic", named, "--timeline", tmp_path / "t.kanata",
                         "--cycles", "0:10")
    assert code == 0, err
    text = (tmp_path / "t.kanata").read_text()
    assert "fadd acc/r2, acc/r2, r1" in text and "li cnt/r9, 3" in text


def test_an_unknown_name_is_one_line_error_and_the_name_in_force_wins(debug, tmp_path):
    (tmp_path / "amb.s").write_text("""
.proc sc
.reg t = r5
        li t, 1
.unreg t
.reg t = r6
        li t, 2
        halt
""")
    code, out = debug(["print nothere", "set pc = 2", "print t", "stepi", "print t"],
                      "--program", tmp_path / "amb.s")
    assert code == 1
    assert "error: unknown name 'nothere'" in out
    assert "t/r6 = 0" in out  # at pc 2 the second definition is in force


# ---------------------------------------------------------------------------------------------
# 80x24 and smaller


def named_session(source: str = NAMED):
    from netsushisen.debugger.session import ProgramsFactory, Session
    from netsushisen.isa.config import load_config

    return Session(ProgramsFactory(load_config(None, []), {"ic": assemble_text(source)}))


def front_end(session, width: int, height: int, answers: list[str] | None = None):
    """An interactive front end on a `width` x `height` terminal (rich's recording console);
    the pager's questions are answered from `answers` and recorded in `front.asked`."""
    import io

    from rich.console import Console

    from netsushisen.debugger.frontend import FrontEnd

    console = Console(record=True, width=width, height=height, file=io.StringIO(),
                      force_terminal=True, markup=False, highlight=False)
    front = FrontEnd(session, console, interactive=True)
    front.asked = []

    def ask(prompt):
        front.asked.append(prompt)
        return answers.pop(0) if answers else "c"

    front.ask = ask
    return front


def screen_of(front, commands=()) -> str:
    for c in commands:
        front.execute(c)
    front.console.export_text(clear=True)
    front.draw()
    return front.console.export_text()


WIDE = """
.proc ic
.reg total = r10
.reg scale = r11
start:  { lf scale, 0.5 ; li r12, 1 }
loop:   { st total, [r12 + 100] ; fadd total, total, scale ; fmul r13, scale, scale ; fsub r14, total, scale }
        halt
"""


def test_at_80x24_the_current_bundle_shows_whole_when_the_columns_cut_it():
    s = named_session(WIDE)
    full = ("=> 1: st total/r10, [r12 + 100] ; fadd total/r10, total/r10, scale/r11 ; "
            "fmul r13, scale/r11, scale/r11 ; fsub r14, total/r10, scale/r11")
    screen = screen_of(front_end(s, 80, 24), ["break loop", "continue"])
    lines = screen.rstrip("\n").split("\n")
    assert len(lines) <= 20 and max(len(line) for line in lines) <= 80
    assert "…" in screen  # the slot columns cut operands ...
    flat = " ".join(line.strip("│ ") for line in lines)
    assert full in flat  # ... and the bundle follows whole (wrapped)
    assert "*scale/r11 0.5" in screen  # names in the registers panel
    # at 200 columns the row itself holds the whole bundle: no extra line
    screen = screen_of(front_end(s, 200, 60))
    assert "fsub r14, total/r10, scale/r11" in screen and "=> 1: " not in screen


def test_a_terminal_below_the_minimum_gets_line_mode():
    s = named_session()
    screen = screen_of(front_end(s, 60, 15), ["break loop", "continue"])
    assert "listing" not in screen and "╭" not in screen
    assert "[cycle 2] pe0.ic issued pc 2 (loop): addi cnt/r9, cnt/r9, -1" in screen
    assert "<string>:10: loop:   { addi cnt, cnt, -1" in screen  # the source line


def test_help_is_an_index_and_long_output_is_paged_as_gdb_does():
    s = named_session()
    front = front_end(s, 80, 24, answers=["q"])
    front.execute("help")
    out = front.console.file.getvalue()
    index = out[out.index("running:"):]
    assert "breakpoints:" in index and "reverse-step" in index and len(index.splitlines()) < 12
    assert not front.asked  # short: no pager
    front.console.file.truncate(0), front.console.file.seek(0)
    front.execute("help all")
    out = front.console.file.getvalue()
    assert front.asked == [PAGER]  # a page, then q: quit
    assert out.rstrip().endswith("Quit") and "step [N]" in out and "quit " not in out
    assert len(out.splitlines()) == 24  # 23 lines of help, then Quit
    front.console.file.truncate(0), front.console.file.seek(0)
    front.execute("info registers")  # 64 registers in one column at 80 wide; c: the rest
    out = front.console.file.getvalue()
    assert front.asked[1:] == [PAGER] and " lr " in out and "cnt/r9" in out
    assert max(len(Text.from_ansi(line).plain) for line in out.splitlines()) <= 80
    code_front = front_end(s, 200, 60)
    code_front.execute("help all")
    assert not code_front.asked  # it fits a 60-line terminal


PAGER = "--Type <RET> for more, q to quit, c to continue without paging--"


def test_help_all_and_help_command_in_batch(debug, named):
    code, out = debug(["help", "help all", "help info", "info registers cnt"], "--program", named)
    assert code == 0
    assert "running:" in out and "breakpoints:" in out
    assert "break LOCATION [if CONDITION]" in out  # help all: every command
    assert "--Type" not in out  # never paged off a terminal
    assert "cnt/r9" in out and "acc/r2" not in out.split("(nss) info registers cnt")[1]


# ---------------------------------------------------------------------------------------------
# gdb's address forms: watch/rwatch/awatch *ADDR, x/NFU ADDR, x/Ni, info line, info symbol
# (NAMED's lines: 8 start (pc 0), 9 lf (1), 10 loop (2), 11 st (3), 12 bnez (4), 13 the second
# .reg, 14 done (5), 15 halt (6); st writes local[0] in c3, c7, c11; ld reads it in c13)


def test_watch_rwatch_awatch_star_address(debug, named):
    code, out = debug(["watch *0", "rwatch *counter", "awatch *local[0]", "info breakpoints",
                       "continue", "delete 1 3", "continue", "watch *99999999", "rwatch *icgm 0"],
                      "--program", named)
    assert code == 1  # the last two are errors
    assert "watchpoint 1 on pe0.ic.local[0] (now 0)" in out
    assert "read watchpoint 2 on pe0.ic.local[0] (now 0)" in out
    assert "acc watchpoint 3 on pe0.ic.local[0] (now 0)" in out
    assert "watchpoint 1: pe0.ic.local[0]: 0 -> 2 in cycle 3 (st at pc 3 (loop+1))" in out
    assert "acc watchpoint 3: pe0.ic.local[0]: 0 -> 2 in cycle 3" in out
    assert "read watchpoint 2: pe0.ic.local[0]: read 0 in cycle 13 (ld at pe0.ic pc 5 (done))" \
        in out
    assert "error: local[99999999]: address outside local" in out
    assert "error: icgm[0]: icgm is empty (size 0)" in out


def test_x_takes_gdb_forms_and_defaults_to_the_data_memory(debug, named):
    code, out = debug(["until done", "x/2f 0", "x/2dw *0", "x/1x counter", "x/3i pc",
                       "x/2i loop", "x/2b 0"], "--program", named)
    assert "local[0]:           0.0         0.0" in out or "local[0]:" in out
    assert "local[0]:             0             0" in out  # x/2dw *0: the loop left 0 there
    assert "local[0]:    0x00000000" in out
    assert "=> 6 <done+1>:  halt" in out  # x/3i pc: the PC's bundle marked, as gdb does
    assert "(the program ends at 6)" in out
    assert "   2 <loop>:  addi cnt/r9, cnt/r9, -1 ; fadd acc/r2, acc/r2, r1" in out
    assert "   3 <loop+1>:  st cnt/r9, [0]" in out
    assert "error: x/2b: expected x/N followed by a format" in out and code == 1


def test_info_line_and_info_symbol_as_gdb_prints_them(debug, named):
    code, out = debug(["info line", "info line 11", "info line 4", "info line 40",
                       "info line loop", "info line *3", "info line named.s:13",
                       "info symbol 3", "info symbol loop", "info symbol 0", "info symbol 99",
                       "info symbol", "info line nosuch"], "--program", named)
    assert 'Line 8 of "named.s" starts at address 0 <start> and ends at 1 <start+1>.' in out
    assert 'Line 11 of "named.s" starts at address 3 <loop+1> and ends at 4 <loop+2>.' in out
    assert 'Line 4 of "named.s" is at address 0 <start> but contains no code.' in out
    assert 'Line 40 of "named.s" is past the last line with code in IC.' in out
    assert 'Line 10 of "named.s" starts at address 2 <loop> and ends at 3 <loop+1>.' in out
    assert 'Line 11 of "named.s" starts at address 3 <loop+1> and ends at 4 <loop+2>.' in out
    assert 'Line 13 of "named.s" is at address 5 <done> but contains no code.' in out
    assert "loop + 1 in section .text of ic" in out
    assert "loop in section .text of ic" in out
    assert "start in section .text of ic\ncounter in section .data of ic" in out
    assert "No symbol matches 99." in out
    assert "error: info symbol takes an address" in out
    assert "error: unknown name 'nosuch'" in out and code == 1


# ---------------------------------------------------------------------------------------------
# Optimised code: a .sched region puts operations of several source lines in one bundle, in
# the schedule's order. SCHED's lines: 5 lf a (pc 0), 6 lf b (1), 8-10 fadd/fmul/fsub (all in
# bundle 2), 12 fmul r7 (3, scheduled before line 11), 11 fadd r6 (4), 13 st (5), 15 halt (6).

SCHED = """
.proc ic
.reg a = r1
.reg b = r2
start:  lf a, 1.5
        lf b, 2.5
.sched
        fadd r3, a, b
        fmul r4, a, a
        fsub r5, b, a
        fadd r6, r3, r4
        fmul r7, r5, r5
        st r6, [0]
.endsched
done:   halt
"""


@pytest.fixture
def sched(tmp_path):
    (tmp_path / "sched.s").write_text(SCHED)
    p = assemble_text(SCHED)
    assert [len(b) for b in p.bundles] == [1, 1, 3, 1, 1, 1, 1]  # the layout these tests assume
    assert [r.line for r in p.source_map] == [5, 6, 8, 12, 11, 13, 15]
    return tmp_path / "sched.s"


def test_step_moves_by_source_line_and_stepi_by_bundle_in_a_sched_region(debug, sched):
    code, out = debug(["stepi 2", "step", "print pc", "step", "print pc", "step", "print pc",
                       "reverse-step", "print pc", "stepi", "print pc", "next", "print pc",
                       "cycle 2", "print cycle", "reverse-cycle 2", "print cycle",
                       "reverse-step 2", "print pc", "nexti", "print pc"], "--program", sched)
    assert code == 0, out
    pcs = [int(line.split("= ")[1].split()[0]) for line in lines_of(out, "pc = ")]
    # step from bundle 2 (lines 8-10): to 3 (line 12), to 4 (line 11), to 5 (line 13);
    # reverse-step: back to 4; stepi: one bundle, 5; next: to 6 (line 15); cycle 2 ends the
    # run (halt), reverse-cycle 2 goes back to pc 5 (line 13), reverse-step 2 back two lines
    # (11 at pc 4, then 12 at pc 3); nexti: one bundle, 4
    assert pcs == [3, 4, 5, 4, 5, 6, 3, 4]
    cycles = [int(line.split("= ")[1]) for line in lines_of(out, "cycle = ")]
    assert cycles[1] == cycles[0] - 2  # cycle 2, then reverse-cycle 2
    assert "issued pc 2 (start+2): fadd r3, a/r1, b/r2 ; fmul r4, a/r1, a/r1 ; fsub r5" in out


def lines_of(out: str, text: str) -> list[str]:
    return [line for line in out.splitlines() if line.startswith(text)]


def test_info_line_and_break_on_a_line_of_a_sched_region(debug, sched):
    code, out = debug(["info line 9", "info line 11", "info line 12", "info line *2",
                       "break sched.s:11", "break sched.s:9", "continue", "continue",
                       "info breakpoints"], "--program", sched)
    assert code == 0, out
    assert 'Line 9 of "sched.s" starts at address 2 <start+2> and ends at 3 <start+3>.' in out
    assert 'Line 11 of "sched.s" starts at address 4 <start+4> and ends at 5 <start+5>.' in out
    assert 'Line 12 of "sched.s" starts at address 3 <start+3> and ends at 4 <start+4>.' in out
    assert 'Line 8 of "sched.s" starts at address 2 <start+2>' in out  # *2: its first line
    assert "breakpoint 1 at ic pc 4 (start+4): file" in out  # line 11: its bundle, 4
    assert "breakpoint 2 at ic pc 2 (start+2): file" in out  # line 9 sits in bundle 2
    assert out.index("breakpoint 2: pe0.ic issued pc 2") < out.index("breakpoint 1: pe0.ic "
                                                                      "issued pc 4")


def test_the_listing_shows_each_bundles_source_lines(sched):
    s = named_session(SCHED)
    screen = screen_of(front_end(s, 80, 24), ["stepi 3"])
    rows = [line.replace("│", " ").split() for line in screen.splitlines()]
    assert ["addr", "line", "label"] == [r for r in rows if r[:1] == ["addr"]][0][:3]
    assert ["=>", "2", "8-10"] in [r[:3] for r in rows]
    assert ["->", "3", "12"] in [r[:3] for r in rows] and ["4", "11"] in [r[:2] for r in rows]
    assert "<string>:8-10: fadd r3, a, b | fmul r4, a, a | fsub r5, b, a" in screen
    # a program without a scheduled region keeps the plain columns
    screen = screen_of(front_end(named_session(), 80, 24))
    assert "line" not in [r for r in (line.replace("│", " ").split() for line in
                                      screen.splitlines()) if r[:1] == ["addr"]][0]


# ---------------------------------------------------------------------------------------------
# info loop: the loop's static bound (asm/bounds.py) beside the run's cycles per iteration


def test_info_loop_shows_the_bound_beside_the_cycles_per_iteration_so_far(debug, named):
    code, out = debug(["info loop", "break loop", "continue", "continue", "continue",
                       "info loop", "delete", "continue", "info loop loop"], "--program", named)
    assert code == 0, out
    assert "pe0.ic pc 0 <start> is not in a loop" in out
    head = "loop loop (header 2 <loop>, pcs 2-4) of pe0.ic: 3 bundles, 4 ops"
    assert out.count(head) == 2
    assert "bound: 4 cycles per iteration (units-bound;" in out
    # at the third issue of the head (cycle 10): two iterations done, 4 cycles each (issue,
    # st, bnez, the taken branch's stall), the third under way
    assert "this run: 2 complete iterations, 4.00 cycles per iteration (the one under way: " \
        "1 cycle so far)" in out
    # at the end: 3 iterations, the last without the taken branch: (4 + 4 + 3) / 3
    assert "this run: 3 iterations, 3.67 cycles per iteration (3.00 issuing; stalls per " \
        "iteration: branch 0.67)" in out


def test_info_loop_bound_follows_the_configuration(debug, named):
    # a slow fadd makes the loop's recurrence (acc += r1 through fadd) the bound
    code, out = debug(["info loop loop"], "--program", named, "--set", "ic.latency.fadd=9")
    assert code == 0, out
    assert "bound: 9 cycles per iteration (recurrence-bound;" in out


def test_the_bundled_kernels_names_in_a_scene_session_and_from_an_object_file(debug, cli,
                                                                              tmp_path):
    """The issue's acceptance: `print npri`, `display npri`, `watch npri`, `info registers npri`
    on a scene's IC kernel (npri: a list cell's P as cell_loop reads it), the listing showing
    npri/r32 — from source and from an object file."""
    commands = ["break cell_loop", "continue", "print npri", "display npri", "watch npri",
                "info registers npri cell", "stepi", "screen"]
    code, out = debug(commands, "tetra:1", "--res", "3", "--proc", "ic", "--width", "120",
                      screen=True)
    assert code == 0, out
    hit = re.search(r"breakpoint 1: pe0\.ic issued pc (\d+) \(cell_loop\)", out)
    assert hit, out
    pc = int(hit.group(1))  # wherever the kernel puts cell_loop
    assert "npri/r32 = 0" in out and "1: npri/r32 = 0" in out
    assert "watchpoint 2 on pe0.ic.npri/r32 (now 0)" in out
    assert " npri/r32 " in out and "*cell/r26 " in out  # info registers npri cell
    assert "watchpoint 2: pe0.ic.npri/r32: 0 -> " in out
    listing = [line for line in out.split("(nss) screen")[1].splitlines() if "│" in line]
    assert any("cell_loop" in line and "ldg npri/r" in line for line in listing)
    assert any(f"=> {pc + 1}: ldg nshp/r33, [cell/r26 + 1]" in line for line in listing)  # whole
    code, _, err = cli("asm", "--scene", "tetra:1", "--res", "3", "--proc", "ic",
                       "-o", tmp_path / "ic.o")
    assert code == 0, err
    code, out2 = debug(commands, "tetra:1", "--res", "3", "--proc", "ic", "--ic",
                       tmp_path / "ic.o", "--width", "120")
    assert code == 0, out2
    assert "watchpoint 2: pe0.ic.npri/r32: 0 -> " in out2 and "1: npri/r32 = 0" in out2


# ---------------------------------------------------------------------------------------------
# 80×24 (issue 42, item 6): the source file by its short name, the registers at the focus kept


def test_a_bundled_kernels_source_is_named_by_its_file_alone():
    from netsushisen.debugger.view import display_file
    from netsushisen.kernels import KERNELS

    assert display_file(str(KERNELS / "ic_polygon.inc")) == "ic_polygon.inc"
    assert display_file("/elsewhere/mine.s") == "/elsewhere/mine.s"


def test_the_focus_bundles_operands_are_shown_before_other_registers():
    from netsushisen.debugger.registers import register_rows

    source = ".proc ic\n" + "".join(f"    li r{r}, {r}\n" for r in range(1, 21)) + \
        "    li r40, 7\n    li r41, 8\n    add r42, r40, r41\n    halt\n"
    s = named_session(source)
    s.stepi(22)
    s.mark_stop()  # a stop, as the front end marks one
    s.stepi(1)  # the add issues: nothing changed since the last stop, its result pending
    regs, left = register_rows(s, s.core, 4)
    assert {40, 41, 42} <= set(regs) and left > 0
