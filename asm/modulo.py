"""Iterative modulo scheduling (Rau 1994) of a loop body: the lower bounds on its initiation
interval and the modulo schedule itself; asm/pipeline.py turns a schedule into code.

- ResMII (`resource_bound`): per unit class, the busy cycles of one iteration over the units (an
  unpipelined unit is busy for its whole latency), plus the cycles loads hold issue.
- The port bound (`port_bound`): distinct values read per iteration over the read ports,
  register writes over the write ports.
- RecMII (`recurrence_bound`): the least II with no dependence cycle of positive weight
  latency - II·distance; `critical_recurrence` names the cycle.
- `modulo_schedule`: flat issue times at a given II in a modulo reservation table of the same
  resources the list scheduler uses (asm/scheduler.py, `Reservations` with `ii`), the loop's
  branch fixed in the last row of stage 0, operations placed by height with eviction and retry
  within a budget.
"""

from __future__ import annotations

import math

from netsushisen.asm.dependences import DependenceGraph, unit_busy
from netsushisen.asm.scheduler import Reservations
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor, register_name



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


def value_of_reads(g: DependenceGraph) -> list[list[tuple[int, int, int | None, int]]]:
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
    values = {(r, d, dist if d is not None else 0) for reads in value_of_reads(g)
              for r, dist, d, _ in reads}
    writes = sum(len(op.writes()) for op in g.ops)
    b = max(math.ceil(len(values) / proc.read_ports), math.ceil(writes / proc.write_ports), 1)
    return b, f"reads {len(values)}/{proc.read_ports}, writes {writes}/{proc.write_ports}"


def recurrence_bound(n: int, edges) -> int:
    """RecMII: the least II with no cycle of positive weight latency - II·distance; the one
    computation `asm --bounds` prints too (`asm.bounds.recurrence_mii`)."""
    from netsushisen.asm.bounds import recurrence_mii

    return recurrence_mii(n, edges)


def critical_recurrence(g: DependenceGraph, edges) -> str:
    """The loop-carried dependence cycle that sets RecMII, in words: its operations and its
    latency over its distance (cycles closed by one loop-carried edge; the longest path back
    through the iteration's own edges)."""
    n = len(g.ops)
    best = None
    for e in edges:
        if not e.distance:
            continue
        # longest path e.dst -> e.src over distance-0 edges (they run forward in the body)
        dist = {e.dst: (0, [e.dst])}
        for k in range(e.dst, n):
            if k not in dist:
                continue
            for f in edges:
                if f.src == k and not f.distance and f.dst > k:
                    cand = dist[k][0] + f.latency
                    if f.dst not in dist or cand > dist[f.dst][0]:
                        dist[f.dst] = (cand, dist[k][1] + [f.dst])
        if e.src not in dist:
            continue
        lat, path = dist[e.src][0] + e.latency, dist[e.src][1]
        key = (math.ceil(lat / e.distance), lat)
        if best is None or key > best[0]:
            best = (key, lat, e.distance, path)
    if best is None:
        return ""
    _, lat, d, path = best
    names = " -> ".join(g.ops[k].mnemonic + " " + ", ".join(register_name(r) for r in g.ops[k].writes())
                        for k in path)
    return f"{names.strip()}: {lat} cycles over {d} iteration{'s' if d > 1 else ''}"


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
    reads = value_of_reads(g)
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
