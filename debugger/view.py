"""The debugger's screen, as rich renderables: listing, registers, scoreboard, FIFOs, memory,
counters. On a terminal they are coloured; printed to a file or a pipe (`--batch`) the same
panels come out as plain text, with markers standing in for colour:

    =>  the bundle the viewed processor issued in the last cycle
    !>  the bundle it stalled on in the last cycle (the stall's PC)
    ->  its PC (the next bundle to issue)
    B1  breakpoint 1 is on this bundle (T2: temporary breakpoint 2; b1, t2: disabled)
    *   a register changed since the previous stop
    ~   a register with a result in flight (the scoreboard panel says when it lands)

Panels take an optional height (the fixed-layout screen gives each its share, layout.py); the
listing (`Listing`) and the packed registers (`registers.RegisterCells`) lay themselves out for the
width they get.
"""

from __future__ import annotations

from rich import box
from rich.console import Group, RenderableType
from rich.measure import Measurement
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from netsushisen.asm.listing import slot_assignment, target_names
from netsushisen.asm.regnames import named_text, register_names
from netsushisen.debugger.expressions import bundle_lines, hex_word, looks_float, reg_label
from netsushisen.isa.stalls import BRANCH
from netsushisen.isa.words import wrap32

ISSUED = "bold black on green"
STALLED = "bold white on red"
CHANGED = "bold yellow"
PENDING = "cyan"
DIM = "dim"


def _panel(body: RenderableType, title: str, height: int | None = None) -> Panel:
    """A titled panel; with `height`, exactly that many lines (the fixed-layout screen)."""
    return Panel(body, title=title, title_align="left", box=box.ROUNDED, padding=(0, 1),
                 height=height)


def _float_text(core, word: int) -> str:
    return str(core.value(word, "f"))




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


def header(session, compact: bool = False) -> RenderableType:
    """The cycle and status, then one line per processor of the PE that has a program (and the
    viewed one, `*`): what it did in the last cycle. Compact (a short terminal): the viewed
    processor's line, then the others together on one."""
    m = session.machine
    status = m.status or "running"
    last = f"last cycle {m.cycle - 1}" if m.cycle else "before cycle 0"
    title = Text.assemble(("netsushisen debug", "bold"), f"  pe{session.pe}.{session.stage}  ",
                          (f"{last} ({m.cycle} cycles run)", "bold"), f"  status {status}")
    title.no_wrap, title.overflow = True, "ellipsis"
    lines: list[RenderableType] = [title]
    others = []
    for stage, core in m.pes[session.pe].cores.items():
        if not core.present and stage != session.stage:
            continue
        mark = "*" if stage == session.stage else " "
        if compact and mark == " ":
            others.append(f"{stage.upper()} {describe_core(core)}")
            continue
        lines.append(Text.assemble((f"{mark}{stage.upper()}", "bold" if mark == "*" else ""),
                                   "  " + describe_core(core), no_wrap=True, overflow="ellipsis"))
    if others:
        lines.append(Text(" " + "; ".join(others), style=DIM, no_wrap=True, overflow="ellipsis"))
    return Group(*lines)


def header_height(session, compact: bool = False) -> int:
    cores = session.machine.pes[session.pe].cores
    shown = sum(1 for s, c in cores.items() if c.present or s == session.stage)
    return 1 + (min(shown, 2) if compact else shown)


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
    """The bundle as one line, branch targets as labels and registers as `pri/r29`."""
    return named_text(program, pc, targets(program)) or "nop"


_TARGETS: dict[int, tuple[object, dict[int, str]]] = {}


def targets(program) -> dict[int, str]:
    """`asm.listing.target_names` of a program, computed once per program: branch targets
    print as `loop` or `loop+4`, never as bare addresses when a label precedes them."""
    hit = _TARGETS.get(id(program))
    if hit is None or hit[0] is not program:
        hit = _TARGETS[id(program)] = (program, target_names(program))
    return hit[1]


# ---------------------------------------------------------------------------------------------
# Listing


def bundle_cells(program, pc: int) -> list[str]:
    labels = targets(program)
    regs = register_names(program).labels(pc)
    bundle = program.bundles[pc]
    if program.processor.vliw:
        return [op.format(labels, regs) if op else "-"
                for _, op in slot_assignment(program, bundle)]
    return [" ; ".join(op.format(labels, regs) for op in bundle) or "nop"]


def line_numbers(lines: list[tuple[str, int]]) -> str:
    """Source line numbers as a short text: `7-9`, `10,12`."""
    nums = sorted({ln for _, ln in lines})
    parts, i = [], 0
    while i < len(nums):
        j = i
        while j + 1 < len(nums) and nums[j + 1] == nums[j] + 1:
            j += 1
        parts.append(str(nums[i]) if i == j else f"{nums[i]}-{nums[j]}")
        i = j + 1
    return ",".join(parts)


def scheduled(program) -> bool:
    """Whether a `.sched` region made the program's layout: some bundle holds several source
    lines (then the listing shows each bundle's lines: one line is no longer one bundle)."""
    return any(len({(s.file, s.line) for s in ops}) > 1 for ops in program.op_sources)


def display_file(path: str) -> str:
    """A source file as the screen names it: relative to the bundled kernels' folder
    (`ic_polygon.inc`), else to the working folder, else as given — the installed path of a
    kernel would leave no room for its source text at 80 columns."""
    import os

    from netsushisen.kernels import KERNELS

    for base in (str(KERNELS.resolve()), os.getcwd()):
        full = os.path.abspath(path)
        if full.startswith(base + os.sep):
            return os.path.relpath(full, base)
    return path


def source_text(program, pc: int) -> str:
    """The source of bundle `pc` as one line: `k.s:7,9: fadd r3, a, b | fmul r7, r5, r5`."""
    lines = bundle_lines(program, pc)
    if not lines:
        return ""
    ops = program.op_sources[pc] if pc < len(program.op_sources) else ()
    if len(lines) > 1 and ops:
        texts = list(dict.fromkeys(s.text.strip() for s in ops))
        return f"{display_file(lines[0][0])}:{line_numbers(lines)}: {' | '.join(texts)}"
    loc = program.source_map[pc]
    return f"{display_file(loc.file)}:{loc.line}: {loc.text.strip()}"


def slot_names(program) -> list[str]:
    """Every issue slot of the processor (IC: int0 fp0 fp1 fp2), the listing's columns."""
    if not program.processor.vliw:
        return ["gen0"]
    return [name for name, _ in slot_assignment(program, ())]


def breakpoint_marks(session, core) -> dict[int, str]:
    """Address -> `B1`, `B1,T3` (T: a temporary breakpoint), lower case when disabled."""
    marks: dict[int, list[str]] = {}
    for bp in session.breakpoints.values():
        if bp.stage == core.proc.name and bp.pe in (None, session.pe):
            letter = "T" if bp.temporary else "B"
            marks.setdefault(bp.address, []).append(
                (letter if bp.enabled else letter.lower()) + str(bp.number))
    return {a: ",".join(m) for a, m in marks.items()}


def fit(text: str, width: int) -> str:
    """`text` in at most `width` characters, cut with an ellipsis (operands are abbreviated,
    never the columns that orient the reader)."""
    if len(text) <= width:
        return text
    return text[:max(width - 1, 0)] + "…" if width > 0 else ""


def share_widths(natural: list[int], room: int, least: int = 3) -> list[int]:
    """Column widths that fit `room`: every column its natural width when they all fit, else
    the narrow ones keep theirs and the wide ones share what is left equally (never below
    `least`: a slot's name, `fp2`, stays readable)."""
    if sum(natural) <= room:
        return list(natural)
    widths = [0] * len(natural)
    left = room
    order = sorted(range(len(natural)), key=lambda i: natural[i])
    for k, i in enumerate(order):
        share = left // (len(natural) - k)
        widths[i] = max(least, min(natural[i], share))
        left -= widths[i]
    return widths


class Listing:
    """Bundles `start..end-1` of a processor as fixed columns: marker (`=>`, `!>`, `->`, then
    breakpoint marks), address, label, and one column per issue slot. It lays itself out for
    the width it is given: the marker, address and label columns keep their full width, every
    slot column stays, and only the operands are cut (`…`)."""

    LABEL_MAX = 16

    def __init__(self, session, core, start: int, end: int, focus: bool = True):
        self.session, self.core, self.start, self.end, self.focus = session, core, start, end, focus
        self.lines_column = core.program is not None and scheduled(core.program)

    def rows(self) -> list[tuple[str, str, str, list[str], str]]:
        core, program = self.core, self.core.program
        bps = breakpoint_marks(self.session, core)
        by_addr = program.code_labels()
        focus = self.focus
        issued = core.last_pc if (focus and core.last_issued) else None
        stalled = core.last_pc if (focus and not core.last_issued and core.cause
                                   and not core.halted) else None
        out = []
        for pc in range(self.start, self.end):
            mark, style = "", ""
            if pc == issued:
                mark, style = "=>", ISSUED
            elif pc == stalled:
                mark, style = "!>", STALLED
            elif focus and pc == core.pc and not core.halted:
                mark = "->"
            mark = (mark or "  ") + bps.get(pc, "")
            label = by_addr.get(pc, "")
            if self.lines_column:
                label = (line_numbers(bundle_lines(program, pc)), label)
            out.append((mark.rstrip(), str(pc), label, bundle_cells(program, pc), style))
        return out

    def cut(self, pc: int, width: int) -> bool:
        """Whether the row of bundle `pc` loses operand text at this width."""
        for text in self.lines(width):
            cells = text.plain.split()
            if len(cells) > 1 and (cells[0] == str(pc) or cells[1] == str(pc)):
                return "…" in text.plain or len(text.plain) >= width
        return False

    def lines(self, width: int) -> list[Text]:
        rows = self.rows()
        if self.lines_column:  # a scheduled program: each bundle's source lines by its address
            src_w = max([4] + [len(r[2][0]) for r in rows])
            rows = [(m, f"{a:>4} {lab[0]:<{src_w}}", lab[1], c, st)
                    for m, a, lab, c, st in rows]
            head_addr = f"{'addr':>4} {'line':<{src_w}}"
        else:
            head_addr = "addr"
        names = slot_names(self.core.program)
        mark_w = max([4] + [len(r[0]) for r in rows])  # room for =>B1: columns stay put
        addr_w = max([4] + [len(r[1]) for r in rows])
        label_w = min(self.LABEL_MAX, max([5] + [len(r[2]) for r in rows]))
        fixed = mark_w + 1 + addr_w + 1 + label_w + 1
        natural = [max([len(n)] + [len(r[3][i]) for r in rows]) for i, n in enumerate(names)]
        gap = 2 if sum(natural) + 2 * (len(names) - 1) <= width - fixed else 1
        room = width - fixed - gap * (len(names) - 1)
        widths = share_widths(natural, room)
        if sum(widths) > room:  # very narrow: the label gives way before the slots do
            label_w = max(5, label_w - (sum(widths) - room))

        def line(mark, addr, label, cells):
            text = (f"{mark:<{mark_w}} {addr:>{addr_w}} {fit(label, label_w):<{label_w}} "
                    + (" " * gap).join(f"{fit(c, w):<{w}}" for c, w in zip(cells, widths)))
            return text.rstrip()

        out = [Text(line("", head_addr, "label", names), style="bold", no_wrap=True,
                    overflow="crop")]
        for mark, addr, label, cells, style in rows:
            out.append(Text(line(mark, addr, label, cells), style=style, no_wrap=True,
                            overflow="crop"))
        return out

    def __rich_console__(self, console, options):
        yield from self.lines(options.max_width)

    def __rich_measure__(self, console, options):
        widest = max((len(t.plain) for t in self.lines(10_000)), default=1)
        return Measurement(min(widest, 30), widest)


def focus_pc(core) -> int:
    if core.last_issued or (core.cause and not core.halted):
        return core.last_pc
    return core.pc


def listing_window(core, rows: int) -> tuple[int, int]:
    """The bundles a listing of `rows` rows shows: the focus a third of the way down."""
    n = len(core.bundles)
    focus = min(focus_pc(core), n - 1)
    start = max(0, min(focus - rows // 3, n - rows))
    return start, min(n, start + rows)


def listing_panel(session, rows: int = 11, height: int | None = None,
                  width: int | None = None) -> Panel:
    """The listing around the focus bundle and its source line. Given the panel's `width`,
    when the slot columns cut an operand of the focus bundle, that bundle follows in full
    (wrapped, `=> 5: fadd sum/r6, ...`), its lines taken from the rows."""
    core = session.core
    title = f"listing pe{session.pe}.{session.stage}"
    if not core.present:
        return _panel(Text("(no program on this processor)"), title, height)
    focus = min(focus_pc(core), len(core.bundles) - 1)
    full = None
    if width is not None:
        start, end = listing_window(core, rows)
        if Listing(session, core, start, end).cut(focus, width - 4):
            mark = "=>" if core.last_issued else "!>" if core.cause and not core.halted else "->"
            full = Text(f"{mark} {focus}: {bundle_text(core.program, focus)}", style="bold")
            rows -= max(1, -(-len(full.plain) // max(width - 4, 1)))
    text = source_text(core.program, focus)
    if text and width is not None:  # the source line whole, wrapped: the listing gives room
        rows -= max(0, -(-len(text) // max(width - 4, 1)) - 1)
    start, end = listing_window(core, max(rows, 1))
    parts: list[RenderableType] = [Listing(session, core, start, end)]
    if full is not None:
        parts.append(full)
    if text:
        parts.append(Text(text, style=DIM))
    legend = "=> issued  !> stalled  -> next  B1 breakpoint"
    return _panel(Group(*parts), f"{title}  ({legend})", height)


# ---------------------------------------------------------------------------------------------
# Scoreboard


def scoreboard_table(session, core) -> Table | None:
    """Results in flight: register, producing op and PC, the cycle it is written, the value
    (as a float when the word looks like one, else as an integer: one column, so the table
    fits a third of a screen)."""
    origin = session.aux.get(core.name, {}).get("origin", {})
    rows = []
    for t in sorted(core.pending):
        for r, w in core.pending[t]:
            src = origin.get(r)
            by = f"{core.producer[r]} pc {src[0]}" if src else core.producer[r]
            value = _float_text(core, w) if looks_float(core, w) else str(wrap32(w))
            rows.append((reg_label(core, r), by, str(t), value))
    if not rows:
        return None
    tab = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1), show_edge=False)
    for col in ("reg", "from", "ready", "value"):
        tab.add_column(col, no_wrap=True, justify="right" if col in ("ready", "value")
                       else "left", overflow="ellipsis")
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
        cause = core.hold_cause if now < core.hold_mem_until else BRANCH
        out.append(Text(f"issue held until cycle {core.hold_until} ({cause or 'branch'}, "
                        f"pc {core.hold_pc})"))
    for unit, until in core.busy.items():
        for i, t in enumerate(until):
            if t > now:
                out.append(Text(f"unit {unit}{i} busy until cycle {t} ({core.occupant[unit][i]})"))
    return out


def scoreboard_panel(session, height: int | None = None) -> Panel:
    lines = scoreboard_lines(session, session.core)
    return _panel(Group(*lines) if lines else Text("nothing pending", style=DIM),
                  f"scoreboard pe{session.pe}.{session.stage}", height)


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


def fifo_panel(session, height: int | None = None) -> Panel:
    return _panel(fifo_table(session, head=False), f"fifos pe{session.pe}", height)


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


def memory_panel(session, height: int | None = None) -> Panel:
    core = session.core
    return _panel(Text("\n".join(memory_lines(session, core)), no_wrap=True, overflow="ellipsis"),
                  f"memory pe{session.pe}.{session.stage}", height)


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


def counters_panel(session, height: int | None = None) -> Panel:
    return _panel(Text("\n".join(counter_lines(session, session.core)), no_wrap=True,
                       overflow="ellipsis"), f"counters pe{session.pe}.{session.stage}", height)
