"""The exact shortest schedule of a small block, by constraint programming (OR-Tools CP-SAT).

A report, never on the assembler's path: `asm --bounds` and `report bounds` ask it for blocks of
up to `asm.bounds.OPTIMUM_MAX_OPS` operations, so they can say "written 14 cycles, optimum 11".
The model is the machine's rules for one pass through a block (docs/timing.md; the dependence
graph's edges, asm/dependences.py), time-indexed:

- one start variable s_o per operation and a 0/1 variable x[o, t] per cycle it may issue in
  (Σ_t x[o, t] = 1, s_o = Σ_t t·x[o, t]);
- one interval per operation, its unit's occupancy long (1; an unpipelined op's latency), in a
  cumulative per unit class with the class's unit count as capacity (T4);
- precedence: s_dst ≥ s_src + latency for every edge of the graph (true, anti, output, memory,
  FIFO, control);
- a load with access time T holds issue: no operation starts in s_load + 1 .. s_load + T − 1
  (T6);
- per cycle: distinct values read ≤ read ports, writes issued ≤ write ports (the bundle rule)
  and writes landing (s_o + latency) ≤ write ports (T5);
- the length, minimised: max over operations of s_o + its issue hold (1, a load's T); in a
  block that halts, the halt's cycle + 1 (T9: the processor stops, so no hold matters).

Registers are ready at the block's entry and every load hits, as for the other bounds. The
solve is deterministic: one worker, a fixed seed and a limit in CP-SAT's *deterministic* time,
so the same block gives the same answer on any machine — and, as a guard on a loaded or slow
host, a wall-clock limit (WALL_SECONDS) that states itself when it ends the search. The answer
is an optimum only when CP-SAT proves it; otherwise the best schedule found, with CP-SAT's bound
("best 14, bound 11 within 10 s"). A model over MAX_MODEL_CELLS (operations × the cycles each
may issue in) is not built at all: "too large: N operations × H cycles" (a 2,000-operation
block once ran out of memory after 46 s). The model is built in time linear in its size: each
cycle's variables are gathered once, not searched for per cycle.
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.asm.dependences import DependenceGraph, unit_busy
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor

DETERMINISTIC_SECONDS = 2.0
"""CP-SAT's deterministic time limit per block (its own work units, about a second each)."""

WALL_SECONDS = 10.0
"""Wall-clock limit of one solve, whatever the deterministic limit: the outcome names it."""

MAX_MODEL_CELLS = 10_000
"""0/1 issue variables (an operation × a cycle it may issue in) plus dependence edges of the
largest model built: a second or two of building (a 40-operation block of the bundled kernels
needs a few thousand); larger is stated as too large, not attempted."""

PROGRAM_MODEL_CELLS = 4 * MAX_MODEL_CELLS
"""The model size (as MAX_MODEL_CELLS counts it) all the optima of one program may build
together: each block under the limit, 30 blocks of a kernel with long loads still took a minute
(`ModelBudget`). The bundled kernels' programs need under a quarter of it."""


@dataclass
class ModelBudget:
    """What is left of one program's PROGRAM_MODEL_CELLS: the optima of its blocks draw on it in
    program order, and a block whose model would overdraw it is stated, not solved — counted
    in model cells, not seconds, so the same program gets the same outcomes on any host."""
    left: int = PROGRAM_MODEL_CELLS


@dataclass(frozen=True)
class Optimum:
    length: int | None
    """Cycles of the best schedule found (the optimum when `proven`; None: none was sought)."""
    proven: bool
    starts: tuple[int, ...]
    """Issue cycle of each operation in that schedule."""
    note: str = ""
    """The outcome when it is not a proven optimum: "best N, bound M within 10 s" or "too
    large: N operations × H cycles"."""


def serial_length(graph: DependenceGraph, proc: Processor, config: MachineConfig) -> int:
    """The length of a schedule that always exists: one operation at a time in serial order,
    each after the previous one's result, hold and unit are done (so no two writes land in one
    cycle and every edge, of latency at most its source's, is met)."""
    total = 0
    for op, lat, hold in zip(graph.ops, graph.latencies, graph.holds):
        total += max(1, lat, hold, unit_busy(op, proc, config))
    return total


def optimum_schedule(graph: DependenceGraph, reads: list[list[tuple[int, int]]], proc: Processor,
                     config: MachineConfig, lower: int = 0, upper: int | None = None,
                     hint: list[int] | None = None,
                     seconds: float = DETERMINISTIC_SECONDS,
                     budget: ModelBudget | None = None) -> Optimum | None:
    """The shortest schedule of the block `graph` (serial order) on `proc`; `reads[o]` the values
    op o reads (asm.bounds.value_reads), `lower` a known bound, `upper` a known feasible length
    (the code as written) with `hint` its start cycles. None when nothing was found in time."""
    try:
        from ortools.sat.python import cp_model
    except ImportError:
        raise NetsushisenError("the optimum schedule needs OR-Tools (a dependency: pip install "
                               "ortools), or leave it out with --optimum-ops 0") from None

    n = len(graph.ops)
    if n == 0:
        return Optimum(0, True, ())
    serial = serial_length(graph, proc, config)
    horizon = min(upper, serial) if upper else serial
    import time

    started = time.monotonic()
    result = _solve(cp_model, graph, reads, proc, config, lower, horizon, hint, seconds,
                    WALL_SECONDS, budget)
    if result is not None and result.length is None:
        return result  # too large: the serial horizon would be larger still
    left = WALL_SECONDS - (time.monotonic() - started)
    if result is None and horizon < serial and left > 1:  # the written length was not enough
        result = _solve(cp_model, graph, reads, proc, config, lower, serial, None, seconds, left,
                        budget)
    return result


def _solve(cp_model, graph: DependenceGraph, reads, proc: Processor, config: MachineConfig,
           lower: int, horizon: int, hint: list[int] | None, seconds: float,
           wall: float, budget: ModelBudget | None = None) -> Optimum | None:
    n = len(graph.ops)
    # earliest and latest issue cycles within the horizon (edges of one pass run forward)
    est = [0] * n
    for i in range(n):
        for e in graph.succs(i):
            est[e.dst] = max(est[e.dst], est[i] + e.latency)
    halts = graph.ops[-1].opcode.kind == "halt"  # last (control edges): nothing issues after it
    tail = [1] * n if halts else list(graph.holds)  # cycles from an op's issue to the end
    for i in reversed(range(n)):
        for e in graph.succs(i):
            tail[i] = max(tail[i], e.latency + tail[e.dst])
    lst = [horizon - tail[i] for i in range(n)]
    if any(lst[i] < est[i] for i in range(n)):
        return None
    cells = sum(lst[i] - est[i] + 1 for i in range(n))
    # a load's hold is a clause per issue slot and held cycle: with a long access time (a legal
    # ic_memory.t_r of 1,024) that, not the slots, is the model's size (millions of clauses)
    holds = sum((lst[i] - est[i] + 1) * (h - 1) for i, h in enumerate(graph.holds) if h > 1)
    size = cells + len(graph.edges) + holds
    if size > MAX_MODEL_CELLS:
        return Optimum(None, False, (), f"too large: {n:,} operations × {horizon:,} cycles "
                                        f"(more than {MAX_MODEL_CELLS:,} issue slots and edges, "
                                        "loads' held cycles counted)")
    if budget is not None:
        if size > budget.left:
            return Optimum(None, False, (), f"not sought: the program's {PROGRAM_MODEL_CELLS:,} "
                                            "issue slots and edges for optima are spent")
        budget.left -= size
    m = cp_model.CpModel()
    starts = [m.NewIntVar(est[i], lst[i], f"s{i}") for i in range(n)]
    x = [{t: m.NewBoolVar(f"x{i}_{t}") for t in range(est[i], lst[i] + 1)} for i in range(n)]
    for i in range(n):
        m.AddExactlyOne(x[i].values())
        m.Add(starts[i] == sum(t * v for t, v in x[i].items()))
    for e in graph.edges:
        if e.distance == 0:
            m.Add(starts[e.dst] >= starts[e.src] + e.latency)
    # units: one interval per operation, a cumulative per class
    by_unit: dict[str, list] = {}
    for i, op in enumerate(graph.ops):
        size = unit_busy(op, proc, config)
        iv = m.NewIntervalVar(starts[i], size, starts[i] + size, f"u{i}")
        by_unit.setdefault(proc.unit(op.opcode.unit), []).append(iv)
    for unit, intervals in by_unit.items():
        m.AddCumulative(intervals, [1] * len(intervals), proc.units[unit])
    cycles = range(horizon)
    by_cycle: list[list[int]] = [[] for _ in cycles]  # operations that may issue in each cycle
    for i in range(n):
        for t in x[i]:
            by_cycle[t].append(i)

    def at(t: int) -> list:
        return [x[i][t] for i in by_cycle[t]]

    # loads hold issue
    issue = {}
    for t in cycles:
        vs = at(t)
        if vs:
            issue[t] = m.NewBoolVar(f"issue{t}")
            m.AddMaxEquality(issue[t], vs)
    for i, hold in enumerate(graph.holds):
        for t, v in x[i].items():
            for k in range(1, hold):
                if t + k in issue:
                    m.AddBoolOr([v.Not(), issue[t + k].Not()])
    # register ports per cycle
    values = sorted({v for vs in reads for v in vs})
    reads_of = [sorted(set(vs)) for vs in reads]
    writes = [len(op.writes()) for op in graph.ops]
    landing: list[list[int]] = [[] for _ in cycles]  # writers whose result lands in each cycle
    for i in range(n):
        if writes[i]:
            for t in x[i]:
                if t + graph.latencies[i] < horizon:
                    landing[t + graph.latencies[i]].append(i)
    for t in cycles:
        used = []
        readers_now: dict = {}
        for i in by_cycle[t]:
            for v in reads_of[i]:
                readers_now.setdefault(v, []).append(x[i][t])
        for v in values:
            vs = readers_now.get(v)
            if not vs:
                continue
            if len(vs) == 1:
                used.append(vs[0])
            else:
                y = m.NewBoolVar(f"r{t}")
                m.AddMaxEquality(y, vs)
                used.append(y)
        if len(used) > proc.read_ports:
            m.Add(sum(used) <= proc.read_ports)
        issued = [writes[i] * x[i][t] for i in by_cycle[t] if writes[i]]
        if sum(writes[i] for i in by_cycle[t]) > proc.write_ports:
            m.Add(sum(issued) <= proc.write_ports)
        land = [(writes[i], x[i][t - graph.latencies[i]]) for i in landing[t]]
        if sum(w for w, _ in land) > proc.write_ports:
            m.Add(sum(w * v for w, v in land) <= proc.write_ports)
    length = m.NewIntVar(max(lower, 1), horizon, "length")
    for i in range(n):
        m.Add(length >= starts[i] + (1 if halts else graph.holds[i]))
    m.Minimize(length)
    if hint is not None and len(hint) == n:
        for i, t in enumerate(hint):
            if t in x[i]:
                m.AddHint(starts[i], t)
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = 0
    solver.parameters.max_deterministic_time = seconds
    solver.parameters.max_time_in_seconds = wall
    status = solver.Solve(m)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return None
    best = int(solver.Value(length))
    proven = status == cp_model.OPTIMAL
    note = ""
    if not proven:
        bound = int(solver.BestObjectiveBound())
        limit = (f"within {WALL_SECONDS:g} s" if solver.WallTime() >= wall * 0.99
                 else f"within {seconds:g} deterministic s")
        note = f"best {best}, bound {bound} {limit}"
    return Optimum(best, proven, tuple(int(solver.Value(s)) for s in starts), note)
