"""The `netsushisen` (alias `nss`) command line: the dispatcher.

Every subcommand is a module of `netsushisen/commands/` exposing `configure(parser)` and
`run(args) -> int` (options several commands share come from `netsushisen/options.py`); this
file only routes to them, so adding a command touches one table. Bad input surfaces as
`NetsushisenError` and is printed as located messages with a non-zero exit; an unexpected
internal error is reported in one line too (set NETSUSHISEN_DEBUG=1 for the traceback).

One convention for every command (netsushisen/options.py, checked by tests/test_cli.py): a usage
error is one line `netsushisen CMD: error: ...` on standard error with exit 1 (an unknown
option names the closest one); `--help` prints the usage. Only the named command's module is
imported, so a command that runs no machine does not pay for numba; a command whose module does
not import (a dependency missing) says so in one line when it is named, and is still listed.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from netsushisen import __version__
from netsushisen.isa.errors import NetsushisenError
from netsushisen.options import Parser, UsageError, closest, parse

# name -> (module that implements it, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "asm": ("netsushisen.commands.asm", "assemble a stage kernel (OS, IC or SC)"),
    "kernels": ("netsushisen.commands.kernels", "export the bundled stage kernels to edit, list them"),
    "disasm": ("netsushisen.commands.disasm", "disassemble an object file back to source"),
    "isa": ("netsushisen.commands.isa", "print the ISA reference generated from the opcode table"),
    "config": ("netsushisen.commands.config", "show or check the machine configuration"),
    "run": ("netsushisen.commands.run", "run assembled programs on memory images"),
    "scene": ("netsushisen.commands.scene", "inspect a scene (built-in SPD name or .nff file)"),
    "golden": ("netsushisen.commands.golden", "render a scene with the golden numpy model"),
    "render": ("netsushisen.commands.render", "render a scene on the emulated machine"),
    "report": ("netsushisen.commands.report", "ILP, stall and memory reports from a statistics file"),
    "paper": ("netsushisen.commands.paper", "reproduce the paper's tables and figures"),
    "accuracy": ("netsushisen.commands.accuracy", "what accuracy costs: error against time per knob"),
    "numerics": ("netsushisen.commands.numerics", "numerical stability: the hard-case catalog or one scene"),
    "sweep": ("netsushisen.commands.sweep", "design-space sweeps on Dask: render every point of a spec"),
    "debug": ("netsushisen.commands.debug", "step through the machine in the terminal"),
}


class CommandUnavailable(NetsushisenError):
    """A command whose module does not import here (a dependency missing or broken, or a
    damaged install): said in one line, never hidden from the list of commands."""


def _load(name: str):
    """The module of command `name`; a CommandUnavailable naming it and why if it does not
    import (an ImportError: its module, or one it needs, is missing)."""
    module_name = COMMANDS[name][0]
    try:
        return importlib.import_module(module_name)
    except ImportError as err:
        raise CommandUnavailable(f"the {name} command is unavailable here: {module_name} does not "
                                 f"import ({type(err).__name__}: {err}); reinstall netsushisen "
                                 "with its dependencies (pip install netsushisen)") from None


def build_parser(only: str | None = None) -> tuple[argparse.ArgumentParser, dict[str, object]]:
    """The parser of every command, or with `only` of that command alone ("": none): the
    others get an empty parser (their name and help for `netsushisen --help`) and their modules
    are not imported, so a command pays only for its own imports (`asm` does not import numba)."""
    parser = Parser(prog="netsushisen",
                    description="Toolchain for the Netsushisen parallel ray-tracing machine.")
    parser.add_argument("--version", action="version", version=f"netsushisen {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    modules: dict[str, object] = {}
    for name, (_, help_text) in COMMANDS.items():
        if only is not None and name != only:
            sub.add_parser(name, help=help_text, description=help_text, add_help=False)
            continue
        module = _load(name)
        p = sub.add_parser(name, help=help_text, description=(module.__doc__ or help_text).strip())
        module.configure(p)
        modules[name] = module
    return parser, modules


def _command_named(argv: list[str]) -> str | None:
    """The command `argv` names (its first word that is not an option), None if none; an
    unknown one is a usage error naming the closest command."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            if word not in COMMANDS:
                raise UsageError("netsushisen", f"unknown command {word!r}{closest(word, COMMANDS)}"
                                 f" (commands: {', '.join(COMMANDS)})")
            return word
    return None


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    prog = "netsushisen"
    try:
        command = _command_named(argv)
        prog = f"netsushisen {command}" if command else prog
        parser, modules = build_parser(only=command or "")
        args = parse(parser, argv)
        if not args.command:
            parser.print_help()
            return 1
        return int(modules[args.command].run(args) or 0)
    except UsageError as err:
        print(err.format(), file=sys.stderr)
        return err.exit_code
    except NetsushisenError as err:
        print(with_command(err, prog), file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print("netsushisen: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as err:  # an internal error: one line, not a traceback, unless debugging
        if os.environ.get("NETSUSHISEN_DEBUG"):
            raise
        print(f"netsushisen: internal error: {type(err).__name__}: {err} "
              "(set NETSUSHISEN_DEBUG=1 for the traceback)", file=sys.stderr)
        return 70


def with_command(err: NetsushisenError, prog: str) -> str:
    """An error's lines, each unlocated one (`error: ...`) as `netsushisen CMD: error: ...`;
    a located one (`file:line:col: error: ...`, a source's caret lines) as it is."""
    lines = err.format().split("\n")
    return "\n".join(f"{prog}: {line}" if line.startswith(("error: ", "warning: ")) else line
                      for line in lines)


if __name__ == "__main__":
    sys.exit(main())
