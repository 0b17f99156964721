"""The run's floor: how far each processor of a run is from the least its executed work needs.

`report bounds` gives every block's and loop's static bounds; this gives the whole run's, per
processor, from the statistics file alone (the per-pc issue counts and the program listing),
with the same arithmetic for every kernel (docs/scheduling.md, "The floor"):

- **unit/port bound**: the issue cycles the executed operations need on their units (per class:
  operations ÷ units) and on the register ports (reads ÷ read ports, writes ÷ write ports), the
  largest of these, plus every cycle a load held issue (`cache_hit` and `cache_miss` stalls:
  nothing issues then, whatever the schedule);
- **work bound**: the executed operations on the processor's busiest unit class alone
  (FP operations ÷ FP units, or integer operations ÷ integer units, the larger) plus the inherent
  memory holds — a cache miss's hold beyond a hit's (`cache_miss` stalls), which no schedule
  hides; a hit's extra cycle is the schedule's business (the unit/port bound counts it);
- **gap**: the processor's cycles (to its halt, else the run's) ÷ work bound;
- bounds are whole cycles, rounded up;
- **starved**: the cycles the processor had nothing to do — waiting on an empty FIFO, or halted
  before the run ended (the run's cycles − bundles issued − stalls of other causes). The
  bottleneck is the processor starved least: everyone else waits for it.
"""

from __future__ import annotations

import math

from netsushisen.isa.processors import PROCESSORS
from netsushisen.reports.annotate import bundle_counts, choose_processors
from netsushisen.reports.tables import Section

COLUMNS = ["processor", "cycles", "unit/port bound", "work bound", "memory holds", "gap",
           "starved", "bottleneck"]
CAPTION = ("cycles: the processor's (to its halt); unit/port bound: the executed operations' issue cycles on their "
           "busiest unit class or register port, plus every load hold; work bound: the "
           "executed operations of the busiest unit class ÷ its units, plus the memory holds "
           "(a cache miss's hold beyond a hit's); gap: cycles ÷ work bound; starved: cycles "
           "waiting on an empty FIFO or halted; bottleneck: the processor starved least "
           "(docs/scheduling.md, \"The floor\")")
HOLDS = ("cache_hit", "cache_miss")


def processor_floor(stats: dict, name: str, p: dict, program) -> dict:
    """The floor row of one processor (module docstring)."""
    proc = PROCESSORS[name.rsplit(".", 1)[-1]]
    by_unit: dict[str, int] = {}
    reads = writes = 0
    for c in bundle_counts(stats, name, p):
        if not c.issued or c.pc >= len(program.bundles):
            continue
        for op in program.bundles[c.pc]:
            if op.opcode.kind == "nop":
                continue
            u = proc.unit(op.opcode.unit)
            by_unit[u] = by_unit.get(u, 0) + c.issued
            reads += len(op.reads()) * c.issued
            writes += len(op.writes()) * c.issued
    stalls = p.get("stalls") or {}
    misses = int(stalls.get("cache_miss", 0))
    holds = sum(int(stalls.get(k, 0)) for k in HOLDS)
    units = max((n / proc.units[u] for u, n in by_unit.items()), default=0.0)
    ports = max(reads / proc.read_ports, writes / proc.write_ports)
    work = units + misses
    cycles = int(p.get("cycles", 0))
    run_cycles = int((stats.get("run") or {}).get("cycles") or cycles)
    fifo = sum(int(n) for k, n in stalls.items() if k.startswith("fifo_empty"))
    other = int(p.get("stall_cycles", 0)) - fifo
    starved = max(run_cycles - int(p.get("bundles", 0)) - other, 0)
    return {"processor": name, "cycles": cycles, "unit/port bound": math.ceil(max(units, ports)) + holds,
            "work bound": math.ceil(units) + misses, "memory holds": misses,
            "gap": cycles / work if work else None, "starved": starved}


def floor_sections(stats: dict, proc: str | None = None, source: str = "<statistics>",
                   **_options) -> list[Section]:
    """The floor table (module docstring): one row per processor, the bottleneck marked."""
    from netsushisen.reports.bounds import listing_program  # (bounds ends with this table)

    rows = []
    programs = {}
    for name, p in choose_processors(stats, None):
        stage = name.rsplit(".", 1)[-1]
        if stage not in programs:
            programs[stage] = listing_program(stats, stage, source)
        rows.append(processor_floor(stats, name, p, programs[stage]))
    if rows:
        least = min(r["starved"] for r in rows)
        for r in rows:
            r["bottleneck"] = "yes" if r["starved"] == least else ""
    chosen = {n for n, _ in choose_processors(stats, proc)}
    return [Section("floor", "The run's floor", COLUMNS,
                    [[r[c] for c in COLUMNS] for r in rows if r["processor"] in chosen],
                    {"cycles": "int", "unit/port bound": "int", "work bound": "int",
                     "memory holds": "int", "gap": "f2", "starved": "int"}, CAPTION)]
