"""Run assembled programs on the emulated machine, through the engine interface.

    netsushisen run --os os.o --ic ic.s --sc sc.o --image image.json [--config cfg.toml]
                    [--set ring.fifo_depth=8 ...] [--pes N] [-D NAME=EXPR ...] [--engine NAME]
                    [--json stats.json] [--frame frame.npy] [--no-schedule]
                    [--regs] [--mem PROC.MEMORY:ADDR[:N[F]] ...]
                    [--trace [--trace-filter pe0.ic] [--cycles A:B]]
                    [--timeline FILE.kanata|FILE.json [--cycles A:B] [--procs pe0.ic,...]]

Each program is optional (a processor without one is absent: it never issues); `.s` sources are
assembled on the fly, anything else is read as an object file. The same programs run on every PE.
A run that ends `finished` with a processor that never halted, waiting forever on an empty
receive FIFO, warns (processor, PC, FIFO) on standard error; the exit status stays 0.
Exit status: 0 the run ended (all halted or quiescent), 1 bad input, 2 run-time fault,
3 deadlock, 4 cycle limit, 5 the tandem engine's two engines differ, 130 interrupted (Ctrl-C).
Statistics (--json) and the frame buffer (--frame) are written whatever the outcome (after
Ctrl-C, what was done so far, run.status "interrupted"). The engine is the compiled one unless
--engine says otherwise; --trace takes the reference engine (the default with --trace). On a
terminal a progress bar shows the host messages handed out, cycles, rate and ETA. --timeline
writes a pipeline timeline of the --cycles window instead of a text trace (docs/timeline.md).
--regs and --mem print the program's result after the summary (emulator/final.py): the registers
each processor ends with, words of a memory; --json's `final` section holds the registers and
the --mem ranges. --no-schedule assembles `.sched` regions serially, as `asm --no-schedule`.
"""

from __future__ import annotations

import argparse
import sys


from netsushisen.isa.outputs import replacing
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.limits import check_words
from netsushisen.options import (add_engine, add_json, add_program_options, add_quiet, add_timeline,
                                 check_footprint,
                                 check_output_folders, engine_from_args, machine_inputs,
                                 npy_writer, timeline_from_args, write_outputs)
from netsushisen.progress import INTERRUPTED, RunMonitor


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    add_program_options(parser)
    add_engine(parser)
    add_json(parser, "write the statistics as JSON to FILE (- : standard output, no summary)")
    parser.add_argument("--frame", metavar="FILE", help="write the frame buffer (.npy, H x W x 3)")
    parser.add_argument("--trace", action="store_true", help="print a line trace, one line per "
                        "cycle per processor")
    parser.add_argument("--trace-filter", metavar="PROCS",
                        help="trace only these processors (name prefixes, comma separated: pe0.ic,pe1)")
    parser.add_argument("--cycles", metavar="A:B", help="trace (or --timeline) only cycles A "
                        "(included) to B (excluded)")
    parser.add_argument("--trace-out", metavar="FILE", help="write the trace to FILE, not stdout")
    parser.add_argument("--regs", action="store_true", help="print each processor's registers "
                        "at the end that are non-zero or named by .reg (name/rN, int, hex, float)")
    parser.add_argument("--mem", action="append", default=[], metavar="PROC.MEMORY:ADDR[:N[F]]",
                        help="print N words (default 1) of a memory at the end, e.g. "
                             "ic.local:0:4, pe1.ic.resident:16:8f (F: x d u f, or a: all views, "
                             "the default; repeatable)")
    add_quiet(parser)
    add_timeline(parser, cycles=False)


def run(args: argparse.Namespace) -> int:
    from netsushisen.emulator import stats
    from netsushisen.emulator.engine import make_engine
    from netsushisen.emulator.final import final_state, parse_memory_request, read_memory
    from netsushisen.emulator.trace import Tracer, parse_cycles
    from netsushisen.timeline import TimelineRun

    request = timeline_from_args(args, owns_cycles=False)  # --cycles alone: the text trace's
    if request is not None and (args.trace or args.trace_filter or args.trace_out):
        raise NetsushisenError("--timeline and --trace: choose one (--cycles sets the window of "
                               "either)")
    tracing = bool(args.trace or args.trace_filter or (args.cycles and request is None))
    engine_name = engine_from_args(args, default="reference" if tracing else None)
    if tracing and engine_name != "reference":
        raise NetsushisenError(f"--trace needs --engine reference (the trace follows the reference "
                               f"engine cycle by cycle), not --engine {engine_name}")
    requests = [parse_memory_request(text) for text in args.mem]
    config, programs, image = machine_inputs(args)
    check_output_folders(args.json, args.frame, args.trace_out)
    args.quiet = args.quiet or args.json == "-"
    try:
        parse_cycles(args.cycles)
    except ValueError:
        raise NetsushisenError(f"--cycles {args.cycles!r}: expected A:B, A: or :B") from None
    width, height = (image.frame or (0, 0)) if image is not None else (0, 0)
    global_words = 0
    for name, words in (image.sizes if image is not None else {}).items():
        check_words(words, f"{args.image}: sizes.{name}")
        global_words += words
    check_footprint("run", config, width, engine_name, height=height, quiet=args.quiet,
                    option=f"{args.image}: frame", extra_bytes=16 * global_words)
    engine = make_engine(engine_name, config, programs, image)
    for req in requests:  # a bad address or label is refused before the run, not after it
        read_memory(engine, programs, req)
    trace_file = None
    if tracing:
        out = sys.stdout
        if args.trace_out:
            trace_file = out = replacing(args.trace_out, "w", encoding="utf-8")
        engine.machine.tracer = Tracer(out, args.trace_filter, args.cycles)
    timeline = TimelineRun(request, engine) if request is not None else None
    # no progress bar beside a trace (it would tear the trace's lines on the terminal)
    monitor = RunMonitor(engine, total=engine.host_messages, unit="host messages",
                         show=not (args.quiet or tracing))
    try:
        with monitor:  # Ctrl-C stops the run between cycles / chunks: the outputs are written
            result = timeline.run(monitor) if timeline is not None else monitor.run()
    finally:
        if trace_file is not None:
            trace_file.close()
    final = final_state(engine, programs, requests)
    statistics = engine.statistics() if args.json else None
    if statistics is not None:
        statistics["final"] = final.json()
    write_outputs([(args.json, stats.dumps(statistics) if args.json else None),
                   (args.frame, npy_writer(engine.frame) if args.frame else None)])
    written = [p for p in (args.json, args.frame) if p]
    if not args.quiet:
        head, _, rest = engine.summary().partition("\n")
        print(f"{head}, {engine.name} engine" + (f"\n{rest}" if rest else ""))
    if args.json != "-":  # on standard output the JSON's `final` holds them
        for asked, text in ((args.regs, final.registers_text()), (requests, final.memory_text())):
            if asked and text:
                print(text)
    if timeline is not None:
        print(timeline.note(), file=sys.stderr)
    if monitor.interrupted:
        print(f"netsushisen run: interrupted at cycle {engine.cycle:,}"
              + (f"; wrote {', '.join(written)}" if written else ""), file=sys.stderr)
        return INTERRUPTED
    if result.error is not None:
        print(result.error.format(), file=sys.stderr)
    for processor, where, port in engine.blocked():
        fifo = ("in `wait`, with every receive FIFO empty" if port == "any"
                else f"on its empty receive FIFO '{port}'")
        print(f"netsushisen run: warning: {processor} never halted: it waits forever at {where} "
              f"{fifo}; nothing is left to send it (the run ended `finished`)", file=sys.stderr)
    return result.exit_code
