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
from netsushisen.asm.objects import Program
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import config_from_dict
from netsushisen.reports.annotate import (BundleCounts, bundle_counts, choose_processors,
                                          find_loops)
from netsushisen.reports.tables import Section, StatsError

STATIC = ["loop", "pcs", "ops", "units", "ports", "rec", "path", "bound", "by", "written"]
BLOCK_STATIC = ["block", "pcs", "ops", "units", "ports", "path", "bound", "by", "written", "list",
                "optimum"]
BY = {"recurrence": "rec"}
"""The binding bound by its column's name."""
SHOWN_CAUSES = 3
"""Stall causes named per row (the rest summed as `other`; JSON and CSV alike)."""
ACHIEVED = ["runs", "achieved", "issued", "stalls per run"]
FORMATS = {"units run": "f2", "bound": "int", "units": "int", "ports": "int", "rec": "int", "path": "int", "written": "int",
           "list": "int", "runs": "int", "achieved": "f2", "issued": "f2"}
CAPTION = ("cycles (a loop's: per iteration); units: issue cycles the unit slots need plus the "
           "cycles nothing issues (load holds, a loop's taken back edge), or an unpipelined "
           "class's busy cycles; ports: the same for the register ports; rec: RecMII (loop-"
           "carried true, memory, FIFO cycles); path: the longest dependence chain; bound: the "
           "largest that applies (a loop: units, ports, rec; a block: units, ports, path), "
           "by: which; written: the code as written by the interlock rules, registers "
           "ready and loads hitting; list: list-scheduled; optimum: CP-SAT's shortest schedule "
           f"(blocks up to {OPTIMUM_MAX_OPS} ops); docs/scheduling.md, \"Bounds\"")
RUN_CAPTION = ("; units run (loops): the issue cycles per iteration the operations the run "
               "executed there need on their units (the bounds count every bundle of a loop "
               "with inner branches once)"
               "; runs: iterations (times the first bundle issued); achieved: cycles spent in "
               "the bundles per run, = issued (bundles per run) + stalls per run by cause, the "
               f"{SHOWN_CAUSES} largest named (docs/stalls.md)")


def ops_text(b: Bounds) -> str:
    return " ".join(f"{u}:{n}" for u, n in b.ops_by_unit.items()) or "0"


def static_cells(b: Bounds) -> list:
    if b.kind == "loop":
        return [b.label, f"{b.start}-{b.end}", ops_text(b), b.units, b.ports, b.recurrence,
                b.critical_path, b.bound, BY.get(b.binding, b.binding), b.written]
    return [b.label, f"{b.start}-{b.end}", ops_text(b), b.units, b.ports, b.critical_path, b.bound,
            BY.get(b.binding, b.binding), b.written, b.list_scheduled, b.optimum_text]



def bounds_sections(rows: list[tuple[str, list[Bounds], dict[int, BundleCounts] | None]],
                    programs: dict[str, Program] | None = None) -> list[Section]:
    """The `loops` and `blocks` tables of (processor, its bounds, its counters by pc or None);
    with counters, `programs` (by stage) gives a loop's executed operations."""
    with_run = any(counts is not None for _, _, counts in rows)
    caption = CAPTION + (RUN_CAPTION if with_run else "")
    loops = Section("loops", "Loops: bounds per iteration" + (" and the run" if with_run else ""),
                    ["processor"] + STATIC + (["units run"] + ACHIEVED if with_run else []),
                    formats=FORMATS, caption="columns explained below the blocks table",
                    group_by="processor")
    blocks = Section("blocks", "Blocks: bounds" + (" and the run, hottest first" if with_run else ""),
                     ["processor"] + BLOCK_STATIC + (ACHIEVED if with_run else []),
                     formats=FORMATS, caption=caption, group_by="processor")
    run = ["units run"] + ACHIEVED
    loops.panels = [loops.columns[:len(STATIC) + 1]] + ([["processor", "loop"] + run] if with_run else [])
    split = BLOCK_STATIC.index("written") + 1
    blocks.panels = [blocks.columns[:split], ["processor", "block"] + blocks.columns[split:]]
    for name, bounds, counts in rows:
        for b in bounds:
            row = [name] + static_cells(b)
            if counts is not None:
                if b.kind == "loop":
                    row.append(executed_units(b, counts, programs[b.proc]))
                row += run_cells(b, counts)
            (loops if b.kind == "loop" else blocks).rows.append(row)
    return [loops, blocks]


def executed_units(b: Bounds, counts: dict[int, BundleCounts], program: Program) -> float | None:
    """The issue cycles per iteration the operations the run executed in the loop need on their
    units: max over classes of (Σ over its bundles of times issued × the bundle's ops of the
    class) / (iterations × units). The `units` bound of the path the run took, where `units`
    counts every bundle of the body once."""
    first = counts.get(b.start)
    if not first or not first.issued:
        return None
    proc = program.processor
    by_unit: dict[str, int] = {}
    for pc in range(b.start, b.end + 1):
        if pc in counts:
            for op in program.bundles[pc]:
                if op.opcode.kind != "nop":
                    u = proc.unit(op.opcode.unit)
                    by_unit[u] = by_unit.get(u, 0) + counts[pc].issued
    return max((n / (first.issued * proc.units[u]) for u, n in by_unit.items()), default=0.0)


def run_cells(b: Bounds, counts: dict[int, BundleCounts]) -> list:
    """Runs, cycles per run, bundles issued per run and stalls per run by cause."""
    first = counts.get(b.start)
    runs = first.issued if first else 0
    if not runs:
        return [0, None, None, None]
    body = [counts[pc] for pc in range(b.start, b.end + 1) if pc in counts]
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
    """The bounds of the chosen processors' loops (every loop `report annotate` finds that
    issued a bundle) and blocks (the `top` hottest, default 20, that ran), each with its run."""
    try:
        config = config_from_dict(stats["config"], source)
    except NetsushisenError as err:
        raise StatsError(f"{source}: the statistics' configuration: "
                         f"{err.diagnostics[0].message}") from None
    programs: dict[str, tuple] = {}
    rows = []
    for name, p in choose_processors(stats, proc):
        stage = name.rsplit(".", 1)[-1]
        listing = ((stats.get("programs") or {}).get(stage) or {}).get("listing")
        if not listing:
            raise StatsError(f"{source}: {name}: these statistics carry no program listing "
                             "(written by an older version): rerun to see the bounds")
        counts = {c.pc: c for c in bundle_counts(stats, name, p)}
        loops = {(lp.start, lp.end) for lp in find_loops(list(counts.values())) if lp.issued}
        if stage not in programs:
            try:
                program = program_from_listing(listing, stage, f"{source}: {stage} listing")
            except NetsushisenError as err:
                raise StatsError(f"{source}: the {stage} program's listing does not assemble "
                                 f"again: {err.diagnostics[0].message}") from None
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
            if b.optimum is None and not b.optimum_note and 0 < b.ops <= optimum_ops:
                add_optimum(program, b, config)
        rows.append((name, chosen_loops + blocks, counts))
    return bounds_sections(rows, {stage: program for stage, (program, _) in programs.items()})
