"""Show what accuracy costs in time: per knob, each setting's error against truth beside its cost.

    netsushisen accuracy [SCENE ...] [--res N | --sizes N,N,...] [--predict N]
                         [--axes precision,depth,prepass,fidelity]
                         [--engine NAME] [--out DIR] [--config FILE] [--set field=value]...
                         [--seed N] [--repeats N] [--scheduler ADDRESS] [--workers N] [--fresh]
                         [--quiet]

Axes (default all): precision (golden fp64 truth; golden fp32, fp16, bf16-rounded scene; the
machine in fp32 and fp64), depth (truth: depth 10, 20, 40 until two give the same 8-bit image; depth 1 … 8), prepass (pre-pass sizes against
the full-resolution ranking), fidelity (analytic, trace-driven, sampled cycle-accurate with 95 %
intervals, the full run on the engine as truth, the reference engine). SCENEs default to the
paper's four (tetra balls mount rings); --res defaults to 32. Writes into DIR (default
`accuracy/`): accuracy.json, accuracy_<axis>.csv and accuracy_<axis>.png per axis, report.md;
prints a table per axis. Machine rows run on --engine (default the compiled engine). Before any
timed row every path is compiled and warmed once per precision (reported once, as "warm-up");
each row's seconds are the median of --repeats runs (default 3) with their min–max spread, host
preparation included on every row. Each scene × axis is one run on the Dask layer
(netsushisen/cluster.py): a LocalCluster of --workers processes (default 1, so that no two
timed runs share the cores), or the cluster at --scheduler ADDRESS; each worker warms its
engine before its first timed row. Rows are written in input order, whatever order they finish
in. A finished scene × axis is kept in DIR/runs/ by content key and reused by a rerun with the
same inputs (--fresh: measure again). Ctrl-C writes every row that had finished (also those of
a scene × axis still running) and exits 130. Every row's time is split into stages (host,
load, machine, read-out, auxiliary), each with its spread; repeats run round-robin over an axis's
settings. --sizes 16,32,64 runs every size into DIR/NxN/ and fits per setting seconds = a + b·rays
(DIR/scaling.json, scaling.md), predicting --predict (default 512).
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

from netsushisen.cluster import add_cluster_options, check_cluster_options
from netsushisen.isa.errors import Diagnostic, NetsushisenError
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
    add_cluster_options(parser, "one scene × axis each at a time",
                        default="1: rows are timed, and runs side by side share the cores")
    parser.add_argument("--fresh", action="store_true",
                        help="measure every scene × axis again (default: one already in DIR/runs/ is reused)")
    parser.add_argument("--sizes", metavar="N,N,...",
                        help="run the study at each of these sizes (e.g. 16,32,64,128; instead of "
                             "--res), each into DIR/NxN/, and fit per setting seconds = a + b·rays "
                             "(least squares, R²) into DIR/scaling.json and scaling.md")
    parser.add_argument("--predict", type=int, default=512, metavar="N",
                        help="the size the --sizes fit predicts (default 512)")
    add_quiet(parser, "no progress, no tables")


def parse_sizes(text: str) -> list[int]:
    """`16,32,64` -> [16, 32, 64] (ascending, each once); anything else is one error."""
    try:
        sizes = sorted({int(x) for x in text.split(",") if x.strip()})
    except ValueError:
        raise NetsushisenError(f"--sizes {text!r}: comma-separated sizes, e.g. 16,32,64,128") from None
    if len(sizes) < 2:
        raise NetsushisenError(f"--sizes {text!r}: at least two sizes (a line needs two points)")
    for n in sizes:
        check_resolution(n)
    return sizes


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
    if args.sizes:
        return run_sizes(args)
    return run_one(args)


def run_sizes(args: argparse.Namespace) -> int:
    """The study at every --sizes size (DIR/NxN/), then the per-ray fits (DIR/scaling.*)."""
    import json

    from netsushisen.isa.outputs import write_text
    from netsushisen.reports.accuracy_scaling import sampled_speedups, scaling_markdown, scalings

    sizes = parse_sizes(args.sizes)
    check_resolution(args.predict)
    base = Path(args.out)
    studies = {}
    for n in sizes:
        args.res, args.out = n, str(base / f"{n}x{n}")
        code = run_one(args)
        studies[n] = _STUDIES.pop()
        if code:
            return code
    fits, ups = scalings(studies, args.predict), sampled_speedups(studies)
    write_text(base / "scaling.json", json.dumps(
        {"sizes": sizes, "predict_res": args.predict, "fits": [f.to_json() for f in fits],
         "sampled_speedups": ups}, indent=1, allow_nan=False, ensure_ascii=False) + "\n")
    md = scaling_markdown(fits, ups)
    write_text(base / "scaling.md", "# How the costs scale\n\n" + md)
    if not args.quiet:
        print(md, end="")
        print(f"wrote {base / 'scaling.json'}, {base / 'scaling.md'}")
    return 0


_STUDIES: list[dict] = []
"""The rows of each `run_one` (per axis), for `run_sizes`."""


def run_one(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    check_cluster_options(args)
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

    from netsushisen.accuracy import run_study
    from netsushisen.host.nff import format_nff
    from netsushisen.reports.accuracy_report import agreement_lines, tables_text, write_all

    start = time.perf_counter()
    study = run_study(scenes, axes, args.res, config, engine, args.seed, args.repeats,
                      args.scheduler, args.workers or 1, show=not args.quiet, cache_dir=out / "runs",
                      fresh=args.fresh)
    rows, warm, interrupted = study.rows, study.warm, study.interrupted
    _STUDIES.append(rows)
    meta = {"command": _command(args, specs), "res": args.res, "engine": engine,
            "machine": _machine(), "seconds": time.perf_counter() - start,
            "config": config.to_dict(), "interrupted": interrupted,
            "repeats": args.repeats, "warm_up_seconds": warm, "ran_on": study.where,
            "scenes": {s.name: {"source": s.source,
                                "sha256": hashlib.sha256(format_nff(s).encode()).hexdigest()}
                       for s in scenes}}
    paths = write_all(out, rows, meta) if rows else []
    if not args.quiet and rows:
        print(tables_text(rows), end="")
        for line in agreement_lines(rows):
            print(line)
        print("warm-up (compile and first run, charged to no row): "
              + ", ".join(f"{k} {v:.1f} s" for k, v in warm.items()))
    if interrupted:
        done = ", ".join(f"{axis} ({len(r_)} rows)" for axis, r_ in rows.items())
        print("netsushisen accuracy: interrupted; " + (
            f"wrote the finished rows to {out}/: {done}" if paths else
            "no row had finished: nothing written"), file=sys.stderr)
        return 130
    if not args.quiet:
        print(f"{len(scenes)} scenes, axes {', '.join(axes)} at {args.res}x{args.res} in "
              f"{meta['seconds']:.0f} s; wrote {', '.join(str(p) for p in paths)}"
              + (f" ({study.cached} scene × axis units from {out}/runs/)" if study.cached else ""))
    return 0
