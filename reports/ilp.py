"""ILP report: where each processor's cycles went and how full its bundles were.

Per processor: cycles, bundles issued, operations, dynamic ILP (operations per cycle, stalls
included) against static ILP (operations per bundle of the program as scheduled), slot fill per
unit class (dynamic: ops of the class / (cycles × units); static: over the program's bundles),
register-port use of the program's bundles, and the hottest code locations (label + offset).

Static ILP comes from the statistics file (`programs.<stage>.static_ilp`, written since the
report existed); for older files the program is reassembled from the recorded source and
defines when the source is still there, else static columns show "-".
"""

from __future__ import annotations

from pathlib import Path

from netsushisen.isa.processors import PROCESSORS
from netsushisen.reports.annotate import bundle_counts
from netsushisen.reports.tables import Section, present_processors


def static_ilp_of(stats: dict, stage: str) -> dict | None:
    prog = (stats.get("programs") or {}).get(stage)
    if not prog:
        return None
    if isinstance(prog.get("static_ilp"), dict):
        return prog["static_ilp"]
    src = prog.get("source")
    if not src or not Path(src).is_file():
        return None
    try:  # an older statistics file: reassemble the program it ran
        from netsushisen.asm.assembler import assemble_file
        from netsushisen.asm.listing import static_ilp
        p = assemble_file(src, proc=stage, defines=prog.get("defines") or {})
    except Exception:  # the source changed or no longer assembles: no static figures
        return None
    if len(p.bundles) != prog.get("bundles"):
        return None
    return static_ilp(p).as_dict()


def hot_locations(stats: dict, name: str, p: dict) -> list[tuple[int, str, int, int, int]]:
    """(pc, label, cycles, issued, stalled) per code location that took cycles, most cycles
    first (the per-bundle counts of `report annotate`). Issued bundles per PC are counted when
    the statistics give `bundles_by_pc`; otherwise cycles = stalls."""
    hot = [(b.pc, b.label, b.cycles, b.issued, b.stalled) for b in bundle_counts(stats, name, p) if b.cycles]
    return sorted(hot, key=lambda r: (-r[2], r[0]))


def ilp_sections(stats: dict, top: int = 5) -> list[Section]:
    procs = present_processors(stats)
    main = Section("processors", "ILP per processor",
                   ["processor", "cycles", "bundles", "ops", "dynamic ILP", "ops/issue", "static ILP",
                    "stalled"],
                   formats={"cycles": "int", "bundles": "int", "ops": "int", "dynamic ILP": "f2",
                            "ops/issue": "f2", "static ILP": "f2", "stalled": "pct"},
                   caption="dynamic ILP = ops per cycle, stalls included; ops/issue = ops per "
                           "bundle issued; static ILP = ops per bundle of the program as scheduled")
    slots = Section("slot_fill", "Slot fill per unit class (share of slots holding an operation)",
                    ["processor", "unit", "units", "ops", "dynamic fill", "static fill"],
                    formats={"units": "int", "ops": "int", "dynamic fill": "pct", "static fill": "pct"},
                    caption="dynamic fill = ops of the class / (cycles × units); static fill = "
                            "over the program's bundles")
    ports = Section("register_ports", "Register-file ports per bundle, as scheduled (static)",
                    ["processor", "reads", "read use", "max R", "writes", "write use", "max W"],
                    formats={"reads": "f2", "read use": "pct", "max R": "int", "writes": "f2",
                             "write use": "pct", "max W": "int"})
    hot = Section("hot_locations", f"Hottest code locations (top {top} per processor)",
                  ["processor", "location", "pc", "cycles", "share"],
                  formats={"pc": "int", "cycles": "int", "share": "pct"})
    any_issue_counts = False
    for name, p in procs:
        stage = name.rsplit(".", 1)[-1]
        proc = PROCESSORS.get(stage)
        cycles = int(p["cycles"])
        st = static_ilp_of(stats, stage)
        main.rows.append([name, cycles, p["bundles"], p["ops"], p["ops"] / max(cycles, 1),
                          p["ops"] / p["bundles"] if p["bundles"] else None,
                          st["ops_per_bundle"] if st else None, p["stall_cycles"] / max(cycles, 1)])
        units = proc.units if proc else {}
        for unit, count in units.items():
            ops = int(p.get("ops_by_unit", {}).get(unit, 0))
            slots.rows.append([name, unit, count, ops, ops / max(cycles * count, 1),
                               (st or {}).get("slot_fill", {}).get(unit)])
        if st:
            ports.rows.append([name, st["reads_per_bundle"], st["read_port_use"], st["max_reads"],
                               st["writes_per_bundle"], st["write_port_use"], st["max_writes"]])
        any_issue_counts |= "bundles_by_pc" in p
        for pc, label, c, _, _ in hot_locations(stats, name, p)[:top]:
            hot.rows.append([name, label, pc, c, c / max(cycles, 1)])
    hot.caption = ("cycles = bundles issued there + stall cycles charged there" if any_issue_counts else
                   "cycles = stall cycles charged to the location (these statistics count no issued "
                   "bundles per PC)")
    return [main, slots] + ([ports] if ports.rows else []) + [hot]
