"""Run assembled programs on the emulated machine, through the engine interface.

    netsushisen run --os os.o --ic ic.s --sc sc.o --image image.json [--config cfg.toml]
                    [--set ring.fifo_depth=8 ...] [--pes N] [-D NAME=EXPR ...] [--engine NAME]
                    [--json stats.json] [--frame frame.npy]
                    [--trace [--trace-filter pe0.ic] [--cycles A:B]]

Each program is optional (a processor without one is absent: it never issues); `.s` sources are
assembled on the fly, anything else is read as an object file. The same programs run on every PE.
Exit status: 0 the run ended (all halted or quiescent), 1 bad input, 2 run-time fault,
3 deadlock, 4 cycle limit. Statistics (--json) and the frame buffer (--frame) are written
whatever the outcome.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from netsushisen.errors import NetsushisenError
from netsushisen.options import add_engine, add_program_options, engine_from_args, machine_inputs


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    add_program_options(parser)
    add_engine(parser)
    parser.add_argument("--json", metavar="FILE", help="write the statistics as JSON")
    parser.add_argument("--frame", metavar="FILE", help="write the frame buffer (.npy, H x W x 3)")
    parser.add_argument("--trace", action="store_true", help="print a line trace, one line per "
                        "cycle per processor")
    parser.add_argument("--trace-filter", metavar="PROCS",
                        help="trace only these processors (name prefixes, comma separated: pe0.ic,pe1)")
    parser.add_argument("--cycles", metavar="A:B", help="trace only cycles A (included) to B (excluded)")
    parser.add_argument("--trace-out", metavar="FILE", help="write the trace to FILE, not stdout")
    parser.add_argument("-q", "--quiet", action="store_true", help="no summary")


def run(args: argparse.Namespace) -> int:
    from netsushisen.emulator import stats
    from netsushisen.emulator.engine import make_engine
    from netsushisen.emulator.trace import Tracer, parse_cycles

    engine_name = engine_from_args(args)
    config, programs, image = machine_inputs(args)
    try:
        parse_cycles(args.cycles)
    except ValueError:
        raise NetsushisenError(f"--cycles {args.cycles!r}: expected A:B, A: or :B") from None
    tracing = bool(args.trace or args.trace_filter or args.cycles)
    if tracing and engine_name != "reference":
        raise NetsushisenError("--trace follows the reference engine cycle by cycle: "
                               "use --engine reference")
    engine = make_engine(engine_name, config, programs, image)
    trace_file = None
    if tracing:
        out = sys.stdout
        if args.trace_out:
            trace_file = out = open(args.trace_out, "w", encoding="utf-8")
        engine.machine.tracer = Tracer(out, args.trace_filter, args.cycles)
    try:
        result = engine.run()
    finally:
        if trace_file is not None:
            trace_file.close()
    if args.json:
        Path(args.json).write_text(stats.dumps(engine.statistics()), encoding="utf-8")
    if args.frame:
        np.save(args.frame, engine.frame)
    if not args.quiet:
        print(engine.summary())
    if result.error is not None:
        print(result.error.format(), file=sys.stderr)
    return result.exit_code
