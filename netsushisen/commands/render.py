"""Render a scene on the emulated machine and print its ILP / memory-stall summary.

    netsushisen render SCENE [--res N] [--corners] [--pes P] [--engine NAME]
        [--precision fp32|fp64] [--generic] [--slots N] [--config FILE] [--set field=value]...
        [-o image.png] [--ids ids.npy] [--json stats.json] [--kernels DIR] [--os F] [--ic F] [--sc F]

SCENE is a built-in SPD scene (tetra, balls, mount, rings, ...; `balls:2` for size factor 2) or
an .nff file. The kernels are assembled for the scene's needs unless --generic; --kernels DIR (or
--os/--ic/--sc FILE) runs your own kernels instead of the bundled ones. The image, ids and JSON
are written whatever the run's end (a deadlock or fault keeps what was computed); the exit code
is the run's (0 done, 2 fault, 3 deadlock, 4 cycle limit).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from netsushisen import render as pipeline
from netsushisen.emulator import stats as run_stats
from netsushisen.emulator.engine import RunResult
from netsushisen.host.images import write_png
from netsushisen.options import (add_config_options, add_engine, add_resolution, check_resolution,
                                 config_from_args, engine_from_args)
from netsushisen.reports.summary import print_render_summary


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="built-in scene name (tetra, balls, mount, rings, ...) or .nff file")
    add_resolution(parser, 32)
    parser.add_argument("--corners", action="store_true", help="SPD corner rays: (N+1)² eye rays")
    add_engine(parser)
    add_config_options(parser, pes=True, precision=True)
    parser.add_argument("--generic", action="store_true", help="assemble every feature, not only the scene's")
    parser.add_argument("--slots", type=int, default=pipeline.DEFAULT_SLOTS, help="rays OS keeps in flight")
    parser.add_argument("-o", dest="output", help="image file (default: SCENE.png)")
    parser.add_argument("--ids", help="save the eye rays' hit-primitive ids (int32 .npy, -1 background)")
    parser.add_argument("--json", help="write the statistics JSON here")
    parser.add_argument("--kernels", help="folder with your own os.s, ic.s, sc.s")
    for stage in ("os", "ic", "sc"):
        parser.add_argument(f"--{stage}", help=f"your own {stage.upper()} kernel source")
    parser.add_argument("--quiet", action="store_true", help="no summary")


def run(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    engine_name = engine_from_args(args)
    config = config_from_args(args)
    overrides = {s: getattr(args, s) for s in ("os", "ic", "sc") if getattr(args, s)}
    start = time.perf_counter()
    setup = pipeline.prepare(args.scene, config, args.res, args.corners, args.generic, args.slots,
                             args.kernels, overrides)
    engine = setup.engine(engine_name)
    progress = _progress_printer() if sys.stderr.isatty() and not args.quiet else None
    interrupted = False
    try:
        run_result = engine.run(progress=progress)
    except KeyboardInterrupt:  # keep what was computed: write the partial image and statistics
        interrupted = True
        print(f"\nnetsushisen render: interrupted at cycle {engine.cycle:,}; writing what was computed",
              file=sys.stderr)
        run_result = RunResult(engine.status or "interrupted", engine.cycle, None)
    result = pipeline.finish(setup, engine, run_result)
    seconds = time.perf_counter() - start
    output = args.output or f"{setup.scene.name}.png"
    write_png(output, result.image_u8)
    if args.ids:
        np.save(args.ids, result.hit_ids)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            f.write(run_stats.dumps(result.stats))
    if not args.quiet:
        print_render_summary(result.stats, seconds, output)
    if run_result.error is not None:
        print(run_result.error.format(), file=sys.stderr)
    return 130 if interrupted else result.exit_code


def _progress_printer():
    last = [0.0]

    def show(cycle: int) -> None:
        now = time.perf_counter()
        if now - last[0] > 0.5:
            print(f"\r  cycle {cycle:,}", end="", file=sys.stderr, flush=True)
            last[0] = now
    return show
