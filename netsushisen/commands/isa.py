"""Print the ISA reference generated from the tables: `netsushisen isa [--markdown] [-o FILE]`."""

from __future__ import annotations

import argparse
from pathlib import Path

from netsushisen.isa.reference import markdown


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--markdown", action="store_true", help="Markdown (the only format; the default)")
    parser.add_argument("-o", dest="output", help="write to this file instead of stdout")


def run(args: argparse.Namespace) -> int:
    text = markdown()
    if args.output:
        Path(args.output).write_text(text)
    else:
        print(text, end="")
    return 0
