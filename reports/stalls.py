"""Stall report: every processor's cycles by cause and its stall cycles by code location.

Causes are the emulator's (emulator/core.py, T10), one table in isa/stalls.py, explained by
reports/glossary.py (and docs/stalls.md, generated from the table): memory holds `local`,
`resident`, `cache_hit`, `cache_miss`; `branch`; `operand:<m>`, `waw:<m>`, `unit_busy:<m>`,
`write_port`; `fifo_empty:<port>`, `fifo_empty:any`, `fifo_full:<port>`. The `(issued)` row counts cycles that issued a bundle, so
each processor's shares add up to 100 %. With `explain`, a third table gives the meaning of
every cause the run charged.
"""

from __future__ import annotations

from netsushisen.reports.glossary import ISSUED, glossary_section
from netsushisen.reports.tables import Section, present_processors


def stall_sections(stats: dict, top: int = 10, explain: bool = False) -> list[Section]:
    causes = Section("causes", "Cycles by cause", ["processor", "cause", "cycles", "of cycles", "of stalls"],
                     formats={"cycles": "int", "of cycles": "pct", "of stalls": "pct"})
    where = Section("locations", f"Stall cycles by code location (top {top} per processor)",
                    ["processor", "location", "pc", "cause", "cycles", "of stalls"],
                    formats={"pc": "int", "cycles": "int", "of stalls": "pct"})
    for name, p in present_processors(stats):
        cycles = max(int(p["cycles"]), 1)
        stalled = int(p["stall_cycles"])
        causes.rows.append([name, ISSUED, p["bundles"], p["bundles"] / cycles, None])
        for cause, c in sorted(p.get("stalls", {}).items(), key=lambda kv: (-kv[1], kv[0])):
            causes.rows.append([name, cause, c, c / cycles, c / max(stalled, 1)])
        rows = []
        for pc, entry in (p.get("stalls_by_pc") or {}).items():
            for cause, c in entry.get("stalls", {}).items():
                rows.append([name, entry.get("label", pc), int(pc), cause, c, c / max(stalled, 1)])
        rows.sort(key=lambda r: (-r[4], r[2], r[3]))
        where.rows += rows[:top]
    out = [causes, where]
    if explain:
        seen = sorted({r[1] for r in causes.rows if r[1] != ISSUED})
        out.append(glossary_section(seen))
    return out
