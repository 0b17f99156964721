"""Annotated listing: each bundle of a processor's program with where its cycles went.

What `perf annotate` is to a profile and llvm-mca's timeline to a loop: per bundle address, the
times it issued, the stall cycles charged to it by cause (memory and branch stalls to the load or
branch holding issue, the others to the waiting bundle: docs/stalls.md), its share of the
processor's cycles (issued + stalled there / the processor's cycles) and its slot fill (its
operations / the processor's unit slots). Hottest first (`order="hot"`) or in program order.

A loop is a backward branch or jump and its target: the bundles target..branch (back edges to
one target make one loop, up to the last of them; loops nest). Per loop: the bundles issued
in it, the cycles spent in its bundles, the static ILP of its body, the dynamic ILP (operations
issued there / its cycles) and the dominant stall cause with its share of the loop's cycles.

The program's text comes from the statistics (`programs.<stage>.listing`, emulator/stats.py);
statistics written before it existed give the per-PC counts with labels only, and no loops.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from netsushisen.asm.listing import loop_ranges
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
    start: int
    end: int
    label: str
    bundles: int
    cycles: int
    issued: int
    ops: int
    static_ops: int
    stalls: dict[str, int]

    @property
    def dominant(self) -> tuple[str, int] | None:
        if not any(self.stalls.values()):
            return None
        return min(self.stalls.items(), key=lambda kv: (-kv[1], kv[0]))


def find_loops(counts: list[BundleCounts]) -> list[Loop]:
    """Loops from the backward branches and jumps (`asm.listing.loop_ranges`), outermost first
    at each start address."""
    at = {b.pc: b for b in counts}
    loops = []
    for start, end in loop_ranges((b.pc, b.target) for b in counts):
        body = [at[pc] for pc in range(start, end + 1) if pc in at]
        stalls: dict[str, int] = {}
        for b in body:
            for c, n in b.stalls.items():
                stalls[c] = stalls.get(c, 0) + n
        loops.append(Loop(start, end, at[start].label if start in at else str(start), len(body),
                          sum(b.cycles for b in body), sum(b.issued for b in body),
                          sum(b.issued * (b.ops or 0) for b in body), sum(b.ops or 0 for b in body),
                          stalls))
    return loops


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
                      order: str = "hot") -> list[Section]:
    """The listing (`bundles`) and the per-loop summary (`loops`) of the chosen processors
    (`proc`: `pe0.ic`, or `ic` for every PE's IC; None: all). `top`: the N hottest bundles per
    processor (default: 20 hottest first; every bundle in program order)."""
    if order not in ORDERS:
        raise StatsError(f"--order {order}: one of {', '.join(ORDERS)}")
    listing = Section("bundles", "Annotated listing" + (" (hottest first)" if order == "hot" else ""),
                      ["processor", "pc", "location", "bundle", "source lines", "issued", "stall cycles",
                       "stalls by cause", "share", "fill"],
                      formats={"pc": "int", "issued": "int", "stall cycles": "int", "share": "pct",
                               "fill": "pct"},
                      caption="share = (issued + stall cycles) / the processor's cycles; fill = the "
                              "bundle's operations / the processor's unit slots; causes: "
                              "docs/stalls.md", group_by="processor")
    loops = Section("loops", "Loops (a backward branch's target .. the branch)",
                    ["processor", "loop", "pcs", "bundles", "cycles", "share", "static ILP",
                     "dynamic ILP", "dominant stall"],
                    formats={"bundles": "int", "cycles": "int", "share": "pct", "static ILP": "f2",
                             "dynamic ILP": "f2"},
                    caption="bundles = bundles issued in the loop; cycles = cycles spent in its "
                            "bundles (issued + stalled); static ILP = ops per bundle of the loop "
                            "body; dynamic ILP = ops issued there / its cycles; dominant stall: "
                            "the cause of most of its stall cycles, as a share of its cycles",
                    group_by="processor")
    without_text = False
    for name, p in choose_processors(stats, proc):
        cycles = max(int(p["cycles"]), 1)
        unit = PROCESSORS.get(name.rsplit(".", 1)[-1])
        slots = sum(unit.units.values()) if unit else None
        counts = bundle_counts(stats, name, p)
        without_text |= any(b.text is None for b in counts)
        shown = counts
        if order == "hot" or top is not None:
            shown = sorted((b for b in counts if b.cycles), key=lambda b: (-b.cycles, b.pc))
            shown = shown[:top if top is not None else 20]
            if order == "program":
                shown.sort(key=lambda b: b.pc)
        for b in shown:
            listing.rows.append([name, b.pc, b.label, b.text, b.lines, b.issued, b.stalled,
                                 stalls_text(b.stalls),
                                 b.cycles / cycles,
                                 b.ops / slots if slots and b.ops is not None else None])
        for lp in find_loops(counts):
            dom = lp.dominant
            loops.rows.append([name, lp.label, f"{lp.start}-{lp.end}", lp.issued, lp.cycles,
                               lp.cycles / cycles, lp.static_ops / max(lp.bundles, 1),
                               lp.ops / lp.cycles if lp.cycles else None,
                               f"{dom[0]} {100 * dom[1] / lp.cycles:.1f}%" if dom else None])
    if without_text:
        listing.caption += (" — these statistics carry no program listing (written by an older "
                            "version): rerun to see the bundles' text and the loops")
    if not any(row[4] and "," in row[4] for row in listing.rows):
        # every bundle from one source line (no .sched region shown): the location says where,
        # and the column would only take width from the operands
        col = listing.columns.index("source lines")
        listing.columns.pop(col)
        for row in listing.rows:
            row.pop(col)
    else:  # too wide for the terminal with it: the bundles and their lines, then their counts
        listing.panels = [["processor", "pc", "location", "bundle", "source lines"],
                          ["processor", "pc", "location", "issued", "stall cycles", "stalls by cause",
                           "share", "fill"]]
    return [listing, loops]
