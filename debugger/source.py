"""The debugger's source-line commands, gdb's: `list` — ten source lines around the viewed
processor's PC, a label or an address (`list loop`), or FILE:LINE; `list` again (or Enter) goes
on after the last line shown, `list -` shows the lines before (the lines come from the file on
disk, or, when it cannot be read, from the lines the programs' source maps kept; marks: `=>` the
PC's line, `B1` a breakpoint's, `b1` disabled) —; `info line [N|FILE:N|LOCATION|*ADDR]`, the
bundles that hold a source line; `info symbol ADDR`, the label an address is at or after; and
`x/Ni LOCATION`, N bundles from a code address. Mixed into `Commands` (commands.py)."""

from __future__ import annotations

import re

from rich.text import Text

from netsushisen.debugger import view
from netsushisen.debugger.expressions import DebugError, bundle_lines, same_file
from netsushisen.debugger.outcome import Outcome


def line_bundles(program, file: str, line: int) -> list[int]:
    """The bundles that hold source line `line` of `file`, in address order."""
    return [a for a in range(len(program.bundles))
            if any(ln == line and same_file(f, file) for f, ln in bundle_lines(program, a))]


def _at(program, addr: int) -> str:
    """`5 <loop+5>`: an address as gdb prints one, with the label it is at or after."""
    where = program.label_at(addr)
    return f"{addr} <{where}>" if where != str(addr) else str(addr)


class SourceCommands:
    """Mixed into `Commands`: needs session, _list_at, last_line."""

    def info_line(self, args) -> Outcome:
        """gdb's `info line`: where the code of a source line starts and ends — here the
        bundles that hold it (several, not adjacent, in a scheduled region)."""
        s = self.session
        arg = " ".join(args).strip()
        stage = s.stage
        program = s.machine.programs.get(stage)
        m = re.fullmatch(r"(?:(.+):)?(\d+)", arg)
        if m and (m.group(1) is None or _is_source(s, m.group(1))):
            if m.group(1) is None:  # a line of the file the viewed processor is in
                if program is None:
                    raise DebugError(f"pe{s.pe}.{s.stage} has no program")
                here = bundle_lines(program, min(view.focus_pc(s.core), len(program.bundles) - 1))
                if not here:
                    raise DebugError("no source file here: info line FILE:LINE")
                file = here[0][0]
            else:
                file = m.group(1)
                stage = next((st for st in [s.stage, *s.machine.programs]
                              if s.machine.programs.get(st) is not None and any(
                                  same_file(loc.file, file)
                                  for loc in s.machine.programs[st].source_map)), stage)
                program = s.machine.programs[stage]
                file = next(loc.file for loc in program.source_map if same_file(loc.file, file))
            line = int(m.group(2))
        else:
            if arg:
                _, stage, addr = s.context().location(arg)
                program = s.machine.programs[stage]
            else:
                if program is None or not s.core.present:
                    raise DebugError(f"pe{s.pe}.{s.stage} has no program")
                addr = view.focus_pc(s.core)
            lines = bundle_lines(program, addr)
            if not lines:
                return Outcome([Text(f"No line number information available for address "
                                     f"{_at(program, addr)}")])
            file, line = lines[0]
        name = file.rsplit("/", 1)[-1]
        bundles = line_bundles(program, file, line)
        if not bundles:
            later = [(ln, a) for a in range(len(program.bundles))
                     for f, ln in bundle_lines(program, a) if same_file(f, file) and ln > line]
            if not later:
                return Outcome([Text(f'Line {line} of "{name}" is past the last line with code '
                                     f"in {stage.upper()}.")])
            addr = min(later)[1]
            return Outcome([Text(f'Line {line} of "{name}" is at address {_at(program, addr)} '
                                 "but contains no code.")])
        if bundles == list(range(bundles[0], bundles[-1] + 1)):
            end = bundles[-1] + 1
            end_text = _at(program, end) if end < len(program.bundles) else f"{end} (the end)"
            return Outcome([Text(f'Line {line} of "{name}" starts at address '
                                 f"{_at(program, bundles[0])} and ends at {end_text}.")])
        shown = ", ".join(_at(program, a) for a in bundles)
        return Outcome([Text(f'Line {line} of "{name}" is in bundles {shown}.')])

    def info_symbol(self, args) -> Outcome:
        """gdb's `info symbol ADDR`: the label at ADDR, or the nearest before it and the
        offset (`loop + 3 in section .text`). Code and data have separate address spaces here
        (bundles, local words): both are looked up, for the viewed processor's program."""
        s = self.session
        arg = " ".join(args).strip().lstrip("*").strip()
        if not arg:
            raise DebugError("info symbol takes an address: info symbol 12, info symbol loop+3")
        ctx = s.context()
        m = re.match(r"^(?:pe\d+\.)?(os|ic|sc)\.(.+)$", arg)
        stage, expr = (m.group(1), m.group(2)) if m else (s.stage, arg)
        program = s.machine.programs.get(stage)
        if program is None:
            raise DebugError(f"{stage.upper()} has no program")
        addr = ctx.value(expr) if not m else s.context(stage=stage).value(expr)
        if isinstance(addr, float):
            raise DebugError(f"an address is an integer, not {addr}")
        out = []
        for section, size in (("text", len(program.bundles)), ("data", len(program.data))):
            if not 0 <= addr < max(size, 1) or (section == "data" and not program.data):
                continue
            best = None
            for name, (sec, a) in sorted(program.labels.items()):
                if sec == section and a <= addr and (best is None or a > best[1]):
                    best = (name, a)
            if best is not None:
                off = f" + {addr - best[1]}" if addr > best[1] else ""
                out.append(f"{best[0]}{off} in section .{section} of {stage}")
        return Outcome([Text("\n".join(out) or f"No symbol matches {arg}.")])

    def info_loop(self, args) -> Outcome:
        """`info loop [LOCATION]`: the innermost natural loop around the viewed processor's PC
        (or LOCATION; asm/loops.py, named by its source label) and the loops around it — its
        static bound per iteration (`asm.bounds`: units, ports, recurrence; the code as
        written) beside the cycles per iteration this run has taken in it so far (its bundles'
        issue and stall cycles over the times its header issued, as `report bounds` counts
        them), or "not in a loop"."""
        from netsushisen.asm.bounds import Region, region_bounds
        from netsushisen.asm.loops import chain, innermost, program_loops
        from netsushisen.reports.annotate import BundleCounts
        from netsushisen.reports.bounds import run_cells

        s = self.session
        arg = " ".join(args).strip()
        if arg:
            pe, stage, pc = s.context().location(arg)
            core = s.context().core(pe, stage)
        else:
            core = s.core
            if not core.present:
                raise DebugError(f"pe{s.pe}.{s.stage} has no program")
            pc = min(view.focus_pc(core), len(core.bundles) - 1)
        program = core.program
        loops = program_loops(program)
        loop = innermost(loops, pc)
        if loop is None:
            return Outcome([Text(f"{core.name} pc {_at(program, pc)} is not in a loop")])
        b = region_bounds(program, Region("loop", loop.header, loop.end, loop.body, loop.name),
                          s.machine.config, optimum_ops=0)
        counts = {p: BundleCounts(p, "", None, None, None, core.bundles_by_pc.get(p, 0),
                                  dict(core.stalls_by_pc.get(p, {})))
                  for p in loop.body}
        runs, cycles, issued, stalls = run_cells(b, counts)
        # an iteration under way is not over: when the processor is in the loop and the head's
        # last issue is known, the figure counts complete iterations only
        head_at = s.aux.get(core.name, {}).get("issued_at", {}).get(loop.header)
        under_way = None
        if runs > 1 and head_at is not None and core.pc in loop and not core.halted:
            under_way = s.machine.cycle - head_at
            runs -= 1
            cycles = (sum(c.cycles for c in counts.values()) - under_way) / runs
        bounds = ", ".join(f"{k} {v}" for k, v in b.candidates().items())
        lines = [f"loop {loop.name} (header {_at(program, loop.header)}, pcs {loop.pcs_text}) "
                 f"of {core.name}: {b.bundles} bundles, {b.ops} ops",
                 f"  bound: {b.bound} cycles per iteration ({b.binding}-bound; {bounds})",
                 f"  as written: {b.written} cycles per iteration (every source ready, every "
                 "load a hit)"]
        if under_way is not None:
            lines.append(f"  this run: {runs} complete iteration{'s' if runs != 1 else ''}, "
                         f"{cycles:.2f} cycles per iteration (the one under way: {under_way} "
                         f"cycle{'s' if under_way != 1 else ''} so far)")
        elif runs:
            lines.append(f"  this run: {runs} iteration{'s' if runs != 1 else ''}, "
                         f"{cycles:.2f} cycles per iteration ({issued:.2f} issuing"
                         + (f"; stalls per iteration: {stalls}" if stalls else "") + ")")
        else:
            lines.append("  this run: the loop has not started yet")
        outer = chain(loops, loop)[1:]
        if outer:
            lines.append("  inside " + " inside ".join(f"loop {o.name} (pcs {o.pcs_text})"
                                                       for o in outer))
        return Outcome([Text("\n".join(lines))])

    def examine_code(self, arg: str, n: int) -> Outcome:
        """gdb's `x/Ni ADDR`: N bundles from a code location, `=>` at the PC."""
        s = self.session
        _, stage, start = s.context().location(arg)
        program = s.machine.programs[stage]
        core = s.machine.pes[s.pe].cores[stage]
        rows = []
        for a in range(start, min(start + n, len(program.bundles))):
            mark = "=> " if a == core.pc and not core.halted else "   "
            rows.append(f"{mark}{_at(program, a)}:  {view.bundle_text(program, a)}")
        if start + n > len(program.bundles):
            rows.append(f"(the program ends at {len(program.bundles) - 1})")
        return Outcome([Text("\n".join(rows))])

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
        for f, line in bundle_lines(core.program, view.focus_pc(core)):
            if same_file(f, file):
                marks[line] = "=>"
    for bp in session.breakpoints.values():
        f, _, line = bp.where.rpartition(":")
        if f and same_file(f, file):
            n = int(line)
            marks[n] = marks.get(n, "") + ("B" if bp.enabled else "b") + str(bp.number)
    return marks
