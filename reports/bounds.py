"""Bounds against a run: for every loop and block, what the machine allows beside what it did.

`report bounds STATS.json` reads a statistics file only: the program comes back from its
listing (`asm.bounds.program_from_listing`), the machine from its configuration, the static
bounds from `asm.bounds` (a pure function of those two), and the counters per bundle address
from `report annotate`'s reading of the file (`annotate.bundle_counts`, its loops from
`annotate.find_loops`). Per loop: the iterations (times its first bundle issued), the cycles per
iteration achieved (the cycles spent in its bundles, issued + stalled, per iteration) and where
the difference to the bound went — bundles issued per iteration (the schedule: the bound counts
the cycles these must take) and stall cycles per iteration by cause (docs/stalls.md). Per block
the same per execution. `asm --bounds` prints the same tables without a run.
"""

from __future__ import annotations

from netsushisen.asm.bounds import (OPTIMUM_MAX_OPS, Bounds, add_optimum, program_bounds,
                                    program_from_listing)
from netsushisen.errors import NetsushisenError
from netsushisen.isa.config import config_from_dict
from netsushisen.reports.annotate import (BundleCounts, bundle_counts, choose_processors,
                                          find_loops, stalls_text)
from netsushisen.reports.tables import Section, StatsError

STATIC = ["loop", "pcs", "ops", "units", "ports", "rec", "path", "bound", "by", "written"]
BLOCK_STATIC = ["block", "pcs", "ops", "units", "ports", "path", "bound", "by", "written", "list",
                "optimum"]
SHOWN_CAUSES = 3
"""Stall causes named per row (the rest summed as `other`; JSON and CSV alike)."""
ACHIEVED = ["runs", "achieved", "issued", "stalls per run"]
FORMATS = {"bound": "int", "units": "int", "ports": "int", "rec": "int", "path": "int", "written": "int",
           "list": "int", "runs": "int", "achieved": "f2", "issued": "f2"}
CAPTION = ("cycles (a loop's: per iteration); units: issue cycles the unit slots need plus the "
           "cycles nothing issues (load holds, a loop's taken back edge), or an unpipelined "
           "class's busy cycles; ports: the same for the register ports; rec: RecMII (loop-"
           "carried true, memory, FIFO cycles); path: the longest dependence chain; bound: the "
           "largest that applies (a loop: units, ports, rec; a block: units, ports, path), "
           "by: which; written: the code as written by the interlock rules, registers "
           "ready and loads hitting; list: list-scheduled; optimum: CP-SAT's shortest schedule "
           f"(blocks up to {OPTIMUM_MAX_OPS} ops); docs/scheduling.md, \"Bounds\"")
RUN_CAPTION = ("; runs: iterations (times the first bundle issued); achieved: cycles spent in "
               "the bundles per run, = issued (bundles per run) + stalls per run by cause, the "
               f"{SHOWN_CAUSES} largest named (docs/stalls.md)")


def ops_text(b: Bounds) -> str:
    return " ".join(f"{u}:{n}" for u, n in b.ops_by_unit.items()) or "0"


def static_cells(b: Bounds) -> list:
    if b.kind == "loop":
        return [b.label, f"{b.start}-{b.end}", ops_text(b), b.units, b.ports, b.recurrence,
                b.critical_path, b.bound, b.binding, b.written]
    return [b.label, f"{b.start}-{b.end}", ops_text(b), b.units, b.ports, b.critical_path, b.bound,
            b.binding, b.written, b.list_scheduled, b.optimum_text]


def bounds_sections(rows: list[tuple[str, list[Bounds], dict[int, BundleCounts] | None]]
                    ) -> list[Section]:
    """The `loops` and `blocks` tables of (processor, its bounds, its counters by pc or None)."""
    with_run = any(counts is not None for _, _, counts in rows)
    extra = ACHIEVED if with_run else []
    caption = CAPTION + (RUN_CAPTION if with_run else "")
    loops = Section("loops", "Loops: bounds per iteration" + (" and the run" if with_run else ""),
                    ["processor"] + STATIC + extra, formats=FORMATS,
                    caption="columns explained below the blocks table", group_by="processor")
    blocks = Section("blocks", "Blocks: bounds" + (" and the run, hottest first" if with_run else ""),
                     ["processor"] + BLOCK_STATIC + extra, formats=FORMATS, caption=caption,
                     group_by="processor")
    for name, bounds, counts in rows:
        for b in bounds:
            row = [name] + static_cells(b)
            if counts is not None:
                row += run_cells(b, counts)
            (loops if b.kind == "loop" else blocks).rows.append(row)
    return [loops, blocks]


def run_cells(b: Bounds, counts: dict[int, BundleCounts]) -> list:
    """Runs, cycles per run, bundles issued per run and stalls per run by cause."""
    first = counts.get(b.start)
    runs = first.issued if first else 0
    body = [counts[pc] for pc in range(b.start, b.end + 1) if pc in counts]
    if not runs:
        return [0, None, None, None]
    stalls: dict[str, int] = {}
    for c in body:
        for cause, n in c.stalls.items():
            stalls[cause] = stalls.get(cause, 0) + n
    ranked = sorted(((c, n / runs) for c, n in stalls.items()), key=lambda kv: (-kv[1], kv[0]))
    shown = ", ".join(f"{c} {v:.2f}" for c, v in ranked[:SHOWN_CAUSES])
    rest = sum(v for _, v in ranked[SHOWN_CAUSES:])
    if rest:
        shown += f", other {rest:.2f}"
    return [runs, sum(c.cycles for c in body) / runs, sum(c.issued for c in body) / runs,
            shown or None]


def bounds_report(stats: dict, proc: str | None = None, top: int | None = None,
                  optimum_ops: int = OPTIMUM_MAX_OPS, source: str = "<statistics>") -> list[Section]:
    """The bounds of the chosen processors' loops (every loop that ran) and blocks (the `top`
    hottest, default 20, that ran), each with its run."""
    try:
        config = config_from_dict(stats["config"], source)
    except NetsushisenError as err:
        raise StatsError(f"{source}: the statistics' configuration: {err}") from None
    programs: dict[str, tuple] = {}
    rows = []
    for name, p in choose_processors(stats, proc):
        stage = name.rsplit(".", 1)[-1]
        listing = ((stats.get("programs") or {}).get(stage) or {}).get("listing")
        if not listing:
            raise StatsError(f"{source}: {name}: these statistics carry no program listing "
                             "(written by an older version): rerun to see the bounds")
        counts = {c.pc: c for c in bundle_counts(stats, name, p)}
        loops = {(lp.start, lp.end) for lp in find_loops(list(counts.values()))
                 if counts[lp.start].issued}
        if stage not in programs:
            program = program_from_listing(listing, stage, f"{source}: {stage} listing")
            programs[stage] = (program, program_bounds(program, config, optimum_ops=0))
        program, all_bounds = programs[stage]
        chosen_loops = [b for b in all_bounds if b.kind == "loop" and (b.start, b.end) in loops]
        blocks = [b for b in all_bounds if b.kind == "block" and b.start in counts
                  and counts[b.start].issued]
        heat = {b.start: sum(counts[pc].cycles for pc in range(b.start, b.end + 1) if pc in counts)
                for b in blocks}
        blocks.sort(key=lambda b: (-heat[b.start], b.start))
        blocks = blocks[:20 if top is None else top]
        for b in blocks:
            if b.optimum is None and 0 < b.ops <= optimum_ops:
                add_optimum(program, b, config)
        rows.append((name, chosen_loops + blocks, counts))
    return bounds_sections(rows)
