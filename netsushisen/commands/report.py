"""Reports from statistics files (`run --json` or `render --json`).

    netsushisen report ilp      STATS.json [--top N]
    netsushisen report stalls   STATS.json [--top N] [--explain] [--plot FILE.png]
    netsushisen report stalls   --explain                     (the glossary of stall causes)
    netsushisen report memory   STATS.json
    netsushisen report annotate STATS.json [--proc pe0.ic] [--top N] [--order hot|program]
                                [--all] [--plot FILE.png]
    netsushisen report bounds   STATS.json [--proc pe0.ic] [--top N] [--optimum-ops N] [--all]
    netsushisen report diff     A.json B.json [--changed]
    each also: [--format table|json|csv|md] [--table NAME] [-o FILE|DIR] [--width N]
    netsushisen report flat     STATS.json [-o FILE]   (one statistic a line, gem5's stats.txt)

ilp: per processor cycles, bundles, operations, dynamic ILP (ops per cycle) against static ILP
(ops per bundle as scheduled), slot fill per unit class, register-port use, the hottest code.
stalls: cycles by cause and stall cycles by code location; `--explain` adds what each cause
means (docs/stalls.md); `--plot` draws cycles by cause per processor. memory: per database
region ρ (resident share), μ (cache hit rate), the measured mean access time and the paper's
t = t_r·{ρ + (1 − ρ)(8 − 6μ)}. annotate: the program listing with, per bundle, times issued,
stall cycles by cause, share of the processor's cycles and slot fill, hottest first or in
program order, each with its innermost loop, a summary per natural loop that ran (`--all`: every
one; asm/loops.py) with its parent, iterations and cycles per iteration beside the bound, and
the hot path (blocks by cycles, share, excess over the bound); `--plot` draws the cycles per
bundle along the listing. bounds: per loop and block the static bounds (units, ports,
recurrence, critical path; the optimum of small blocks by CP-SAT) beside its cycles per run,
stalls per run by cause, and a block's share and excess; then the run's floor per processor
(docs/scheduling.md, "The floor").
diff: the inputs that differ, then every processor's and memory region's figures in A and B
with the change and relative change (`--changed`: only the figures that changed). flat: every
statistic as `name value # description (unit)`, dotted stable names (reports/flat.py). Every
report reads a statistics JSON or a flat dump alike, so `report diff A.txt B.txt` diffs dumps.

Tables fit the terminal's width (80 columns when not a terminal or with `-o`; `--width` or
`COLUMNS` to choose) and wrap between words only. CSV is one table per file, readable by pandas as it is:
`--table NAME` picks one table of a report (to standard output or `-o FILE`), and `-o DIR`
writes a report's tables to `DIR/<report>_<table>.csv`.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from pathlib import Path

from netsushisen.isa.outputs import write_text
from netsushisen.isa.errors import Diagnostic
from netsushisen.options import add_output, closest
from netsushisen.reports.tables import (FORMATS, StatsError, load_stats, render, report_sections,
                                       select, write_csv_dir)

REPORTS = {"ilp": "ILP per processor, slot fill, register ports, hottest code",
           "stalls": "cycles by stall cause and by code location; --explain: what the causes mean",
           "memory": "resident share ρ, cache hit rate μ, access time t per database region",
           "annotate": "the program listing with cycles, stalls and slot fill per bundle; loops",
           "bounds": "every loop's and block's static bounds beside its cycles per run, stalls by cause; the run's floor",
           "diff": "compare two statistics files: inputs that differ, then every figure's change",
           "flat": "every statistic, one a line: name value # description (unit)"}
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=FORMATS, default="table", help="output format (default table)")
    p.add_argument("--table", metavar="NAME", help="only this table of the report (its key, as "
                   "in the JSON output: e.g. causes, locations); CSV holds one table")
    add_output(p, "write to this file instead of standard output (CSV of several tables: a "
                  "folder, one file per table)", metavar="FILE|DIR")
    p.add_argument("--width", type=int, metavar="N", help="table width (default: the terminal's; "
                   "80 when the output is not a terminal, or with -o)")


def _top(p: argparse.ArgumentParser, default: str) -> None:
    p.add_argument("--top", type=int, default=None, metavar="N", help=f"code locations per processor "
                   f"(default {default})")


def _proc(p: argparse.ArgumentParser) -> None:
    p.add_argument("--proc", metavar="NAME", help="one processor (pe0.ic), or a stage (ic: "
                   "every PE's); default every processor")


def add_optimum_option(p: argparse.ArgumentParser) -> None:
    """`--optimum-ops N` (report bounds, asm --bounds)."""
    from netsushisen.asm.bounds import OPTIMUM_MAX_OPS

    p.add_argument("--optimum-ops", type=int, default=OPTIMUM_MAX_OPS, metavar="N",
                   help=f"blocks up to N operations get CP-SAT's optimum schedule length "
                        f"(default {OPTIMUM_MAX_OPS}; 0: none)")


def _plot(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--plot", metavar="FILE.png", help=f"also draw {what} (.png, .svg or .pdf)")


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="kind", metavar="REPORT", required=True)
    for kind, help_text in REPORTS.items():
        p = sub.add_parser(kind, help=help_text, description=help_text)
        if kind == "flat":
            p.add_argument("stats", metavar="STATS.json", help="statistics file (run --json / "
                           "render --json)")
            add_output(p, "write to this file instead of standard output")
            continue
        if kind == "diff":
            p.add_argument("stats", metavar="A.json", help="the first statistics file (JSON or "
                           "a flat dump)")
            p.add_argument("other", metavar="B.json", help="the second, compared with the first")
            p.add_argument("--changed", action="store_true", help="only the figures that changed")
        else:
            p.add_argument("stats", metavar="STATS.json", nargs="?" if kind == "stalls" else None,
                           help="statistics file (run --json / render --json)")
        _common(p)
        if kind in ("ilp", "stalls", "annotate", "bounds"):
            _top(p, {"ilp": "5", "stalls": "10", "annotate": "20 hottest; every bundle with "
                     "--order program", "bounds": "20 hottest blocks"}[kind])
        if kind == "stalls":
            p.add_argument("--explain", action="store_true", help="add what each cause means; "
                           "without STATS.json: print the glossary of every cause")
            _plot(p, "the cycles by cause per processor as stacked bars")
        if kind in ("bounds", "annotate"):
            p.add_argument("--all", dest="all_loops", action="store_true",
                           help="every loop, also those that never ran (default: the loops "
                                "whose header issued)")
        if kind == "bounds":
            _proc(p)
            add_optimum_option(p)
        if kind == "annotate":
            _proc(p)
            p.add_argument("--order", choices=("hot", "program"), default="hot",
                           help="hottest bundles first (default) or in program order")
            _plot(p, "the cycles charged to each bundle along the listing")


def sections_for(args: argparse.Namespace, stats: dict, other: dict | None = None):
    kind, top = args.kind, args.top if "top" in args else None
    defaults = {"ilp": 5, "stalls": 10}
    if kind in defaults:
        return report_sections(kind, stats, top if top is not None else defaults[kind],
                               **({"explain": args.explain} if kind == "stalls" else {}))
    if kind == "annotate":
        return report_sections(kind, stats, args.proc, top, args.order, args.all_loops)
    if kind == "bounds":
        from netsushisen.reports.bounds import bounds_report
        return bounds_report(stats, args.proc, top, args.optimum_ops, str(args.stats),
                             args.all_loops)
    if kind == "diff":
        return report_sections(kind, stats, other, args.changed)
    if kind == "memory":
        return report_sections(kind, stats)
    raise StatsError(f"unknown report {kind!r}{closest(kind, REPORTS)} (reports: "
                     f"{', '.join(REPORTS)})")


def _check(args: argparse.Namespace) -> None:
    """Option errors, before any file is read."""
    if getattr(args, "top", None) is not None and args.top < 0:
        raise StatsError("--top must not be negative")
    if getattr(args, "optimum_ops", 0) < 0:
        raise StatsError("--optimum-ops must not be negative")
    if getattr(args, "width", None) is not None and args.width < 20:
        raise StatsError(f"--width {args.width}: a table needs at least 20 columns")
    plot = getattr(args, "plot", None)
    if plot:
        p = Path(plot)
        if p.suffix.lower() not in PLOT_SUFFIXES:
            raise StatsError(Diagnostic(f"a plot is written as {', '.join(PLOT_SUFFIXES)}; "
                                        f"'{p.suffix or '(no suffix)'}' is none of them", file=plot))
        if not p.parent.is_dir():
            raise StatsError(Diagnostic("the plot's folder does not exist", file=plot))
    if args.kind == "stalls" and args.stats is None and not args.explain:
        raise StatsError("report stalls: give a STATS.json (or --explain alone for the glossary)")


def _write_plot(args: argparse.Namespace, stats: dict) -> None:
    from netsushisen.reports import stall_plots

    try:
        if args.kind == "stalls":
            stall_plots.plot_stalls(stats, args.plot)
        else:
            stall_plots.plot_annotate(stats, args.plot, args.proc)
    except OSError as err:
        raise StatsError(Diagnostic(f"cannot write the plot: {err.strerror}", file=args.plot)) from None
    print(f"report {args.kind}: plot -> {args.plot}", file=sys.stderr)


@contextlib.contextmanager
def _malformed(path) -> Iterator[None]:
    """A statistics file whose shape is wrong (a field missing, a table that is a number) is a
    located one-line error, whichever report reads it."""
    try:
        yield
    except (KeyError, TypeError, ValueError, AttributeError, ZeroDivisionError) as err:
        what = f"missing field {err}" if isinstance(err, KeyError) else str(err)
        raise StatsError(Diagnostic(f"malformed statistics: {what}", file=str(path))) from None


def run(args: argparse.Namespace) -> int:
    _check(args)
    if args.kind == "stalls" and args.stats is None:
        from netsushisen.reports.glossary import glossary_markdown, glossary_section
        sections, source, stats = [glossary_section()], "isa/stalls.py", None
        if args.format == "md":
            return _emit(args, glossary_markdown())
    elif args.kind == "flat":
        from netsushisen.reports.flat import format_flat
        stats = load_stats(args.stats)
        with _malformed(args.stats):
            text = format_flat(stats)
        return _emit(args, text)
    else:
        stats = load_stats(args.stats)
        other = load_stats(args.other) if args.kind == "diff" else None
        source = str(args.stats) + (f" {args.other}" if other is not None else "")
        with _malformed(args.stats):
            sections = sections_for(args, stats, other)
            if getattr(args, "plot", None):
                _write_plot(args, stats)
    sections = select(sections, args.table)
    if args.format == "csv" and len(sections) > 1 and args.out:
        paths = write_csv_dir(sections, args.kind, args.out)
        print(f"report {args.kind}: {len(paths)} tables -> {', '.join(map(str, paths))}", file=sys.stderr)
        return 0
    width = args.width or (80 if args.out else None)  # a file is not the terminal
    return _emit(args, render(sections, args.format, args.kind, source, width))


def _emit(args: argparse.Namespace, text: str) -> int:
    if args.out:
        write_text(args.out, text)
    else:
        sys.stdout.write(text)
    return 0
