"""Static bounds: how few cycles the machine could spend on each block and each loop iteration.

A pure function of (program, processor table, configuration), for `asm --bounds` (a source
alone) and `report bounds` (a run's statistics, whose listing gives the program back:
`program_from_listing`). What llvm-mca's resource pressure and TI's "software pipelining
information" (ResMII, RecMII) tell their users, for this machine's rules (docs/timing.md T1–T7;
docs/scheduling.md, "Bounds", works two examples by hand):

- **units**: per unit class, the issue cycles its operations need (`ceil(ops / units)`), plus
  the cycles nothing can issue — a load with access time T holds issue T − 1 cycles (T6; ldg
  counted as a cache hit, t_c), a loop's taken back edge costs `taken_branch_penalty` (T7) —
  or, if larger, the cycles an unpipelined unit class stays busy (`ceil(Σ latency / units)`, T4).
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

Blocks: a label, a branch target or the bundle after a control transfer starts one. Loops: a
backward branch or jump and its target (`asm.listing.loop_ranges`, as `report annotate`); the
bounds of a loop with inner branches count its body once, every bundle of it (the path that
falls through every forward branch).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from netsushisen.asm.listing import bundle_target, loop_ranges
from netsushisen.asm.objects import Op, Program
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.processors import Processor

OPTIMUM_MAX_OPS = 40
"""Blocks up to this many operations get an exact optimum from CP-SAT (`asm.optimum`)."""


# ---------------------------------------------------------------------------------------------
# Timing facts of one operation under a configuration (docs/timing.md T2, T4, T6)


def access_time(proc: Processor, op: Op, config: MachineConfig) -> int:
    """A load's access time T (its result is readable T cycles after issue, and issue is held
    until then): OS local `ld` its latency; IC/SC `ld`/`ldr` t_r, `ldg` t_c (a hit: a bound
    cannot know the misses). 1 for every other operation."""
    oc = op.opcode
    if oc.kind != "load":
        return 1
    if proc.name == "os":
        return config.os.latency.get(op.mnemonic, oc.latency)
    mem = config.ic_memory if proc.name == "ic" else config.sc_memory
    return mem.t_c if oc.space == "global" else mem.t_r


def latency(proc: Processor, op: Op, config: MachineConfig) -> int:
    """Cycles from issue until the op's result is readable: `<proc>.latency.<mnemonic>`, else
    the opcode table's; a load's access time."""
    if op.opcode.kind == "load":
        return access_time(proc, op, config)
    return getattr(config, proc.name).latency.get(op.mnemonic, op.opcode.latency)


def occupancy(proc: Processor, op: Op, config: MachineConfig) -> int:
    """Cycles the op keeps its unit: its latency on an unpipelined unit, else 1."""
    return 1 if op.opcode.pipelined else latency(proc, op, config)


# ---------------------------------------------------------------------------------------------
# Regions: blocks and loops


@dataclass(frozen=True)
class Region:
    kind: str  # "block" or "loop"
    start: int
    end: int  # last bundle address, inclusive

    def pcs(self) -> range:
        return range(self.start, self.end + 1)


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
    """Every loop (outermost first at each start), then every block, in address order."""
    targets = [(pc, bundle_target(b)) for pc, b in enumerate(program.bundles)]
    loops = [Region("loop", s, e) for s, e in loop_ranges(targets)]
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
    notes: list[str] = field(default_factory=list)

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
        if self.optimum is None:
            return None
        return str(self.optimum) if self.optimum_proven else f"≤ {self.optimum} (not proven)"

    def as_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items()}
        d.update(units=self.units, ports=self.ports, bound=self.bound, binding=self.binding)
        return d


def region_ops(program: Program, region: Region) -> list[tuple[int, Op]]:
    """(pc, op) of every operation in the region, in program order (nops left out)."""
    return [(pc, op) for pc in region.pcs() for op in program.bundles[pc]
            if op.opcode.kind != "nop"]


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
    busy_by_unit: Counter = Counter()
    for _, op in ops:
        busy_by_unit[proc.unit(op.opcode.unit)] += occupancy(proc, op, config)
    slots = max((math.ceil(n / proc.units[u]) for u, n in by_unit.items()), default=0)
    busy = max((math.ceil(n / proc.units[u]) for u, n in busy_by_unit.items()), default=0)
    load_unit = proc.unit("int")
    hold = sum(access_time(proc, op, config) - 1 for _, op in ops if op.opcode.kind == "load")
    dead = math.ceil(hold / proc.units[load_unit])
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
                   iterations: int = 1) -> list[int]:
    """The cycle after each pass over `bundles` in which the next bundle could issue, by the
    interlock rules: in order, one bundle a cycle, not before its sources and destinations are
    written (T2, T3), its units free (T4), its results' write cycles within the write ports
    (T5), a load's hold over (T6); each pass after the first follows a taken back edge (T7).
    Every load hits; registers are ready at the start. The static twin of the emulator's issue
    stage for straight-line code (no FIFO, no memory state), so a schedule can be judged
    without a run."""
    penalty = getattr(config, proc.name).taken_branch_penalty
    ready: dict[int, int] = {}
    busy: dict[str, list[int]] = {u: [] for u in proc.units}  # release cycles of unpipelined units
    writes_at: Counter = Counter()
    c_next, ends = 0, []
    for it in range(iterations):
        if it:
            c_next += penalty
        for bundle in bundles:
            real = [op for op in bundle if op.opcode.kind != "nop"]
            c = c_next
            for op in real:
                for r in op.reads() + op.writes():
                    c = max(c, ready.get(r, 0))
            need = Counter(proc.unit(op.opcode.unit) for op in real)
            lats = [(op, latency(proc, op, config)) for op in real]
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
            c_next = c + max([1] + [access_time(proc, op, config) for op in real])
        ends.append(c_next)
    return ends


def written_cycles(proc: Processor, bundles: list[tuple[Op, ...]], config: MachineConfig,
                   loop: bool) -> int:
    """A block's cycles as written, or a loop's cycles per iteration in the steady state (the
    third pass over the body minus the second)."""
    if not loop:
        return written_timing(proc, bundles, config)[0]
    ends = written_timing(proc, bundles, config, iterations=3)
    return ends[2] - ends[1]


# ---------------------------------------------------------------------------------------------
# Reading a program back from a statistics file's listing


def program_from_listing(listing: dict, proc: str, source: str = "<statistics>") -> Program:
    """The program a statistics file's `programs.<stage>.listing` shows (its label column names
    the labels, its text column the operations as the disassembler writes them), assembled
    again: the bounds of a run's code without its source files. Data words are not in the
    listing, and the bounds do not need them."""
    from netsushisen.asm.assembler import assemble_text

    labels, texts, targets = listing["label"], listing["text"], listing["target"]
    n = len(texts)
    lines = [f".proc {proc}"]
    for pc, (label, text) in enumerate(zip(labels, texts)):
        if "+" not in label and not label.isdigit():
            lines.append(f"{label}:")
        lines.append("    { " + ("" if text == "nop" else text) + " }")
    for text, target in zip(texts, targets):
        if target is None or target < n:
            continue
        # a branch to the end of the program names a label the label column cannot show
        for part in text.split(" ; "):
            words = part.replace(",", " ").split()
            if words and words[0] in OPCODES and OPCODES[words[0]].kind in ("branch", "jump"):
                if f"{words[-1]}:" not in lines:
                    lines.append(f"{words[-1]}:")
    return assemble_text("\n".join(lines) + "\n", proc=proc, filename=source)
