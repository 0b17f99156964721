"""Show what accuracy costs in time: per knob, each setting's error against truth beside its cost.

    netsushisen accuracy [SCENE ...] [--res N] [--axes precision,depth,prepass,fidelity]
                         [--engine NAME] [--out DIR] [--config FILE] [--set field=value]...
                         [--seed N] [--repeats N] [--quiet]

Axes (default all): precision (golden fp64 truth; golden fp32, fp16, bf16-rounded scene; the
machine in fp32 and fp64), depth (truth: depth 10, 20, 40 until two give the same 8-bit image; depth 1 … 8), prepass (pre-pass sizes against
the full-resolution ranking), fidelity (analytic, trace-driven, sampled cycle-accurate with 95 %
intervals, the full run on the engine as truth, the reference engine). SCENEs default to the
paper's four (tetra balls mount rings); --res defaults to 32. Writes into DIR (default
`accuracy/`): accuracy.json, accuracy_<axis>.csv and accuracy_<axis>.png per axis, report.md;
prints a table per axis. Machine rows run on --engine (default the compiled engine). Before any
timed row every path is compiled and warmed once per precision (reported once, as "warm-up");
each row's seconds are the median of --repeats runs (default 3) with their min–max spread, host
preparation included on every row. Ctrl-C writes what the finished scenes and axes give and
exits 130.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import platform
import shlex
import sys
import time
from pathlib import Path

from netsushisen.errors import Diagnostic, NetsushisenError
from netsushisen.host.catalog import load_scene
from netsushisen.options import (add_config_options, add_engine, add_output, add_quiet,
                                 add_resolution, check_footprint,
                                 check_resolution, config_from_args, engine_from_args)
from netsushisen.reports.accuracy import AXES

DEFAULT_SCENES = ("tetra", "balls", "mount", "rings")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenes", nargs="*", metavar="SCENE",
                        help="built-in scenes or .nff files (default: tetra balls mount rings)")
    add_resolution(parser, 32, "N×N image of every run (default 32)")
    parser.add_argument("--axes", default=",".join(AXES), metavar="A,B,...",
                        help=f"axes to measure, comma-separated (default {','.join(AXES)})")
    add_engine(parser)
    add_output(parser, "output folder (default accuracy/)", metavar="DIR", default="accuracy")
    add_config_options(parser)
    parser.add_argument("--seed", type=int, default=1992, help="seed of the sampled tiles (default 1992)")
    parser.add_argument("--repeats", type=int, default=3, metavar="N",
                        help="runs each row is timed over: its seconds are their median (default 3)")
    add_quiet(parser, "no progress, no tables")


def parse_axes(text: str) -> list[str]:
    """`precision,depth` -> ["precision", "depth"] in the order given; unknown names are one error."""
    names = [a.strip() for a in text.split(",") if a.strip()]
    bad = [a for a in names if a not in AXES]
    if bad or not names:
        raise NetsushisenError(f"--axes {text!r}: unknown axis {', '.join(map(repr, bad)) or '(none given)'}"
                               f" (axes: {', '.join(AXES)})")
    return list(dict.fromkeys(names))


def _command(args: argparse.Namespace, scenes: list[str]) -> str:
    parts = ["netsushisen", "accuracy", *scenes, "--res", str(args.res), "--axes", args.axes_text,
             "--engine", args.engine, "--out", args.out]
    if args.config:
        parts += ["--config", args.config]
    for s in args.sets:
        parts += ["--set", s]
    parts += ["--repeats", str(args.repeats)]
    return " ".join(shlex.quote(p) for p in parts)


def _machine() -> str:
    return f"{platform.machine()} {platform.system()}, {os.cpu_count()} cores, Python {platform.python_version()}"


def run(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    if args.repeats < 1:
        raise NetsushisenError(f"--repeats {args.repeats}: at least 1 run per row")
    args.axes_text = args.axes
    axes = parse_axes(args.axes)
    engine = engine_from_args(args)
    config = config_from_args(args)
    check_footprint("accuracy", config, args.res, engine, golden=True, quiet=args.quiet)
    specs = list(args.scenes) or list(DEFAULT_SCENES)
    scenes = [load_scene(s) for s in specs]  # every bad name is reported before any work
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise NetsushisenError(Diagnostic("the output folder is a file", file=str(out)))
    out.mkdir(parents=True, exist_ok=True)

    from netsushisen.accuracy import AXIS_RUNNERS, fidelity_rows, warm_up
    from netsushisen.host.nff import format_nff
    from netsushisen.reports.accuracy_report import tables_text, write_all

    start = time.perf_counter()
    rows: dict[str, list] = {a: [] for a in axes}
    progress = None
    if not args.quiet:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        progress = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                            TimeElapsedColumn(), console=Console(stderr=True), transient=True)
        progress.start()
        task = progress.add_task("accuracy", total=len(scenes) * len(axes))

    def show(description: str) -> None:
        if progress is not None:
            progress.update(task, description=description)

    interrupted = False
    warm: dict[str, float] = {}
    try:
        warm = warm_up(scenes[0], config, engine, progress=show)
        for scene in scenes:
            for axis in axes:
                if axis == "fidelity":
                    found = fidelity_rows(scene, args.res, config, engine, show, seed=args.seed,
                                          repeats=args.repeats)
                else:
                    found = AXIS_RUNNERS[axis](scene, args.res, config, engine, show, repeats=args.repeats)
                rows[axis] += found
                if progress is not None:
                    progress.advance(task)
                    if not progress.console.is_terminal:  # a log: one line per scene and axis
                        progress.console.print(f"{scene.name} {axis}: done at "
                                               f"{time.perf_counter() - start:.0f} s")
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if progress is not None:
            progress.stop()
    rows = {a: r for a, r in rows.items() if r}
    meta = {"command": _command(args, specs), "res": args.res, "engine": engine,
            "machine": _machine(), "seconds": time.perf_counter() - start,
            "config": config.to_dict(), "interrupted": interrupted,
            "repeats": args.repeats, "warm_up_seconds": warm,
            "scenes": {s.name: {"source": s.source,
                                "sha256": hashlib.sha256(format_nff(s).encode()).hexdigest()}
                       for s in scenes}}
    paths = write_all(out, rows, meta) if rows else []
    if not args.quiet and rows:
        print(tables_text(rows), end="")
        print("warm-up (compile and first run, charged to no row): "
              + ", ".join(f"{k} {v:.1f} s" for k, v in warm.items()))
    if interrupted:
        done = ", ".join(f"{axis} ({len({r.scene for r in r_})} scenes)" for axis, r_ in rows.items())
        print("netsushisen accuracy: interrupted; " + (
            f"wrote the finished scene × axis rows to {out}/: {done}" if paths else
            "no scene × axis had finished: nothing written"), file=sys.stderr)
        return 130
    if not args.quiet:
        print(f"{len(scenes)} scenes, axes {', '.join(axes)} at {args.res}x{args.res} in "
              f"{meta['seconds']:.0f} s; wrote {', '.join(str(p) for p in paths)}")
    return 0
