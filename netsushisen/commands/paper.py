"""Reproduce the paper's Table 1, Table 2 and Figures 3–5 (its evaluation of IC's memory) and
say where we agree.

    netsushisen paper [--res N] [--scenes S ...] [--out DIR] [--corners] [--precision fp32|fp64]
                      [--config FILE] [--set field=value]... [--engine NAME]

Writes into DIR (default `paper/`): report.md (both tables with the paper's numbers beside ours,
each of the paper's findings with our numbers, whether we agree and why we differ),
fig3_locality.png, fig4_miss_rate.png, fig5_access_time.png, and the CSV files behind them
(table1.csv, table2.csv, fig3_locality.csv, fig4_miss_rate.csv, fig5_access_time.csv).

It answers from the fastest exact path: the golden model's IC reference trace, in the machine's
serial ray order, replayed through a trace-driven resident memory + direct-mapped cache for every
memory configuration of the figures (no cycle-accurate emulation). The default resolution is the
paper's 512×512 (several minutes); --res 128 takes well under a minute per scene. Ctrl-C stops
after writing what the finished scenes give. `--engine` is checked and recorded in the report's
command line; this path runs no machine yet.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

from netsushisen.errors import Diagnostic, NetsushisenError
from netsushisen.host.catalog import load_scene
from netsushisen.options import (add_config_options, add_engine, add_resolution, check_footprint,
                                 check_resolution, config_from_args, engine_from_args)
from netsushisen.reports.paper import findings, report_markdown, verdict_counts
from netsushisen.reports.paper_data import PAPER_SCENES, analyse_scene
from netsushisen.reports.paper_plots import write_csvs, write_figures


def configure(parser: argparse.ArgumentParser) -> None:
    add_resolution(parser, 512, "N×N main pass (default 512, the paper's)")
    parser.add_argument("--scenes", nargs="+", default=list(PAPER_SCENES), metavar="SCENE",
                        help="built-in scenes or .nff files (default: tetra balls mount rings)")
    parser.add_argument("--out", default="paper", help="output folder (default paper/)")
    parser.add_argument("--corners", action="store_true", help="SPD corner rays: (N+1)² eye rays")
    add_config_options(parser, precision=True)
    add_engine(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bars or summary")


def _command(args: argparse.Namespace) -> str:
    parts = ["netsushisen", "paper", "--res", str(args.res), "--scenes", *args.scenes, "--out", args.out]
    if args.corners:
        parts.append("--corners")
    if args.precision:
        parts += ["--precision", args.precision]
    if args.config:
        parts += ["--config", args.config]
    for s in args.sets:
        parts += ["--set", s]
    parts += ["--engine", args.engine]
    return " ".join(shlex.quote(p) for p in parts)


def run(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    engine = engine_from_args(args)
    config = config_from_args(args)
    check_footprint("paper", None, args.res + 1 if args.corners else args.res, None, golden=True,
                    quiet=args.quiet)
    scenes = [load_scene(s) for s in args.scenes]  # every bad name is reported before any work
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise NetsushisenError(Diagnostic("the output folder is a file", file=str(out)))
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    done = []
    interrupted = False
    progress = None
    if not args.quiet:
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn)
        progress = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                            TimeElapsedColumn(), console=Console(stderr=True), transient=False)
        progress.start()
    try:
        for scene in scenes:
            task = progress.add_task(f"{scene.name}: start", total=1) if progress else None

            def show(description: str, k: float, total: float, task=task) -> None:
                if progress is not None:
                    progress.update(task, description=description, completed=k, total=total)

            done.append(analyse_scene(scene, args.res, config, args.corners, show))
            if progress is not None and not progress.console.is_terminal:  # a log: one line per scene
                progress.console.print(f"{scene.name}: done in {done[-1].seconds['total']:.0f} s")
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if progress is not None:
            progress.stop()
    missing = [s.name for s in scenes[len(done):]]
    files: list[Path] = []
    items = []
    if done:
        files += write_figures(done, out)
        files += write_csvs(done, out)
        items = findings(done)
    settings = {"res": args.res, "command": _command(args), "max_depth": config.render.max_depth,
                "engine": engine, "seconds": time.perf_counter() - start}
    report = out / "report.md"
    names = [p.name for p in files]
    report.write_text(report_markdown(done, items, settings, [report.name] + names,
                                      missing if interrupted else None), encoding="utf-8")
    if interrupted:
        print(f"netsushisen paper: interrupted; finished {', '.join(d.name for d in done) or 'no scene'}, "
              f"not {', '.join(missing)}; wrote what was finished to {out}/", file=sys.stderr)
        return 130
    if not args.quiet:
        counts = verdict_counts(items)
        print(f"{len(done)} scenes at {args.res}x{args.res} in {settings['seconds']:.0f} s: findings "
              + ", ".join(f"{v} {k}" for k, v in counts.items()) + f"; wrote {report} and "
              + ", ".join(names))
    return 0
