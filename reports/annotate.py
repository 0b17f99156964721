"""Annotated listing: each bundle of a processor's program with where its cycles went.

What `perf annotate` is to a profile and llvm-mca's timeline to a loop: per bundle address, the
times it issued, the stall cycles charged to it by cause (memory and branch stalls to the load or
branch holding issue, the others to the waiting bundle: docs/stalls.md), its share of the
processor's cycles (issued + stalled there / the processor's cycles) and its slot fill (its
operations / the processor's unit slots). Hottest first (`order="hot"`) or in program order.

Loops are natural loops (asm/loops.py: a back edge to a bundle that dominates it, nested into a
tree, named by the source label). Per loop that ran (every loop with `all_loops`): the loop
around it, its iterations (times its header issued), the cycles spent in its bundles, cycles per
iteration beside its bound (asm/bounds.py), the static ILP of its body, the dynamic ILP
(operations issued there / its cycles) and the dominant stall cause with its share of the loop's
cycles. Each bundle row names the innermost loop that holds it. The hot path (reports/bounds.py)
closes the report: blocks by total cycles, their share and excess over the bound.

The program's text comes from the statistics (`programs.<stage>.listing`, emulator/stats.py);
statistics written before it existed give the per-PC counts with labels only, and no loops.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from netsushisen.isa.processors import PROCESSORS
from netsushisen.reports.tables import Section, StatsError, present_processors

ORDERS = ("hot", "program")


@dataclass
class BundleCounts:
    """One bundle address of one processor: its text and counters."""
    pc: int
    label: str
    text: str | None
    ops: int | None
    target: int | None
    issued: int = 0
    stalls: dict[str, int] = field(default_factory=dict)
    lines: str | None = None
    """The source lines of its operations (a scheduled bundle gathers several)."""

    @property
    def stalled(self) -> int:
        return sum(self.stalls.values())

    @property
    def cycles(self) -> int:
        return self.issued + self.stalled


def bundle_counts(stats: dict, name: str, p: dict) -> list[BundleCounts]:
    """Every bundle of the processor's program in address order (with the listing), or every PC
    that issued or stalled (without it)."""
    stage = name.rsplit(".", 1)[-1]
    listing = ((stats.get("programs") or {}).get(stage) or {}).get("listing")
    issued = {int(k): int(v) for k, v in (p.get("bundles_by_pc") or {}).items()}
    by_pc = {int(k): v for k, v in (p.get("stalls_by_pc") or {}).items()}
    if listing:
        out = [BundleCounts(pc, *row) for pc, row in enumerate(
            zip(listing["label"], listing["text"], listing["ops"], listing["target"]))]
        for b, lines in zip(out, listing.get("lines") or []):
            b.lines = lines
    else:
        out = [BundleCounts(pc, (by_pc.get(pc) or {}).get("label", str(pc)), None, None, None)
               for pc in sorted(set(issued) | set(by_pc))]
    at = {b.pc: b for b in out}
    for pc, n in issued.items():
        if pc in at:
            at[pc].issued = n
    for pc, entry in by_pc.items():
        if pc in at:
            at[pc].stalls = dict(entry.get("stalls", {}))
    return out


def stalls_text(stalls: dict[str, int]) -> str:
    return ", ".join(f"{c} {n:,}" for c, n in sorted(stalls.items(), key=lambda kv: (-kv[1], kv[0])))


@dataclass
class Loop:
    """A natural loop of the listing (asm/loops.py) with the run's counters over its body."""
    start: int
    end: int
    label: str
    bundles: int
    cycles: int
    issued: int
    ops: int
    static_ops: int
    stalls: dict[str, int]
    header: int = 0
    body: tuple[int, ...] = ()
    parent: int | None = None
    """The index of the loop around it in `find_loops`'s list (None: outermost)."""
    parent_label: str | None = None
    iterations: int = 0
    """Times its header issued: the iterations (each pass through the loop issues it once)."""
    pcs_text: str = ""

    @property
    def dominant(self) -> tuple[str, int] | None:
        if not any(self.stalls.values()):
            return None
        return min(self.stalls.items(), key=lambda kv: (-kv[1], kv[0]))


def find_loops(counts: list[BundleCounts]) -> list[Loop]:
    """The natural loops of the listing (asm/loops.py: by dominators, nested, named by their
    source label), outermost first, each with its counters; none without the listing's text."""
    from netsushisen.asm.loops import listing_loops

    if not counts or any(b.text is None for b in counts) or counts[-1].pc != len(counts) - 1:
        return []
    at = {b.pc: b for b in counts}
    natural = listing_loops([b.label for b in counts], [b.text for b in counts],
                            [b.target for b in counts])
    loops = []
    for lp in natural:
        body = [at[pc] for pc in lp.body]
        stalls: dict[str, int] = {}
        for b in body:
            for c, n in b.stalls.items():
                stalls[c] = stalls.get(c, 0) + n
        loops.append(Loop(lp.start, lp.end, lp.name, len(body), sum(b.cycles for b in body),
                          sum(b.issued for b in body), sum(b.issued * (b.ops or 0) for b in body),
                          sum(b.ops or 0 for b in body), stalls, lp.header, lp.body, lp.parent,
                          None if lp.parent is None else natural[lp.parent].name,
                          at[lp.header].issued, lp.pcs_text))
    return loops


def innermost_loop(loops: list[Loop], pc: int) -> Loop | None:
    """The deepest loop whose body holds `pc`."""
    inside = [lp for lp in loops if pc in lp.body]
    return min(inside, key=lambda lp: len(lp.body), default=None)


def choose_processors(stats: dict, proc: str | None) -> list[tuple[str, dict]]:
    procs = present_processors(stats)
    if proc is None:
        return procs
    names = [n for n, _ in procs]
    chosen = [(n, p) for n, p in procs if n == proc or n.endswith("." + proc)]
    if not chosen:
        raise StatsError(f"--proc {proc}: these statistics have {', '.join(names) or 'no processors'}")
    return chosen


def annotate_sections(stats: dict, proc: str | None = None, top: int | None = None,
                      order: str = "hot", all_loops: bool = False) -> list[Section]:
    """The listing (`bundles`), the per-loop summary (`loops`) and the hot path (`hot`) of the
    chosen processors (`proc`: `pe0.ic`, or `ic` for every PE's IC; None: all). `top`: the N
    hottest bundles per processor (default: 20 hottest first; every bundle in program order).
    `all_loops`: also the loops that never ran."""
    from netsushisen.reports.bounds import add_hot_path, hot_path_section, loop_bounds

    if order not in ORDERS:
        raise StatsError(f"--order {order}: one of {', '.join(ORDERS)}")
    listing = Section("bundles", "Annotated listing" + (" (hottest first)" if order == "hot" else ""),
                      ["processor", "pc", "location", "loop", "bundle", "source lines", "issued",
                       "stall cycles", "stalls by cause", "share", "fill"],
                      formats={"pc": "int", "issued": "int", "stall cycles": "int", "share": "pct",
                               "fill": "pct"},
                      caption="loop = the innermost loop holding the bundle; share = (issued + "
                              "stall cycles) / the processor's cycles; fill = the "
                              "bundle's operations / the processor's unit slots; causes: "
                              "docs/stalls.md", group_by="processor")
    loops = Section("loops", "Loops (natural loops, each after the loop around it)"
                    + ("" if all_loops else " that ran"),
                    ["processor", "loop", "parent", "pcs", "bundles", "iterations", "cycles",
                     "share", "cycles/iter", "bound", "static ILP", "dynamic ILP",
                     "dominant stall"],
                    formats={"bundles": "int", "iterations": "int", "cycles": "int", "share": "pct",
                             "cycles/iter": "f2", "bound": "int", "static ILP": "f2",
                             "dynamic ILP": "f2"},
                    caption="pcs: its first and last bundle; bundles: in its body (a natural "
                            "loop need not hold every bundle between); iterations = times the "
                            "loop's header issued; cycles = cycles spent "
                            "in its bundles (issued + stalled); cycles/iter beside bound: the "
                            "static bound per iteration (report bounds); static ILP = ops per "
                            "bundle of the loop body; dynamic ILP = ops issued there / its "
                            "cycles; dominant stall: the cause of most of its stall cycles, as a "
                            "share of its cycles" + ("" if all_loops else "; --all: every loop"),
                    group_by="processor")
    loops.panels = [loops.columns[:8], ["processor", "loop"] + loops.columns[8:]]  # 80 columns
    hot = hot_path_section()
    without_text = False
    for name, p in choose_processors(stats, proc):
        cycles = max(int(p["cycles"]), 1)
        unit = PROCESSORS.get(name.rsplit(".", 1)[-1])
        slots = sum(unit.units.values()) if unit else None
        counts = bundle_counts(stats, name, p)
        without_text |= any(b.text is None for b in counts)
        found = find_loops(counts)
        shown = counts
        if order == "hot" or top is not None:
            shown = sorted((b for b in counts if b.cycles), key=lambda b: (-b.cycles, b.pc))
            shown = shown[:top if top is not None else 20]
            if order == "program":
                shown.sort(key=lambda b: b.pc)
        for b in shown:
            inner = innermost_loop(found, b.pc)
            listing.rows.append([name, b.pc, b.label, inner.label if inner else None, b.text,
                                 b.lines, b.issued, b.stalled, stalls_text(b.stalls),
                                 b.cycles / cycles,
                                 b.ops / slots if slots and b.ops is not None else None])
        ran = [lp for lp in tree_order(found) if all_loops or lp.iterations]
        bounds = loop_bounds(stats, name, ran) if ran else {}
        for lp in ran:
            dom = lp.dominant
            loops.rows.append([name, lp.label, lp.parent_label, lp.pcs_text, lp.bundles,
                               lp.iterations, lp.cycles, lp.cycles / cycles,
                               lp.cycles / lp.iterations if lp.iterations else None,
                               bounds.get(lp.header), lp.static_ops / max(lp.bundles, 1),
                               lp.ops / lp.cycles if lp.cycles else None,
                               f"{dom[0]} {100 * dom[1] / lp.cycles:.1f}%" if dom else None])
        if counts and all(b.text is not None for b in counts):
            add_hot_path(hot, stats, name, p, counts, top)
    if without_text:
        listing.caption += (" — these statistics carry no program listing (written by an older "
                            "version): rerun to see the bundles' text and the loops")
    if not any(row[5] and "," in row[5] for row in listing.rows):
        # every bundle from one source line (no .sched region shown): the location says where,
        # and the column would only take width from the operands
        col = listing.columns.index("source lines")
        listing.columns.pop(col)
        for row in listing.rows:
            row.pop(col)
    else:  # too wide for the terminal with it: the bundles and their lines, then their counts
        listing.panels = [["processor", "pc", "location", "loop", "bundle", "source lines"],
                          ["processor", "pc", "location", "issued", "stall cycles", "stalls by cause",
                           "share", "fill"]]
    return [listing, loops, hot]


def tree_order(loops: list[Loop]) -> list[Loop]:
    """The loops as a tree in preorder: each loop, then the loops inside it (by header)."""
    children: dict[int | None, list[int]] = {}
    for i, lp in enumerate(loops):
        children.setdefault(lp.parent, []).append(i)
    out: list[Loop] = []

    def walk(parent: int | None) -> None:
        for i in sorted(children.get(parent, []), key=lambda i: loops[i].header):
            out.append(loops[i])
            walk(i)
    walk(None)
    return out
