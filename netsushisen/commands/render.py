"""Render a scene on the emulated machine and print its ILP / memory-stall summary.

    netsushisen render SCENE [--res N] [--corners] [--pes P] [--engine NAME]
        [--precision fp32|fp64] [--generic] [--slots N] [--config FILE] [--set field=value]...
        [-o image.png] [--ids ids.npy] [--json stats.json] [--kernels DIR] [--os F] [--ic F] [--sc F]
        [--timeline FILE.kanata|FILE.json [--cycles A:B] [--procs pe0.ic,...]]

SCENE is a built-in SPD scene (tetra, balls, mount, rings, ...; `balls:2` for size factor 2) or
an .nff file. The kernels are assembled for the scene's needs unless --generic; --kernels DIR (or
--os/--ic/--sc FILE) runs your own kernels instead of the bundled ones (`--kernels classic`: the
bundled 1992-style set, kernels/classic/). The image, ids and JSON
are written whatever the run's end (a deadlock or fault keeps what was computed); the exit code
is the run's (0 done, 2 fault, 3 deadlock, 4 cycle limit). The engine is the compiled one unless
--engine says otherwise (netsushisen/options.py). On a terminal a progress bar shows the eye
rays handed out, cycles, rate and ETA (netsushisen/progress.py); Ctrl-C stops the run, writes the
partial image, ids and statistics (run.status "interrupted") and exits 130. --timeline writes
a pipeline timeline of a window of the run (docs/timeline.md).
"""

from __future__ import annotations

import argparse
import sys
import time


from netsushisen import pipeline
from netsushisen.emulator import stats as run_stats
from netsushisen.host.images import encode_png
from netsushisen.host.nff import scene_warnings
from netsushisen.options import (add_config_options, add_engine, add_json, add_output, add_quiet,
                                 add_resolution, add_timeline,
                                 check_footprint, check_output_folders, check_resolution,
                                 config_from_args, engine_from_args, fresh_output,
                                 timeline_from_args, npy_writer, write_outputs)
from netsushisen.progress import INTERRUPTED, RunMonitor
from netsushisen.reports.summary import print_render_summary


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="built-in scene name (tetra, balls, mount, rings, ...) or .nff file")
    add_resolution(parser, 32)
    parser.add_argument("--corners", action="store_true", help="SPD corner rays: (N+1)² eye rays")
    add_engine(parser)
    add_config_options(parser, pes=True, precision=True, depth=True, max_cycles=True)
    parser.add_argument("--generic", action="store_true", help="assemble every feature, not only the scene's")
    parser.add_argument("--slots", type=int, default=pipeline.DEFAULT_SLOTS, help="rays OS keeps in flight")
    add_output(parser, "image file (default: SCENE.png, or SCENE-1.png, SCENE-2.png, ... when "
                       "that exists: never overwritten unless named here)", metavar="PNG")
    parser.add_argument("--ids", help="save the eye rays' hit-primitive ids (int32 .npy, -1 background)")
    add_json(parser, "write the statistics as JSON to FILE (- : standard output, no summary)")
    parser.add_argument("--kernels", help="folder with your own os.s, ic.s, sc.s, or `classic` "
                        "for the bundled 1992-style kernels")
    for stage in ("os", "ic", "sc"):
        parser.add_argument(f"--{stage}", help=f"your own {stage.upper()} kernel source")
    add_quiet(parser)
    add_timeline(parser)


def run(args: argparse.Namespace) -> int:
    from netsushisen.timeline import TimelineRun

    check_resolution(args.res)
    check_output_folders(args.out, args.ids, args.json)
    args.quiet = args.quiet or args.json == "-"
    engine_name = engine_from_args(args)
    request = timeline_from_args(args)
    config = config_from_args(args)
    check_footprint(f"render {args.scene}", config, args.res + 1 if args.corners else args.res,
                    engine_name, quiet=args.quiet)
    overrides = {s: getattr(args, s) for s in ("os", "ic", "sc") if getattr(args, s)}
    start = time.perf_counter()
    setup = pipeline.prepare(args.scene, config, args.res, args.corners, args.generic, args.slots,
                             args.kernels, overrides)
    for line in scene_warnings(setup.scene):
        print(line, file=sys.stderr)
    engine = setup.engine(engine_name)
    side = setup.side
    monitor = RunMonitor(engine, total=side * side, unit="eye rays",
                         label=f"{setup.scene.name} {side}x{side}", show=not args.quiet)
    timeline = TimelineRun(request, engine) if request is not None else None
    with monitor:  # Ctrl-C stops the run between cycles / chunks: what was computed is kept
        run_result = timeline.run(monitor) if timeline is not None else monitor.run()
    result = pipeline.finish(setup, engine, run_result)
    seconds = time.perf_counter() - start
    output = args.out or fresh_output(setup.scene.name)
    write_outputs([(output, lambda p: p.write_bytes(encode_png(result.image_u8))),
                   (args.ids, npy_writer(result.hit_ids) if args.ids else None),
                   (args.json, run_stats.dumps(result.stats) if args.json else None)])
    written = [p for p in (output, args.ids, args.json) if p]
    if not args.quiet:
        print_render_summary(result.stats, seconds, output)
    if timeline is not None:
        print(timeline.note(), file=sys.stderr)
    if monitor.interrupted:
        _, handed, _ = engine.progress_counts()
        print(f"netsushisen render: interrupted at cycle {engine.cycle:,} ({handed:,} of "
              f"{side * side:,} eye rays handed out); wrote {', '.join(written)}", file=sys.stderr)
        return INTERRUPTED
    if run_result.error is not None:
        print(run_result.error.format(), file=sys.stderr)
    return result.exit_code
