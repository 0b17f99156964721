"""Software pipelining of `.pipeline` loops: iterative modulo scheduling (Rau 1994), modulo
variable expansion into the `.temps` registers, prologue, kernel, epilogues and a trip-count guard.

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
rewritten before its last read) and keeps true, memory and FIFO edges (asm/dependences.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from netsushisen.asm.dependences import DependenceGraph, dependences, unit_busy
from netsushisen.asm.objects import Op
from netsushisen.asm.scheduler import Reservations, list_schedule
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor, register_name

NEGATED = {"beq": "bne", "bne": "beq", "blt": "bge", "bge": "blt", "bltu": "bgeu",
           "bgeu": "bltu", "beqz": "bnez", "bnez": "beqz"}
MAX_II_TRIES = 16


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
    ii: int = 0
    stages: int = 0
    unroll: int = 0
    registers: tuple[int, ...] = ()
    temps: tuple[int, ...] = ()
    penalty: int = 0
    reason: str = ""

    @property
    def mii(self) -> int:
        return max(self.res_mii, self.port_mii, self.rec_mii)

    def format(self) -> str:
        head = f";* software pipelining information: loop '{self.name}' ({self.where}), {self.ops} operations"
        if not self.ops:
            return head
        rows = [head,
                f";*   resource bound (units)  : {self.res_mii}   ({self.res_detail})",
                f";*   port bound              : {self.port_mii}   ({self.port_detail})",
                f";*   recurrence bound        : {self.rec_mii}",
                f";*   minimum II              : {self.mii}"]
        if self.reason:
            rows.append(f";*   not pipelined: {self.reason}; the loop is list-scheduled")
            return "\n".join(rows)
        per_iter = self.ii + self.penalty / self.unroll
        temps = ", ".join(register_name(r) for r in self.registers) or "none"
        rows += [f";*   II achieved             : {self.ii}   ({per_iter:g} cycles per iteration with the "
                 f"taken-branch penalty {self.penalty} once per {self.unroll} kernel "
                 f"cop{'y' if self.unroll == 1 else 'ies'})",
                 f";*   stages                  : {self.stages}",
                 f";*   kernel copies (MVE)     : {self.unroll}",
                 f";*   registers used          : {len(self.registers)} of {len(self.temps)} .temps ({temps})",
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
# Bounds


def _class_use(ops, proc: Processor, config: MachineConfig) -> dict[str, int]:
    use: dict[str, int] = {}
    for op in ops:
        if op.opcode.kind != "nop":
            u = proc.unit(op.opcode.unit)
            use[u] = use.get(u, 0) + unit_busy(op, proc, config)
    return use


def resource_bound(g: DependenceGraph, proc: Processor, config: MachineConfig) -> tuple[int, str]:
    """ResMII: per unit class, busy cycles over units; plus the cycles loads hold issue."""
    use = _class_use(g.ops, proc, config)
    held = sum(h - 1 for h in g.holds)
    if not proc.vliw:
        n = sum(1 for op in g.ops if op.opcode.kind != "nop")
        return n + held, f"{n} operations on 1 unit" + (f", {held} held" if held else "")
    best = max((math.ceil(n / proc.units[u]) for u, n in use.items()), default=1)
    detail = ", ".join(f"{u} {use.get(u, 0)}/{proc.units[u]}" for u in proc.units)
    if held:
        detail += f", loads hold issue {held}"
    return max(1, best + held), detail


def _value_of_reads(g: DependenceGraph) -> list[list[tuple[int, int, int | None, int]]]:
    """Per operation, (register, distance, defining op or None, reg) for each register read."""
    ops = g.ops
    last: dict[int, int] = {}
    for j, op in enumerate(ops):
        for r in op.writes():
            last[r] = j
    out = []
    seen: dict[int, int] = {}
    for j, op in enumerate(ops):
        here = []
        for r in sorted(set(op.reads())):
            if r in seen:
                here.append((r, 0, seen[r], r))
            elif r in last:
                here.append((r, 1, last[r], r))
            else:
                here.append((r, 0, None, r))
        out.append(here)
        for r in op.writes():
            seen[r] = j
    return out


def port_bound(g: DependenceGraph, proc: Processor) -> tuple[int, str]:
    """Every distinct value read once per iteration, every write through a write port."""
    values = {(r, d, dist if d is not None else 0) for reads in _value_of_reads(g)
              for r, dist, d, _ in reads}
    writes = sum(len(op.writes()) for op in g.ops)
    b = max(math.ceil(len(values) / proc.read_ports), math.ceil(writes / proc.write_ports), 1)
    return b, f"reads {len(values)}/{proc.read_ports}, writes {writes}/{proc.write_ports}"


def recurrence_bound(n: int, edges) -> int:
    """RecMII: the least II with no cycle of positive weight latency - II·distance."""
    if not any(e.distance for e in edges):
        return 1

    def positive_cycle(ii: int) -> bool:
        d = np.full((n, n), -np.inf)
        for e in edges:
            d[e.src, e.dst] = max(d[e.src, e.dst], e.latency - ii * e.distance)
        for k in range(n):
            d = np.maximum(d, d[:, k, None] + d[None, k, :])
        return bool(np.any(np.diag(d) > 0))

    lo, hi = 1, max(1, sum(e.latency for e in edges) + 1)
    while lo < hi:
        mid = (lo + hi) // 2
        if positive_cycle(mid):
            lo = mid + 1
        else:
            hi = mid
    return lo


# ---------------------------------------------------------------------------------------------
# The loop's shape


@dataclass
class _Loop:
    branch: int
    induction: int | None  # register
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
    return _Loop(br, induction, step, addi)


# ---------------------------------------------------------------------------------------------
# Iterative modulo scheduling


def _heights(n: int, edges, ii: int) -> list[int]:
    h = [0] * n
    for _ in range(n + 1):
        changed = False
        for e in edges:
            v = e.latency - ii * e.distance + h[e.dst]
            if v > h[e.src]:
                h[e.src] = v
                changed = True
        if not changed:
            break
    return h


def _read_keys(reads, t: int, ii: int) -> frozenset:
    """Names an operation reads when issued at flat time t: a renamed value's copy depends on the
    iteration (its stage), so reads are told apart by (register, definition, iteration)."""
    stage = t // ii
    return frozenset((r, d, -stage - dist) if d is not None else (r,) for r, dist, d, _ in reads)


def modulo_schedule(g: DependenceGraph, edges, ii: int, branch: int, proc: Processor,
                    config: MachineConfig, budget_factor: int = 6) -> list[int] | None:
    """Flat issue times (stage = time // II) of the body at this II, the branch fixed in the last
    row of stage 0; None when the budget of placements runs out."""
    n = len(g.ops)
    reads = _value_of_reads(g)
    preds: list[list] = [[] for _ in range(n)]
    succs: list[list] = [[] for _ in range(n)]
    for e in edges:
        preds[e.dst].append(e)
        succs[e.src].append(e)
    h = _heights(n, edges, ii)
    time: list[int | None] = [None] * n
    time[branch] = ii - 1
    last_try: dict[int, int] = {}

    def reservations() -> Reservations:
        res = Reservations(proc, config, ii)
        for i in range(n):
            if time[i] is not None:
                res.place(g.ops[i], time[i], g.latencies[i], g.holds[i],
                          _read_keys(reads[i], time[i], ii))
        return res

    def fits(res: Reservations, i: int, t: int) -> bool:
        return res.fits(g.ops[i], t, g.latencies[i], g.holds[i], _read_keys(reads[i], t, ii))

    res = reservations()
    if not fits(Reservations(proc, config, ii), branch, ii - 1):
        return None
    budget = budget_factor * n
    while budget > 0:
        todo = [i for i in range(n) if time[i] is None]
        if not todo:
            return [t for t in time]  # type: ignore[misc]
        budget -= 1
        i = min(todo, key=lambda k: (-h[k], k))
        est = 0
        for e in preds[i]:
            if time[e.src] is not None:
                est = max(est, time[e.src] + e.latency - ii * e.distance)
        ub = math.inf
        for e in succs[i]:
            if e.dst == branch:
                ub = min(ub, time[branch] - e.latency + ii * e.distance)
        if est > ub:
            return None
        slot = next((t for t in range(est, int(min(est + ii - 1, ub)) + 1) if fits(res, i, t)), None)
        if slot is None:
            slot = est if last_try.get(i, -1) < est else last_try[i] + 1
            if slot > ub:
                slot = est
            # evict what shares the rows this operation needs, lowest priority first
            rows = {(slot + k) % ii for k in range(max(unit_busy(g.ops[i], proc, config), g.holds[i]))}
            rows.add((slot + g.latencies[i]) % ii)
            victims = sorted((k for k in range(n) if time[k] is not None and k != branch and
                              (time[k] % ii in rows or
                               any((time[k] + x) % ii in rows
                                   for x in range(1, max(g.holds[k], unit_busy(g.ops[k], proc, config))))
                               or (time[k] + g.latencies[k]) % ii in rows)),
                             key=lambda k: (h[k], -k))
            for k in victims:
                if fits(res, i, slot):
                    break
                time[k] = None
                res = reservations()
            if not fits(res, i, slot):
                return None
        time[i] = slot
        last_try[i] = slot
        res.place(g.ops[i], slot, g.latencies[i], g.holds[i], _read_keys(reads[i], slot, ii))
        evicted = False
        for e in succs[i]:
            k = e.dst
            if k != i and time[k] is not None and time[k] + ii * e.distance < slot + e.latency:
                if k == branch:
                    return None
                time[k] = None
                evicted = True
        for e in preds[i]:  # a self-loop or a predecessor placed later can be violated too
            k = e.src
            if k != i and time[k] is not None and slot + ii * e.distance < time[k] + e.latency:
                if k == branch:
                    return None
                time[k] = None
                evicted = True
        if evicted:
            res = reservations()
    return None


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


def pipeline_loop(ops: list[Op], proc: Processor, config: MachineConfig, temps: list[int],
                  report: PipelineReport) -> Layout | None:
    """The pipelined layout of a loop body (serial order, its back edge last), or None with
    `report.reason` saying why not. `report` gets the bounds and what was achieved."""
    report.ops = len(ops)
    shape = analyse(ops)
    g = dependences(ops, proc, config, loop=True)
    edges = [e for e in g.edges if e.kind in ("true", "memory", "fifo")]
    report.res_mii, report.res_detail = resource_bound(g, proc, config)
    report.port_mii, report.port_detail = port_bound(g, proc)
    report.rec_mii = recurrence_bound(len(ops), edges)
    report.temps = tuple(temps)
    report.penalty = getattr(config, proc.name).taken_branch_penalty
    if isinstance(shape, str):
        report.reason = shape
        return None
    used = {r for op in ops for r in (*op.reads(), *op.writes())}
    clash = sorted(set(temps) & used)
    if clash:
        report.reason = f".temps {register_name(clash[0])} is used by the loop"
        return None
    reads = _value_of_reads(g)
    reason = "no schedule found"
    for ii in range(report.mii, report.mii + MAX_II_TRIES):
        time = modulo_schedule(g, edges, ii, shape.branch, proc, config)
        if time is None:
            reason = f"no modulo schedule within II {report.mii}..{ii}"
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
        return _emit(ops, g, reads, time, ii, stages, unroll, names, shape, proc, config,
                     temps[0] if temps else 0, last_def)
    report.reason = reason
    return None


def _emit(ops, g, reads, time, ii, stages, unroll, names, shape: _Loop, proc, config, guard_temp,
          last_def) -> Layout:
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
        src = shape.induction
        for p in range(1, stages):
            base = shape.induction if p == 1 else guard_temp
            emit_block([Placed(-1, op=Op("addi", (guard_temp, base, shape.step)), source=shape.addi),
                        Placed(br, reads=((src, guard_temp),), mnemonic=NEGATED[ops[br].mnemonic],
                               target="fallback")])
    # prologue
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

    move = "fmov" if proc.units.get("fp", 0) > proc.units.get("int", 0) else "mov"
    order = [unroll - 1] + list(range(unroll - 1))
    for k, c in enumerate(order):
        if c != unroll - 1:
            out.add_label(f"epilogue{c}")
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
        if items:
            emit_block(items)
    if stages > 1:
        out.add_label("fallback")
        for b in list_schedule(ops, proc, config):
            out.bundles.append([Placed(k, target="fallback" if k == br else "") for k in b])
    out.add_label("done")
    return out
