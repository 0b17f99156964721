"""Reproduce the paper's Table 1, Table 2 and Figures 3–5 (its evaluation of IC's memory) and
say where we agree.

    netsushisen paper [--res N] [--scenes S ...] [--out DIR] [--corners] [--precision fp32|fp64]
                      [--sizing records|records+lists] [--lists local|cache] [--jobs N]
                      [--on-machine] [--config FILE] [--set field=value]... [--engine NAME]

Writes into DIR (default `paper/`): report.md (both tables with the paper's numbers beside ours,
each of the paper's findings decided by a stated threshold, counted per primitive reference —
the paper's counting — and per word, with a tested explanation or "unexplained" for every
difference), fig3_locality.png, fig4_miss_rate.png, fig5_access_time.png with the paper's claims
drawn on them, and the CSV files behind them.

It answers from the fastest exact path: the golden model's IC reference trace, in the machine's
serial ray order, replayed through a trace-driven resident memory + direct-mapped cache for every
memory configuration of the figures. `--on-machine` also renders every scene on the emulated
machine (serial ray-tree mode, `--engine`, default compiled) with the default memory
configuration and checks IC's counters equal the trace-driven path's. Scenes run in parallel
over `--jobs` worker processes (default: one per core). Ctrl-C stops after writing what the
finished scenes give.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from pathlib import Path

from netsushisen.outputs import write_text
from netsushisen.errors import Diagnostic, NetsushisenError
from netsushisen.host.catalog import load_scene
from netsushisen.options import (add_config_options, add_engine, add_output, add_quiet,
                                 add_resolution, check_footprint,
                                 check_resolution, config_from_args, engine_from_args)
from netsushisen.reports.paper import findings
from netsushisen.reports.paper_data import (LIST_PLACEMENTS, PAPER_SCENES, SIZINGS, PaperOptions,
                                            SceneData, analyse_scene)
from netsushisen.reports.paper_machine import compare_counters, run_parallel
from netsushisen.reports.paper_report import report_markdown, verdict_counts
from netsushisen.reports.paper_plots import write_csvs, write_figures


def machine_check(scene: str, res: int, config, engine: str, corners: bool = False) -> dict:
    """Render `scene` on the machine in the serial ray-tree mode (SLOTS=1, SERIAL_TREES=1: one
    ray tree in flight, so IC sees the golden trace's rays in `ic_access.machine_order`) and
    compare IC's counters with the trace-driven path's for the same images. Runs in a worker
    process: module-level, picklable arguments."""
    from netsushisen.host.golden import render as golden_render
    from netsushisen.pipeline import render
    from netsushisen.emulator.tracesim import TraceMemory
    from netsushisen.host.ic_access import machine_order, ordered_stream_chunks

    t0 = time.perf_counter()
    r = render(scene, config, res=res, corners=corners, slots=1, defines={"SERIAL_TREES": 1}, engine=engine)
    t_machine = time.perf_counter() - t0
    setup = r.setup
    machine = r.stats["memory"]["pe0.ic"]
    out = {"scene": setup.scene.name, "cycles": int(r.run.cycles), "status": r.run.status,
           "machine_seconds": t_machine}
    if r.run.status not in ("halted", "finished"):
        out.update(equal=False, difference=f"the machine stopped: {r.run.status}"
                   + (f" ({r.run.error})" if r.run.error else ""), rho="–", mu="–",
                   seconds=time.perf_counter() - t0)
        return out
    golden = golden_render(setup.scene, setup.config, res=res, corners=corners, keep_trace=True,
                           grid=setup.images.layout.grid)
    model = TraceMemory.for_images(setup.images)
    for space, address in ordered_stream_chunks(setup.images.layout, golden, machine_order(golden)):
        model.replay(space, address)
    trace = model.stats()
    diff = compare_counters(trace, machine)
    res_acc, cache = machine["resident"]["accesses"], machine["cache"]
    total = res_acc + cache["accesses"]
    out.update(equal=not diff, difference=diff,
               rho=f"{res_acc / total:.4f}" if total else "–",
               mu=f"{cache['hits'] / cache['accesses']:.4f}" if cache["accesses"] else "–",
               loads=total, seconds=time.perf_counter() - t0)
    return out


def configure(parser: argparse.ArgumentParser) -> None:
    add_resolution(parser, 512, "N×N main pass (default 512, the paper's)")
    parser.add_argument("--scenes", nargs="+", default=list(PAPER_SCENES), metavar="SCENE",
                        help="built-in scenes or .nff files (default: tetra balls mount rings)")
    add_output(parser, "output folder (default paper/)", metavar="DIR", default="paper")
    parser.add_argument("--corners", action="store_true", help="SPD corner rays: (N+1)² eye rays")
    parser.add_argument("--sizing", choices=SIZINGS, default="records",
                        help="what local memory sizes are shares of: the shape records (default, the "
                             "paper's primitive database) or list cells + records")
    parser.add_argument("--lists", choices=LIST_PLACEMENTS, default="local",
                        help="list cells in local memory, never cached (default, the paper's §4.4) or "
                             "in ICGM through the cache (the machine's IC kernel)")
    parser.add_argument("--jobs", type=int, default=None, metavar="N",
                        help="worker processes, one scene each (default: the cores, at most one per scene)")
    parser.add_argument("--on-machine", action="store_true",
                        help="also render each scene on the emulated machine (serial mode) and check "
                             "IC's counters equal the trace-driven path's")
    add_config_options(parser, precision=True)
    add_engine(parser)
    add_quiet(parser, "no progress bars or summary")


def _command(args: argparse.Namespace) -> str:
    parts = ["netsushisen", "paper", "--res", str(args.res), "--scenes", *args.scenes, "--out", args.out]
    if args.corners:
        parts.append("--corners")
    if args.precision:
        parts += ["--precision", args.precision]
    parts += ["--sizing", args.sizing, "--lists", args.lists]
    if args.on_machine:
        parts.append("--on-machine")
    if args.config:
        parts += ["--config", args.config]
    for s in args.sets:
        parts += ["--set", s]
    parts += ["--engine", args.engine]
    return " ".join(shlex.quote(p) for p in parts)


def _jobs(args: argparse.Namespace, n_scenes: int) -> int:
    if args.jobs is not None and args.jobs < 1:
        raise NetsushisenError(Diagnostic(f"--jobs {args.jobs}: need at least 1 worker"))
    return args.jobs or max(1, min(os.cpu_count() or 1, n_scenes))


def run(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    engine = engine_from_args(args)
    config = config_from_args(args)
    check_footprint("paper", None, args.res + 1 if args.corners else args.res, None, golden=True,
                    quiet=args.quiet)
    options = PaperOptions(sizing=args.sizing, lists=args.lists)
    scenes = [load_scene(s) for s in args.scenes]  # every bad name is reported before any work
    jobs = _jobs(args, len(scenes))
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise NetsushisenError(Diagnostic("the output folder is a file", file=str(out)))
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    results: dict[int, SceneData] = {}
    checks: dict[int, dict] = {}
    progress = None
    if not args.quiet:
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn)
        progress = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                            TimeElapsedColumn(), console=Console(stderr=True), transient=False)
        progress.start()

    def log(text: str) -> None:
        if progress is not None and not progress.console.is_terminal:  # a log: one line per scene
            progress.console.print(text)

    try:
        if jobs == 1 and not args.on_machine:
            complete = True
            try:
                for i, scene in enumerate(scenes):
                    task = progress.add_task(f"{scene.name}: start", total=1) if progress else None

                    def show(description: str, k: float, total: float, task=task) -> None:
                        if progress is not None:
                            progress.update(task, description=description, completed=k, total=total)

                    results[i] = analyse_scene(scene, args.res, config, args.corners, show, options=options)
                    log(f"{scene.name}: done in {results[i].seconds['total']:.0f} s")
            except KeyboardInterrupt:
                complete = False
        else:
            tasks = [(analyse_scene, (spec, args.res, config, args.corners, None, 16384, options))
                     for spec in args.scenes]
            if args.on_machine:
                tasks += [(machine_check, (spec, args.res, config, engine, args.corners)) for spec in args.scenes]
            bar = progress.add_task(f"{len(tasks)} tasks on {jobs} workers", total=len(tasks)) if progress else None
            n = len(scenes)

            def done(i: int, result) -> None:
                if i < n:
                    results[i] = result
                    log(f"{result.name}: trace-driven path done in {result.seconds['total']:.0f} s")
                else:
                    checks[i - n] = result
                    log(f"{result['scene']}: machine {result['cycles']:,} cycles, counters "
                        + ("equal" if result["equal"] else "differ") + f", {result['seconds']:.0f} s")
                if progress is not None:
                    progress.advance(bar)

            complete = run_parallel(tasks, jobs, done)
    finally:
        if progress is not None:
            progress.stop()
    done_scenes = [results[i] for i in sorted(results)]
    interrupted = not complete
    missing = [s.name for i, s in enumerate(scenes) if i not in results]
    files: list[Path] = []
    items, word_items = [], []
    if done_scenes:
        files += write_figures(done_scenes, out)
        files += write_csvs(done_scenes, out)
        items = findings(done_scenes, "ref")
        word_items = findings(done_scenes, "all")
    seconds = time.perf_counter() - start
    machine = None
    if args.on_machine and checks:
        mc = config.ic_memory
        machine = {"engine": engine, "res": args.res, "workers": jobs, "seconds": seconds,
                   "memory": f"IC cache {mc.cache_bytes} B, resident {mc.resident_bytes} B"
                   if mc.cache_share is None else f"IC cache share {mc.cache_share}, resident share {mc.resident_share}",
                   "scenes": [checks[i] for i in sorted(checks)]}
    settings = {"res": args.res, "command": _command(args), "max_depth": config.render.max_depth,
                "engine": engine, "seconds": seconds}
    report = out / "report.md"
    names = [p.name for p in files]
    write_text(report, report_markdown(done_scenes, items, settings, [report.name] + names,
                                       missing if interrupted else None, word_items, machine))
    if interrupted:
        print(f"netsushisen paper: interrupted; finished {', '.join(d.name for d in done_scenes) or 'no scene'}, "
              f"not {', '.join(missing)}; wrote what was finished to {out}/", file=sys.stderr)
        return 130
    if not args.quiet:
        counts = verdict_counts(items)
        print(f"{len(done_scenes)} scenes at {args.res}x{args.res} in {seconds:.0f} s: findings "
              + ", ".join(f"{v} {k}" for k, v in counts.items()) + f"; wrote {report} and "
              + ", ".join(names))
    bad = [c for c in checks.values() if not c["equal"]]
    if bad:
        print("netsushisen paper: on the machine, IC's counters differ from the trace-driven path's: "
              + "; ".join(f"{c['scene']}: {c['difference']}" for c in bad), file=sys.stderr)
        return 1
    if machine and not args.quiet:
        print(f"on the machine: IC's counters equal the trace-driven path's for "
              f"{', '.join(c['scene'] for c in machine['scenes'])}")
    return 0
