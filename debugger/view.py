"""The debugger's screen, as rich renderables: listing, registers, scoreboard, FIFOs, memory,
counters. On a terminal they are coloured; printed to a file or a pipe (`--batch`) the same
panels come out as plain text, with markers standing in for colour:

    =>  the bundle the viewed processor issued in the last cycle
    !>  the bundle it stalled on in the last cycle (the stall's PC)
    ->  its PC (the next bundle to issue)
    B1  breakpoint 1 is on this bundle
    *   a register changed since the previous stop
    ~   a register with a result in flight (the scoreboard panel says when it lands)
"""

from __future__ import annotations

from rich import box
from rich.console import Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from netsushisen.asm.listing import slot_assignment
from netsushisen.debugger.expressions import hex_word
from netsushisen.isa.words import wrap32

ISSUED = "bold black on green"
STALLED = "bold white on red"
CHANGED = "bold yellow"
PENDING = "cyan"
DIM = "dim"


def _panel(body: RenderableType, title: str) -> Panel:
    return Panel(body, title=title, title_align="left", box=box.ROUNDED, padding=(0, 1))


def _float_text(core, word: int) -> str:
    return str(core.value(word, "f"))


def _reg_name(r: int) -> str:
    return {0: "r0", 63: "lr"}.get(r, f"r{r}")


def in_flight(core) -> dict[int, tuple[int, int]]:
    """Registers with a result in flight: register -> (cycle it is written, word)."""
    return {r: (t, w) for t, writes in core.pending.items() for r, w in writes}


# ---------------------------------------------------------------------------------------------
# Header: the cycle and what every processor of the PE did in it


def describe_core(core) -> str:
    if not core.present:
        return "no program"
    if core.last_issued:
        return f"issued {core.where(core.last_pc)}" + (", halted" if core.halted else "")
    if core.halted:
        return f"halted ({core.where(core.pc)})"
    if not core.cause:
        return f"at {core.where(core.pc)}, not started"
    return f"stall {core.cause} at {core.where(core.last_pc)}"


def header(session) -> RenderableType:
    m = session.machine
    status = m.status or "running"
    last = f"last cycle {m.cycle - 1}" if m.cycle else "before cycle 0"
    title = Text.assemble(("netsushisen debug", "bold"), f"  pe{session.pe}.{session.stage}  ",
                          (f"{last} ({m.cycle} cycles run)", "bold"), f"  status {status}")
    t = Table(box=None, show_header=False, pad_edge=False, padding=(0, 1))
    t.add_column(no_wrap=True)
    t.add_column()
    for stage, core in m.pes[session.pe].cores.items():
        mark = "*" if stage == session.stage else " "
        style = "bold" if stage == session.stage else ""
        t.add_row(Text(f"{mark}{stage.upper()}", style=style), describe_core(core))
    return Group(title, t)


def where_line(session) -> Text:
    """One line for a stop when the panels are off: the cycle and what the viewed processor did."""
    m = session.machine
    core = session.core
    last = f"cycle {m.cycle - 1}" if m.cycle else "before cycle 0"
    text = f"[{last}] pe{session.pe}.{session.stage} {describe_core(core)}"
    if core.present and core.last_issued:
        text += ": " + bundle_text(core.program, core.last_pc)
    return Text(text)


def bundle_text(program, pc: int) -> str:
    labels = program.code_labels()
    return " ; ".join(op.format(labels) for op in program.bundles[pc]) or "nop"


# ---------------------------------------------------------------------------------------------
# Listing


def bundle_cells(program, pc: int) -> list[str]:
    labels = program.code_labels()
    bundle = program.bundles[pc]
    if program.processor.vliw:
        return [op.format(labels) if op else "-" for _, op in slot_assignment(program, bundle)]
    return [" ; ".join(op.format(labels) for op in bundle) or "nop"]


def slot_names(program) -> list[str]:
    if not program.bundles:
        return []
    return [name for name, _ in slot_assignment(program, ())] if program.processor.vliw \
        else ["gen0"]


def listing_table(session, core, start: int, end: int, focus: bool = True) -> Table:
    program = core.program
    t = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), show_edge=False)
    t.add_column("", no_wrap=True)
    t.add_column("addr", justify="right", no_wrap=True)
    t.add_column("label", no_wrap=True, max_width=14)
    for name in slot_names(program):
        t.add_column(name, no_wrap=True, overflow="ellipsis")
    bps: dict[int, list[int]] = {}
    pe = session.pe
    for bp in session.breakpoints.values():
        if bp.stage == core.proc.name and bp.pe in (None, pe):
            bps.setdefault(bp.address, []).append(bp.number)
    by_addr: dict[int, str] = {}
    for name, (section, addr) in sorted(program.labels.items()):
        if section == "text":
            by_addr.setdefault(addr, name)
    issued = core.last_pc if (focus and core.last_issued) else None
    stalled = core.last_pc if (focus and not core.last_issued and core.cause
                               and not core.halted) else None
    for pc in range(start, end):
        mark = "  "
        style = ""
        if pc == issued:
            mark, style = "=>", ISSUED
        elif pc == stalled:
            mark, style = "!>", STALLED
        elif focus and pc == core.pc and not core.halted:
            mark = "->"
        bp = ",".join(f"B{n}" for n in bps.get(pc, []))
        t.add_row(Text(f"{mark}{bp}", style=style), str(pc), by_addr.get(pc, ""),
                  *bundle_cells(program, pc), style=style or None)
    return t


def focus_pc(core) -> int:
    if core.last_issued or (core.cause and not core.halted):
        return core.last_pc
    return core.pc


def listing_panel(session, rows: int = 11) -> Panel:
    core = session.core
    title = f"listing pe{session.pe}.{session.stage}"
    if not core.present:
        return _panel(Text("(no program on this processor)"), title)
    n = len(core.bundles)
    focus = min(focus_pc(core), n - 1)
    start = max(0, min(focus - rows // 3, n - rows))
    end = min(n, start + rows)
    t = listing_table(session, core, start, end)
    parts: list[RenderableType] = [t]
    smap = core.program.source_map
    if focus < len(smap):
        loc = smap[focus]
        parts.append(Text(f"{loc.file}:{loc.line}: {loc.text.strip()}", style=DIM,
                          overflow="ellipsis", no_wrap=True))
    legend = "=> issued  !> stalled  -> next"
    return _panel(Group(*parts), f"{title}  ({legend})")


# ---------------------------------------------------------------------------------------------
# Registers


def register_rows(session, core, rows: int | None) -> tuple[list[int], int]:
    """Registers worth showing: changed since the previous stop, pending, non-zero (in that
    priority when they do not all fit), in register order; and how many were left out."""
    prev = session.previous_regs.get(core.name, core.regs)
    changed = [r for r in range(1, len(core.regs)) if core.regs[r] != prev[r]]
    pending = sorted(in_flight(core))
    nonzero = [r for r in range(1, len(core.regs)) if core.regs[r]]
    chosen: list[int] = []
    for group in (changed, pending, nonzero):
        for r in group:
            if r not in chosen:
                chosen.append(r)
    left = 0
    if rows is not None and len(chosen) > rows:
        left = len(chosen) - rows
        chosen = chosen[:rows]
    return sorted(chosen), left


def registers_table(session, core, regs: list[int]) -> Table:
    prev = session.previous_regs.get(core.name, core.regs)
    t = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), show_edge=False)
    t.add_column("reg", no_wrap=True)
    t.add_column("int", justify="right", no_wrap=True)
    t.add_column("hex", no_wrap=True)
    t.add_column("float", justify="right", no_wrap=True)
    flying = in_flight(core)
    for r in regs:
        w = core.regs[r]
        changed = w != prev[r]
        style = CHANGED if changed else (PENDING if r in flying else None)
        name = ("*" if changed else "~" if r in flying else " ") + _reg_name(r)
        t.add_row(name, str(wrap32(w)), hex_word(core, w), _float_text(core, w), style=style)
    return t


def registers_panel(session, rows: int = 11) -> Panel:
    core = session.core
    regs, left = register_rows(session, core, rows)
    title = f"registers pe{session.pe}.{session.stage}  (* changed, ~ in flight)"
    if not regs:
        return _panel(Text("all registers are 0"), title)
    parts: list[RenderableType] = [registers_table(session, core, regs)]
    if left:
        parts.append(Text(f"... {left} more non-zero (info registers)", style=DIM))
    return _panel(Group(*parts), title)


# ---------------------------------------------------------------------------------------------
# Scoreboard


def scoreboard_table(session, core) -> Table | None:
    """Results in flight: register, producing op and PC, the cycle it is written, the value."""
    origin = session.aux.get(core.name, {}).get("origin", {})
    rows = []
    for t in sorted(core.pending):
        for r, w in core.pending[t]:
            src = origin.get(r)
            by = f"{core.producer[r]} pc {src[0]}" if src else core.producer[r]
            rows.append((_reg_name(r), by, str(t), str(wrap32(w)), _float_text(core, w)))
    if not rows:
        return None
    tab = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), show_edge=False)
    for col in ("reg", "from", "ready", "int", "float"):
        tab.add_column(col, no_wrap=True, justify="right" if col in ("ready", "int", "float")
                       else "left")
    for row in rows:
        tab.add_row(*row, style=PENDING)
    return tab


def scoreboard_lines(session, core) -> list[RenderableType]:
    now = session.machine.cycle
    out: list[RenderableType] = []
    tab = scoreboard_table(session, core)
    if tab is not None:
        out.append(tab)
    if core.hold_until > now and not core.halted:
        cause = core.hold_cause if now < core.hold_mem_until else "branch"
        out.append(Text(f"issue held until cycle {core.hold_until} ({cause or 'branch'}, "
                        f"pc {core.hold_pc})"))
    for unit, until in core.busy.items():
        for i, t in enumerate(until):
            if t > now:
                out.append(Text(f"unit {unit}{i} busy until cycle {t} ({core.occupant[unit][i]})"))
    return out


def scoreboard_panel(session) -> Panel:
    lines = scoreboard_lines(session, session.core)
    return _panel(Group(*lines) if lines else Text("nothing pending", style=DIM),
                  f"scoreboard pe{session.pe}.{session.stage}")


# ---------------------------------------------------------------------------------------------
# FIFOs


def fifo_table(session, all_fifos: bool = False, head: bool = True) -> Table:
    """The PE's FIFOs: occupancy/capacity with a bar, peak, and the word at the head. Link
    channels that never carried a word are left out unless `all_fifos`."""
    ring = session.machine.pes[session.pe].ring
    t = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), show_edge=False)
    t.add_column("fifo", no_wrap=True)
    t.add_column("words", justify="right", no_wrap=True)
    t.add_column("", no_wrap=True)
    t.add_column("peak", justify="right", no_wrap=True)
    if head:
        t.add_column("head", no_wrap=True)
    core = session.core
    for f in ring.fifos():
        if not all_fifos and ".link." in f.name and f.total == 0 and not len(f):
            continue
        n = len(f)
        width = 6
        filled = round(width * n / f.capacity) if f.capacity else 0
        if n and not filled:
            filled = 1
        row = [f.name.split(".", 1)[1], f"{n}/{f.capacity}", "#" * filled + "." * (width - filled),
               str(f.peak)]
        if head:
            row.append(hex_word(core, f.q[0][1]) if n else "")
        t.add_row(*row, style="bold" if n else None)
    return t


def fifo_panel(session) -> Panel:
    return _panel(fifo_table(session, head=False), f"fifos pe{session.pe}")


# ---------------------------------------------------------------------------------------------
# Memory


def memory_lines(session, core) -> list[str]:
    mem = session.machine.pes[session.pe].memories[core.proc.name]
    aux = session.aux.get(core.name, {})
    lines = [f"local: {mem.local.reads} reads, {mem.local.writes} writes"]
    if mem.resident is not None:
        lines.append(f"resident: {mem.resident.reads} hits, {mem.resident.size} words")
        last = aux.get("ldr")
        if last:
            lines.append(f"  last ldr resident[{last[0]}] (cycle {last[1]})")
    cache = mem.cache
    if cache is not None:
        lines.append(f"cache: {cache.sets} sets x {cache.block_bytes} B")
        rate = f" ({100 * cache.hits / cache.accesses:.0f}% hits)" if cache.accesses else ""
        lines.append(f"  {cache.accesses} ldg: {cache.hits} hits, {cache.misses} misses{rate}")
        last = aux.get("ldg")
        if last:
            addr, s, hit, c = last
            gname = "icgm" if core.proc.name == "ic" else "scgm"
            lines.append(f"  last ldg {gname}[{addr}] (cycle {c}): {'hit' if hit else 'miss'}")
            if s >= 0:
                tag = int(cache.tags[s])
                block = tag * cache.sets + s
                words = cache.block_bytes // cache.word_bytes
                lines.append(f"  set {s}: tag {tag}, {gname}[{block * words}..{block * words + words - 1}]")
    return lines


def memory_panel(session) -> Panel:
    core = session.core
    return _panel(Text("\n".join(memory_lines(session, core))),
                  f"memory pe{session.pe}.{session.stage}")


# ---------------------------------------------------------------------------------------------
# Counters


def counter_lines(session, core) -> list[str]:
    ipc = core.ops / core.cycles if core.cycles else 0.0
    stalls = sum(core.stalls.values())
    lines = [f"{core.cycles} cycles, {core.bundles_issued} bundles, {core.ops} ops",
             f"{ipc:.2f} ops/cycle, {stalls} stall cycles"]
    for cause, n in sorted(core.stalls.items(), key=lambda kv: (-kv[1], kv[0]))[:4]:
        lines.append(f"  {cause}: {n}")
    m = session.machine
    lines.append(f"DIS {m.dis.words_sent} words, COL {m.col.messages} pixels")
    return lines


def counters_panel(session) -> Panel:
    return _panel(Text("\n".join(counter_lines(session, session.core))),
                  f"counters pe{session.pe}.{session.stage}")


# ---------------------------------------------------------------------------------------------
# The whole screen


def screen(session, width: int, height: int | None = None) -> RenderableType:
    rows = 11
    if height:  # fit the terminal: the listing and registers take what the rest leaves
        rows = max(5, min(24, height - 30))
    top = [header(session)]
    listing = listing_panel(session, rows)
    regs = registers_panel(session, rows + 1)
    lower = [scoreboard_panel(session), fifo_panel(session), memory_panel(session),
             counters_panel(session)]
    if width >= 150:
        g1 = Table.grid(expand=True)
        g1.add_column(ratio=3)
        g1.add_column(ratio=2)
        g1.add_row(listing, regs)
        g2 = Table.grid(expand=True)
        g2.add_column(ratio=4)
        g2.add_column(ratio=3)
        g2.add_column(ratio=3)
        g2.add_row(lower[0], lower[1], Group(lower[2], lower[3]))
        return Group(*top, g1, g2)
    g2 = Table.grid(expand=True)
    g2.add_column(ratio=1)
    g2.add_column(ratio=1)
    g2.add_row(lower[0], lower[1])
    g2.add_row(lower[2], lower[3])
    if width >= 110:
        g1 = Table.grid(expand=True)
        g1.add_column(ratio=3)
        g1.add_column(ratio=2)
        g1.add_row(listing, regs)
        return Group(*top, g1, g2)
    return Group(*top, listing, regs, g2)
