"""Software pipelining of `.pipeline` loops: a modulo schedule (asm/modulo.py) made into code —
modulo variable expansion into the `.temps` registers, prologue, kernel, epilogues and a
trip-count guard.

A pipelinable loop is one block ending in a conditional branch back to its head whose register
operands are loop invariants and at most one *induction register* i, written in the body only by
`addi i, i, k`. Then whether iteration j+1 exists depends on i alone, which lets the kernel test
exactly the branch of its newest iteration (the branch is fixed in the last row of stage 0) and
lets a guard evaluate the first few tests before the loop:

    guard      for p = 1 .. S-1:  addi t, (i | t), k ; <negated branch> t, n -> fallback
               (S stages need S iterations: fewer and the loop runs list-scheduled, unpipelined)
    prologue   S-1 rounds starting iterations 0 .. S-2 (stages 0..p of round p)
    kernel     U copies of the II rows (U = the expansion factor); copy c < U-1 ends in the
               negated branch to epilogue c, copy U-1 in the branch back to the kernel
    epilogue c S-1 rounds finishing the iterations in flight, then moves that put each register's
               final value back in the register the source names, then a jump past the loop
    fallback   the loop as written, list-scheduled (trip counts 1 .. S-1)

The guard repeats the loop's own induction update and comparison, so it decides exactly as the
serial loop would (wraparound included). Trip count 0 does not exist for the loop itself (its
body runs before its branch, as written); a writer's test before the loop keeps it 0.

Registers: every value the body defines gets U/q copies (`q` = how many iterations its
lifetime spans); the last copy of a register's last definition is the register itself, so
values live into the loop need no copying in and live-out values are moved back once at exit.
The scheduler drops register anti and output edges (the renaming honours them: a copy is not
rewritten before its last read) and keeps true, memory, FIFO and (`.sched inorder`) load-order
edges (asm/dependences.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from netsushisen.asm.dependences import DependenceGraph, dependences
from netsushisen.asm.modulo import (_class_use, critical_recurrence, modulo_schedule,
                                    port_bound, recurrence_bound, resource_bound, value_of_reads)
from netsushisen.asm.objects import Op
from netsushisen.asm.scheduler import issue_times, list_schedule
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor, register_name

NEGATED = {"beq": "bne", "bne": "beq", "blt": "bge", "bge": "blt", "bltu": "bgeu",
           "bgeu": "bltu", "beqz": "bnez", "bnez": "beqz"}
MAX_II_TRIES = 16

MAX_PIPELINE_II = 256
"""The largest minimum II the modulo scheduler tries: its reservation table has a row per
cycle of the II, so its cost grows with the II, which a legal load latency (up to 4,096
cycles) sets; such a loop is list-scheduled as a plain block instead."""


@dataclass(frozen=True)
class Placed:
    """One operation of a scheduled layout: the source operation `index` with its registers
    renamed (`reads`, `writes`: register -> register) and, for a branch, a new mnemonic or a
    local `target` label; or a generated `op` (index -1) standing for source operation `source`."""

    index: int
    reads: tuple[tuple[int, int], ...] = ()
    writes: tuple[tuple[int, int], ...] = ()
    mnemonic: str = ""
    target: str = ""
    op: Op | None = None
    source: int = -1


@dataclass
class Layout:
    bundles: list[list[Placed]] = field(default_factory=list)
    labels: dict[str, int] = field(default_factory=dict)

    def add_label(self, name: str) -> None:
        self.labels[name] = len(self.bundles)


@dataclass
class PipelineReport:
    """The software pipelining information of one `.pipeline` loop (docs/scheduling.md)."""

    name: str
    where: str
    ops: int
    res_mii: int = 0
    res_detail: str = ""
    port_mii: int = 0
    port_detail: str = ""
    rec_mii: int = 0
    rec_detail: str = ""
    ii: int = 0
    stages: int = 0
    unroll: int = 0
    registers: tuple[int, ...] = ()
    temps: tuple[int, ...] = ()
    penalty: int = 0
    reason: str = ""
    units: dict[str, tuple[int, int]] = field(default_factory=dict)
    """Per unit class: (busy slots per iteration, units): TI's resource partition."""
    live: tuple[int, ...] = ()
    """The registers live in the kernel: the loop's own and the `.temps` its copies use."""
    tried: list[str] = field(default_factory=list)
    """Each II tried that failed, and why (`II 4: no modulo schedule`)."""
    parts: dict[str, int] = field(default_factory=dict)
    """Where each part of the pipelined code starts, in bundles from its first (the guard's):
    guard, prologue, kernel, epilogue (then epilogue0.. of the other copies), fallback, done,
    and `end` (the bundles it takes)."""

    @property
    def mii(self) -> int:
        return max(self.res_mii, self.port_mii, self.rec_mii)

    def as_dict(self) -> dict:
        """The information as JSON-ready data (`asm --stats --json`)."""
        return {"loop": self.name, "where": self.where, "ops": self.ops,
                "res_mii": self.res_mii, "port_mii": self.port_mii, "rec_mii": self.rec_mii,
                "mii": self.mii, "pipelined": not self.reason, "reason": self.reason,
                "ii": self.ii, "stages": self.stages, "kernel_copies": self.unroll,
                "registers": [register_name(r) for r in self.registers],
                "resources": {u: {"busy": b, "units": n} for u, (b, n) in self.units.items()},
                "live_registers": [register_name(r) for r in self.live],
                "temps_left": len(self.temps) - len(self.registers),
                "tried": list(self.tried), "parts": dict(self.parts)}

    def resource_rows(self) -> list[str]:
        """The per-unit table: each class's busy slots per iteration, its units, and the II it
        alone would allow (TI's resource partition)."""
        if not self.units:
            return []
        rows = [";*   resources per iteration : unit   busy  units  slots used at II"
                + (f" {self.ii}" if self.ii else "")]
        for unit, (busy, n) in self.units.items():
            use = f"{busy}/{n * self.ii}" if self.ii else "-"
            rows.append(f";*                             {unit:<5} {busy:>5}  {n:>5}  {use}")
        return rows

    def format(self) -> str:
        head = f";* software pipelining information: loop '{self.name}' ({self.where}), {self.ops} operations"
        if not self.ops:
            return head
        rows = [head,
                f";*   resource bound (units)  : {self.res_mii}   ({self.res_detail})",
                f";*   port bound              : {self.port_mii}   ({self.port_detail})",
                f";*   recurrence bound        : {self.rec_mii}" +
                (f"   ({self.rec_detail})" if self.rec_detail else ""),
                f";*   minimum II              : {self.mii}"]
        rows += self.resource_rows()
        rows += [f";*   II {t}" for t in self.tried]
        if self.reason:
            rows.append(f";*   not pipelined: {self.reason}; the loop is list-scheduled")
            return "\n".join(rows)
        per_iter = round(self.ii + self.penalty / self.unroll, 2)
        temps = ", ".join(register_name(r) for r in self.registers) or "none"
        rows += [f";*   II achieved             : {self.ii}   ({per_iter:g} cycles per iteration with the "
                 f"taken-branch penalty {self.penalty} once per {self.unroll} kernel "
                 f"cop{'y' if self.unroll == 1 else 'ies'})",
                 f";*   stages                  : {self.stages}",
                 f";*   kernel copies (MVE)     : {self.unroll}",
                 f";*   registers used          : {len(self.registers)} of {len(self.temps)} .temps ({temps}), "
                 f"{len(self.temps) - len(self.registers)} left",
                 f";*   registers live in kernel: {len(self.live)} ("
                 + ", ".join(register_name(r) for r in self.live) + ")",
                 f";*   guard                   : " + (
                     f"fewer than {self.stages} iterations run the list-scheduled loop"
                     if self.stages > 1 else "none (one stage)")]
        return "\n".join(rows)


def materialize(p: Placed, ops) -> Op:
    """The operation a `Placed` stands for (a branch keeps its old target until it is laid out)."""
    if p.op is not None:
        return p.op
    op = ops[p.index]
    rmap, wmap = dict(p.reads), dict(p.writes)
    args = []
    for operand, a in zip(op.opcode.operands, op.args):
        if operand.kind == "rd":
            a = wmap.get(a, a)
        elif operand.kind == "rs":
            a = rmap.get(a, a)
        elif operand.kind == "mem":
            a = (rmap.get(a[0], a[0]), a[1])
        args.append(a)
    return Op(p.mnemonic or op.mnemonic, tuple(args))

# ---------------------------------------------------------------------------------------------
# The loop's shape


@dataclass
class _Loop:
    branch: int
    induction: int  # register
    step: int
    addi: int  # op index of the induction update, -1 if none


def analyse(ops: list[Op]) -> _Loop | str:
    """The loop's control (induction register, step) or why it cannot be pipelined."""
    br = len(ops) - 1
    last = ops[br]
    if last.opcode.kind != "branch":
        return "its back edge is not a conditional branch"
    writers: dict[int, list[int]] = {}
    for j, op in enumerate(ops[:-1]):
        if op.opcode.is_control:
            return f"it holds a control transfer ({op.mnemonic}) before its back edge"
        for r in op.writes():
            writers.setdefault(r, []).append(j)
    induction, step, addi = None, 0, -1
    for r in set(last.reads()):
        if r not in writers:
            continue
        ws = writers[r]
        op = ops[ws[0]]
        if len(ws) != 1 or op.mnemonic != "addi" or op.args[1] != r or op.args[0] != r:
            return (f"its branch tests {register_name(r)}, which is not an induction "
                    f"(written only by addi {register_name(r)}, {register_name(r)}, k)")
        if induction is not None:
            return "its branch tests two induction registers"
        induction, step, addi = r, op.args[2], ws[0]
    if induction is None:
        return "its branch tests no induction register (the loop would run once or forever)"
    return _Loop(br, induction, step, addi)

# ---------------------------------------------------------------------------------------------
# Modulo variable expansion and code generation


def _copies_needed(g: DependenceGraph, reads, time: list[int], ii: int) -> dict[int, int]:
    """Per defining operation, how many iterations its value must survive (its copies)."""
    need: dict[int, int] = {}
    for d, op in enumerate(g.ops):
        if op.writes():
            need[d] = max(1, math.ceil(g.latencies[d] / ii))
    for u, rs in enumerate(reads):
        for r, dist, d, _ in rs:
            if d is not None:
                span = time[u] + dist * ii - time[d]
                need[d] = max(need[d], math.ceil(span / ii))
    return need


def _list_scheduled_pass(ops, g: DependenceGraph, edges, proc, config,
                         report: PipelineReport) -> int:
    """Cycles a pass of the loop takes list-scheduled, at least: its bundles' span, its resources
    (ResMII), each loop-carried dependence between two passes, and the taken-branch penalty."""
    t = issue_times(ops, proc, config, g)
    carried = [t[e.src] + e.latency - t[e.dst] for e in edges if e.distance]
    return max([max(t) + 1, report.res_mii] + carried) + report.penalty


def _join(bundle: list[Placed], items: list[Placed], ops, proc: Processor) -> bool:
    """Add the exit's moves and jump to the epilogue's last bundle if they fit there and read
    nothing it writes (a bundle sees none of its own results)."""
    from netsushisen.asm.checker import check_bundle

    made = [materialize(p, ops) for p in bundle]
    extra = [materialize(p, ops) for p in items]
    written = {r for op in made for r in op.writes()}
    if any(r in written for op in extra for r in op.reads()) or check_bundle(proc, made + extra):
        return False
    bundle.extend(items)
    return True


def pipeline_loop(ops: list[Op], proc: Processor, config: MachineConfig, temps: list[int],
                  report: PipelineReport, inorder: bool = False) -> Layout | None:
    """The pipelined layout of a loop body (serial order, its back edge last), or None with
    `report.reason` saying why not. `report` gets the bounds and what was achieved."""
    report.ops = len(ops)
    shape = analyse(ops)
    g = dependences(ops, proc, config, loop=True, inorder=inorder)
    edges = [e for e in g.edges if e.kind in ("true", "memory", "fifo", "order")]
    report.res_mii, report.res_detail = resource_bound(g, proc, config)
    report.port_mii, report.port_detail = port_bound(g, proc)
    report.rec_mii = recurrence_bound(len(ops), edges)
    report.rec_detail = critical_recurrence(g, edges)
    report.temps = tuple(temps)
    report.penalty = getattr(config, proc.name).taken_branch_penalty
    report.units = {u: (n, proc.units[u]) for u, n in _class_use(ops, proc, config).items()}
    if isinstance(shape, str):
        report.reason = shape
        return None
    used = {r for op in ops for r in (*op.reads(), *op.writes())}
    clash = sorted(set(temps) & used)
    if clash:
        report.reason = f".temps {register_name(clash[0])} is used by the loop"
        return None
    if report.mii > MAX_PIPELINE_II:
        report.reason = (f"its minimum II {report.mii:,} is over {MAX_PIPELINE_II} "
                         "(asm.pipeline.MAX_PIPELINE_II): a pass that long gains nothing "
                         "from overlapping the next")
        return None
    reads = value_of_reads(g)
    reason = "no schedule found"
    plain = _list_scheduled_pass(ops, g, edges, proc, config, report)
    for ii in range(report.mii, report.mii + MAX_II_TRIES):
        if ii + report.penalty / 2 >= plain:
            reason = (f"pipelining gains nothing: II {ii} against {plain} cycles a pass "
                      f"list-scheduled")
            report.tried.append(f"{ii}: gains nothing against {plain} cycles a pass "
                                "list-scheduled")
            break
        time = modulo_schedule(g, edges, ii, shape.branch, proc, config)
        if time is None:
            reason = f"no modulo schedule within II {report.mii}..{ii}"
            report.tried.append(f"{ii}: no modulo schedule (no placement of every operation "
                                "within the units, ports and dependences, evictions included)")
            continue
        stages = max(time) // ii + 1
        need = _copies_needed(g, reads, time, ii)
        unroll = max(need.values(), default=1)
        if report.penalty > 0:
            unroll = max(unroll, 2)
        copies = {d: next(q for q in range(k, unroll + 1) if unroll % q == 0) for d, k in need.items()}
        last_def: dict[int, int] = {}
        for d, op in enumerate(ops):
            for r in op.writes():
                last_def[r] = d
        wanted = sum(q - (1 if last_def.get(ops[d].writes()[0]) == d else 0) for d, q in copies.items())
        wanted_guard = 1 if stages > 1 and wanted == 0 else 0
        if wanted + wanted_guard > len(temps):
            reason = (f"needs {wanted + wanted_guard} registers for its copies and guard at II {ii}, "
                      f".temps grants {len(temps)}")
            report.tried.append(f"{ii}: needs {wanted + wanted_guard} .temps for its copies and "
                                f"guard, {len(temps)} granted")
            continue
        pool = list(temps)
        names: dict[int, list[int]] = {}
        for d in sorted(copies):
            r = ops[d].writes()[0]
            if last_def[r] == d:
                names[d] = [pool.pop(0) for _ in range(copies[d] - 1)] + [r]
            else:
                names[d] = [pool.pop(0) for _ in range(copies[d])]
        report.ii, report.stages, report.unroll = ii, stages, unroll
        report.registers = tuple(sorted({r for d in names for r in names[d] if r in temps} |
                                        ({temps[0]} if stages > 1 else set())))
        report.live = tuple(sorted(used | set(report.registers)))
        layout = _emit(ops, g, reads, time, ii, stages, unroll, names, shape, proc, config,
                       temps[0] if temps else 0, last_def, inorder)
        report.parts = dict(sorted(layout.labels.items(), key=lambda kv: kv[1]))
        report.parts["end"] = len(layout.bundles)
        return layout
    report.reason = reason
    return None


def _emit(ops, g, reads, time, ii, stages, unroll, names, shape: _Loop, proc, config, guard_temp,
          last_def, inorder: bool = False) -> Layout:
    n = len(ops)
    br = shape.branch
    out = Layout()

    def instance(o: int, j: int, **kw) -> Placed:
        rmap = []
        for r, dist, d, _ in reads[o]:
            if d is not None:
                q = names[d]
                rmap.append((r, q[(j - dist) % len(q)]))
        wmap = [(r, names[o][j % len(names[o])]) for r in ops[o].writes()]
        return Placed(o, tuple(rmap), tuple(wmap), **kw)

    def rows_of(stage_ok, iteration) -> list[list[Placed]]:
        rows = []
        for row in range(ii):
            here = [o for o in range(n) if o != br and time[o] % ii == row and stage_ok(time[o] // ii)]
            here.sort(key=lambda o: (-(time[o] // ii), o))
            rows.append([instance(o, iteration(time[o] // ii)) for o in here])
        return rows

    def emit_rows(rows) -> None:
        out.bundles.extend(r for r in rows if r)

    def emit_block(items: list[Placed]) -> None:
        """Generated operations list-scheduled as one block (moves, then a jump)."""
        real = [materialize(p, ops) for p in items]
        for b in list_schedule(real, proc, config):
            out.bundles.append([items[k] for k in b])

    # guard: the loop's own update and test for the iterations the prologue starts
    if stages > 1:
        out.add_label("guard")
        src = shape.induction
        for p in range(1, stages):
            base = shape.induction if p == 1 else guard_temp
            emit_block([Placed(-1, op=Op("addi", (guard_temp, base, shape.step)), source=shape.addi),
                        Placed(br, reads=((src, guard_temp),), mnemonic=NEGATED[ops[br].mnemonic],
                               target="fallback")])
    # prologue
    if stages > 1:
        out.add_label("prologue")
    for p in range(stages - 1):
        emit_rows(rows_of(lambda s, p=p: s <= p, lambda s, p=p: p - s))
    # kernel copies
    out.add_label("kernel")
    for c in range(unroll):
        rows = rows_of(lambda s: True, lambda s, c=c: c + stages - 1 - s)
        j = c + stages - 1
        last = c == unroll - 1
        rows[ii - 1].append(instance(br, j, mnemonic="" if last else NEGATED[ops[br].mnemonic],
                                     target="kernel" if last else f"epilogue{c}"))
        out.bundles.extend(r for r in rows if r)

    out.add_label("epilogue")
    move = "fmov" if proc.units.get("fp", 0) > proc.units.get("int", 0) else "mov"
    order = [unroll - 1] + list(range(unroll - 1))
    for k, c in enumerate(order):
        if c != unroll - 1:
            out.add_label(f"epilogue{c}")
        first = len(out.bundles)
        for e in range(stages - 1):
            emit_rows(rows_of(lambda s, e=e: s >= e + 1, lambda s, c=c, e=e: c + stages + e - s))
        items = []
        for r, d in sorted(last_def.items()):
            q = names[d]
            final = q[(c + stages - 1) % len(q)]
            if final != r:
                items.append(Placed(-1, op=Op(move, (r, final)), source=d))
        if k < len(order) - 1 or stages > 1:
            items.append(Placed(-1, op=Op("j", (0,)), target="done", source=br))
        if items and not (len(out.bundles) > first and _join(out.bundles[-1], items, ops, proc)):
            emit_block(items)
    if stages > 1:
        out.add_label("fallback")
        for b in list_schedule(ops, proc, config, dependences(ops, proc, config, inorder=inorder)):
            out.bundles.append([Placed(k, target="fallback" if k == br else "") for k in b])
    out.add_label("done")
    return out
