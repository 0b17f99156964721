"""The debugger's `list` command (gdb's): ten source lines around the viewed processor's PC,
a label or an address (`list loop`), or FILE:LINE; `list` again (or Enter) goes on after the
last line shown, `list -` shows the lines before. The lines come from the file on disk, or, when
it cannot be read, from the lines the programs' source maps kept. Marks: `=>` the PC's line,
`B1` a breakpoint's (`b1` disabled). Mixed into `Commands` (commands.py)."""

from __future__ import annotations

import re

from rich.text import Text

from netsushisen.debugger import view
from netsushisen.debugger.expressions import DebugError, same_file
from netsushisen.debugger.outcome import Outcome


class SourceCommands:
    """Mixed into `Commands`: needs session, _list_at, last_line."""

    def cmd_list(self, arg: str) -> Outcome:
        """gdb's `list`: ten lines around a place, then the next ten on each repeat."""
        s = self.session
        arg = arg.strip()
        if arg in ("", "-") and self._list_at is not None:
            file, first, last = self._list_at
            first = max(1, first - 10) if arg == "-" else last + 1
        elif arg == "-":
            raise DebugError("list -: nothing listed yet (list, list LABEL, list FILE:LINE)")
        else:
            if arg:
                pe, stage, addr = s.context().location(arg)
            else:
                stage, core = s.stage, s.core
                if not core.present:
                    raise DebugError(f"pe{s.pe}.{s.stage} has no program")
                addr = view.focus_pc(core)
            smap = s.machine.programs[stage].source_map
            if addr >= len(smap):
                raise DebugError(f"no source line for {stage} pc {addr}")
            file, line = smap[addr].file, smap[addr].line
            m = re.fullmatch(r"(.+):(\d+)", arg)
            if m and m.group(2).isdigit() and _is_source(s, m.group(1)):
                line = int(m.group(2))  # list FILE:LINE centres on that line, code or not
            first = max(1, line - 5)
        text = _source_text(s, file)
        if first > max(text, default=0):
            raise DebugError(f"line {first} is beyond the end of {file} ({max(text, default=0)} "
                             "lines)")
        last = min(first + 9, max(text))
        self._list_at = (file, first, last)
        self.last_line = "list"  # Enter goes on where this listing stopped
        marks = _source_marks(s, file)
        rows = [f"{n:>5} {marks.get(n, ''):<6}{text.get(n, '')}".rstrip()
                for n in range(first, last + 1)]
        return Outcome([Text("\n".join(rows))])


def _is_source(session, file: str) -> bool:
    return any(same_file(loc.file, file) for p in session.machine.programs.values()
               if p is not None for loc in p.source_map)


def _source_text(session, file: str) -> dict[int, str]:
    """Line number -> text of a source file: read from disk, or, when it cannot be read (moved,
    an object file's source), the lines the programs' source maps kept."""
    try:
        with open(file, encoding="utf-8", errors="replace") as fh:
            return {i: line.rstrip("\n").expandtabs(8) for i, line in enumerate(fh, 1)}
    except OSError:
        pass
    out: dict[int, str] = {}
    for p in session.machine.programs.values():
        if p is not None:
            for loc in p.source_map:
                if same_file(loc.file, file):
                    out[loc.line] = loc.text
    return out


def _source_marks(session, file: str) -> dict[int, str]:
    """Per source line: `=>` the viewed processor's PC, `B1` a breakpoint's line."""
    marks: dict[int, str] = {}
    core = session.core
    if core.present:
        smap = core.program.source_map
        pc = view.focus_pc(core)
        if pc < len(smap) and same_file(smap[pc].file, file):
            marks[smap[pc].line] = "=>"
    for bp in session.breakpoints.values():
        f, _, line = bp.where.rpartition(":")
        if f and same_file(f, file):
            n = int(line)
            marks[n] = marks.get(n, "") + ("B" if bp.enabled else "b") + str(bp.number)
    return marks
