"""The debugger's command language: parsing a line and running it on a `Session`.

`Commands.execute(line)` returns an `Outcome`: what to print, whether the screen should be
drawn again (the machine moved, the view changed, a value was set) and whether to quit. A bad
command, location or expression comes back as one line `error: ...`, never a traceback.
"""

from __future__ import annotations

import os
import re
import shlex

from rich.console import RenderableType
from rich.table import Table
from rich.text import Text

from netsushisen.debugger import layout, registers, view
from netsushisen.debugger.breakcommands import BreakpointCommands, Display
from netsushisen.debugger.expressions import DebugError, format_number, format_word, hex_word
from netsushisen.debugger.help import (ALIASES, CLASSES, HELP, INFO_ALIASES, INFO_TOPICS, LAYOUTS,
                                        MOVES)
from netsushisen.debugger.outcome import Outcome
from netsushisen.debugger.source import SourceCommands
from netsushisen.debugger.state import state_digest
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.processors import STAGES
from netsushisen.isa.words import wrap32


def resolve_command(word: str) -> str:
    if word in ALIASES:
        return ALIASES[word]
    if word in HELP:
        return word
    matches = [name for name in HELP if name.startswith(word)]
    if len(matches) == 1:
        return matches[0]
    if matches:
        raise DebugError(f"ambiguous command {word!r}: {', '.join(matches)}")
    raise DebugError(f"unknown command {word!r} (help lists the commands)")


def _count(arg: str, name: str) -> int:
    arg = arg.strip()
    if not arg:
        return 1
    try:
        n = int(arg, 0)
    except ValueError:
        raise DebugError(f"{name} takes a number, not {arg!r}") from None
    if n < 1:
        raise DebugError(f"{name} takes a positive number")
    return n


class Commands(BreakpointCommands, SourceCommands):
    """The command language over a session; breakpoint and display commands come from
    breakcommands.py, `list` from source.py."""

    def __init__(self, session, *, auto_screen: bool = True):
        self.session = session
        self.auto_screen = auto_screen
        self.last_line = ""
        self.source_depth = 0
        self.run_source = None  # set by the front end: runs a file's commands
        self._trace_lines: list[str] = []
        self.displays: dict[int, Display] = {}
        self._next_display = 1
        self._list_at: tuple[str, int, int] | None = None  # file, first, last line listed
        self.layout = "auto"  # `layout`: a preset name or panel names (layout.PANELS)

    # -- entry point --------------------------------------------------------------------------

    def execute(self, line: str, repeat_empty: bool = False) -> Outcome:
        text = line.strip()
        if not text:
            if repeat_empty and self.last_line:
                text = self.last_line
            else:
                return Outcome()
        if text.startswith("#"):
            return Outcome()
        self.last_line = text
        try:
            return self._dispatch(text)
        except DebugError as err:
            return Outcome([Text(f"error: {err}")], failed=True)
        except NetsushisenError as err:
            first = err.format().splitlines()[0] if err.format() else type(err).__name__
            return Outcome([Text(f"error: {first}")], failed=True)
        except RecursionError:
            return Outcome([Text("error: expression nested too deeply")], failed=True)
        except Exception as err:  # never a traceback in the session
            if os.environ.get("NETSUSHISEN_DEBUG"):
                raise
            return Outcome([Text(f"error: internal: {type(err).__name__}: {err}")], failed=True)

    def _dispatch(self, text: str) -> Outcome:
        m = re.match(r"^(x|print|p|display)(/\w*)?(?=\s|$)", text)
        if m:
            word, fmt, rest = m.group(1), (m.group(2) or "")[1:], text[m.end():]
        else:
            word, rest = (text.split(None, 1) + [""])[:2]
            fmt = ""
        name = resolve_command(word)
        rest = rest.strip()
        if name in MOVES:
            self.session.mark_stop()
        handler = getattr(self, "cmd_" + name.replace("-", "_"))
        if name in ("print", "x", "display"):
            return handler(rest, fmt)
        if name in MOVES:
            self._list_at = None  # after a stop, `list` starts around the PC again
        return handler(rest)

    def _moved(self, stop) -> Outcome:
        out: list[RenderableType] = []
        if self._trace_lines:
            out.append(Text("\n".join(self._trace_lines)))
            self._trace_lines.clear()
        out += [Text(msg) for msg in stop.messages]
        out += self.display_lines()
        return Outcome(out, redraw=True, moved=True)

    # -- movement -----------------------------------------------------------------------------

    def cmd_cycle(self, arg: str) -> Outcome:
        return self._moved(self.session.step(_count(arg, "cycle")))

    def cmd_step(self, arg: str) -> Outcome:
        return self._moved(self.session.stepi(_count(arg, "step"), by_line=True))

    def cmd_stepi(self, arg: str) -> Outcome:
        return self._moved(self.session.stepi(_count(arg, "stepi")))

    def cmd_next(self, arg: str) -> Outcome:
        return self._moved(self.session.stepi(_count(arg, "next"), over_calls=True, by_line=True))

    def cmd_nexti(self, arg: str) -> Outcome:
        return self._moved(self.session.stepi(_count(arg, "nexti"), over_calls=True))

    def cmd_continue(self, arg: str) -> Outcome:
        return self._moved(self.session.cont(_count(arg, "continue")))

    def cmd_finish(self, arg: str) -> Outcome:
        if arg:
            raise DebugError("finish takes no argument")
        return self._moved(self.session.finish())

    def cmd_until(self, arg: str) -> Outcome:
        return self._moved(self.session.until(arg or None))

    def cmd_reverse_cycle(self, arg: str) -> Outcome:
        return self._moved(self.session.reverse_step(_count(arg, "reverse-cycle")))

    def cmd_reverse_step(self, arg: str) -> Outcome:
        return self._moved(self.session.reverse_step_line(_count(arg, "reverse-step")))

    def cmd_reverse_stepi(self, arg: str) -> Outcome:
        return self._moved(self.session.reverse_stepi(_count(arg, "reverse-stepi")))

    def cmd_reverse_continue(self, arg: str) -> Outcome:
        if arg:
            raise DebugError("reverse-continue takes no argument")
        return self._moved(self.session.reverse_continue())

    def cmd_restart(self, arg: str) -> Outcome:
        self.session.restart()
        c = self.session.machine.cycle
        what = "" if self.session.origin == 0 else ", where --fast-forward handed over"
        return Outcome([Text(f"restarted: cycle {c}{what}")], redraw=True, moved=True)

    # -- inspection ---------------------------------------------------------------------------

    def cmd_info(self, arg: str) -> Outcome:
        words = arg.split()
        if not words:
            raise DebugError(f"info what? {', '.join(INFO_TOPICS)}")
        topic = INFO_ALIASES.get(words[0], words[0])
        matches = [t for t in INFO_TOPICS if t.startswith(topic)]
        if len(matches) != 1:
            raise DebugError(f"info {words[0]}: choose one of {', '.join(INFO_TOPICS)}")
        return getattr(self, "info_" + matches[0])(words[1:])

    def info_registers(self, args) -> Outcome:
        """All registers, or only those named (`info registers pri r5 ic.cell`, gdb's
        `info registers REG...`), as a table in as many column groups as the width holds."""
        s = self.session
        ctx = s.context()
        if args:
            places = []
            for word in args:
                place = ctx.place(word)
                if place is None or place.kind != "reg":
                    raise DebugError(f"info registers: {word!r} is not a register")
                places.append(place)
            core = ctx.core(places[0].pe, places[0].stage)
            if any((p.pe, p.stage) != (places[0].pe, places[0].stage) for p in places):
                raise DebugError("info registers: name registers of one processor")
            regs = [p.index for p in places]
        else:
            core, regs = s.core, list(range(len(s.core.regs)))
        title = f"registers {core.name} (* changed since the previous stop)"
        return Outcome([registers.RegisterTable(s, core, regs, title),
                        Text(f"pc {core.pc} ({core.label(core.pc)})")])

    def info_fifo(self, args) -> Outcome:
        s = self.session
        out: list[RenderableType] = [view.fifo_table(s, all_fifos=bool(args and args[0] == "all"))]
        locks = []
        for cmu in s.machine.pes[s.pe].ring.cmus:
            locks += [f"CMU {cmu.stage}: {t}" for t in cmu.describe_locks()]
        out.append(Text("\n".join(locks) or "no wormhole locks held"))
        return Outcome(out)

    def info_cache(self, args) -> Outcome:
        s = self.session
        core = s.core
        lines = view.memory_lines(s, core)
        cache = s.machine.pes[s.pe].memories[s.stage].cache
        if cache is not None and cache.sets:
            valid = [(i, int(t)) for i, t in enumerate(cache.tags) if t >= 0]
            lines.append(f"{len(valid)} of {cache.sets} lines valid")
            for i, tag in valid[:16]:
                block = tag * cache.sets + i
                lines.append(f"  set {i}: tag {tag} (block {block})")
            if len(valid) > 16:
                lines.append(f"  ... {len(valid) - 16} more")
        return Outcome([Text("\n".join(lines))])

    def info_stats(self, args) -> Outcome:
        s = self.session
        m = s.machine
        state = f"ended: {m.status}" if m.status is not None else "running"
        lines = [f"{state}, {m.cycle} cycles run, {len(m.pes)} PE{'s' if len(m.pes) != 1 else ''}"]
        lines += m.summary().splitlines()[1:]  # per processor (the first line is the status)
        for core in m.pes[s.pe].cores.values():
            if core.present:
                lines.append(f"{core.name} memory:")
                lines += [f"  {line}" for line in view.memory_lines(s, core)]
        return Outcome([Text("\n".join(lines))])

    def info_scoreboard(self, args) -> Outcome:
        lines = view.scoreboard_lines(self.session, self.session.core)
        return Outcome(lines or [Text("nothing pending")])

    def info_checkpoints(self, args) -> Outcome:
        return Outcome([Text("\n".join(self.session.checkpoint_info()))])

    def info_state(self, args) -> Outcome:
        m = self.session.machine
        return Outcome([Text(f"state digest after {m.cycle} cycles: {state_digest(m)}")])

    def cmd_print(self, arg: str, fmt: str = "") -> Outcome:
        if not arg:
            raise DebugError("print takes an expression")
        return Outcome([Text(self._print_text(arg, fmt))])

    def _print_text(self, arg: str, fmt: str = "") -> str:
        """`NAME = VALUE` as print shows it (display uses the same)."""
        if fmt and fmt not in ("x", "d", "u", "f"):
            raise DebugError(f"print/{fmt}: formats are /x /d /u /f")
        ctx = self.session.context()
        place = ctx.place(arg)
        if place is not None and place.kind == "pc" and not fmt:
            core = ctx.core(place.pe, place.stage)
            return f"{_name(self.session, place)} = {core.where(core.pc)[3:]}"
        if place is not None and place.kind != "pc":
            core = ctx.core(place.pe, place.stage)
            word = ctx.read_word(place)
            name = _name(self.session, place)
            if fmt:
                return f"{name} = {_format(core, word, fmt)}"
            if place.view:
                return f"{name} = {format_number(ctx.value_of(place))}"
            return f"{name} = {format_word(core, word)}"
        v = ctx.value(arg)
        if fmt == "x" and isinstance(v, int):
            text = hex(v & 0xFFFFFFFF)
        elif fmt == "f":
            text = format_number(float(v))
        else:
            text = format_number(v)
        if isinstance(v, int) and ctx.program() is not None and not fmt:
            labels = ctx.program().labels
            names = [n for n, (sec, a) in labels.items() if a == v and arg.strip() == n]
            if names and labels[names[0]][0] == "text":
                text += f"  (code address: {ctx.program().label_at(v)})"
        return f"{arg.strip()} = {text}"

    def cmd_x(self, arg: str, fmt: str = "") -> Outcome:
        """gdb's `x/NFU ADDR`: N words from ADDR — a number or a data label (the processor's
        local memory, its data memory), `REGION ADDR` or `REGION[ADDR]`, `*ADDR` as gdb writes
        it; F a format (x d u f a, or i: N bundles from a code location); U may be w (a word,
        the only unit)."""
        m = re.fullmatch(r"(\d*)([xdufai]?)w?", fmt)
        if not m:
            raise DebugError(f"x/{fmt}: expected x/N followed by a format x, d, u, f, a or i "
                             "(the unit is always a word: w)")
        n = int(m.group(1) or 1)
        f = m.group(2) or "x"
        if not arg:
            raise DebugError("x takes an address: x/8 icgm 512, x/4f local[table], x/4f 12")
        if arg.startswith("*") and f != "i":
            arg = arg[1:].strip()
        if f == "i":
            return self.examine_code(arg, n)
        if n == 0:
            self.session.context().memory_ref(arg)  # the address is still checked
            return Outcome([Text("x/0: a count of 0 words shows nothing")])
        ctx = self.session.context()
        place = ctx.memory_ref(arg)
        words = ctx.memory_array(place)
        core = ctx.core(place.pe, place.stage)
        end = min(len(words), place.index + n)
        region = place.region if place.region in ("icgm", "scgm") else \
            (f"{place.stage}.{place.region}" if place.stage != self.session.stage or
             place.pe != self.session.pe else place.region)
        lines = []
        per = 1 if f == "a" else 4
        for a in range(place.index, end, per):
            cells = [_format(core, int(words[k]), f) for k in range(a, min(a + per, end))]
            lines.append(f"{region}[{a}]:  " + "  ".join(c.rjust(12) if f != "a" else c
                                                         for c in cells))
        if end < place.index + n:
            lines.append(f"(the memory ends at {len(words) - 1})")
        return Outcome([Text("\n".join(lines))])

    def cmd_disassemble(self, arg: str) -> Outcome:
        s = self.session
        ctx = s.context()
        if arg:
            pe, stage, start = ctx.location(arg)
            core = ctx.core(pe, stage)
        else:
            core = s.core
            if not core.present:
                raise DebugError(f"pe{s.pe}.{s.stage} has no program")
            pc = view.focus_pc(core)
            starts = [a for sec, a in core.program.labels.values() if sec == "text" and a <= pc]
            start = max(starts, default=0)
        program = core.program
        later = [a for sec, a in program.labels.values() if sec == "text" and a > start]
        end = min(min(later, default=len(program.bundles)), start + 64, len(program.bundles))
        if end - start < 4:
            end = min(len(program.bundles), start + 16)
        t = view.Listing(s, core, start, end, focus=core is s.core)
        return Outcome([Text(f"{core.name}: bundles {start}..{end - 1}"), t])

    # -- view ---------------------------------------------------------------------------------

    def cmd_proc(self, arg: str) -> Outcome:
        if arg not in STAGES:
            raise DebugError("proc takes os, ic or sc")
        self.session.set_view(stage=arg)
        return Outcome(redraw=True)

    def cmd_pe(self, arg: str) -> Outcome:
        try:
            k = int(arg)
        except ValueError:
            raise DebugError(f"pe takes a PE number, not {arg!r}") from None
        self.session.set_view(pe=k)
        return Outcome(redraw=True)

    def cmd_layout(self, arg: str) -> Outcome:
        words = arg.replace(",", " ").split()
        if not words:
            shown = self.layout if isinstance(self.layout, str) else " ".join(self.layout)
            return Outcome([Text(f"layout {shown} (presets: {', '.join(LAYOUTS)}; panels: "
                                 f"{', '.join(layout.PANELS)})")])
        if len(words) == 1 and words[0] in LAYOUTS:
            self.layout = words[0]
        else:
            bad = [w for w in words if w not in layout.PANELS]
            if bad:
                raise DebugError(f"layout: no panel {bad[0]!r} (presets: {', '.join(LAYOUTS)}; "
                                 f"panels: {', '.join(layout.PANELS)})")
            self.layout = tuple(dict.fromkeys(words))
        return Outcome(redraw=True)

    def cmd_screen(self, arg: str) -> Outcome:
        if arg in ("on", "off"):
            self.auto_screen = arg == "on"
            return Outcome([Text(f"screen after every stop: {arg}")])
        if arg:
            raise DebugError("screen takes on, off or nothing")
        return Outcome(redraw=True)

    def cmd_trace(self, arg: str) -> Outcome:
        if arg not in ("on", "off"):
            raise DebugError("trace takes on or off")
        self.session.trace_out = self._trace_lines.append if arg == "on" else None
        return Outcome([Text(f"trace {arg}")])

    # -- edits --------------------------------------------------------------------------------

    def cmd_set(self, arg: str) -> Outcome:
        lhs, eq, rhs = arg.partition("=")
        if not eq or not lhs.strip() or not rhs.strip() or rhs.startswith("="):
            raise DebugError("set takes REGISTER=VALUE, *ADDRESS=VALUE or pc=LOCATION")
        s = self.session
        ctx = s.context()
        lhs = lhs.strip()
        if lhs.startswith("*"):
            place = ctx.memory_ref(lhs[1:])
        else:
            place = ctx.place(lhs)
            if place is None or place.kind == "mem":
                raise DebugError(f"set {lhs}: write a register (r5, f:r6), pc, or memory "
                                 "as *local[10]")
        if place.kind == "pc":
            _, _, value = ctx.location(f"pe{place.pe}.{place.stage}.{rhs.strip()}")
        else:
            value = ctx.value(rhs)
        if s.ended:
            raise DebugError(s.end_message() + ": the state can no longer change")
        core = ctx.core(place.pe, place.stage)
        old, new = s.set_place(place, value)
        name = _name(s, place)
        lines = [f"{name} = {s._show(core, place, new)} (was {s._show(core, place, old)})"]
        flying = view.in_flight(core)
        if place.kind == "reg" and place.index in flying:
            lines.append(f"note: {name} has a {core.producer[place.index]} result in "
                         f"flight (written in cycle {flying[place.index][0]}); it will "
                         "overwrite this value")
        return Outcome([Text("\n".join(lines))], redraw=True)

    # -- scripting, help, quit ----------------------------------------------------------------

    def cmd_source(self, arg: str) -> Outcome:
        if not arg:
            raise DebugError("source takes a file name")
        path = shlex.split(arg)[0]
        if self.run_source is None:
            raise DebugError("source is not available here")
        if self.source_depth >= 8:
            raise DebugError("source files nested too deeply")
        try:
            with open(path, encoding="utf-8") as fh:
                lines = fh.read().splitlines()
        except OSError as err:
            raise DebugError(f"{path}: {err.strerror}") from None
        self.source_depth += 1
        try:
            going = self.run_source(lines)
        finally:
            self.source_depth -= 1
        return Outcome(quit=not going)

    def cmd_help(self, arg: str) -> Outcome:
        """gdb's help: an index by default (one line per class of commands), `help COMMAND`
        for one command, `help all` for the one-line description of every command."""
        if not arg:
            lines = [f"{cls + ':':<13} {' '.join(names)}" for cls, names in CLASSES]
            lines.append('Type "help" followed by a command name for its description, '
                         '"help all" for every command. Enter repeats the last command.')
            return Outcome([Text("\n".join(lines))])
        if arg.split()[0] != "all":
            name = resolve_command(arg.split()[0])
            usage, short, more = HELP[name]
            aliases = [a for a, n in ALIASES.items() if n == name]
            text = f"{usage}\n  {short}" + (f"\n  {more}" if more else "")
            if aliases:
                text += f"\n  aliases: {', '.join(aliases)}"
            return Outcome([Text(text)])
        t = Table(box=None, show_header=False, pad_edge=False, padding=(0, 2))
        t.add_column(no_wrap=True)
        t.add_column()
        for name, (usage, short, _) in HELP.items():
            t.add_row(usage, short)
        return Outcome([t, Text("Enter repeats the last command; help COMMAND for details.")])

    def cmd_quit(self, arg: str) -> Outcome:
        return Outcome(quit=True)


def _name(session, place) -> str:
    """A place's name, qualified when it is not on the viewed processor."""
    return place.name(qualify=(place.pe, place.stage) != (session.pe, session.stage)
                      and place.region not in ("icgm", "scgm"))


def _format(core, word: int, f: str) -> str:
    if f == "x":
        return hex_word(core, word)
    if f == "d":
        return str(wrap32(word))
    if f == "u":
        return str(word & core.mask)
    if f == "f":
        return str(core.value(word, "f"))
    return f"{hex_word(core, word)}  {wrap32(word):>11}  {str(core.value(word, 'f'))}"
