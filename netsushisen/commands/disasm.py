"""Disassemble an object file: `netsushisen disasm FILE.o [-o OUT.s]`.

The output reassembles to the identical program (bundles, data and labels)."""

from __future__ import annotations

import argparse

from netsushisen.outputs import write_text
from netsushisen.asm.disasm import disassemble
from netsushisen.asm.objects import Program

from netsushisen.options import add_output


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("object", help="object file written by `netsushisen asm`")
    add_output(parser, "write the source here instead of standard output")


def run(args: argparse.Namespace) -> int:
    text = disassemble(Program.load(args.object))
    if args.out:
        write_text(args.out, text)
    else:
        print(text, end="")
    return 0
