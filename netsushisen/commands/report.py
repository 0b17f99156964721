"""ILP, stall and memory reports from a statistics file (`run --json` or `render --json`).

    netsushisen report ilp    STATS.json [--format table|json|csv|md] [--top N] [-o FILE]
    netsushisen report stalls STATS.json [...]
    netsushisen report memory STATS.json [...]

ilp: per processor cycles, bundles, operations, operations per cycle (dynamic ILP) against
operations per bundle as scheduled (static ILP), slot fill per unit class, register-port use,
the hottest code locations. stalls: cycles by cause and stall cycles by code location, counts
and shares. memory: per database region ρ (resident share), μ (cache hit rate), the measured
mean access time and the paper's t = t_r·{ρ + (1 − ρ)(8 − 6μ)}. Tables fit 80 columns.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from netsushisen.errors import Diagnostic
from netsushisen.reports.ilp import ilp_sections
from netsushisen.reports.memory import memory_sections
from netsushisen.reports.stalls import stall_sections
from netsushisen.reports.tables import FORMATS, StatsError, load_stats, render

REPORTS = {"ilp": "ILP per processor, slot fill, register ports, hottest code",
           "stalls": "cycles by stall cause and by code location",
           "memory": "resident share ρ, cache hit rate μ, access time t per database region"}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kind", choices=list(REPORTS), help="; ".join(f"{k}: {v}" for k, v in REPORTS.items()))
    parser.add_argument("stats", metavar="STATS.json", help="statistics file (run --json / render --json)")
    parser.add_argument("--format", choices=FORMATS, default="table", help="output format (default table)")
    parser.add_argument("--top", type=int, default=None,
                        help="code locations per processor (default 5 for ilp, 10 for stalls)")
    parser.add_argument("-o", dest="output", help="write to this file instead of standard output")


def sections_for(kind: str, stats: dict, top: int | None = None):
    if kind == "ilp":
        return ilp_sections(stats, top if top is not None else 5)
    if kind == "stalls":
        return stall_sections(stats, top if top is not None else 10)
    return memory_sections(stats)


def run(args: argparse.Namespace) -> int:
    stats = load_stats(args.stats)
    if args.top is not None and args.top < 0:
        raise StatsError("--top must not be negative")
    try:
        sections = sections_for(args.kind, stats, args.top)
    except (KeyError, TypeError, ValueError, AttributeError, ZeroDivisionError) as err:
        what = f"missing field {err}" if isinstance(err, KeyError) else str(err)
        raise StatsError(Diagnostic(f"malformed statistics: {what}", file=str(args.stats))) from None
    text = render(sections, args.format, args.kind, str(args.stats))
    if args.output:
        Path(args.output).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0
