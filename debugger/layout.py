"""The debugger's screen: which panels show and how they share the terminal (gdb's TUI and
Ripes are the models: a fixed layout, redrawn in place, one stop per screen).

On a terminal of H lines the screen takes exactly `H - RESERVED` of them — the rest is for
what the stop printed (the breakpoint that fired, the displays) and the prompt — so a stop
never scrolls the listing away. Which panels show depends on the size (`layout auto`) or on
the `layout` command:

    auto    80x24 and smaller: listing + registers (packed as cells); below 64x18 line mode
            (no panels); from 30 lines: also
            scoreboard and FIFOs; from 36 lines and 110 columns: memory too; from 140
            columns: every panel (counters too)
    asm     the listing only          regs    listing + registers
    full    every panel               or a list of panel names (PANELS)

Where the width allows (110 columns), the registers stand beside the listing as a table;
otherwise they are packed below it. The listing always shows the marker, address, label and
every slot column of the viewed processor; only operands are cut to fit (view.Listing).

At 80x24 the header shrinks to two lines (the viewed processor, then the others in one), the
registers get four lines of `name/rN value` cells, and the listing adds the current bundle in
full under its rows whenever its columns cut an operand. Below MIN_WIDTH x MIN_HEIGHT there is
no room for panels: the screen degrades to line mode (`line_mode`: what the processor did, the
bundle in full, its source line), as `--no-screen` prints.

Off a terminal (`--batch`, a pipe) there is no height to fit: the panels are printed at their
natural height, as a scrolling log (every panel unless `layout` chose some).
"""

from __future__ import annotations

from rich.console import Group, RenderableType
from rich.table import Table
from rich.text import Text

from netsushisen.debugger import registers, view

PANELS = ("listing", "registers", "scoreboard", "fifos", "memory", "counters")
PRESETS = {"asm": ("listing",), "regs": ("listing", "registers"), "full": PANELS}
RESERVED = 4  # terminal lines left below the screen: the stop's messages and the prompt
WIDE = 110  # from this width the registers stand beside the listing
LOWER = ("scoreboard", "fifos", "memory", "counters")
MIN_WIDTH, MIN_HEIGHT = 64, 18  # below either: line mode
COMPACT = 30  # below this height the header takes two lines


def line_mode(session, width: int) -> RenderableType:
    """The screen of a terminal too small for panels: the stop in a few lines."""
    core = session.core
    lines = [view.where_line(session)]
    if core.present:
        focus = min(view.focus_pc(core), len(core.bundles) - 1)
        if not core.last_issued:
            lines.append(Text(f"{focus}: {view.bundle_text(core.program, focus)}"))
        text = view.source_text(core.program, focus)
        if text:
            lines.append(Text(text, style=view.DIM))
    return Group(*lines)


def choose_panels(layout, width: int, height: int | None) -> tuple[str, ...]:
    """The panels a layout shows at a size (`layout` is a preset name or panel names)."""
    if not isinstance(layout, str):
        return tuple(p for p in PANELS if p in layout)
    if layout in PRESETS:
        return PRESETS[layout]
    if height is None or (height >= 36 and width >= 140):
        return PANELS
    if height >= 36 and width >= WIDE:  # four lower panels would cut each other's lines
        return ("listing", "registers", "scoreboard", "fifos", "memory")
    if height >= 30:
        return ("listing", "registers", "scoreboard", "fifos")
    return ("listing", "registers")


def _row(panels: list[RenderableType], ratios: list[int | str]) -> Table:
    """Panels side by side; a ratio that is a name is a fixed-width column (FIXED)."""
    grid = Table.grid(expand=True)
    for r in ratios:
        if isinstance(r, str):  # a fixed-width column
            grid.add_column(width=FIXED[r])
        else:
            grid.add_column(ratio=r)
    grid.add_row(*panels)
    return grid


_LOWER_MAKERS = {"scoreboard": view.scoreboard_panel, "fifos": view.fifo_panel,
                 "memory": view.memory_panel, "counters": view.counters_panel}
_LOWER_RATIO = {"scoreboard": 4, "fifos": "fifos", "memory": 4, "counters": 3}
FIXED = {"fifos": 42,  # name (link.os-ic.0), words/capacity, bar, peak: never cut
         "registers": 48}  # reg, int, hex, float: the listing takes the rest of the width


def screen(session, width: int, height: int | None = None, layout="auto") -> RenderableType:
    """The screen for a terminal of `width` x `height` (height None: natural heights)."""
    chosen = choose_panels(layout, width, height)
    lower = [p for p in LOWER if p in chosen]
    wide = width >= WIDE
    if height is None:
        return _natural(session, chosen, lower, wide, width)
    compact = height < COMPACT
    room = height - RESERVED - view.header_height(session, compact)
    # the lower panels: one row beside each other when wide, rows of two when narrow
    lower_rows = [lower] if wide else [lower[i:i + 2] for i in range(0, len(lower), 2)]
    lower_rows = [r for r in lower_rows if r]
    lower_h = 12 if room >= 40 else 9 if room >= 30 else 7
    regs_below = "registers" in chosen and not wide
    regs_lines = 4 if room >= 15 else 2
    regs_h = regs_lines + 2 if regs_below else 0
    # the listing needs at least 3 bundles (7 lines with its borders, header, source line):
    # lower panels give way first, when the layout is auto
    while lower_rows and room - regs_h - lower_h * len(lower_rows) < 7:
        lower_rows.pop()
    listing_h = max(room - regs_h - lower_h * len(lower_rows), 5)
    parts: list[RenderableType] = [view.header(session, compact)]
    listing_w = width - FIXED["registers"] if "registers" in chosen and wide else width
    listing = view.listing_panel(session, rows=listing_h - 4, height=listing_h,
                                 width=listing_w) if "listing" in chosen else None
    if "registers" in chosen and wide:
        regs = registers.registers_panel(session, rows=listing_h - 4, height=listing_h)
        parts.append(_row([listing, regs], [1, "registers"]) if listing is not None else regs)
    elif listing is not None:
        parts.append(listing)
    if regs_below:
        parts.append(registers.register_cells_panel(session, regs_lines, height=regs_h))
    for row in lower_rows:
        parts.append(_row([_LOWER_MAKERS[p](session, height=lower_h) for p in row],
                          [_LOWER_RATIO[p] for p in row]))
    return Group(*parts)


def _natural(session, chosen, lower, wide: bool, width: int) -> RenderableType:
    """The scrolling log's screen: every chosen panel at its natural height."""
    parts: list[RenderableType] = [view.header(session)]
    listing_w = width - FIXED["registers"] if "registers" in chosen and wide else width
    listing = view.listing_panel(session, 11, width=listing_w) if "listing" in chosen else None
    regs = registers.registers_panel(session, 12) if "registers" in chosen else None
    if listing is not None and regs is not None and wide:
        parts.append(_row([listing, regs], [1, "registers"]))
    else:
        parts += [p for p in (listing, regs) if p is not None]
    panels = [_LOWER_MAKERS[p](session) for p in lower]
    if wide and len(panels) == 4:  # scoreboard, fifos, memory over counters
        parts.append(_row([panels[0], panels[1], Group(panels[2], panels[3])], [4, "fifos", 3]))
    else:
        for i in range(0, len(panels), 2):
            pair = lower[i:i + 2]
            parts.append(_row(panels[i:i + 2], ["fifos" if p == "fifos" else 1 for p in pair]))
    return Group(*parts)
