"""Symbolic registers in `.sched` regions: `.vreg` names get registers from the region's pool.

A writer of linear assembly names values (`.vreg cx, cy, b`) and the assembler picks their
registers, as TI's assembly optimizer does with symbolic `.reg` names: liveness over the
region's operations and its branches (a backward dataflow to a fixed point), interference (a
name written while another is live may not share its register), and a greedy colouring in the
order names are first written, from the region's pool (`.temps`, or `.temps auto`: every
register no physical name of the program uses). Among the free registers it takes the one
freed longest ago, so the list scheduler after it finds few false dependences. Values live into
or out of the region stay physical (`.reg` names, or a pinned `.vreg x = r12`): a `.vreg` read
before any write is an error. When a point needs more registers than the pool has, allocation
fails with the point, the count and the live names — never a silent spill.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Pressure:
    """Too many values live at operation `at` for a pool of `pool` registers."""

    at: int
    live: tuple[str, ...]


def liveness(reads: list[set[str]], writes: list[set[str]], succ: list[tuple[int, ...]]
             ) -> tuple[list[frozenset[str]], list[frozenset[str]]]:
    """(live in, live out) of each operation: the names read later before a write."""
    n = len(reads)
    live_in = [frozenset()] * n
    live_out = [frozenset()] * n
    changed = True
    while changed:
        changed = False
        for i in range(n - 1, -1, -1):
            out = frozenset().union(*(live_in[j] for j in succ[i])) if succ[i] else frozenset()
            new_in = frozenset(reads[i]) | (out - writes[i])
            if out != live_out[i] or new_in != live_in[i]:
                live_out[i], live_in[i], changed = out, new_in, True
    return live_in, live_out


def allocate(reads: list[set[str]], writes: list[set[str]], succ: list[tuple[int, ...]],
             pool: list[int]) -> dict[str, int] | Pressure:
    """Registers for the names (module docstring), or the first point with too many live."""
    live_in, live_out = liveness(reads, writes, succ)
    for i in range(len(reads)):
        need = max(live_in[i], live_out[i] | writes[i], key=len)
        if len(need) > len(pool):
            return Pressure(i, tuple(sorted(need)))
    neighbours: dict[str, set[str]] = {}
    order: list[str] = []
    for i, ws in enumerate(writes):
        for w in sorted(ws):
            if w not in neighbours:
                order.append(w)
            neighbours.setdefault(w, set())
            for v in live_out[i] | ws:
                if v != w:
                    neighbours[w].add(v)
                    neighbours.setdefault(v, set()).add(w)
    last_use = {w: max([i for i in range(len(reads)) if w in reads[i] or w in writes[i]])
                for w in order}
    freed = {r: -1 for r in pool}  # when each register's last value died
    out: dict[str, int] = {}
    for i, name in enumerate(order):
        taken = {out[v] for v in neighbours[name] if v in out}
        free = [r for r in pool if r not in taken]
        if not free:
            first = min(k for k, ws in enumerate(writes) if name in ws)
            return Pressure(first, tuple(sorted({name} | neighbours[name])))
        reg = min(free, key=lambda r: (freed[r], pool.index(r)))
        out[name] = reg
        freed[reg] = last_use[name]
    return out


def pool_text(pool: list[int]) -> str:
    """`r40-r59, r61`: a pool as `.temps` would write it."""
    parts = []
    for r in sorted(pool):
        if parts and parts[-1][1] == r - 1:
            parts[-1][1] = r
        else:
            parts.append([r, r])
    return ", ".join(f"r{a}" if a == b else f"r{a}-r{b}" for a, b in parts)
