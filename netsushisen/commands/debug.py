"""Step through the machine in the terminal, cycle by cycle (docs/debugger.md).

    netsushisen debug --program os.s --program ic.o [--image img.json] [--config cfg.toml]
                      [--set KEY=VALUE ...] [--pes N] [--pe K] [--proc os|ic|sc]
    netsushisen debug --ic ic.s --batch commands.txt        (or --batch - : commands on stdin)
    netsushisen debug SCENE [--res N] [--corners] [--generic] [--kernels DIR] [--pes N] ...
                                                            (scene mode: as `netsushisen render`)
    netsushisen debug ... --fast-forward CYCLE|LOCATION     (the compiled engine runs there first)

`--program` takes object files or `.s` sources that name their processor (`.proc`); `--os`,
`--ic`, `--sc` and the image/config options are those of `netsushisen run`. Scene mode prepares
the scene as `netsushisen render` does (grid, pre-pass, databases, kernels, eye rays); there
`--os/--ic/--sc FILE` are your own kernel sources.

`--fast-forward 250000` or `--fast-forward LOCATION` (`loop`, `loop+3`, `*12`, `ic:loop`,
`pe1.sc:color`; unqualified: the processor of --pe/--proc) builds the machine through the compiled
engine and runs it to that cycle, or until the processor arrives at the location (its PC, the
next bundle, is there; the PC at cycle 0 does not count); the session then steps the reference
engine from that state, and its reverse-execution history starts there. An unknown location is
a one-line error (exit 1); a run that ends first starts the session at its end, with a note.

Interactive: a screen of panels after every stop, a `(nss)` prompt with history and tab
completion; Enter repeats the last command; `help` lists the commands. `--batch` runs commands
without a terminal and prints the same panels as plain text; exit 1 if a command failed. The
debugger itself (session, commands, screen, front ends) is the `netsushisen.debugger` package.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.processors import STAGES
from netsushisen.options import (add_program_options, add_resolution, check_resolution,
                                 config_from_args, machine_inputs)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("scene", nargs="?", metavar="SCENE",
                        help="debug a scene's render (needs the render pipeline)")
    parser.add_argument("--program", action="append", default=[], metavar="FILE",
                        help="a program (object file or .s with .proc); repeat for each processor")
    add_program_options(parser)
    add_resolution(parser, None, "scene mode: N x N image (default: render's)")
    parser.add_argument("--corners", action="store_true", help="scene mode: SPD corner rays")
    parser.add_argument("--generic", action="store_true",
                        help="scene mode: assemble every kernel feature, not only the scene's")
    parser.add_argument("--slots", type=int, metavar="N", help="scene mode: rays OS keeps in flight")
    parser.add_argument("--kernels", metavar="DIR",
                        help="scene mode: your own os.s, ic.s, sc.s (--os/--ic/--sc FILE: one)")
    parser.add_argument("--pe", type=int, default=0, metavar="K", help="PE to view first (0)")
    parser.add_argument("--proc", choices=STAGES, help="processor to view first "
                        "(default: the first with a program)")
    parser.add_argument("--batch", metavar="FILE", help="run the commands in FILE ('-': stdin) "
                        "without a terminal, printing the panels as text")
    parser.add_argument("-x", "--commands", metavar="FILE",
                        help="run the commands in FILE first, then go on interactively")
    parser.add_argument("--fast-forward", metavar="CYCLE|LOCATION",
                        help="run with the compiled engine to cycle CYCLE, or until a processor "
                             "arrives at LOCATION (loop, *12, ic:loop, pe1.sc:color; unqualified: "
                             "--pe/--proc's), then debug from there")
    parser.add_argument("--checkpoint-interval", type=int, default=2048, metavar="K",
                        help="cycles between checkpoints for reverse execution (2048)")
    parser.add_argument("--max-checkpoints", type=int, default=256, metavar="N",
                        help="checkpoints kept before the interval doubles (256)")
    parser.add_argument("--width", type=int, metavar="COLUMNS",
                        help="screen width (default: the terminal's; 120 when not a terminal)")
    parser.add_argument("--no-screen", action="store_true",
                        help="do not draw the panels after every stop (the `screen` command does)")


# ---------------------------------------------------------------------------------------------
# Machine factories


def programs_factory(args: argparse.Namespace):
    from netsushisen.debugger.session import ProgramsFactory

    if not (args.program or args.os or args.ic or args.sc):
        raise NetsushisenError("nothing to debug: give programs (--program FILE, --os/--ic/--sc) "
                               "or a SCENE")
    try:
        config, programs, image = machine_inputs(args, args.program)
    except NetsushisenError as err:
        raise _program_advice(err) from None
    names = ", ".join(f"{s} {p.source_map[0].file if p.source_map else '?'}"
                      for s, p in programs.items() if p is not None)
    return ProgramsFactory(config, programs, image, description=names)


_WHICH = "which processor? give --proc os|ic|sc"


def _program_advice(err: NetsushisenError) -> NetsushisenError:
    """The assembler asks a source without `.proc` for `--proc`, which is `asm`'s option; in
    `debug`, `--proc` only picks the view, and a `--program` file's processor comes from the
    file. Say what works here: a `.proc` line, or the file given as --os/--ic/--sc."""
    if not any(d.message.startswith(_WHICH) for d in err.diagnostics):
        return err
    fixed = [replace(d, message="which processor? a --program source names its own: write "
                     "`.proc os|ic|sc` before the first instruction, or give the file as "
                     "--os/--ic/--sc FILE (--proc only chooses the processor viewed)")
             if d.message.startswith(_WHICH) else d for d in err.diagnostics]
    return type(err)(fixed)


def scene_factory(args: argparse.Namespace):
    """Scene mode: `netsushisen.pipeline` prepares the scene as `netsushisen render` does."""
    if args.program or args.image:
        raise NetsushisenError("scene mode builds its own programs and memory image: --program "
                               "and --image are for raw programs (use --os/--ic/--sc FILE or "
                               "--kernels DIR for your own kernels)")
    from netsushisen import pipeline
    from netsushisen.debugger.session import SceneFactory

    check_resolution(args.res)
    config = config_from_args(args)
    kernels = {s: getattr(args, s) for s in STAGES if getattr(args, s)}
    options = {"corners": args.corners, "generic": args.generic, "kernel_dir": args.kernels,
               "kernels": kernels}
    if args.res is not None:
        options["res"] = args.res
    if args.slots is not None:
        options["slots"] = args.slots
    return SceneFactory(pipeline.prepare(args.scene, config, **options))


def run(args: argparse.Namespace) -> int:
    from netsushisen.debugger.expressions import DebugError
    from netsushisen.debugger.frontend import FrontEnd, make_console
    from netsushisen.debugger.session import Session

    if not args.scene and (args.res is not None or args.corners or args.generic or args.kernels
                           or args.slots is not None):
        raise NetsushisenError("--res, --corners, --generic, --slots and --kernels are for scene "
                               "mode (debug SCENE ...)")
    if args.scene and args.no_schedule:
        raise NetsushisenError("--no-schedule is for programs given as files (--os/--ic/--sc, "
                               "--program): scene mode schedules the kernels as `render` does")
    factory = scene_factory(args) if args.scene else programs_factory(args)
    if args.fast_forward is not None and sys.stderr.isatty():
        print(f"fast-forwarding to {args.fast_forward} with the compiled engine (its first use "
              "compiles it: about a minute) ...", file=sys.stderr, flush=True)
    try:
        session = Session(factory, pe=args.pe, stage=args.proc,
                          checkpoint_interval=args.checkpoint_interval,
                          max_checkpoints=args.max_checkpoints, fast_forward=args.fast_forward)
    except DebugError as err:
        raise NetsushisenError(str(err)) from None
    batch = args.batch
    if batch is None and not sys.stdin.isatty():
        batch = "-"  # commands piped in: run them as a batch
    console = make_console(args.width)
    front = FrontEnd(session, console, interactive=batch is None, auto_screen=not args.no_screen)
    if batch is not None:
        if batch == "-":
            lines = sys.stdin.read().splitlines()
        else:
            try:
                with open(batch, encoding="utf-8") as fh:
                    lines = fh.read().splitlines()
            except OSError as err:
                raise NetsushisenError(f"{batch}: {err.strerror}") from None
        front.banner()
        if args.commands:
            front.execute(f"source {args.commands}")
        front.run_lines(lines)
        return 1 if front.failed else 0
    if args.commands:
        front.execute(f"source {args.commands}")
    front.interactive_loop()
    return 0
