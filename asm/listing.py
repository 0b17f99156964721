"""Listings and static ILP: what a kernel writer reads to judge a schedule.

A listing shows every bundle with its address, the operations placed in their unit slots, and
the source line. Static ILP counts what the schedule offers before any stall: operations per
bundle, how full each unit class's slots are, and how much of the register-file ports it uses.
(The emulator's statistics give the dynamic ILP, after stalls.)
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.asm.checker import bundle_usage
from netsushisen.asm.objects import Op, Program, format_float
from netsushisen.asm.parser import _code_part
from netsushisen.asm.regnames import register_names


def slot_assignment(program: Program, bundle: tuple[Op, ...]) -> list[tuple[str, Op | None]]:
    """The bundle's ops placed in unit slots (int0, int1, fp0, ... / gen0) in written order;
    empty slots shown as None so a listing shows every slot."""
    proc = program.processor
    slots: dict[str, list[Op]] = {u: [] for u in proc.units}
    for op in bundle:
        if op.opcode.kind == "nop":
            continue
        slots[proc.unit(op.opcode.unit)].append(op)
    out: list[tuple[str, Op | None]] = []
    for unit, count in proc.units.items():
        placed = slots[unit]
        for i in range(count):
            out.append((f"{unit}{i}", placed[i] if i < len(placed) else None))
        for j, extra in enumerate(placed[count:], start=count):  # only in unchecked programs
            out.append((f"{unit}{j}!", extra))
    return out


def target_names(program: Program) -> dict[int, str]:
    """Every code address -> how to name it as a branch target: the label at it (the first
    alphabetically among equals, as `Program.code_labels`), else `label+N` from the nearest
    label before it (gdb's `<loop+4>`). The assembler reads `label+N` back to the same address,
    so a disassembly that names targets this way reassembles to the identical program; an
    address before the first label stays a number."""
    text = sorted((addr, name) for name, (section, addr) in program.labels.items()
                  if section == "text")
    out: dict[int, str] = {}
    i = 0
    best: tuple[int, str] | None = None
    for addr in range(len(program.bundles) + 1):
        while i < len(text) and text[i][0] <= addr:
            if best is None or text[i][0] > best[0]:
                best = text[i]
            i += 1
        if best is not None:
            out[addr] = best[1] if best[0] == addr else f"{best[1]}+{addr - best[0]}"
    return out


def bundle_target(bundle: tuple[Op, ...]) -> int | None:
    """The code address a bundle's branch or jump names (None without one, and for `jr`, `ret`,
    `call`: their targets are not loop edges). asm/loops.py finds the natural loops from them; the statistics carry it per bundle (`programs.<stage>.listing.target`)."""
    return next((op.args[-1] for op in bundle if op.opcode.kind in ("branch", "jump")
                 and isinstance(op.args[-1], int)), None)


MARKS = {"guard": "guard", "prologue": "PROLOG", "kernel": "KERNEL", "epilogue": "EPILOG",
         "fallback": "fallback"}
"""The parts of a pipelined loop the listing marks (`;** KERNEL`), as TI's assembler does."""


def pipeline_marks(program: Program, pipelines) -> tuple[dict[int, str], dict[int, list[str]]]:
    """Per bundle address, the information block to print above it (a `.pipeline` loop's,
    above its first bundle: the guard's, where its label is) and the part marks to print there."""
    blocks: dict[int, str] = {}
    marks: dict[int, list[str]] = {}
    for report in pipelines or ():
        label = program.labels.get(report.name)
        if label is None or label[0] != "text":
            continue
        base = label[1]
        blocks[base] = blocks.get(base, "") + report.format() + "\n"
        for part, offset in report.parts.items():
            if part in MARKS:  # (epilogue0.. are the other copies' epilogues: one EPILOG)
                marks.setdefault(base + offset, []).append(f";** {MARKS[part]}")
    return blocks, marks


def listing(program: Program, region_lines: set | None = None, pipelines=()) -> str:
    """Address, slots and source of every bundle; then the data words. A bundle a macro or
    `.rept` produced shows the body line it was written at, as substituted, under a row naming
    the expansion (invocation line and text), as GNU as's `-alm` listing shows macro lines.
    Then the scheduled source lines and the bundles each landed in (`region_lines`: the
    assembler's `(file, line, expansion)` of every `.sched` line, else those whose operations
    share a bundle with another line's or landed in several). Registers with a `.reg` name show
    it (`pri/r29`), and the name table closes the listing. Each `.pipeline` loop's software
    pipelining information (`pipelines`: the assembler's reports) is printed above the loop's
    first bundle, and its parts marked: `;** guard`, `;** PROLOG`, `;** KERNEL`, `;** EPILOG`,
    `;** fallback`."""
    labels = target_names(program)
    names = register_names(program)
    rows = [f"; listing of a {program.processor.title} program: "
            f"{len(program.bundles)} bundles, {len(program.data)} data words"]
    by_addr: dict[int, list[str]] = {}
    for name, (section, addr) in sorted(program.labels.items()):
        if section == "text":
            by_addr.setdefault(addr, []).append(name)
    expansion = ""
    blocks, marks = pipeline_marks(program, pipelines)
    for addr, bundle in enumerate(program.bundles):
        if addr in blocks:
            rows.append(blocks[addr].rstrip("\n"))
        for name in by_addr.get(addr, []):
            rows.append(f"{name}:")
        rows += marks.get(addr, [])
        loc = program.source_map[addr] if addr < len(program.source_map) else None
        if loc and loc.via and loc.via != expansion:  # the invocation, then its bundles (as -alm)
            rows.append(f"{'':5s}  ; expands {loc.via}")
        expansion = loc.via if loc else ""
        regs = names.labels(addr)
        if program.processor.vliw:
            cells = [op.format(labels, regs) if op else "-"
                     for _, op in slot_assignment(program, bundle)]
            text = " | ".join(cells) if bundle else "(nop)"
        else:
            text = " ; ".join(op.format(labels, regs) for op in bundle) or "nop"
        where = f"{loc.file}:{loc.line}" if loc else ""
        rows.append(f"{addr:5d}  {text:<60s} ; {where}  {loc.text if loc else ''}".rstrip())
        for other in _other_lines(program, addr):
            rows.append(f"{'':5s}  {'':<60s} ; {other.file}:{other.line}  {other.text}".rstrip())
    rows += _source_map_rows(program, region_lines)
    if program.data:
        rows.append("; data (local memory)")
        data_labels: dict[int, list[str]] = {}
        for name, (section, addr) in sorted(program.labels.items()):
            if section == "data":
                data_labels.setdefault(addr, []).append(name)
        for addr, (kind, value) in enumerate(program.data):
            for name in data_labels.get(addr, []):
                rows.append(f"{name}:")
            shown = format_float(value) if kind == "f" else str(value)
            rows.append(f"{addr:5d}  .{'float' if kind == 'f' else 'word'} {shown}")
    if program.reg_names:
        rows.append("; .reg names (name = register, bundles in force)")
        for r in program.reg_names:
            rows.append(f";   {r.name} = r{r.reg}  {r.start}..{r.end - 1}")
    return "\n".join(rows) + "\n"


def _other_lines(program: Program, addr: int) -> list:
    """The source lines of a bundle's operations besides the bundle's own (a scheduled bundle
    gathers several), first occurrence order."""
    if addr >= len(program.op_sources) or addr >= len(program.source_map):
        return []
    own = program.source_map[addr]
    out, seen = [], {(own.file, own.line)}
    for s in program.op_sources[addr]:
        if (s.file, s.line) not in seen:
            seen.add((s.file, s.line))
            out.append(s)
    return out


def source_bundles(program: Program) -> dict[tuple[str, int, str], tuple[str, list[int]]]:
    """(file, line, expansion) -> (its text, the bundles its operations landed in), for every
    line with an operation (a macro body line once per expansion): how a scheduled region's
    lines map to bundles."""
    out: dict[tuple[str, int, str], tuple[str, list[int]]] = {}
    for addr, sources in enumerate(program.op_sources):
        for s in sources:
            entry = out.setdefault((s.file, s.line, s.via), (s.text, []))
            if not entry[1] or entry[1][-1] != addr:
                entry[1].append(addr)
    return out


def _source_map_rows(program: Program, region_lines: set | None = None) -> list[str]:
    """For every source line that shares a bundle with another line or landed in several
    bundles (the lines of `.sched` regions; a macro body line counts once per expansion), the
    bundles it landed in."""
    shared = {(s.file, s.line, s.via) for addr, sources in enumerate(program.op_sources)
              if len({(t.file, t.line, t.via) for t in sources}) > 1 for s in sources}
    rows = []
    for key, (text, addrs) in source_bundles(program).items():
        if (key in region_lines) if region_lines is not None else (key in shared or len(addrs) > 1):
            rows.append((*key, text, addrs))
    if not rows:
        return []
    out = ["; scheduled source lines -> bundles"]
    for file, line, via, text, addrs in sorted(rows, key=lambda r: (r[0], r[1], r[2])):
        where = f"{file}:{line}"
        code = _code_part(text).strip()
        out.append(f";   {where:<24s} {code:<40s} -> {', '.join(map(str, addrs))}")
    return out


@dataclass
class StaticIlp:
    proc: str
    bundles: int
    ops: int
    ops_per_bundle: float
    slot_fill: dict[str, float]
    """Share of each unit class's slots holding an op: ops of the class / (bundles × units)."""
    reads_per_bundle: float
    writes_per_bundle: float
    read_port_use: float
    """Mean distinct register reads per bundle / read ports."""
    write_port_use: float
    max_reads: int
    max_writes: int

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def static_ilp(program: Program) -> StaticIlp:
    proc = program.processor
    n = len(program.bundles)
    ops = 0
    by_unit = {u: 0 for u in proc.units}
    reads = writes = max_r = max_w = 0
    for bundle in program.bundles:
        u = bundle_usage(proc, bundle)
        ops += u["ops"]
        for unit, c in u["units"].items():
            by_unit[unit] = by_unit.get(unit, 0) + c
        reads += len(u["reads"])
        writes += len(u["writes"])
        max_r, max_w = max(max_r, len(u["reads"])), max(max_w, len(u["writes"]))
    d = max(n, 1)
    return StaticIlp(
        proc=proc.name, bundles=n, ops=ops, ops_per_bundle=ops / d,
        slot_fill={u: by_unit[u] / (d * proc.units[u]) for u in proc.units},
        reads_per_bundle=reads / d, writes_per_bundle=writes / d,
        read_port_use=reads / (d * proc.read_ports), write_port_use=writes / (d * proc.write_ports),
        max_reads=max_r, max_writes=max_w,
    )


def format_static_ilp(s: StaticIlp, name: str = "") -> str:
    fills = "  ".join(f"{u} {100 * f:5.1f}%" for u, f in s.slot_fill.items())
    head = f"{name}: " if name else ""
    return (f"{head}{s.proc.upper()}  {s.bundles} bundles, {s.ops} ops, "
            f"{s.ops_per_bundle:.2f} ops/bundle\n"
            f"  slot fill   {fills}\n"
            f"  read ports  {s.reads_per_bundle:.2f}/bundle ({100 * s.read_port_use:.1f}%, max {s.max_reads})\n"
            f"  write ports {s.writes_per_bundle:.2f}/bundle ({100 * s.write_port_use:.1f}%, max {s.max_writes})")
