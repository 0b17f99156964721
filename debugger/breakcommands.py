"""The debugger's breakpoint, watchpoint and display commands, gdb's names and behaviour:
break/tbreak LOCATION [if COND], watch/rwatch/awatch, delete/disable/enable [N...],
condition N [EXPR], ignore N COUNT, info breakpoints (gdb's table), display[/FMT] EXPR,
undisplay [N...], info display. Mixed into `Commands` (commands.py)."""

from __future__ import annotations

import re
from dataclasses import dataclass

from rich.console import RenderableType
from rich.text import Text

from netsushisen.debugger.breakpoints import WATCH_TYPES
from netsushisen.debugger.expressions import DebugError
from netsushisen.debugger.outcome import Outcome


@dataclass
class Display:
    """A `display` expression, printed at every stop."""

    number: int
    expression: str
    format: str = ""
    enabled: bool = True


def _numbers(arg: str, name: str) -> list[int]:
    """Breakpoint numbers as gdb takes them: `2`, `1 3`, `2-4`."""
    out: list[int] = []
    for word in arg.split():
        m = re.fullmatch(r"(\d+)(?:-(\d+))?", word)
        if not m:
            raise DebugError(f"{name} takes breakpoint numbers (1, 2-4), not {word!r}")
        lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
        if hi < lo:
            raise DebugError(f"{name}: inverted range {word}")
        out += [n for n in range(lo, hi + 1) if n not in out]
    return out


class BreakpointCommands:
    """Mixed into `Commands`: needs session, displays, _next_display, _print_text;"""

    def cmd_break(self, arg: str, temporary: bool = False) -> Outcome:
        name = "tbreak" if temporary else "break"
        if not arg:
            raise DebugError(f"{name} takes a location: {name} LABEL|ADDRESS|FILE:LINE "
                             "[if CONDITION]")
        m = re.match(r"^(.*?)\s+if(?:\s+(.*))?$", arg, re.S)
        loc, cond = (m.group(1), m.group(2) or "") if m else (arg, "")
        if m and not cond.strip():
            raise DebugError(f"{name} ... if: the condition is missing")
        bp = self.session.add_breakpoint(loc.strip(), cond.strip() or None, temporary=temporary)
        where = f": file {bp.where}" if bp.where else ""
        return Outcome([Text(bp.describe() + where)], refresh=True)

    def cmd_tbreak(self, arg: str) -> Outcome:
        return self.cmd_break(arg, temporary=True)

    def _watch(self, arg: str, kind: str) -> Outcome:
        if not arg:
            raise DebugError("watch takes a register or a local memory address" if kind == "watch"
                             else f"{kind} takes a memory address: {kind} icgm[12], "
                             f"{kind} local[table]")
        wp = self.session.add_watchpoint(arg, kind)
        ctx = self.session.context()
        now = self.session._show(ctx.core(wp.place.pe, wp.place.stage), wp.place,
                                 ctx.read_word(wp.place))
        return Outcome([Text(f"{wp.describe()} (now {now})")])

    def cmd_watch(self, arg: str) -> Outcome:
        return self._watch(arg, "watch")

    def cmd_rwatch(self, arg: str) -> Outcome:
        return self._watch(arg, "rwatch")

    def cmd_awatch(self, arg: str) -> Outcome:
        return self._watch(arg, "awatch")

    def cmd_delete(self, arg: str) -> Outcome:
        if arg:
            numbers = _numbers(arg, "delete")
            for n in numbers:
                self.session.item(n)  # every number checked before any is deleted
            for n in numbers:
                self.session.delete(n)
            return Outcome([Text(f"deleted {', '.join(map(str, numbers))}")], refresh=True)
        n = self.session.delete()
        return Outcome([Text(f"deleted {n} breakpoint{'s' if n != 1 else ''} and watchpoint"
                             f"{'s' if n != 1 else ''}")], refresh=True)

    def _enable(self, arg: str, on: bool) -> Outcome:
        word = "enable" if on else "disable"
        numbers = _numbers(arg, word) if arg else None
        if numbers is None and not self.session.items():
            return Outcome([Text("no breakpoints or watchpoints")])
        self.session.set_enabled(numbers, on)
        which = "all" if numbers is None else ", ".join(map(str, numbers))
        return Outcome([Text(f"{word}d {which}")], refresh=True)

    def cmd_enable(self, arg: str) -> Outcome:
        return self._enable(arg, True)

    def cmd_disable(self, arg: str) -> Outcome:
        return self._enable(arg, False)

    def cmd_condition(self, arg: str) -> Outcome:
        words = arg.split(None, 1)
        if not words:
            raise DebugError("condition takes a breakpoint number and an expression: "
                             "condition 1 r9 == 2 (no expression: remove the condition)")
        n = _numbers(words[0], "condition")[0]
        cond = words[1].strip() if len(words) > 1 else ""
        b = self.session.set_condition(n, cond or None)
        kind = "breakpoint" if b.kind == "breakpoint" else "watchpoint"
        if not cond:
            return Outcome([Text(f"{kind} {n} now unconditional")])
        return Outcome([Text(f"{kind} {n}: stop only if {cond}")])

    def cmd_ignore(self, arg: str) -> Outcome:
        words = arg.split()
        if len(words) != 2:
            raise DebugError("ignore takes a breakpoint number and a count: ignore 1 5")
        n = _numbers(words[0], "ignore")[0]
        try:
            count = int(words[1], 0)
        except ValueError:
            raise DebugError(f"ignore: the count is a number, not {words[1]!r}") from None
        b = self.session.set_ignore(n, count)
        kind = "breakpoint" if b.kind == "breakpoint" else "watchpoint"
        if count == 0:
            return Outcome([Text(f"will stop next time {kind} {n} is reached")])
        return Outcome([Text(f"will ignore next {count} crossing{'s' if count != 1 else ''} "
                             f"of {kind} {n}")])

    # -- displays -----------------------------------------------------------------------------

    def cmd_display(self, arg: str, fmt: str = "") -> Outcome:
        if not arg:
            if fmt:
                raise DebugError("display/FMT takes an expression")
            return Outcome(self.display_lines())
        if fmt and fmt not in ("x", "d", "u", "f"):
            raise DebugError(f"display/{fmt}: formats are /x /d /u /f")
        self._print_text(arg, fmt)  # a bad expression is an error now, not at every stop
        d = Display(self._next_display, arg.strip(), fmt)
        self._next_display += 1
        self.displays[d.number] = d
        return Outcome([Text(self._display_text(d))])

    def cmd_undisplay(self, arg: str) -> Outcome:
        if not arg:
            n = len(self.displays)
            self.displays.clear()
            return Outcome([Text(f"deleted {n} display{'s' if n != 1 else ''}")])
        numbers = _numbers(arg, "undisplay")
        for n in numbers:
            if n not in self.displays:
                raise DebugError(f"no display number {n}")
        for n in numbers:
            del self.displays[n]
        return Outcome([Text(f"deleted display {', '.join(map(str, numbers))}")])

    def info_display(self, args) -> Outcome:
        if not self.displays:
            return Outcome([Text("there are no auto-display expressions now")])
        lines = ["Auto-display expressions now in effect:", "Num Enb Expression"]
        for d in self.displays.values():
            what = f"/{d.format} {d.expression}" if d.format else d.expression
            lines.append(f"{d.number}:   {'y' if d.enabled else 'n'}  {what}")
        return Outcome([Text("\n".join(lines))])

    def info_breakpoints(self, args) -> Outcome:
        """gdb's table: Num Type Disp Enb Address What, then per item its condition, hit
        count and ignore count on indented lines."""
        items = self.session.items()
        if not items:
            return Outcome([Text("no breakpoints or watchpoints")])
        rows = [("Num", "Type", "Disp", "Enb", "Address", "What")]
        notes: dict[int, list[str]] = {}
        for b in items:
            if b.kind == "breakpoint":
                stage = (f"pe{b.pe}." if b.pe is not None else "") + b.stage
                what = f"{stage} {b.label}" + (f" at {b.where}" if b.where else "")
                rows.append((str(b.number), "breakpoint", "del" if b.temporary else "keep",
                             "y" if b.enabled else "n", str(b.address), what))
            else:
                rows.append((str(b.number), WATCH_TYPES[b.kind], "keep",
                             "y" if b.enabled else "n", "", b.place.name(qualify=True)))
            lines = []
            if b.condition:
                lines.append(f"stop only if {b.condition}")
            if b.hits:
                lines.append(f"breakpoint already hit {b.hits} time{'s' if b.hits != 1 else ''}")
            if b.ignore:
                lines.append(f"will ignore next {b.ignore} crossing"
                             f"{'s' if b.ignore != 1 else ''} of breakpoint")
            notes[b.number] = lines
        widths = [max(len(r[i]) for r in rows) for i in range(5)]
        out = []
        for r in rows:
            out.append("  ".join(c.ljust(w) for c, w in zip(r, widths)) + "  " + r[5])
            if r[0].isdigit():
                out += ["        " + line for line in notes[int(r[0])]]
        return Outcome([Text("\n".join(line.rstrip() for line in out))])

    def display_lines(self) -> list[RenderableType]:
        """The `display` expressions, each as `N: EXPR = VALUE` (gdb), shown at every stop."""
        out: list[RenderableType] = []
        for d in self.displays.values():
            if d.enabled:
                out.append(Text(self._display_text(d)))
        return out

    def _display_text(self, d: "Display") -> str:
        try:
            shown = self._print_text(d.expression, d.format)
        except DebugError as err:
            shown = f"{d.expression}: error: {err}"
        return f"{d.number}: {shown}"
