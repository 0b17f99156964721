"""The `netsushisen` (alias `nss`) command line: the dispatcher.

Every subcommand is a module of `netsushisen/commands/` exposing `configure(parser)` and
`run(args) -> int` (options several commands share come from `netsushisen/options.py`); this
file only routes to them, so adding a command touches one table. Bad input surfaces as
`NetsushisenError` and is printed as located messages with a non-zero exit; an unexpected
internal error is reported in one line too (set NETSUSHISEN_DEBUG=1 for the traceback).
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import sys

from netsushisen import __version__
from netsushisen.errors import NetsushisenError

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


def _available_commands() -> dict[str, tuple[str, str]]:
    """Only the commands whose module exists in this build (capabilities land one by one)."""
    found = {}
    for name, (module, help_text) in COMMANDS.items():
        if importlib.util.find_spec(module) is not None:
            found[name] = (module, help_text)
    return found


def build_parser() -> tuple[argparse.ArgumentParser, dict[str, object]]:
    parser = argparse.ArgumentParser(
        prog="netsushisen",
        description="Toolchain for the Netsushisen parallel ray-tracing machine.",
    )
    parser.add_argument("--version", action="version", version=f"netsushisen {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    modules: dict[str, object] = {}
    for name, (module_name, help_text) in _available_commands().items():
        module = importlib.import_module(module_name)
        p = sub.add_parser(name, help=help_text, description=(module.__doc__ or help_text).strip())
        module.configure(p)
        modules[name] = module
    return parser, modules


def main(argv: list[str] | None = None) -> int:
    try:
        parser, modules = build_parser()
        args = parser.parse_args(argv)
        if not args.command:
            parser.print_help()
            return 2
        return int(modules[args.command].run(args) or 0)
    except NetsushisenError as err:
        print(err.format(), file=sys.stderr)
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


if __name__ == "__main__":
    sys.exit(main())
