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
from netsushisen.asm.listing import format_static_ilp, listing, static_ilp
from netsushisen.errors import NetsushisenError
from netsushisen.options import add_defines, add_include_dirs, parse_defines


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", help="assembly source file (.s)")
    parser.add_argument("--proc", choices=["os", "ic", "sc"],
                        help="target processor (may be omitted when the source says .proc)")
    add_defines(parser)
    add_include_dirs(parser)
    parser.add_argument("-o", dest="output", help="object file to write (default: STEM.o)")
    parser.add_argument("--listing", metavar="PATH|-", help="write a listing (- for stdout)")
    parser.add_argument("--stats", action="store_true", help="print static ILP statistics")
    parser.add_argument("--json", action="store_true", help="with --stats: print them as JSON")


def run(args: argparse.Namespace) -> int:
    defines = parse_defines(args.defines)
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
