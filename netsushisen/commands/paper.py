"""Reproduce the paper's Table 1, Table 2 and Figures 3–5 (its evaluation of IC's memory) and
say where we agree.

    netsushisen paper [--res N | --series N,N,...] [--scenes S ...] [--out DIR] [--corners]
                      [--precision fp32|fp64]
                      [--sizing records|records+lists] [--lists local|cache] [--on-machine]
                      [--scheduler ADDRESS] [--workers N] [--config FILE] [--set field=value]...
                      [--engine NAME]

Writes into DIR (default `paper/`): report.md (both tables with the paper's numbers beside ours,
each of the paper's findings decided by a stated threshold, counted per primitive reference —
the paper's counting — and per word, with a tested explanation or "unexplained" for every
difference), fig3_locality.png, fig4_miss_rate.png, fig5_access_time.png with the paper's claims
drawn on them, and the CSV files behind them.

It answers from the fastest exact path: the golden model's IC reference trace, in the machine's
serial ray order, replayed through a trace-driven resident memory + direct-mapped cache for every
memory configuration of the figures. `--on-machine` also renders every scene on the emulated
machine (serial ray-tree mode, `--engine`, default compiled) with the default memory
configuration, at four sweep points (`paper.MACHINE_POINTS`), with 4 PEs and in the findings'
reading (lists in IC's local memory, `--sizing records --lists local`), and checks IC's counters
equal the trace-driven path's; it also runs the pre-pass on the machine (its share of the main pass's
cycles is §4.3's finding). Each scene's analysis
and each machine check is one run on the Dask layer (netsushisen/cluster.py): a LocalCluster of
`--workers` processes (default one per core; `--jobs` is the old name), or the cluster whose
scheduler listens at `--scheduler ADDRESS`. Each finished run is kept in DIR/runs/ by content
key: a rerun with the same inputs reuses it (`--fresh`: compute again). Ctrl-C stops after
writing what the finished scenes give (exit 130).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from netsushisen.cluster import add_cluster_options, check_cluster_options
from netsushisen.isa.errors import NetsushisenError
from netsushisen.options import (add_config_options, add_engine, add_output, add_quiet,
                                 add_resolution, check_footprint,
                                 check_resolution, config_from_args, engine_from_args)
from netsushisen.reports.paper_data import LIST_PLACEMENTS, PAPER_SCENES, SIZINGS, PaperOptions
from netsushisen.reports.paper_report import verdict_counts


def configure(parser: argparse.ArgumentParser) -> None:
    add_resolution(parser, 512, "N×N main pass (default 512, the paper's)")
    parser.add_argument("--scenes", nargs="+", default=list(PAPER_SCENES), metavar="SCENE",
                        help="built-in scenes or .nff files (default: tetra balls mount rings)")
    add_output(parser, "output folder (default paper/)", metavar="DIR", default="paper")
    parser.add_argument("--corners", action="store_true", help="SPD corner rays: (N+1)² eye rays")
    parser.add_argument("--sizing", choices=SIZINGS, default="records",
                        help="what local memory sizes are shares of: the shape records (default, "
                             "the paper's primitive database) or list cells + records")
    parser.add_argument("--lists", choices=LIST_PLACEMENTS, default="local",
                        help="list cells in local memory, never cached (default, the paper's §4.4) "
                             "or in ICGM through the cache (the machine's IC kernel)")
    add_cluster_options(parser, "one scene's analysis or machine check each at a time",
                        aliases=("--jobs",))
    parser.add_argument("--no-candidates", action="store_true",
                        help="skip rerunning Figures 4–5 under the candidate readings (sizing, "
                             "list placement, 32- and 128-byte blocks, 4 PEs) that explain a "
                             "differing finding")
    parser.add_argument("--on-machine", action="store_true",
                        help="also render each scene on the emulated machine (serial mode) and "
                             "check IC's counters and per-reference counts equal the "
                             "trace-driven path's, and run the ray-order study (normal mode)")
    parser.add_argument("--series", type=_resolutions, default=None, metavar="N,N,...",
                        help="the resolution series: a whole reproduction at each N (in DIR/res-N/) "
                             "and DIR/series.md with each finding's verdict and margin per "
                             "resolution (below 512: provisional); replaces --res")
    parser.add_argument("--draws", type=int, default=0, metavar="N",
                        help="also replay Figures 4–5 under N draws of eye-ray jitter, pre-pass "
                             "sampling and record order: each point's spread, and the verdicts "
                             "that change within it (default 0; 5 or more for a spread)")
    parser.add_argument("--fresh", action="store_true",
                        help="compute every run again (default: a run already in DIR/runs/ is "
                             "reused)")
    add_config_options(parser, precision=True)
    add_engine(parser)
    add_quiet(parser, "no progress bars or summary")


def _resolutions(text: str) -> list[int]:
    """--series's list: resolutions separated by commas, each 1 or more, at least two."""
    try:
        out = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give resolutions separated by commas, "
                                         "e.g. 32,64,128") from None
    if len(out) < 2 or len(set(out)) != len(out):
        raise argparse.ArgumentTypeError(f"{text!r}: give two or more different resolutions "
                                         "of at least 1, e.g. 32,64,128")
    return sorted(out)


def _command(args: argparse.Namespace, res: int | None = None) -> str:
    where = (["--res", str(args.res if res is None else res)] if res is not None or not args.series
             else ["--series", ",".join(map(str, args.series))])
    out = args.out if res is None else str(Path(args.out) / f"res-{res}")
    parts = ["netsushisen", "paper", *where, "--scenes", *args.scenes, "--out", out]
    if args.corners:
        parts.append("--corners")
    if args.precision:
        parts += ["--precision", args.precision]
    parts += ["--sizing", args.sizing, "--lists", args.lists]
    if args.no_candidates:
        parts.append("--no-candidates")
    if args.draws:
        parts += ["--draws", str(args.draws)]
    if args.on_machine:
        parts.append("--on-machine")
    if args.config:
        parts += ["--config", args.config]
    for s in args.sets:
        parts += ["--set", s]
    parts += ["--engine", args.engine]
    return " ".join(shlex.quote(p) for p in parts)


def run(args: argparse.Namespace) -> int:
    for res in args.series or [args.res]:
        check_resolution(res)
    engine = engine_from_args(args)
    config = config_from_args(args)
    top = max(args.series or [args.res])
    check_footprint("paper", None, top + 1 if args.corners else top, None, golden=True,
                    quiet=args.quiet)
    check_cluster_options(args)
    if not 0 <= args.draws <= 100:
        raise NetsushisenError(f"--draws {args.draws}: give 0 to 100 draws")
    from netsushisen.paper import (MACHINE_POINTS, PE_CANDIDATE,  # noqa: PLC0415 (heavy)
                                   PaperRequest, run_paper)

    def request(res: int, out: Path, command: str) -> "PaperRequest":
        return PaperRequest(list(args.scenes), res, config, out,
                            PaperOptions(sizing=args.sizing, lists=args.lists), args.corners,
                            args.on_machine, engine, command, args.workers, args.fresh,
                            candidates=not args.no_candidates, draws=args.draws)

    if args.series:
        return _series(args, request)
    done = run_paper(request(args.res, Path(args.out), _command(args)), args.scheduler,
                     show=not args.quiet)
    names = ", ".join(p.name for p in done.files)
    if done.interrupted:
        print("netsushisen paper: interrupted; finished "
              f"{', '.join(d.name for d in done.scenes) or 'no scene'}, not "
              f"{', '.join(done.missing)}; wrote what was finished to {args.out}/", file=sys.stderr)
        return 130
    if not args.quiet:
        counts = verdict_counts(done.items)
        print(f"{len(done.scenes)} scenes at {args.res}x{args.res} in {done.seconds:.0f} s: "
              "findings "
              + ", ".join(f"{v} {k}" for k, v in counts.items())
              + f"; wrote {done.report} and " + names
              + (f" ({done.cached} runs from {args.out}/runs/)" if done.cached else ""))
    if done.differing:
        print("netsushisen paper: on the machine, IC's counters differ from the trace-driven "
              "path's: "
              + "; ".join(f"{c['scene']}" + (f" ({c['point']})" if c.get("point") else "")
                         + f": {c['difference'] or c.get('ref_difference', '')}"
                         for c in done.differing),
              file=sys.stderr)
        return 1
    if done.checks and not args.quiet:
        scenes = list(dict.fromkeys(c["scene"] for c in done.checks))
        print(f"on the machine: IC's counters and per-reference counts equal the trace-driven "
              f"path's for {', '.join(scenes)} ({len(done.checks)} runs: the default memory, "
              f"{len(MACHINE_POINTS)} sweep points, {PE_CANDIDATE} PEs and the findings' "
              "reading each)")
    return 0


def _series(args: argparse.Namespace, request) -> int:
    """`--series`: a whole reproduction per resolution (DIR/res-N/), then DIR/series.md; Ctrl-C
    writes the series of the resolutions that finished (exit 130)."""
    from netsushisen.paper import output_folder, run_paper  # noqa: PLC0415 (heavy)
    from netsushisen.reports.paper_series import write_series  # noqa: PLC0415

    out = output_folder(Path(args.out))
    runs, interrupted = {}, False
    for res in args.series:
        done = run_paper(request(res, out / f"res-{res}", _command(args, res)), args.scheduler,
                         show=not args.quiet)
        if done.interrupted:
            interrupted = True
            break
        runs[res] = done.items
        if not args.quiet:
            counts = verdict_counts(done.items)
            print(f"{res}x{res}: findings " + ", ".join(f"{v} {k}" for k, v in counts.items())
                  + f" in {done.seconds:.0f} s")
    files = write_series(runs, out, _command(args)) if runs else []
    if interrupted:
        print(f"netsushisen paper: interrupted; the series holds "
              f"{', '.join(map(str, runs)) or 'no resolution'}; wrote what was finished to "
              f"{args.out}/", file=sys.stderr)
        return 130
    if not args.quiet:
        print("wrote " + " and ".join(str(p) for p in files))
    return 0
