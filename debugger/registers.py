"""The registers on the debugger's screen, by `.reg` name and number (`pri/r29`): the panel
beside the listing (name, value, raw word), the packed cells of a narrow terminal, and `info
registers` (every view, as many column groups as the width holds). Marks: `*` changed since the
previous stop, `~` a result in flight."""

from __future__ import annotations

from rich import box
from rich.console import Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from netsushisen.debugger.expressions import hex_word, looks_float, reg_label
from netsushisen.debugger.view import (CHANGED, DIM, PENDING, _float_text, _panel, fit,
                                       in_flight)
from netsushisen.isa.words import wrap32



def register_rows(session, core, rows: int | None) -> tuple[list[int], int]:
    """Registers worth showing: changed since the previous stop, pending, the operands of the
    bundle at the focus, non-zero (in that priority when they do not all fit), in register
    order; and how many were left out."""
    from netsushisen.debugger.view import focus_pc

    prev = session.previous_regs.get(core.name, core.regs)
    changed = [r for r in range(1, len(core.regs)) if core.regs[r] != prev[r]]
    pending = sorted(in_flight(core))
    operands: list[int] = []
    if core.present and core.bundles:
        focus = min(focus_pc(core), len(core.bundles) - 1)
        for op in core.program.bundles[focus]:
            operands += [r for r in (*op.reads(), *op.writes()) if r and r not in operands]
    nonzero = [r for r in range(1, len(core.regs)) if core.regs[r]]
    chosen: list[int] = []
    for group in (changed, pending, operands, nonzero):
        for r in group:
            if r not in chosen:
                chosen.append(r)
    left = 0
    if rows is not None and len(chosen) > rows:
        left = len(chosen) - rows
        chosen = chosen[:rows]
    return sorted(chosen), left


def registers_table(session, core, regs: list[int]) -> Table:
    """The registers beside the listing: name (`pri/r29`), value (a float when the word looks
    like one, else the integer) and the raw word: three columns, so names and values stay
    whole in the panel's fixed width (`info registers` shows every view)."""
    prev = session.previous_regs.get(core.name, core.regs)
    t = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), show_edge=False)
    t.add_column("reg", no_wrap=True, overflow="ellipsis")
    t.add_column("value", justify="right", no_wrap=True)
    t.add_column("hex", no_wrap=True)
    flying = in_flight(core)
    for r in regs:
        w = core.regs[r]
        changed = w != prev[r]
        style = CHANGED if changed else (PENDING if r in flying else None)
        name = ("*" if changed else "~" if r in flying else " ") + reg_label(core, r)
        value = _float_text(core, w) if looks_float(core, w) else str(wrap32(w))
        t.add_row(name, value, hex_word(core, w), style=style)
    return t


def registers_panel(session, rows: int = 11, height: int | None = None) -> Panel:
    core = session.core
    regs, left = register_rows(session, core, rows)
    title = f"registers pe{session.pe}.{session.stage}  (* changed, ~ in flight)"
    if not regs:
        return _panel(Text("all registers are 0"), title, height)
    parts: list[RenderableType] = [registers_table(session, core, regs)]
    if left:
        parts.append(Text(f"... {left} more non-zero (info registers)", style=DIM))
    return _panel(Group(*parts), title, height)


class RegisterTable:
    """`info registers`: reg, int, hex and float columns, in as many groups side by side as
    the width holds (two at 120 columns, one at 80, registers down the columns)."""

    def __init__(self, session, core, regs: list[int], title: str):
        self.session, self.core, self.regs, self.title = session, core, regs, title

    def __rich_console__(self, console, options):
        core = self.core
        prev = self.session.previous_regs.get(core.name, core.regs)
        rows = []
        for r in self.regs:
            w = core.regs[r]
            rows.append((("*" if w != prev[r] else " ") + reg_label(core, r), str(wrap32(w)),
                         hex_word(core, w), _float_text(core, w)))
        widths = [max([len(h)] + [len(row[i]) for row in rows])
                  for i, h in enumerate(("reg", "int", "hex", "float"))]
        group_w = sum(widths) + 3 + 3  # gaps, and the space between groups
        groups = 1 if len(rows) <= 8 else max(1, min(2, options.max_width // group_w))
        per = -(-len(rows) // groups)
        title = self.title if groups == 2 else self.title.split(" (")[0] + " (* changed)"
        t = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), title=title)
        for _ in range(groups):
            for col in ("reg", "int", "hex", "float"):
                t.add_column(col, justify="left" if col in ("reg", "hex") else "right",
                             no_wrap=True)
        for i in range(per):
            cells: list[str] = []
            for g in range(groups):
                k = g * per + i
                cells += list(rows[k]) if k < len(rows) else ["", "", "", ""]
            t.add_row(*cells)
        yield t


class RegisterCells:
    """Registers packed as `*r9 3  ~r2 0.0  r1 1.5` cells, as many per line as the width
    holds, on at most `lines` lines: the small screen's registers (the same choice and marks
    as the table: changed, in flight, non-zero)."""

    def __init__(self, session, core, lines: int):
        self.session, self.core, self.lines = session, core, lines

    def cells(self, regs: list[int]) -> list[tuple[str, str]]:
        core = self.core
        prev = self.session.previous_regs.get(core.name, core.regs)
        flying = in_flight(core)
        out = []
        for r in regs:
            w = core.regs[r]
            changed = w != prev[r]
            mark = "*" if changed else "~" if r in flying else " "
            value = _float_text(core, w) if looks_float(core, w) else str(wrap32(w))
            out.append((f"{mark}{reg_label(core, r)} {value}",
                        CHANGED if changed else PENDING if r in flying else ""))
        return out

    def __rich_console__(self, console, options):
        width = options.max_width
        regs, _ = register_rows(self.session, self.core, None)
        if not regs:
            yield Text("all registers are 0", style=DIM)
            return
        cells = self.cells(regs)
        cell_w = min(max(len(c) for c, _ in cells) + 2, max(width, 1))
        per_line = max(1, width // cell_w)
        room = per_line * self.lines
        if len(cells) > room:  # the last cell says how many more
            cells = cells[:room - 1] + [(f"+{len(cells) - room + 1} more", DIM)]
        for i in range(0, len(cells), per_line):
            line = Text(no_wrap=True, overflow="crop")
            for text, style in cells[i:i + per_line]:
                line.append(f"{fit(text, cell_w - 2):<{cell_w}}", style=style or None)
            yield line


def register_cells_panel(session, lines: int, height: int | None = None) -> Panel:
    title = f"registers pe{session.pe}.{session.stage}  (* changed, ~ in flight)"
    return _panel(RegisterCells(session, session.core, lines), title, height)
