"""Design-space sweeps on Dask: every point of a spec rendered on the emulated machine.

    netsushisen sweep SPEC.toml [--scheduler ADDRESS] [--workers N] [--out DIR] [--engine NAME]
                                [--quiet]
    netsushisen sweep plot RESULTS [--x FIELD] [--y METRIC] [--hue FIELD] [--kind line|heat]
                                   [-o FILE]

The spec format is in netsushisen/sweep.py (and the README's "Sweeps"). Without --scheduler the
points run on a Dask LocalCluster with one worker process per core (or --workers N); with it,
on the cluster whose scheduler listens at ADDRESS (`dask scheduler`, then `dask worker ADDRESS`
on each machine). Each finished point is written at once to DIR/points/KEY.json (DIR default
`sweep/`); a rerun computes only the missing points. A failed point (fault, deadlock, cycle
limit, bad configuration, a worker lost too often) is recorded with its error and the sweep goes
on; the next run computes it again (`--no-retry` keeps it). Each point file carries a checksum of
its content and the hash of the spec that wrote it: a point file that is truncated, not JSON,
edited or written for another key is named in one line and computed again. At the end, and on
Ctrl-C (exit 130), DIR/results.csv and DIR/results.parquet hold one row per finished point; the
last line says `sweep: P points, C computed, K cached, F failed` (P distinct points: C + K = P
unless interrupted, when the rest are counted as not run).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from netsushisen.cluster import add_cluster_options, check_cluster_options
from netsushisen.isa.errors import NetsushisenError
from netsushisen.options import add_output, add_quiet, check_output_dir
from netsushisen.sweep import check_sweep_footprint, engine_of, load_spec, run_sweep


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", metavar="SPEC.toml | plot",
                        help="the sweep spec; or `plot RESULTS` to draw a results table")
    parser.add_argument("results", nargs="?", metavar="RESULTS",
                        help="(plot) results.csv or results.parquet of a sweep")
    add_cluster_options(parser, "one point each at a time")
    add_output(parser, "output folder (default sweep/); with plot: the image file (default next "
                       "to RESULTS)", metavar="PATH", aliases=("--output",))
    parser.add_argument("--engine", help="engine of every point (default: the spec's, else compiled)")
    parser.add_argument("--no-retry", dest="retry", action="store_false",
                        help="keep failed points as they are (default: compute them again)")
    add_quiet(parser, "no progress bar")
    plot = parser.add_argument_group("plot")
    plot.add_argument("--x", help="(plot) field on the x axis (default: the first varied field)")
    plot.add_argument("--y", default="cycles", help="(plot) metric (default cycles)")
    plot.add_argument("--hue", help="(plot) field drawn as one line per value (or the heat map's y axis)")
    plot.add_argument("--kind", choices=("line", "heat"), default="line", help="(plot) line plot or heat map")


def run(args: argparse.Namespace) -> int:
    if args.spec == "plot":
        from netsushisen.reports.sweep_plot import plot_results
        if not args.results:
            raise NetsushisenError("sweep plot: give the results file (DIR/results.csv)")
        out = plot_results(args.results, x=args.x, y=args.y, hue=args.hue, kind=args.kind,
                           output=args.out)
        print(f"wrote {out}")
        return 0
    if args.results:
        raise NetsushisenError(f"sweep: unexpected argument {args.results!r} (only `sweep plot` takes RESULTS)")
    check_output_dir(args.out or "sweep")
    check_cluster_options(args)
    spec = load_spec(args.spec)
    engine = engine_of(args.engine or spec.engine)
    check_sweep_footprint(spec, engine, args.quiet)
    summary = run_sweep(spec, Path(args.out or "sweep"), engine, scheduler=args.scheduler,
                        workers=args.workers, show=not args.quiet and sys.stderr.isatty(),
                        retry=args.retry)
    print(summary.line())
    if summary.interrupted:
        return 130
    return 1 if summary.failed else 0
