"""Static bounds: how few cycles the machine could spend on each block and each loop iteration.

A pure function of (program, processor table, configuration), for `asm --bounds` (a source
alone) and `report bounds` (a run's statistics, whose listing gives the program back:
`program_from_listing`). What llvm-mca's resource pressure and TI's "software pipelining
information" (ResMII, RecMII) tell their users, for this machine's rules (docs/timing.md T1–T7;
docs/scheduling.md, "Bounds", works two examples by hand):

- **units**: per unit class, the issue cycles its operations need (`ceil(ops / units)`), plus
  the cycles nothing can issue — a load with access time T holds issue T − 1 cycles (T6; ldg
  counted as a cache hit, t_c), a loop's taken back edge costs `taken_branch_penalty` (T7) —
  or, if larger, the cycles an unpipelined unit class stays busy (T4): a loop iteration's
  `ceil(Σ occupancy / units)`; a block's the same less the cycles after the last issue on each
  unit (its U longest operations count 1 each), or, if larger, the k − 1 shortest occupancies
  + 1 of the unit that runs k = ceil(n / U) of the class's n operations.
- **ports**: the issue cycles the register-file ports need: distinct values read (a register
  read twice in one bundle uses one port, but a value and its redefinition are two reads) over
  the read ports, writes over the write ports; plus the same dead cycles.
- **recurrence** (loops): RecMII, the largest Σ latency / Σ distance over the loop-carried
  dependence cycles (`asm.dependences`), rounded up.
- **path** (blocks and one iteration of a loop): the longest latency-weighted dependence chain,
  with the last operation's issue cycle (or its load's access time) at its end.

A block's bound is the largest of units, ports and path; a loop's (cycles per iteration in the
steady state, when iterations may overlap) the largest of units, ports and recurrence. Beside
the bounds: `written`, the cycles the code as written takes by the interlock rules with every
source ready at entry and every load hitting (a loop: per iteration, in the steady state), so
`written − bound` is what the schedule leaves on the table before any dynamic stall.

Blocks: a label, a branch target or the bundle after a control transfer starts one. Loops: the
natural loops of asm/loops.py (dominators; named by their source label), as `report annotate`
and `info loop` find them; the bounds of a loop with inner branches count its body once, every
bundle of it in address order (the path that falls through every forward branch).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Sequence

from netsushisen.asm.dependences import (DependenceGraph, dependences, issue_hold, result_latency,
                                         unit_busy)
from netsushisen.asm.listing import bundle_target
from netsushisen.asm.objects import Op, Program
from netsushisen.asm.recurrence import recurrence_mii
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor

OPTIMUM_MAX_OPS = 40
"""Blocks up to this many operations get an exact optimum from CP-SAT (`asm.optimum`)."""


# ---------------------------------------------------------------------------------------------
# Regions: blocks and loops


@dataclass(frozen=True)
class Region:
    kind: str  # "block" or "loop"
    start: int  # a block's first bundle; a loop's header
    end: int  # last bundle address, inclusive
    body: tuple[int, ...] = ()
    """A loop's bundles in address order (a natural loop's need not be consecutive); a block:
    start..end."""
    name: str | None = None
    """A loop's name (asm/loops.py: its source label)."""

    def pcs(self) -> Sequence[int]:
        return self.body or range(self.start, self.end + 1)


def block_starts(program: Program) -> list[int]:
    """Bundle addresses that start a block: 0, every text label, every branch or jump target,
    every bundle after a control transfer."""
    n = len(program.bundles)
    starts = {0} | {addr for section, addr in program.labels.values() if section == "text"}
    for pc, bundle in enumerate(program.bundles):
        target = bundle_target(bundle)
        if target is not None:
            starts.add(target)
        if any(op.opcode.is_control for op in bundle):
            starts.add(pc + 1)
    return sorted(s for s in starts if 0 <= s < n)


def regions(program: Program) -> list[Region]:
    """Every natural loop (asm/loops.py: outermost first), then every block, in address
    order."""
    from netsushisen.asm.loops import program_loops

    loops = [Region("loop", lp.header, lp.end, lp.body, lp.name) for lp in program_loops(program)]
    starts = block_starts(program)
    ends = starts[1:] + [len(program.bundles)]
    return loops + [Region("block", s, e - 1) for s, e in zip(starts, ends)]


# ---------------------------------------------------------------------------------------------
# The bounds


@dataclass
class Bounds:
    """The static bounds of one block or loop (cycles; a loop's per iteration)."""

    proc: str
    kind: str
    start: int
    """A block's first bundle; a loop's header."""
    end: int
    label: str
    bundles: int
    """Bundles as written."""
    ops: int
    ops_by_unit: dict[str, int]
    slots: int
    """Issue cycles the unit slots need: max over classes of ceil(ops / units)."""
    busy: int
    """Cycles the busiest class's units are occupied (unpipelined ops: their latency)."""
    dead: int
    """Cycles nothing issues: load holds (T − 1 each, shared by a bundle's loads) and a loop's
    taken back edge."""
    reads: int
    """Distinct values read (register versions)."""
    writes: int
    port_cycles: int
    """Issue cycles the register ports need: max(ceil(reads / read ports), ceil(writes / write ports))."""
    recurrence: int | None = None
    critical_path: int | None = None
    written: int | None = None
    """Cycles as written by the interlock rules (a loop: per iteration, steady state)."""
    list_scheduled: int | None = None
    optimum: int | None = None
    optimum_proven: bool = False
    body: tuple[int, ...] = ()
    """Its bundles (a loop's natural body, in address order)."""

    def pcs(self) -> Sequence[int]:
        return self.body or range(self.start, self.end + 1)

    @property
    def pcs_text(self) -> str:
        """`8-15`: the first and last bundle (a loop's body need not be every bundle between:
        `bundles` counts it)."""
        return f"{min(self.pcs())}-{max(self.pcs())}"
    optimum_note: str = ""
    """CP-SAT's outcome when it is not a proven optimum (asm/optimum.py)."""

    @property
    def units(self) -> int:
        return max(self.slots + self.dead, self.busy)

    @property
    def ports(self) -> int:
        return self.port_cycles + self.dead

    def candidates(self) -> dict[str, int]:
        """The bounds that limit this region, by name."""
        out = {"units": self.units, "ports": self.ports}
        if self.kind == "loop":
            if self.recurrence is not None:
                out["recurrence"] = self.recurrence
        elif self.critical_path is not None:
            out["path"] = self.critical_path
        return out

    @property
    def bound(self) -> int:
        return max(self.candidates().values())

    @property
    def binding(self) -> str:
        """The name of the largest bound (the first in units, ports, recurrence/path on a tie)."""
        c = self.candidates()
        return next(k for k, v in c.items() if v == self.bound)

    @property
    def optimum_text(self) -> str | None:
        if self.optimum_note:
            return self.optimum_note
        if self.optimum is None:
            return None
        return str(self.optimum) if self.optimum_proven else f"≤ {self.optimum} (not proven)"

    def as_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items()}
        d.update(units=self.units, ports=self.ports, bound=self.bound, binding=self.binding)
        return d


def value_reads(ops: list[tuple[int, Op]]) -> list[list[tuple[int, int]]]:
    """Per op, the values it reads as (register, index of the op that wrote it in this list or
    -1 for a value from before): a bundle reads before any of its writes land, so a read sees
    the last write of an earlier bundle. Two reads of one value in one bundle share a port."""
    last: dict[int, int] = {}
    out: list[list[tuple[int, int]]] = []
    pending: list[tuple[int, int]] = []
    pc_now = None
    for i, (pc, op) in enumerate(ops):
        if pc != pc_now:
            for reg, j in pending:
                last[reg] = j
            pending, pc_now = [], pc
        out.append([(r, last.get(r, -1)) for r in dict.fromkeys(op.reads())])
        pending += [(r, i) for r in op.writes()]
    return out


def resource_bounds(proc: Processor, ops: list[tuple[int, Op]], config: MachineConfig,
                    loop: bool) -> dict:
    """The units and ports bounds' parts (see the module's docstring)."""
    by_unit = Counter(proc.unit(op.opcode.unit) for _, op in ops)
    occupied: dict[str, list[int]] = {}
    for _, op in ops:
        occupied.setdefault(proc.unit(op.opcode.unit), []).append(unit_busy(op, proc, config))
    slots = max((math.ceil(n / proc.units[u]) for u, n in by_unit.items()), default=0)
    busy = 0
    for u, occ in occupied.items():
        # a block is over once its last op issues: the last op on each unit counts one cycle
        # (the U longest do best); a loop's next iteration needs the units again: all of it
        units = proc.units[u]
        if loop:
            busy = max(busy, math.ceil(sum(occ) / units))
            continue
        occ.sort()
        spare = sum(o - 1 for o in occ[-units:])
        # and some unit runs k = ceil(n / U) of them: its first k - 1 at least the shortest
        k = math.ceil(len(occ) / units)
        busy = max(busy, math.ceil((sum(occ) - spare) / units), sum(occ[:k - 1]) + 1)
    load_unit = proc.unit("int")
    holds = sorted(issue_hold(op, proc, config) - 1 for _, op in ops if op.opcode.kind == "load")
    if ends_in_halt([op for _, op in ops]):  # loads sharing the halt's bundle hold nothing
        holds = holds[:-proc.units[load_unit]]
    dead = math.ceil(sum(holds) / proc.units[load_unit])
    if loop:
        dead += getattr(config, proc.name).taken_branch_penalty
    reads = len({v for vs in value_reads(ops) for v in vs})
    writes = sum(len(op.writes()) for _, op in ops)
    ports = max(math.ceil(reads / proc.read_ports), math.ceil(writes / proc.write_ports))
    return {"ops": len(ops), "ops_by_unit": dict(sorted(by_unit.items())), "slots": slots,
            "busy": busy, "dead": dead, "reads": reads, "writes": writes, "port_cycles": ports}


# ---------------------------------------------------------------------------------------------
# Timing of the code as written (docs/timing.md T1–T7, from a cold start: every source ready)


def written_timing(proc: Processor, bundles: list[tuple[Op, ...]], config: MachineConfig,
                   iterations: int = 1) -> tuple[list[int], list[int]]:
    """When each bundle of the last pass over `bundles` issues, and the cycle after each pass in
    which the next bundle could issue, by the interlock rules: in order, one bundle a cycle, not
    before its sources and destinations are written (T2, T3), its units free (T4), its results'
    write cycles within the write ports (T5), a load's hold over (T6); each pass after the first
    follows a taken back edge (T7). Every load hits; registers are ready at the start. The
    static twin of the emulator's issue stage for straight-line code (no FIFO, no memory
    state), so a schedule can be judged without a run."""
    penalty = getattr(config, proc.name).taken_branch_penalty
    ready: dict[int, int] = {}
    busy: dict[str, list[int]] = {u: [] for u in proc.units}  # release cycles of unpipelined units
    writes_at: Counter = Counter()
    c_next, ends, issued = 0, [], []
    for it in range(iterations):
        if it:
            c_next += penalty
        issued = []
        for bundle in bundles:
            real = [op for op in bundle if op.opcode.kind != "nop"]
            c = c_next
            for op in real:
                for r in op.reads() + op.writes():
                    c = max(c, ready.get(r, 0))
            need = Counter(proc.unit(op.opcode.unit) for op in real)
            lats = [(op, result_latency(op, proc, config)) for op in real]
            while True:
                free_ok = all(sum(1 for t in busy[u] if t > c) + n <= proc.units[u]
                              for u, n in need.items())
                landing = Counter(c + lat for op, lat in lats for _ in op.writes())
                ports_ok = all(writes_at[t] + n <= proc.write_ports for t, n in landing.items())
                if free_ok and ports_ok:
                    break
                c += 1
            for op, lat in lats:
                for r in op.writes():
                    ready[r] = c + lat
                    writes_at[c + lat] += 1
                if not op.opcode.pipelined:
                    busy[proc.unit(op.opcode.unit)].append(c + lat)
            issued.append(c)
            halts = any(op.opcode.kind == "halt" for op in real)  # T9: nothing issues after
            c_next = c + max([1] + [0 if halts else issue_hold(op, proc, config) for op in real])
        ends.append(c_next)
    return issued, ends


def written_cycles(proc: Processor, bundles: list[tuple[Op, ...]], config: MachineConfig,
                   loop: bool) -> int:
    """A block's cycles as written, or a loop's cycles per iteration in the steady state (the
    third pass over the body minus the second)."""
    if not loop:
        return written_timing(proc, bundles, config)[1][0]
    ends = written_timing(proc, bundles, config, iterations=3)[1]
    return ends[2] - ends[1]


# ---------------------------------------------------------------------------------------------
# Dependence-graph bounds (the graph is asm.dependences')


def serial_order(bundle: tuple[Op, ...]) -> list[Op]:
    """A bundle's operations in an order that, run one at a time, means what the bundle means:
    a bundle reads before it writes, and its loads read before its stores write (T2, T6), so a
    reader of a register goes before the bundle's writer of it, loads before stores, and the
    control transfer last (the whole bundle issues whatever it decides). (A bundle that swaps
    two registers has no such order: it keeps its written order.)"""
    real = [op for op in bundle if op.opcode.kind != "nop"]
    after = {i: {j for j, b in enumerate(real) if j != i and (
        set(a.reads()) & set(b.writes()) or (a.opcode.kind == "load" and b.opcode.kind == "store")
        or b.opcode.is_control)}
        for i, a in enumerate(real)}  # i must come before every j in after[i]
    order, left = [], list(range(len(real)))
    while left:
        free = [i for i in left if not any(i in after[k] for k in left if k != i)]
        if not free:
            return real
        order.append(free[0])
        left.remove(free[0])
    return [real[i] for i in order]


def region_graph(program: Program, region: Region, config: MachineConfig
                 ) -> tuple[list[tuple[int, Op]], DependenceGraph]:
    """The region's operations in serial order (bundle by bundle, `serial_order`) and their
    dependence graph (a loop's with its loop-carried edges)."""
    ops = [(pc, op) for pc in region.pcs() for op in serial_order(program.bundles[pc])]
    graph = dependences([op for _, op in ops], program.processor, config,
                        loop=region.kind == "loop")
    return ops, graph


def earliest_starts(graph: DependenceGraph) -> list[int]:
    """ASAP issue cycles over the edges of one pass (distance 0: they run forward in serial
    order), resources aside."""
    est = [0] * len(graph.ops)
    for i in range(len(graph.ops)):
        for e in graph.succs(i):
            if e.distance == 0:
                est[e.dst] = max(est[e.dst], est[i] + e.latency)
    return est


def issue_path(graph: DependenceGraph) -> int:
    """The longest dependence chain in issue cycles: from the first issue to the cycle after
    the chain's last operation issues (after its hold, for a load): no schedule of the block
    is shorter."""
    est = earliest_starts(graph)
    if ends_in_halt(graph.ops):  # a load may share the halt's bundle: it holds nothing then
        return max((t + 1 for t in est), default=0)
    return max((t + h for t, h in zip(est, graph.holds)), default=0)


def ends_in_halt(ops) -> bool:
    """A block that halts: its length is the halt's cycle + 1 (T9), whatever its loads hold."""
    return bool(ops) and ops[-1].opcode.kind == "halt"


RECURRENCE_KINDS = ("true", "memory", "fifo")
"""Loop-carried dependences a renaming cannot remove (register anti and output dependences
can: modulo variable expansion, docs/scheduling.md), as TI's RecMII counts them and the modulo
scheduler (asm/pipeline.py) uses them."""


def recurrence_bound(graph: DependenceGraph) -> int:
    """A loop's RecMII over its true, memory and FIFO edges (`recurrence_mii`)."""
    return recurrence_mii(len(graph.ops), [e for e in graph.edges if e.kind in RECURRENCE_KINDS])


# ---------------------------------------------------------------------------------------------
# Every region of a program


def list_timing(proc: Processor, graph: DependenceGraph, config: MachineConfig
                ) -> tuple[int, list[int]]:
    """The cycles of the block as the list scheduler (asm/scheduler.py) bundles it, by the same
    interlock rules as the code as written, and each operation's issue cycle."""
    from netsushisen.asm.scheduler import list_schedule

    groups = list_schedule(graph.ops, proc, config, graph)
    issued, ends = written_timing(proc, [tuple(graph.ops[i] for i in g) for g in groups], config)
    starts = [0] * len(graph.ops)
    for t, g in zip(issued, groups):
        for i in g:
            starts[i] = t
    return ends[0], starts


def region_bounds(program: Program, region: Region, config: MachineConfig,
                  optimum_ops: int = OPTIMUM_MAX_OPS, seconds: float | None = None,
                  label: str | None = None, budget=None) -> Bounds:
    """The bounds of one block or loop; a block of 1..`optimum_ops` operations also gets its
    optimum from CP-SAT (`asm.optimum`; `seconds` of deterministic time, default its own; its
    model drawn from the program's `budget`, an `asm.optimum.ModelBudget`, when given)."""
    proc = program.processor
    loop = region.kind == "loop"
    ops, graph = region_graph(program, region, config)
    bundles = [program.bundles[pc] for pc in region.pcs()]
    b = Bounds(proc.name, region.kind, region.start, region.end,
               region.name or (label if label is not None else str(region.start)), len(bundles),
               **resource_bounds(proc, ops, config, loop))
    b.body = tuple(region.pcs())
    b.critical_path = issue_path(graph)
    if loop:
        b.recurrence = recurrence_bound(graph)
    b.written = written_cycles(proc, bundles, config, loop)
    if not loop and ops:
        b.list_scheduled = list_timing(proc, graph, config)[0]
    if not loop and 0 < len(ops) <= optimum_ops:
        add_optimum(program, b, config, seconds, (ops, graph), budget)
    return b


def add_optimum(program: Program, b: Bounds, config: MachineConfig, seconds: float | None = None,
                graph: tuple | None = None, budget=None) -> None:
    """Set a block's optimum (`asm.optimum`: CP-SAT, `seconds` of deterministic time), starting
    from the shorter of the schedule as written and the list scheduler's."""
    from netsushisen.asm.optimum import DETERMINISTIC_SECONDS, optimum_schedule

    proc = program.processor
    ops, g = graph or region_graph(program, Region(b.kind, b.start, b.end), config)
    bundles = program.bundles[b.start:b.end + 1]
    issued, ends = written_timing(proc, bundles, config)
    start = {"written": (ends[0], [issued[pc - b.start] for pc, _ in ops]),
             "list": list_timing(proc, g, config)}
    upper, hint = min(start.values(), key=lambda lh: lh[0])
    best = optimum_schedule(g, value_reads(ops), proc, config, lower=b.bound, upper=upper,
                            hint=hint, seconds=DETERMINISTIC_SECONDS if seconds is None else seconds,
                            budget=budget)
    if best is not None:
        b.optimum, b.optimum_proven, b.optimum_note = best.length, best.proven, best.note


def program_bounds(program: Program, config: MachineConfig, optimum_ops: int = OPTIMUM_MAX_OPS,
                   seconds: float | None = None) -> list[Bounds]:
    """The bounds of every loop and block of `program` (`regions`), the blocks' optima within one
    model budget for the program (`asm.optimum.ModelBudget`: many blocks with long loads, each
    under the size limit, took a minute together)."""
    from netsushisen.asm.listing import target_names
    from netsushisen.asm.optimum import ModelBudget

    names = target_names(program)
    budget = ModelBudget()
    return [region_bounds(program, r, config, optimum_ops, seconds, names.get(r.start, str(r.start)),
                          budget) for r in regions(program)]


# ---------------------------------------------------------------------------------------------
# Reading a program back from a statistics file's listing


def program_from_listing(listing: dict, proc: str, source: str = "<statistics>") -> Program:
    """The program a statistics file's `programs.<stage>.listing` shows (its label column names
    the labels, its text column the operations as the disassembler writes them), assembled
    again: the bounds of a run's code without its source files. Data words are not in the
    listing, and the bounds do not need them."""
    from netsushisen.asm.assembler import assemble_text

    labels, texts = listing["label"], listing["text"]
    lines = [f".proc {proc}"]
    for label, text in zip(labels, texts):
        if "+" not in label and not label.isdigit():
            lines.append(f"{label}:")
        lines.append("    { " + ("" if text == "nop" else text) + " }")
    return assemble_text("\n".join(lines) + "\n", proc=proc, filename=source)
