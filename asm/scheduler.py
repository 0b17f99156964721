"""The list scheduler of linear assembly (`.sched` regions): a block's operations into bundles.

Cycle by cycle, the ready operations (every predecessor placed, its latency elapsed) are placed
highest priority first — in a superblock, what its earliest side exit waits for; then a load
that holds issue; then the longest latency-weighted path to the end of the block
(`DependenceGraph.heights`; in a superblock, to the operation's exit); then serial order, so the
result is deterministic — wherever the
processor's resources allow (`Reservations`): unit slots (an unpipelined unit stays busy for its
latency), distinct register reads within the read ports, register writes within the write ports
both per bundle and per completion cycle (T5), one control transfer, nothing issued while a load
holds issue (T6). The order kept is the dependence graph's (asm/dependences.py). Empty cycles are
dropped from the output: the interlocks wait there just as long.

`Reservations` also serves the modulo scheduler (asm/pipeline.py): with `ii` set, cycles are
folded modulo II into the rows of a modulo reservation table.
"""

from __future__ import annotations

import bisect

from collections import Counter
from dataclasses import dataclass, field

from netsushisen.asm.dependences import BLOCK_END_KINDS, DependenceGraph, dependences, unit_busy
from netsushisen.asm.objects import Op
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor


@dataclass
class _Row:
    units: Counter = field(default_factory=Counter)
    reads: set = field(default_factory=set)
    writes: int = 0
    completions: int = 0
    control: int = 0
    ops: int = 0
    blocked: int = 0  # load holds covering this cycle


class Reservations:
    """Resource use per cycle (or per row modulo `ii`) of the bundles being built."""

    def __init__(self, proc: Processor, config: MachineConfig, ii: int | None = None):
        self.proc, self.config, self.ii = proc, config, ii
        self.rows: dict[int, _Row] = {}
        self.issued: list[int] = []  # sorted cycles holding an operation (list schedules)
        self.held: list[tuple[int, int]] = []  # (first, last) cycles a placed load holds

    def _row(self, cycle: int) -> _Row:
        key = cycle % self.ii if self.ii else cycle
        row = self.rows.get(key)
        if row is None:
            row = self.rows[key] = _Row()
        return row

    def _claims(self, op: Op, cycle: int, latency: int, hold: int, reads,
                holds: bool = True) -> list:
        unit = None if op.opcode.kind == "nop" else self.proc.unit(op.opcode.unit)
        out = []
        if unit is not None:
            for k in range(unit_busy(op, self.proc, self.config)):
                out.append((cycle + k, "unit", unit))
        out.append((cycle, "op", reads))
        n = len(op.writes())
        if n:
            out.append((cycle, "writes", n))
            out.append((cycle + latency, "completions", n))
        if op.opcode.is_control:
            out.append((cycle, "control", 1))
        for k in range(1, hold if holds else 1):
            out.append((cycle + k, "blocked", 1))
        return out

    def unheld(self, cycle: int) -> int:
        """The first cycle from `cycle` on that no placed load holds (list schedules): no
        operation can issue in a held cycle, so the scheduler goes past them at once."""
        k = bisect.bisect_right(self.held, (cycle, 1 << 62)) - 1
        while 0 <= k < len(self.held) and self.held[k][0] <= cycle <= self.held[k][1]:
            cycle = self.held[k][1] + 1
            k += 1
        return cycle

    def _hold_clear(self, cycle: int, hold: int) -> bool:
        """Whether no operation is placed in the cycles a load issued in `cycle` holds
        (cycle+1 .. cycle+hold-1), found by bisection in the sorted issue cycles, not by a
        claim per held cycle: a check costs log(placed), never the load's latency times the
        attempts (the list scheduler's horizon does not grow with a 4,096-cycle load)."""
        k = bisect.bisect_left(self.issued, cycle + 1)
        return k == len(self.issued) or self.issued[k] > cycle + hold - 1

    def fits(self, op: Op, cycle: int, latency: int, hold: int, reads=None) -> bool:
        """Whether `op` can issue in `cycle` beside what is placed (`reads`: the register names
        it reads, if not `op.reads()` — the modulo scheduler passes names per iteration)."""
        reads = frozenset(op.reads() if reads is None else reads)
        if self.ii and hold > self.ii:  # a load holding issue for a whole II blocks its own row
            return False
        claims = self._claims(op, cycle, latency, hold, reads, holds=bool(self.ii))
        if not self.ii and hold > 1 and not self._hold_clear(cycle, hold):
            return False
        proc = self.proc
        # group claims per row (a modulo row may be claimed twice by one op)
        per: dict[int, dict] = {}
        for c, kind, v in claims:
            key = c % self.ii if self.ii else c
            d = per.setdefault(key, {"unit": Counter(), "writes": 0, "completions": 0,
                                     "control": 0, "blocked": 0, "reads": None})
            if kind == "unit":
                d["unit"][v] += 1
            elif kind == "op":
                d["reads"] = v
            else:
                d[kind] += v
        for key, d in per.items():
            row = self.rows.get(key) or _Row()
            for unit, n in d["unit"].items():
                if row.units[unit] + n > proc.units.get(unit, 0):
                    return False
            if d["reads"] is not None:
                if row.blocked or (not proc.vliw and row.ops):
                    return False
                if len(row.reads | d["reads"]) > proc.read_ports:
                    return False
            if row.writes + d["writes"] > proc.write_ports:
                return False
            if row.completions + d["completions"] > proc.write_ports:
                return False
            if row.control + d["control"] > 1:
                return False
            if d["blocked"] and (row.ops or (d["reads"] is not None)):
                return False
        return True

    def place(self, op: Op, cycle: int, latency: int, hold: int, reads=None) -> None:
        """Claim what `op` uses. A list schedule keeps a load's held cycles as one interval in
        `held`, not a row each (the scheduler never tries a held cycle: `unheld`): a row per
        held cycle made a 2,000-operation region with loads of 4,096 cycles take 10 s."""
        reads = frozenset(op.reads() if reads is None else reads)
        for c, kind, v in self._claims(op, cycle, latency, hold, reads, holds=bool(self.ii)):
            row = self._row(c)
            if kind == "unit":
                row.units[v] += 1
            elif kind == "op":
                row.ops += 1
                row.reads |= v
                if not self.ii and row.ops == 1:
                    bisect.insort(self.issued, c)
                if not self.ii and hold > 1:
                    bisect.insort(self.held, (c + 1, c + hold - 1))
            else:
                setattr(row, kind, getattr(row, kind) + v)


def list_schedule(ops: list[Op] | tuple[Op, ...], proc: Processor, config: MachineConfig,
                  graph: DependenceGraph | None = None) -> list[list[int]]:
    """One block's operations (serial order; a control transfer or halt only last) as bundles of
    operation indices, each bundle in serial order."""
    time = issue_times(ops, proc, config, graph)
    by_cycle: dict[int, list[int]] = {}
    for i, t in enumerate(time):
        by_cycle.setdefault(t, []).append(i)
    return [sorted(by_cycle[t]) for t in sorted(by_cycle)]


def issue_times(ops: list[Op] | tuple[Op, ...], proc: Processor, config: MachineConfig,
                graph: DependenceGraph | None = None) -> list[int]:
    """The cycle the list scheduler issues each operation in (empty cycles kept)."""
    g = graph or dependences(ops, proc, config)
    n = len(g.ops)
    if n == 0:
        return []
    res = Reservations(proc, config)
    time: list[int | None] = [None] * n
    waiting = [sum(1 for e in g.preds(i) if e.distance == 0) for i in range(n)]
    earliest = [0] * n
    ready = {i for i in range(n) if waiting[i] == 0}
    # a superblock's side exits first: an operation ranks by the first control transfer at or
    # after it (serial order), so what an exit waits for is placed before what may be hoisted
    ends = [j for j, op in enumerate(g.ops) if op.opcode.kind in BLOCK_END_KINDS]
    rank = [bisect.bisect_left(ends, i) for i in range(n)]  # the first end at or after i
    height = list(g.heights)
    if len(ends) > 1:  # ... and within a rank, the longest path to that exit (not past it)
        for k, end in enumerate(ends):
            h = g.heights_to(end)
            for i in range(end + 1):
                if rank[i] == k:
                    height[i] = h[i]
    # a load that holds issue goes first among its rank: every cycle it waits is a cycle the
    # whole machine waits later (T6), which the heights do not see
    hold = [g.holds[i] > 1 for i in range(n)]
    key = {i: (rank[i], not hold[i], -height[i], i) for i in range(n)}
    left = n
    cycle = 0
    while left:
        for i in sorted((i for i in ready if earliest[i] <= cycle), key=key.__getitem__):
            if res.fits(g.ops[i], cycle, g.latencies[i], g.holds[i]):
                res.place(g.ops[i], cycle, g.latencies[i], g.holds[i])
                time[i] = cycle
                ready.discard(i)
                left -= 1
                for e in g.succs(i):
                    if e.distance:
                        continue
                    earliest[e.dst] = max(earliest[e.dst], cycle + e.latency)
                    waiting[e.dst] -= 1
                    if waiting[e.dst] == 0:
                        ready.add(e.dst)
        # newly ready operations with latency 0 may join this cycle's bundle
        if any(earliest[i] <= cycle and res.fits(g.ops[i], cycle, g.latencies[i], g.holds[i])
               for i in ready):
            continue
        # no cycle before the earliest a ready operation may issue in can take one: go there at
        # once (a load of 4,096 cycles must not cost 4,096 turns of this loop)
        cycle = res.unheld(max(cycle + 1, min((earliest[i] for i in ready), default=cycle + 1)))
    return time  # type: ignore[return-value]
