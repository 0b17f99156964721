"""Disassemble an object file: `netsushisen disasm FILE.o [--names] [-o OUT.s]`.

The output reassembles to the identical program (bundles, data and labels); `--names` writes
registers by their `.reg` names (with the `.reg` lines) where the object file records them."""

from __future__ import annotations

import argparse

from netsushisen.isa.outputs import write_text
from netsushisen.asm.disasm import disassemble
from netsushisen.asm.objects import Program

from netsushisen.options import add_output


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("object", help="object file written by `netsushisen asm`")
    add_output(parser, "write the source here instead of standard output")
    parser.add_argument("--names", action="store_true",
                        help="registers by their .reg names (pri for r29), with the .reg lines")


def run(args: argparse.Namespace) -> int:
    text = disassemble(Program.load(args.object), names=args.names)
    if args.out:
        write_text(args.out, text)
    else:
        print(text, end="")
    return 0
