"""Bounds against a run: for every loop and block, what the machine allows beside what it did.

`report bounds STATS.json` reads a statistics file only: the program comes back from its
listing (`asm.bounds.program_from_listing`), the machine from its configuration, the static
bounds from `asm.bounds` (a pure function of those two), and the counters per bundle address
from `report annotate`'s reading of the file (`annotate.bundle_counts`, its loops from
its natural loops from asm/loops.py, as `report annotate` and `info loop` find them). Per loop
(that ran; every one with `all_loops`): the loop around it, the iterations (times its header
issued), the cycles per iteration achieved (the cycles spent in its bundles, issued + stalled, per iteration) and where
the difference to the bound went — bundles issued per iteration (the schedule: the bound counts
the cycles these must take) and stall cycles per iteration by cause (docs/stalls.md). Per block
the same per execution, hottest first — the hot path: each block's share of the processor's cycles
and its excess, (achieved − bound) × runs, the cycles a perfect schedule of it would save, so
the first line is the one to fix (`report annotate` shows the same table). `asm --bounds` prints
the same tables without a run.
"""

from __future__ import annotations

from netsushisen.asm.bounds import (OPTIMUM_MAX_OPS, Bounds, Region, add_optimum,
                                    program_bounds, program_from_listing, region_bounds, regions)
from netsushisen.asm.listing import target_names
from netsushisen.asm.objects import Program
from netsushisen.asm.optimum import ModelBudget
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import config_from_dict
from netsushisen.reports.annotate import BundleCounts, bundle_counts, choose_processors
from netsushisen.reports.tables import Section, StatsError

STATIC = ["loop", "parent", "pcs", "ops", "units", "ports", "rec", "path", "bound", "by", "written"]
BLOCK_STATIC = ["block", "pcs", "ops", "units", "ports", "path", "bound", "by", "written", "list",
                "optimum"]
BY = {"recurrence": "rec"}
"""The binding bound by its column's name."""
SHOWN_CAUSES = 3
"""Stall causes named per row (the rest summed as `other`; JSON and CSV alike)."""
ACHIEVED = ["runs", "achieved", "issued", "stalls per run"]
HOT = ["share", "excess"]
"""A block's share of its processor's cycles and (achieved − bound) × runs."""
FORMATS = {"units run": "f2", "bound": "int", "units": "int", "ports": "int", "rec": "int", "path": "int", "written": "int",
           "list": "int", "runs": "int", "achieved": "f2", "issued": "f2", "share": "pct",
           "excess": "int", "cycles": "int"}
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
               "; parent: the loop around it; runs: a loop's iterations (times its header "
               "issued), a block's executions; achieved: cycles spent in "
               "the bundles per run, = issued (bundles per run) + stalls per run by cause, the "
               f"{SHOWN_CAUSES} largest named (docs/stalls.md); share: the block's cycles / "
               "the processor's; excess: (achieved − bound) × runs, the cycles a schedule at the "
               "bound would save")


def ops_text(b: Bounds) -> str:
    return " ".join(f"{u}:{n}" for u, n in b.ops_by_unit.items()) or "0"


def static_cells(b: Bounds, parent: str | None = None) -> list:
    if b.kind == "loop":
        return [b.label, parent, b.pcs_text, ops_text(b), b.units, b.ports, b.recurrence,
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
    if with_run:
        blocks.columns += HOT
        blocks.panels.append(["processor", "block", "runs"] + HOT)
    for name, bounds, counts in rows:
        parents = loop_parents(bounds)
        total = max(sum(c.cycles for c in counts.values()), 1) if counts else 1
        for b in bounds:
            row = [name] + static_cells(b, parents.get(b.start))
            if counts is not None:
                if b.kind == "loop":
                    row.append(executed_units(b, counts, programs[b.proc]))
                row += run_cells(b, counts)
                if b.kind == "block":
                    row += hot_cells(b, counts, total)
            (loops if b.kind == "loop" else blocks).rows.append(row)
    return [loops, blocks]


def loop_parents(bounds: list[Bounds]) -> dict[int, str]:
    """A loop's header -> the name of the smallest other loop whose body holds it."""
    loops = [b for b in bounds if b.kind == "loop"]
    out = {}
    for b in loops:
        around = [o for o in loops if o is not b and b.start in o.pcs()
                  and len(o.pcs()) >= len(b.pcs())]
        if around:
            out[b.start] = min(around, key=lambda o: len(o.pcs())).label
    return out


def hot_cells(b: Bounds, counts: dict[int, BundleCounts], total: int) -> list:
    """A block's share of the processor's cycles and its excess (achieved − bound) × runs."""
    first = counts.get(b.start)
    runs = first.issued if first else 0
    cycles = sum(counts[pc].cycles for pc in b.pcs() if pc in counts)
    return [cycles / total, cycles - b.bound * runs if runs else None]


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
    for pc in b.pcs():
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
    body = [counts[pc] for pc in b.pcs() if pc in counts]
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


def listing_program(stats: dict, stage: str, source: str = "<statistics>") -> Program:
    """The program a statistics file's listing of `stage` shows, assembled again (kept for the
    listing object, which reports read several times); a one-line StatsError without one."""
    listing = ((stats.get("programs") or {}).get(stage) or {}).get("listing")
    if not listing:
        raise StatsError(f"{source}: {stage}: these statistics carry no program listing "
                         "(written by an older version): rerun to see the bounds")
    hit = _PROGRAMS.get((stage, id(listing)))
    if hit is not None and hit[0] is listing:
        return hit[1]
    try:
        program = program_from_listing(listing, stage, f"{source}: {stage} listing")
    except NetsushisenError as err:
        raise StatsError(f"{source}: the {stage} program's listing does not assemble "
                         f"again: {err.diagnostics[0].message}") from None
    if len(_PROGRAMS) > 16:
        _PROGRAMS.clear()
    _PROGRAMS[(stage, id(listing))] = (listing, program)
    return program


_PROGRAMS: dict[tuple[str, int], tuple[dict, Program]] = {}


def stats_config(stats: dict, source: str = "<statistics>"):
    try:
        return config_from_dict(stats["config"], source)
    except NetsushisenError as err:
        raise StatsError(f"{source}: the statistics' configuration: "
                         f"{err.diagnostics[0].message}") from None


def loop_bounds(stats: dict, name: str, loops) -> dict[int, int]:
    """Header -> bound per iteration of each of `loops` (annotate's, of processor `name`)."""
    program = listing_program(stats, name.rsplit(".", 1)[-1])
    config = stats_config(stats)
    return {lp.header: region_bounds(program, Region("loop", lp.header, lp.end, lp.body,
                                                     lp.label), config, optimum_ops=0).bound
            for lp in loops}


def hot_path_section() -> Section:
    """The hot path's table (rows: `add_hot_path`)."""
    return Section("hot", "Hot path: blocks by total cycles",
                   ["processor", "block", "pcs", "cycles", "share", "runs", "achieved", "bound",
                    "excess"], formats=FORMATS,
                   caption="cycles: spent in the block's bundles (issued + stalled); share: of "
                           "the processor's cycles; achieved: cycles per run; bound: the "
                           "block's static bound (report bounds); excess: (achieved − bound) × "
                           "runs, what a schedule at the bound would save", group_by="processor")


def add_hot_path(section: Section, stats: dict, name: str, p: dict,
                 counts: list[BundleCounts], top: int | None = None) -> None:
    """The `top` (default 10) blocks of processor `name` with the most cycles, as rows."""
    program = listing_program(stats, name.rsplit(".", 1)[-1])
    config = stats_config(stats)
    at = {c.pc: c for c in counts}
    total = max(int(p["cycles"]), 1)
    blocks = [r for r in regions(program) if r.kind == "block" and r.start in at
              and at[r.start].issued]
    heat = {r.start: sum(at[pc].cycles for pc in r.pcs() if pc in at) for r in blocks}
    blocks.sort(key=lambda r: (-heat[r.start], r.start))
    names = target_names(program)
    for r in blocks[:10 if top is None else top]:
        b = region_bounds(program, r, config, optimum_ops=0, label=names.get(r.start))
        runs = at[r.start].issued
        section.rows.append([name, b.label, b.pcs_text, heat[r.start], heat[r.start] / total,
                             runs, heat[r.start] / runs, b.bound, heat[r.start] - b.bound * runs])


def bounds_report(stats: dict, proc: str | None = None, top: int | None = None,
                  optimum_ops: int = OPTIMUM_MAX_OPS, source: str = "<statistics>",
                  all_loops: bool = False) -> list[Section]:
    """The bounds of the chosen processors' loops (the natural loops whose header issued; every
    one with `all_loops`) and blocks (the `top` hottest, default 20, that ran), each with its
    run."""
    config = stats_config(stats, source)
    programs: dict[str, tuple] = {}
    rows = []
    for name, p in choose_processors(stats, proc):
        stage = name.rsplit(".", 1)[-1]
        program = listing_program(stats, stage, source)
        counts = {c.pc: c for c in bundle_counts(stats, name, p)}
        if stage not in programs:
            programs[stage] = (program, program_bounds(program, config, optimum_ops=0))
        program, all_bounds = programs[stage]
        chosen_loops = [b for b in all_bounds if b.kind == "loop" and
                        (all_loops or (b.start in counts and counts[b.start].issued))]
        blocks = [b for b in all_bounds if b.kind == "block" and b.start in counts
                  and counts[b.start].issued]
        heat = {b.start: sum(counts[pc].cycles for pc in range(b.start, b.end + 1) if pc in counts)
                for b in blocks}
        blocks.sort(key=lambda b: (-heat[b.start], b.start))
        blocks = blocks[:20 if top is None else top]
        budget = ModelBudget()  # the hottest blocks first
        for b in blocks:
            if b.optimum is None and not b.optimum_note and 0 < b.ops <= optimum_ops:
                add_optimum(program, b, config, budget=budget)
        rows.append((name, chosen_loops + blocks, counts))
    from netsushisen.reports.floor import floor_sections

    return (bounds_sections(rows, {stage: program for stage, (program, _) in programs.items()})
            + floor_sections(stats, proc, source))
