"""Assemble a stage kernel: `netsushisen asm SOURCE.s --proc os|ic|sc [-D NAME[=VALUE]]... [-I DIR]...
[-o OUT] [--listing PATH|-] [--stats]`.

Writes the object file (default: SOURCE's stem + .o in the current directory; with --stats or
--listing and no -o, nothing is written). Any error in the source: every error is printed as
`file:line:col: error: message` with the line and a caret, and the exit code is 1.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from netsushisen.asm.assembler import assemble_file
from netsushisen.asm.expressions import ExprError, evaluate
from netsushisen.asm.listing import format_static_ilp, listing, static_ilp
from netsushisen.asm.parser import Chunk, Directive, parse_chunk
from netsushisen.errors import Diagnostic, NetsushisenError


def parse_define(item: str) -> tuple[str, int | float]:
    """`NAME` (= 1) or `NAME=VALUE` where VALUE is a constant expression."""
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


def add_assembly_options(parser: argparse.ArgumentParser) -> None:
    """-D and -I, shared by every command that assembles kernels."""
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME[=VALUE]",
                        help="define a symbol for .if / expressions (value defaults to 1)")
    parser.add_argument("-I", dest="include_dirs", action="append", default=[], metavar="DIR",
                        help="add an include directory (the source's own directory is always searched)")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", help="assembly source file (.s)")
    parser.add_argument("--proc", choices=["os", "ic", "sc"],
                        help="target processor (may be omitted when the source says .proc)")
    add_assembly_options(parser)
    parser.add_argument("-o", dest="output", help="object file to write (default: STEM.o)")
    parser.add_argument("--listing", metavar="PATH|-", help="write a listing (- for stdout)")
    parser.add_argument("--stats", action="store_true", help="print static ILP statistics")
    parser.add_argument("--json", action="store_true", help="with --stats: print them as JSON")


def run(args: argparse.Namespace) -> int:
    defines = dict(parse_define(d) for d in args.defines)
    program = assemble_file(args.source, proc=args.proc, defines=defines,
                            include_dirs=args.include_dirs)
    analysis_only = (args.stats or args.listing) and not args.output
    if not analysis_only:
        out = Path(args.output or (Path(args.source).stem + ".o"))
        try:
            program.save(out)
        except OSError as err:
            raise NetsushisenError(f"{out}: cannot write object file: {err.strerror}") from None
    if args.listing:
        text = listing(program)
        if args.listing == "-":
            print(text, end="")
        else:
            Path(args.listing).write_text(text)
    if args.stats:
        s = static_ilp(program)
        print(json.dumps(s.as_dict(), indent=2, sort_keys=True) if args.json
              else format_static_ilp(s, args.source))
    return 0
