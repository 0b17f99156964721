"""Run assembled programs on the emulated machine (the reference engine).

    netsushisen run --os os.o --ic ic.s --sc sc.o --image image.json [--config cfg.toml]
                    [--set ring.fifo_depth=8 ...] [--pes N] [--json stats.json]
                    [--frame frame.npy] [--trace [--trace-filter pe0.ic] [--cycles A:B]]

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

from netsushisen.errors import Diagnostic, NetsushisenError
from netsushisen.isa.config import load_config
from netsushisen.isa.processors import STAGES


def add_machine_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that say what machine to build: programs, memory image, configuration.
    Shared by `run` and `debug` (see `machine_inputs`)."""
    for stage in STAGES:
        parser.add_argument(f"--{stage}", metavar="PROGRAM",
                            help=f"{stage.upper()} program: object file or .s source")
    parser.add_argument("--image", metavar="FILE", help="memory image (.json or .npz)")
    parser.add_argument("--config", metavar="FILE", help="machine configuration (TOML)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override one configuration field, e.g. --set ic_memory.t_g=16")
    parser.add_argument("--pes", type=int, metavar="N", help="number of PEs (same as --set pes=N)")
    parser.add_argument("--max-cycles", type=int, metavar="N",
                        help="stop after N cycles (same as --set max_cycles=N)")
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                        help="define a symbol when assembling .s sources")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    add_machine_arguments(parser)
    parser.add_argument("--json", metavar="FILE", help="write the statistics as JSON")
    parser.add_argument("--frame", metavar="FILE", help="write the frame buffer (.npy, H x W x 3)")
    parser.add_argument("--trace", action="store_true", help="print a line trace, one line per "
                        "cycle per processor")
    parser.add_argument("--trace-filter", metavar="PROCS",
                        help="trace only these processors (name prefixes, comma separated: pe0.ic,pe1)")
    parser.add_argument("--cycles", metavar="A:B", help="trace only cycles A (included) to B (excluded)")
    parser.add_argument("--trace-out", metavar="FILE", help="write the trace to FILE, not stdout")
    parser.add_argument("-q", "--quiet", action="store_true", help="no summary")


def _defines(items: list[str]) -> dict[str, int | float]:
    out: dict[str, int | float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not name.isidentifier():
            raise NetsushisenError(f"-D {item!r}: expected NAME or NAME=VALUE")
        if not sep:
            out[name] = 1
            continue
        try:
            out[name] = int(value, 0)
        except ValueError:
            try:
                out[name] = float(value)
            except ValueError:
                raise NetsushisenError(f"-D {item!r}: the value must be a number") from None
    return out


def load_program(path: str, stage: str | None, defines: dict[str, int | float]):
    """An object file or `.s` source for `stage`; with `stage` None the program says which
    processor it is for (the object's `proc`, the source's `.proc`)."""
    from netsushisen.asm.assembler import assemble_file
    from netsushisen.asm.objects import Program

    p = Path(path)
    if p.suffix == ".s":
        if not p.is_file():
            raise NetsushisenError(Diagnostic("no such source file", file=path))
        prog = assemble_file(p, proc=stage, defines=defines)
    else:
        prog = Program.load(p)
    if stage is not None and prog.proc != stage:
        raise NetsushisenError(Diagnostic(
            f"this is a {prog.proc.upper()} program, given as --{stage}", file=path))
    return prog


def config_from_args(args: argparse.Namespace):
    """The machine configuration from --config, --set, --pes and --max-cycles."""
    overrides = list(args.overrides)
    if args.pes is not None:
        overrides.append(f"pes={args.pes}")
    if args.max_cycles is not None:
        overrides.append(f"max_cycles={args.max_cycles}")
    return load_config(args.config, overrides)


def machine_inputs(args: argparse.Namespace, extra_programs: list[str] = ()):
    """(config, programs by stage, memory image or None) from the `add_machine_arguments`
    options; `extra_programs` are files whose processor the program itself names."""
    from netsushisen.isa.images import load_image

    config = config_from_args(args)
    defines = _defines(args.defines)
    programs = {s: load_program(getattr(args, s), s, defines) if getattr(args, s) else None
                for s in STAGES}
    for path in extra_programs:
        prog = load_program(path, None, defines)
        if programs[prog.proc] is not None:
            raise NetsushisenError(Diagnostic(
                f"a second {prog.proc.upper()} program (one program per processor)", file=path))
        programs[prog.proc] = prog
    if not any(programs.values()):
        raise NetsushisenError("nothing to run: give at least one of --os, --ic, --sc")
    image = load_image(args.image) if args.image else None
    return config, programs, image


def run(args: argparse.Namespace) -> int:
    from netsushisen.emulator import stats
    from netsushisen.emulator.machine import Machine
    from netsushisen.emulator.trace import Tracer, parse_cycles

    config, programs, image = machine_inputs(args)
    try:
        parse_cycles(args.cycles)
    except ValueError:
        raise NetsushisenError(f"--cycles {args.cycles!r}: expected A:B, A: or :B") from None
    machine = Machine(config, programs, image)
    trace_file = None
    if args.trace or args.trace_filter or args.cycles:
        out = sys.stdout
        if args.trace_out:
            trace_file = out = open(args.trace_out, "w", encoding="utf-8")
        machine.tracer = Tracer(out, args.trace_filter, args.cycles)
    try:
        result = machine.run()
    finally:
        if trace_file is not None:
            trace_file.close()
    if args.json:
        stats.write(machine, args.json)
    if args.frame:
        np.save(args.frame, machine.col.frame)
    if not args.quiet:
        print(machine.summary())
    if result.error is not None:
        print(result.error.format(), file=sys.stderr)
    return result.exit_code
