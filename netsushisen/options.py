"""The options the commands share, each defined and parsed in one place.

Every command in `netsushisen/commands/` takes its shared options from here, so an option means
the same and is checked the same way wherever it appears:

    add_defines(parser)         -D NAME[=EXPR]: a symbol for the assembler (`args.defines`);
                                `parse_defines(args.defines)` evaluates each EXPR exactly as the
                                assembler's `.equ` does (`-D 'X=1<<4'`, `-D N=0x10`, `-D F=1.5`)
    add_include_dirs(parser)    -I DIR (`args.include_dirs`)
    add_config_options(parser, pes=, precision=, max_cycles=, depth=)
                                --config FILE and --set PATH=VALUE (`args.sets`, repeatable),
                                and those of --pes N, --precision fp32|fp64, --max-cycles N,
                                --depth D the command asks for; `config_from_args(args)` builds
                                the validated machine configuration from them (file, then each
                                --set, then the shorthands, which are --set in disguise)
    add_resolution(parser, default)
                                --res N (`args.res`); `check_resolution(args.res)` rejects
                                N outside 1..MAX_RES with one line before anything is allocated
    check_footprint(what, config, width, engine, golden=, quiet=)
                                the run's frame against the machine's pixel index and its
                                estimated memory against this host's (isa/limits.py):
                                one line if it cannot fit, its size printed if it is large
    check_output_folders(*paths), write_output(path, write), fresh_output(stem)
                                outputs: folders checked before the run, OSErrors as located
                                lines, and `SCENE.png` or the first free `SCENE-N.png`
    add_engine(parser)          --engine NAME (`args.engine`, None when not given);
                                `engine_from_args(args)` checks the name, or picks the engine
                                interface's default (compiled where it imports, else reference)
    add_program_options(parser) --os/--ic/--sc PROGRAM, --image FILE (with -D, --no-schedule
                                and the config options: what `run` and `debug` build a
                                machine from);
                                `machine_inputs(args)` -> (config, programs, image)
    add_timeline(parser)        --timeline FILE, --cycles A:B, --procs PROCS (`render`, `run`);
                                `timeline_from_args(args)` checks them before any work

    Parser, parse(parser, argv)
                                the argument parser of every command: a usage error is one
                                line `netsushisen CMD: error: ...` (`UsageError`, exit 1), an
                                unknown option names the command and the closest option
    add_output(parser, help, metavar=, default=, aliases=)
                                -o/--out PATH (`args.out`): every command's output file or
                                folder has this one name; `aliases` are old spellings kept hidden
    add_quiet(parser, help=)    -q/--quiet (`args.quiet`)
    add_json(parser, help), write_text(path, text)
                                --json [FILE] (`args.json`): JSON to FILE, or to standard
                                output with `-` or no FILE

One name, one meaning: an option several commands take (`-o/--out`, `-q/--quiet`, `--depth`,
`--max-cycles`, `--res`, `--engine`, `--config`, `--set`, ...) is added by the one helper here,
so it has the same spelling, destination and type everywhere (tests/test_cli.py walks every
command's parser and checks it).

Bad values are `NetsushisenError`s: the command line prints one line and exits 1.
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.config import MachineConfig, load_config
from netsushisen.isa.processors import STAGES
from netsushisen.isa.limits import (MAX_SIDE, Footprint, check_frame, check_host,
                                    machine_bytes, render_footprint)

if TYPE_CHECKING:
    from netsushisen.timeline import TimelineRequest

MAX_RES = MAX_SIDE - 1
"""The largest --res the machine can number: 46,339, so that even the SPD corners' (N+1)² eye
rays fit the frame's 32-bit pixel index (isa/limits.py). Whether this host can hold
the run is `check_footprint`'s question, asked before anything is allocated."""


# ---------------------------------------------------------------------------------------------
# The parser: one line per usage error, exit 1


class UsageError(NetsushisenError):
    """A command line argparse or the option check refuses: `PROG: error: MESSAGE`, one line
    (argparse's own is the usage and exit 2)."""

    def __init__(self, prog: str, message: str):
        self.prog = prog
        super().__init__(message)

    def format(self) -> str:
        return f"{self.prog}: error: {self.diagnostics[0].message}"


class Parser(argparse.ArgumentParser):
    """argparse with the project's convention: an error is a `UsageError` (one line, exit 1),
    not the usage and exit 2; `--help` still prints the usage. Subcommands' parsers are of this
    class too (argparse makes them of their parent's class)."""

    def error(self, message: str):
        raise UsageError(self.prog, _choice_message(message))


def _choice_message(message: str) -> str:
    """argparse's `invalid choice: 'x' (choose from 'a', 'b')` with the nearest choice named:
    `invalid choice: 'stall' (did you mean 'stalls'?) (choose from ilp, stalls, ...)`; any
    other message as it is."""
    m = re.fullmatch(r"(argument [^:]+: )?invalid choice: '(.*)' \(choose from (.*)\)", message)
    if m is None:
        return message
    choices = [c.strip().strip("'") for c in m.group(3).split(",")]
    return (f"{m.group(1) or ''}invalid choice: {m.group(2)!r}{closest(m.group(2), choices)} "
            f"(choose from {', '.join(choices)})")


def closest(word: str, candidates) -> str:
    """` (did you mean 'X'?)` for the candidate nearest `word`, "" if none is near."""
    names = {c.lstrip("-"): c for c in candidates}  # '--bogus' is not near '--os' for its dashes
    match = difflib.get_close_matches(word.lstrip("-"), list(names), n=1, cutoff=0.6)
    return f" (did you mean {names[match[0]]!r}?)" if match else ""


def _subparsers(parser: argparse.ArgumentParser):
    return next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)


def option_names(parser: argparse.ArgumentParser, hidden: bool = True) -> list[str]:
    """The option strings `parser` takes (with `hidden`, its hidden aliases too)."""
    return [o for a in parser._actions for o in a.option_strings
            if hidden or a.help != argparse.SUPPRESS]


_NEGATIVE = re.compile(r"^-\d+$|^-\d*\.\d+$")


def parse(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """`parser.parse_args(argv)`, with an unknown option reported first (before a missing
    argument) by the (sub)command it was given to, naming the closest option it takes."""
    target = parser
    for word in argv:  # the deepest (sub)command named: its options are the ones to take
        if word == "--":
            break
        sub = _subparsers(target)
        if sub is not None and not word.startswith("-") and word in sub.choices:
            target = sub.choices[word]
    known = option_names(target) + option_names(parser)
    for word in argv:
        if word == "--":
            break
        if not word.startswith("-") or word == "-" or _NEGATIVE.match(word):
            continue
        name = word.split("=", 1)[0]
        ok = (any(o.startswith(name) for o in known if o.startswith("--")) if name.startswith("--")
              else name[:2] in known)
        if not ok:
            near = closest(name, [o for o in option_names(target, hidden=False) if o.startswith("--")])
            raise UsageError(target.prog, f"unrecognized option {name!r}"
                                          f"{near or f' (see {target.prog} --help)'}")
    args, extras = parser.parse_known_args(argv)
    if extras:
        raise UsageError(target.prog, f"unrecognized arguments: {' '.join(extras)}")
    return args


def add_output(parser: argparse.ArgumentParser, help: str, metavar: str = "FILE",
               default: str | None = None, aliases: tuple[str, ...] = ()) -> None:
    """-o/--out: where a command writes its output (a file or a folder, as `help` says);
    `aliases` (e.g. "--output") are earlier spellings, accepted and not shown."""
    parser.add_argument("-o", "--out", dest="out", metavar=metavar, default=default, help=help)
    for alias in aliases:
        parser.add_argument(alias, dest="out", metavar=metavar, default=default,
                            help=argparse.SUPPRESS)


def add_json(parser: argparse.ArgumentParser, help: str) -> None:
    """--json [FILE]: the command's result as JSON, to FILE, or to standard output with `-` or
    no FILE (`args.json`: None, "-" or the path); `write_text(args.json, text)` writes it."""
    parser.add_argument("--json", nargs="?", const="-", default=None, metavar="FILE", help=help)


def write_text(path: str, text: str) -> None:
    """`text` to standard output (`-`) or to the file `path` (an OSError as a located line)."""
    import sys

    if path == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    write_output(path, lambda p: p.write_text(text, encoding="utf-8"))


def add_quiet(parser: argparse.ArgumentParser, help: str = "no progress bar, no summary") -> None:
    """-q/--quiet: nothing on the terminal but errors and warnings (and what `help` keeps)."""
    parser.add_argument("-q", "--quiet", action="store_true", help=help)


# ---------------------------------------------------------------------------------------------
# -D and -I: assembler symbols and include folders


def parse_define(item: str) -> tuple[str, int | float]:
    """`NAME` (= 1) or `NAME=EXPR`, EXPR a constant expression as `.equ` accepts it."""
    from netsushisen.asm.expressions import ExprError, evaluate
    from netsushisen.asm.parser import Chunk, Directive, parse_chunk

    name, _, raw = item.partition("=")
    name = name.strip()
    if not name.isidentifier():
        raise NetsushisenError(f"-D {item!r}: expected NAME or NAME=VALUE")
    if not raw.strip():
        return name, 1
    stmt = parse_chunk(Chunk(f".equ {name}, {raw}", "-D", 1, [raw]))
    if isinstance(stmt, Diagnostic) or not isinstance(stmt.item, Directive) or len(stmt.item.args) != 2:
        raise NetsushisenError(f"-D {item!r}: VALUE must be a constant expression")

    def no_symbols(symbol: str, loc):
        raise ExprError(f"undefined symbol '{symbol}' (a -D value must be a constant)")

    try:
        return name, evaluate(stmt.item.args[1].value, no_symbols)
    except ExprError as err:
        raise NetsushisenError(f"-D {item!r}: {err.message}") from None


def parse_defines(items: list[str]) -> dict[str, int | float]:
    """The symbols of every -D, later ones winning."""
    return dict(parse_define(item) for item in items)


def add_defines(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME[=VALUE]",
                        help="define a symbol for .if / expressions when assembling (VALUE: a "
                             "constant expression as .equ takes it; default 1)")


def add_include_dirs(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-I", dest="include_dirs", action="append", default=[], metavar="DIR",
                        help="add an include directory (the source's own directory is always searched)")


# ---------------------------------------------------------------------------------------------
# The machine configuration


SHORTHANDS: dict[str, tuple[str, str, dict]] = {
    "pes": ("--pes", "pes", dict(type=int, metavar="N", help="number of PEs (default: the config's, 1)")),
    "precision": ("--precision", "precision", dict(choices=("fp32", "fp64"), help="machine "
                  "floating-point format (default: the config's, fp32)")),
    "max_cycles": ("--max-cycles", "max_cycles", dict(type=int, metavar="N",
                   help="stop after N cycles")),
    "depth": ("--depth", "render.max_depth", dict(type=int, metavar="D", help="maximum ray-tree "
              "depth, eye ray = 1 (default: the config's, 5)")),
}
"""The configuration shorthands: attribute -> (option, configuration field it sets, argparse
keywords). Each is `--set FIELD=VALUE` in disguise, applied after every --set."""


def add_config_options(parser: argparse.ArgumentParser, *, pes: bool = False,
                       precision: bool = False, max_cycles: bool = False,
                       depth: bool = False) -> None:
    """--config and --set, and the shorthands the command asks for."""
    parser.add_argument("--config", metavar="FILE", help="machine configuration (TOML; "
                        "`netsushisen config --dump` prints the defaults)")
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="PATH=VALUE",
                        help="override one configuration field, e.g. --set ic_memory.t_g=16 "
                             "(repeatable)")
    wanted = {"pes": pes, "precision": precision, "max_cycles": max_cycles, "depth": depth}
    for attr, (option, field, kwargs) in SHORTHANDS.items():
        if wanted[attr]:
            parser.add_argument(option, dest=attr, **(kwargs | {
                "help": f"{kwargs['help']}; same as --set {field}=VALUE"}))


def config_overrides(args: argparse.Namespace) -> list[str]:
    """Every --set, then the shorthands given, as `field=value` overrides."""
    overrides = list(args.sets)
    for attr, (_, field, _) in SHORTHANDS.items():
        value = getattr(args, attr, None)
        if value is not None:
            overrides.append(f"{field}={value}")
    return overrides


def config_from_args(args: argparse.Namespace, path: str | None = None,
                     host: bool = True) -> MachineConfig:
    """The validated configuration: defaults, the --config file (or `path`), the overrides.
    With `host`, also refused (one line) when even the leanest engine could not hold its PEs
    in this host's memory (`--pes 100000`): the command's own `check_footprint`, which knows
    the image and the engine, then refines the estimate."""
    config = load_config(path if path is not None else args.config, config_overrides(args))
    if host:
        check_host(Footprint(f"a machine of {config.pes:,} PEs",
                             machine_bytes(config, "reference")), quiet=True)
    return config


def check_footprint(what: str, config: MachineConfig | None, width: int, engine: str | None,
                    golden: bool = False, quiet: bool = False, height: int | None = None,
                    option: str = "--res", extra_bytes: int = 0) -> Footprint:
    """Before any allocation: a width×height (default square) frame must fit the machine's
    pixel index, and the run (a machine run of `config` on `engine`, and/or the golden model)
    this host's memory; a large run prints its size (unless quiet). One-line errors
    (isa/limits.py)."""
    height = width if height is None else height
    check_frame(width, height, f"{option} {width}" if option == "--res" else option)
    pes = f" on {config.pes:,} PE{'s' if config.pes != 1 else ''}" if config and engine else ""
    size = f" {width}×{height}" if width * height else ""
    return check_host(render_footprint(f"{what}{size}{pes}", config, width, engine,
                                       golden, height, extra_bytes=extra_bytes), quiet=quiet)


# ---------------------------------------------------------------------------------------------
# --res and --engine


def add_resolution(parser: argparse.ArgumentParser, default: int | None, help: str = "") -> None:
    parser.add_argument("--res", type=int, default=default, metavar="N",
                        help=help or f"N×N image (default {default})")


def check_resolution(res: int | None) -> int | None:
    """`res` if it is a resolution the tools take (None: not given), else a one-line error:
    beyond the machine's pixel index, or more eye rays than this host holds even at a machine
    render's least cost per ray (a command that knows its engine and PEs checks the whole run
    with `check_footprint`; this catches every other taker of --res, e.g. `debug`)."""
    if res is not None and not 1 <= res <= MAX_RES:
        raise NetsushisenError(f"--res {res}: the image must be 1 to {MAX_RES:,} pixels on a "
                               "side (the machine numbers its pixels in one 32-bit word)")
    if res is not None:
        check_host(render_footprint(f"a {res}×{res} image", None, res, None, per_ray=True),
                   quiet=True)
    return res


def add_engine(parser: argparse.ArgumentParser) -> None:
    from netsushisen.emulator.engine import DEFAULT_ENGINE

    parser.add_argument("--engine", default=None, metavar="NAME",
                        help=f"simulation engine: reference, compiled or tandem (default "
                             f"{DEFAULT_ENGINE}; an unknown name lists the engines)")


def engine_from_args(args: argparse.Namespace, default: str | None = None) -> str:
    """The --engine name, checked against the engines there are (a one-line error otherwise).
    Without --engine: `default`, else the engine interface's default (`default_engine()`: the
    compiled engine where it imports, else the reference engine); `args.engine` is set to it."""
    from netsushisen.emulator.engine import check_engine, default_engine

    if args.engine is None:
        args.engine = default or default_engine()
    return check_engine(args.engine)


def fresh_output(stem: str, suffix: str = ".png") -> str:
    """The default output `STEM.png`, or when that exists the first free `STEM-1.png`,
    `STEM-2.png`, ...: a command writes over a file only where `-o` names it (as `wget` and
    browsers number a download rather than lose the earlier one)."""
    path = Path(f"{stem}{suffix}")
    n = 0
    while os.path.lexists(path):  # a dangling link is taken too: never written through
        n += 1
        path = Path(f"{stem}-{n}{suffix}")
    return str(path)


def check_output_folders(*paths: str | None) -> None:
    """Before any work: every output's folder exists (a run must not end unable to write what
    it computed). A one-line located error otherwise."""
    for path in paths:
        if path:
            folder = Path(path).parent
            if not folder.is_dir():
                raise NetsushisenError(Diagnostic(f"cannot write here: no folder {str(folder)!r}",
                                                  file=str(path)))


def check_output_dir(path: str | Path) -> None:
    """Before any work: an output folder that exists is a folder (a sweep must not compute for
    minutes and then fail to make DIR/points inside a regular file)."""
    p = Path(path)
    if os.path.lexists(p) and not p.is_dir():
        raise NetsushisenError(Diagnostic("the output folder is a file (or a dangling link): "
                                          "give a folder", file=str(p)))


def write_output(path: str, write) -> None:
    """`write(tmp)` for the file `path`, atomically and never through a link
    (isa/outputs.py); an OSError (no such folder, no permission, a full disk) as a
    located one-line error, the earlier file untouched."""
    from netsushisen.isa.outputs import write_file

    write_file(path, write)


def write_outputs(outputs: list[tuple[str | None, object]]) -> None:
    """A command's several outputs as one set (isa/outputs.py `write_all`): each
    (path, writer) with `writer(tmp)` writing the file, or with a str written as UTF-8 text; a
    path None is skipped and a str to `-` goes to standard output once the files are in place.
    A failure leaves every earlier file as it was."""
    from netsushisen.isa.outputs import write_all

    files, stdout = [], []
    for path, what in outputs:
        if not path:
            continue
        if path == "-":
            stdout.append(what)
        elif isinstance(what, str):
            files.append((path, lambda p, text=what: p.write_text(text, encoding="utf-8")))
        else:
            files.append((path, what))
    write_all(files)
    for text in stdout:
        write_text("-", text)


def npy_writer(array):
    """A writer of `array` as .npy at exactly the path given (np.save on a name would add
    `.npy` to a temporary's name)."""
    import numpy as np

    def write(path: Path) -> None:
        with open(path, "wb") as f:
            np.save(f, array)
    return write


# ---------------------------------------------------------------------------------------------
# Programs, image and configuration: what `run` and `debug` build a machine from


def add_program_options(parser: argparse.ArgumentParser) -> None:
    for stage in STAGES:
        parser.add_argument(f"--{stage}", metavar="PROGRAM",
                            help=f"{stage.upper()} program: object file or .s source")
    parser.add_argument("--image", metavar="FILE", help="memory image (.json or .npz)")
    add_config_options(parser, pes=True, max_cycles=True)
    add_defines(parser)
    add_no_schedule(parser)


def add_no_schedule(parser: argparse.ArgumentParser) -> None:
    """--no-schedule (`args.no_schedule`): `.sched` regions one operation per bundle, as
    written (their serial form, to compare with the scheduled one)."""
    parser.add_argument("--no-schedule", action="store_true",
                        help="leave .sched regions one operation per bundle, as written (their "
                             "serial form)")


def load_program(path: str, stage: str | None, defines: dict[str, int | float],
                 config: MachineConfig | None = None, schedule: bool = True):
    """An object file or `.s` source for `stage` (a source's `.sched` regions scheduled for
    `config`, the machine it will run on; without `schedule`, left serial); with `stage` None
    the program says which processor it is for (the object's `proc`, the source's `.proc`)."""
    from netsushisen.asm.assembler import assemble_file
    from netsushisen.asm.objects import Program

    p = Path(path)
    if p.suffix == ".s":
        if not p.is_file():
            raise NetsushisenError(Diagnostic("no such source file", file=path))
        prog = assemble_file(p, proc=stage, defines=defines, config=config, schedule=schedule)
    else:
        prog = Program.load(p)
    if stage is not None and prog.proc != stage:
        raise NetsushisenError(Diagnostic(
            f"this is a {prog.proc.upper()} program, given as --{stage}", file=path))
    return prog


def machine_inputs(args: argparse.Namespace, extra_programs: list[str] = ()):
    """(config, programs by stage, memory image or None) from the `add_program_options`
    options; `extra_programs` are files whose processor the program itself names."""
    from netsushisen.isa.images import load_image

    config = config_from_args(args)
    defines = parse_defines(args.defines)
    schedule = not getattr(args, "no_schedule", False)
    programs = {s: load_program(getattr(args, s), s, defines, config, schedule)
                if getattr(args, s) else None for s in STAGES}
    for path in extra_programs:
        prog = load_program(path, None, defines, config, schedule)
        if programs[prog.proc] is not None:
            raise NetsushisenError(Diagnostic(
                f"a second {prog.proc.upper()} program (one program per processor)", file=path))
        programs[prog.proc] = prog
    if not any(programs.values()):
        raise NetsushisenError("nothing to run: give at least one of --os, --ic, --sc")
    image = load_image(args.image) if args.image else None
    return config, programs, image


# ---------------------------------------------------------------------------------------------
# --timeline FILE [--cycles A:B] [--procs PROCS]: a pipeline timeline of a window of the run


def add_timeline(parser: argparse.ArgumentParser, cycles: bool = True) -> None:
    """--timeline, --procs and (unless the command has it already) --cycles."""
    parser.add_argument("--timeline", metavar="FILE",
                        help="write a pipeline timeline: FILE.kanata / FILE.log (Konata) or "
                             "FILE.json (Perfetto, chrome://tracing); docs/timeline.md")
    if cycles:
        parser.add_argument("--cycles", metavar="A:B", help="the timeline's window: cycles A "
                            "(included) to B (excluded); default the first 100,000")
    parser.add_argument("--procs", metavar="PROCS", help="the processors the timeline shows "
                        "(name prefixes, comma separated: pe0.ic,pe1; default all)")


def timeline_from_args(args: argparse.Namespace,
                       owns_cycles: bool = True) -> TimelineRequest | None:
    """The checked request (None without --timeline): a one-line error for an unknown
    extension, a malformed or too long --cycles, or --procs (or --cycles, when `owns_cycles`:
    the command's --cycles is only the timeline's) without --timeline."""
    from netsushisen.emulator.trace import parse_processors
    from netsushisen.timeline import TimelineRequest, timeline_window
    from netsushisen.reports.timeline import timeline_format

    if not args.timeline:
        for option, value in (("--procs", args.procs),
                              ("--cycles", args.cycles if owns_cycles else None)):
            if value:
                raise NetsushisenError(f"{option} {value}: it chooses what a --timeline shows; "
                                       "give --timeline FILE")
        return None
    timeline_format(args.timeline)
    return TimelineRequest(args.timeline, timeline_window(args.cycles),
                           parse_processors(args.procs))
