"""Print the ISA reference generated from the tables: `netsushisen isa [--markdown] [-o FILE]`."""

from __future__ import annotations

import argparse

from netsushisen.isa.outputs import write_text
from netsushisen.isa.reference import markdown

from netsushisen.options import add_output


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--markdown", action="store_true", help="Markdown (the only format; the default)")
    add_output(parser, "write to this file instead of standard output")


def run(args: argparse.Namespace) -> int:
    text = markdown()
    if args.out:
        write_text(args.out, text)
    else:
        print(text, end="")
    return 0
