"""Assemble a stage kernel: `netsushisen asm SOURCE.s --proc os|ic|sc [-D NAME[=VALUE]]... [-I DIR]...
[-o OUT] [--listing PATH|-] [--stats] [--bounds] [--config FILE] [--set PATH=VALUE]...`, or the kernels
`render` runs for a scene:
`netsushisen asm --scene SCENE [--generic] [--proc os|ic|sc] [--stats] [--listing -] [--show-defines]`.

Writes the object file (default: SOURCE's stem + .o in the current directory; with --stats,
--listing, --bounds or --show-defines and no -o, nothing is written). With --scene the bundled kernels (or
--kernels DIR's, or SOURCE) are assembled with exactly the symbols `render` gives them for that
scene (`render.kernel_inputs`: the databases' layout, the pre-pass's resident records at --res,
HAS_* needs, SLOTS, MAX_DEPTH), so --stats prints the static ILP `render`'s statistics report;
--precision, --depth, --set and --config matter where they change those symbols; -D adds or
overrides one. `.sched` regions are scheduled for the machine --config and --set describe
(docs/scheduling.md); every `.pipeline` loop's software pipelining information goes into the
listing and --stats, and a loop that could not be pipelined is one warning line on stderr.
--bounds prints every loop's and block's static bounds for that machine (asm/bounds.py; the
tables of `report bounds` without the run; --optimum-ops N, --format). Any
error in the source: every error is printed as `file:line:col: error: message` with the line
and a caret, and the exit code is 1.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import sys

from netsushisen.asm.assembler import Assembler
from netsushisen.asm.listing import format_static_ilp, listing, static_ilp
from netsushisen.asm.objects import Program
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import STAGES
from netsushisen.commands.report import add_optimum_option
from netsushisen.reports.tables import FORMATS
from netsushisen.options import (add_config_options, add_defines, add_include_dirs, add_json,
                                 add_no_schedule,
                                 add_output, add_resolution, write_output, write_text, check_resolution,
                                 config_from_args, parse_defines)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", nargs="?",
                        help="assembly source file (.s); optional with --scene (the bundled kernels)")
    parser.add_argument("--proc", choices=list(STAGES),
                        help="target processor (may be omitted when the source says .proc; with "
                             "--scene and no SOURCE: only this stage's kernel, else all three)")
    add_defines(parser)
    add_include_dirs(parser)
    add_output(parser, "object file to write (default: STEM.o)")
    parser.add_argument("--listing", metavar="PATH|-", help="write a listing (- for stdout)")
    parser.add_argument("--stats", action="store_true", help="print static ILP statistics")
    add_json(parser, "with --stats: print them as JSON (to FILE if given)")
    parser.add_argument("--bounds", action="store_true", help="print every loop's and block's "
                        "static bounds (units, ports, recurrence, critical path, CP-SAT's "
                        "optimum of small blocks: docs/scheduling.md, \"Bounds\")")
    parser.add_argument("--format", choices=FORMATS, default="table",
                        help="with --bounds: table (default), json, csv or md")
    add_optimum_option(parser)
    add_no_schedule(parser)
    scene = parser.add_argument_group("kernels for a scene (the symbols `render` uses)")
    scene.add_argument("--scene", metavar="SCENE",
                       help="built-in scene name (tetra, balls, ...) or .nff file")
    scene.add_argument("--generic", action="store_true",
                       help="every feature (HAS_* = 1), as `render --generic`")
    scene.add_argument("--kernels", metavar="DIR",
                       help="assemble DIR's os.s, ic.s, sc.s instead of the bundled kernels")
    scene.add_argument("--show-defines", action="store_true",
                       help="print the symbols, one NAME=VALUE a line (-D syntax)")
    scene.add_argument("--slots", type=int, default=None, metavar="N",
                       help="rays OS keeps in flight, as `render --slots`")
    scene.add_argument("--corners", action="store_true", help="as `render --corners`")
    add_resolution(scene, 32, "the render's N×N size: its pre-pass picks the resident records "
                              "(default 32, as `render`)")
    add_config_options(scene, pes=True, precision=True, depth=True)
    for action in scene._group_actions:
        if action.dest in ("config", "sets"):
            action.help += "; also the machine .sched regions are scheduled for"


def scene_defines(args: argparse.Namespace) -> dict[str, int | float]:
    """The symbols `render` gives the kernels for `args.scene`, -D on top."""
    from netsushisen import pipeline

    check_resolution(args.res)
    slots = pipeline.DEFAULT_SLOTS if args.slots is None else args.slots
    return pipeline.kernel_inputs(args.scene, config_from_args(args), args.res, args.corners,
                                  args.generic, slots, parse_defines(args.defines)).defines


def format_defines(defines: dict[str, int | float]) -> str:
    """One `NAME=VALUE` a line, sorted: what `-D` takes back."""
    return "".join(f"{k}={v!r}\n" for k, v in sorted(defines.items()))


def _sources(args: argparse.Namespace) -> list[tuple[str | None, Path]]:
    """(processor, source) pairs to assemble."""
    from netsushisen.kernels import kernel_folder, kernel_source

    if args.source:
        if args.kernels:
            raise NetsushisenError("give SOURCE or --kernels DIR, not both")
        return [(args.proc, Path(args.source))]
    if not args.scene:
        raise NetsushisenError("asm: give a SOURCE.s, or --scene SCENE for the bundled kernels")
    folder = kernel_folder(args.kernels)
    if args.kernels and not folder.is_dir():
        raise NetsushisenError(f"--kernels {args.kernels}: no such folder")
    return [(stage, kernel_source(folder, stage)) for stage in ([args.proc] if args.proc else STAGES)]


def run(args: argparse.Namespace) -> int:
    if not args.scene:
        for flag in ("generic", "kernels", "show_defines", "corners", "slots",
                     "pes", "precision", "depth"):
            if getattr(args, flag) not in (None, False, []):
                option = "--set" if flag == "sets" else f"--{flag.replace('_', '-')}"
                raise NetsushisenError(f"{option} needs --scene SCENE (it changes the symbols "
                                       "a scene's kernels are assembled with)")
    sources = _sources(args)
    defines = scene_defines(args) if args.scene else parse_defines(args.defines)
    if args.show_defines:
        print(format_defines(defines), end="")
    from netsushisen.kernels import KERNELS

    includes = list(args.include_dirs) + ([KERNELS] if args.scene else [])
    config = config_from_args(args)
    programs: list[tuple[Path, Program]] = []
    infos: dict[str, str] = {}
    pipelines: dict[str, list] = {}
    reports: dict[str, list] = {}
    region_lines: dict[str, set] = {}
    for proc, path in sources:
        asm = Assembler(proc, defines, includes, config, schedule=not args.no_schedule)
        programs.append((path, asm.assemble_file(path)))
        infos[str(path)] = "".join(r.format() + "\n" for r in asm.pipeline_reports)
        pipelines[str(path)] = list(asm.pipeline_reports)
        region_lines[str(path)] = asm.region_lines
        reports[str(path)] = [r.as_dict() for r in asm.pipeline_reports]
        for w in asm.warnings:
            print(w.format(), file=sys.stderr)
        for r in asm.pipeline_reports:
            if r.reason:
                print(f"{r.where}: warning: loop '{r.name}' not pipelined: {r.reason}",
                      file=sys.stderr)
    analysis_only = (args.stats or args.listing or args.show_defines or args.bounds) and not args.out
    if not analysis_only:
        if args.out and len(programs) > 1:
            raise NetsushisenError("-o names one object file: add --proc os|ic|sc, or leave -o "
                                   "out to write os.o, ic.o and sc.o")
        for path, program in programs:
            out = Path(args.out or (path.stem + ".o"))
            try:
                program.save(out)
            except OSError as err:
                raise NetsushisenError(f"{out}: cannot write object file: {err.strerror}") from None
    if args.listing:
        text = "".join(listing(program, region_lines[str(path)], pipelines[str(path)])
                       for path, program in programs)
        if args.listing == "-":
            print(text, end="")
        else:
            write_output(args.listing, lambda p: p.write_text(text, encoding="utf-8"))
    if args.stats:
        stats = {program.proc: static_ilp(program) for _, program in programs}
        if args.json:
            body = {program.proc: stats[program.proc].as_dict() |
                    ({"pipelines": reports[str(path)]} if reports[str(path)] else {})
                    for path, program in programs}
            write_text(args.json, json.dumps(body[programs[0][1].proc] if args.source else body,
                                             indent=2, sort_keys=True) + "\n")
        else:
            print("\n".join(format_static_ilp(stats[program.proc], str(path)) +
                            ("\n" + infos[str(path)].rstrip() if infos[str(path)] else "")
                            for path, program in programs))
    if args.bounds:
        print_bounds(args, programs, config)
    return 0


def print_bounds(args: argparse.Namespace, programs: list[tuple[Path, Program]],
                 config: MachineConfig) -> None:
    """`--bounds`: the static bounds of every loop and block (reports/bounds.py's tables)."""
    from netsushisen.asm.bounds import program_bounds
    from netsushisen.reports.bounds import bounds_sections
    from netsushisen.reports.tables import render

    if args.optimum_ops < 0:
        raise NetsushisenError("--optimum-ops must not be negative")
    if args.format == "csv":
        raise NetsushisenError("--bounds --format csv: CSV holds one table; use json or md, or "
                               "`report bounds --table loops|blocks`")
    rows = [(program.proc, program_bounds(program, config, args.optimum_ops), None)
            for _, program in programs]
    print(render(bounds_sections(rows), args.format, "bounds",
                 " ".join(str(path) for path, _ in programs)), end="")
