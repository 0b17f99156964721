"""RecMII, the recurrence bound of a loop (docs/scheduling.md, "Bounds"): the least II with no
dependence cycle of positive weight latency − II·distance. `asm --bounds`, `report bounds` and
the modulo scheduler (asm/modulo.py) all ask this one computation; it is cheap because a cycle
lies within one strongly connected component and a longest-path search of each II tried costs
O(V·E) at most, a few passes in practice.
"""

from __future__ import annotations


def recurrence_mii(n: int, edges) -> int:
    """RecMII of `n` operations joined by `edges` (src, dst, latency, distance; an edge of
    distance 0 runs forward, src < dst): the smallest II ≥ 1 with no cycle c of
    Σ latency(c) > II · Σ distance(c); 1 when no edge is carried.

    A cycle lies within one strongly connected component, so only the edges inside one count;
    a binary search over II asks `positive_cycle` of them, a longest-path Bellman–Ford of at
    most O(V·E) relaxations (an all-pairs closure over every carried edge's head took 17 s on
    `report bounds` of a small run)."""
    comp = strong_components(n, edges)
    inner = [e for e in edges if comp[e.src] == comp[e.dst]]
    if not any(e.distance for e in inner):
        return 1
    lo, hi = 1, max(1, sum(max(e.latency, 0) for e in inner))  # a cycle's ratio is at most that
    while lo < hi:
        mid = (lo + hi) // 2
        cycle = positive_cycle(n, inner, mid)
        if cycle is None:
            hi = mid
        else:  # the II must exceed that cycle's ratio too: often the answer at once
            lat, dist = cycle
            lo = min(hi, max(mid + 1, -(-lat // dist) if dist else 0))
    return lo


def positive_cycle(n: int, edges, ii: int) -> tuple[int, int] | None:
    """A cycle of `edges` weighing Σ (latency − ii·distance) > 0 as (Σ latency, Σ distance)
    ((0, 0) when one exists but was not singled out), or None: longest paths from everywhere
    by passes over the edges in source order. Edges that run forward in that order are all
    followed within a pass, so the longest simple path, which takes each backward (carried)
    edge at most once, is found within backward + 1 passes; a change in the pass after that
    means a positive cycle (without one, a pass with no change is a fixpoint). A cycle among
    the best-predecessor links is a positive one (each link was a strict improvement), so
    most searches end in a pass or two."""
    order = sorted(edges, key=lambda e: e.src)
    arcs = [(e.src, e.dst, e.latency - ii * e.distance) for e in order]
    backward = sum(1 for e in order if e.dst <= e.src)
    longest = [0] * n
    pred: list[int] = [-1] * n  # the arc that last improved each node
    for _ in range(backward + 2):
        changed = False
        for k, (src, dst, w) in enumerate(arcs):
            if longest[src] + w > longest[dst]:
                longest[dst] = longest[src] + w
                pred[dst] = k
                changed = True
        if not changed:
            return None
        cycle = _predecessor_cycle(pred, order)
        if cycle is not None:
            return cycle
    return (0, 0)


def _predecessor_cycle(pred: list[int], order) -> tuple[int, int] | None:
    """(Σ latency, Σ distance) of a cycle of best-predecessor links, if there is one: O(V)."""
    seen = [0] * len(pred)  # 0 unvisited, else the walk that reached it
    for start in range(len(pred)):
        walk, v = start + 1, start
        while v >= 0 and not seen[v]:
            seen[v] = walk
            v = order[pred[v]].src if pred[v] >= 0 else -1
        if v >= 0 and seen[v] == walk:  # closed on this walk: the cycle through v
            lat = dist = 0
            u = v
            while True:
                e = order[pred[u]]
                lat, dist = lat + e.latency, dist + e.distance
                u = e.src
                if u == v:
                    return lat, dist
    return None


def strong_components(n: int, edges) -> list[int]:
    """The strongly connected component of each of `n` nodes (Tarjan's, without recursion: a
    loop may be thousands of operations)."""
    succs: list[list[int]] = [[] for _ in range(n)]
    for e in edges:
        succs[e.src].append(e.dst)
    index, low, comp = [-1] * n, [0] * n, [-1] * n
    stack: list[int] = []
    on_stack = [False] * n
    counter = found = 0
    for root in range(n):
        if index[root] >= 0:
            continue
        work = [(root, 0)]
        while work:
            v, i = work.pop()
            if i == 0:
                index[v] = low[v] = counter
                counter += 1
                stack.append(v)
                on_stack[v] = True
            if i < len(succs[v]):
                work.append((v, i + 1))
                w = succs[v][i]
                if index[w] < 0:
                    work.append((w, 0))
                elif on_stack[w]:
                    low[v] = min(low[v], index[w])
                continue
            if low[v] == index[v]:
                while True:
                    w = stack.pop()
                    on_stack[w] = False
                    comp[w] = found
                    if w == v:
                        break
                found += 1
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[v])
    return comp
