"""Show or check the machine configuration.

    netsushisen config [--dump] [--config FILE] [--set KEY=VALUE ...]   print the TOML
    netsushisen config --check FILE [--set ...]                         validate a file

`--dump` prints the defaults (or FILE with the overrides applied) as TOML that `--config` reads
back; `--check` reports every problem of FILE as a located error (exit 1) or prints `ok`.
"""

from __future__ import annotations

import argparse

from netsushisen.isa.config import dump_toml, load_config


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("--dump", action="store_true", help="print the configuration as TOML "
                        "(the default action)")
    parser.add_argument("--check", metavar="FILE", help="validate a configuration file")
    parser.add_argument("--config", metavar="FILE", help="start from this file instead of the defaults")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override one field, e.g. --set ring.buffer_pool=false")


def run(args: argparse.Namespace) -> int:
    if args.check:
        load_config(args.check, args.overrides)
        print(f"{args.check}: ok")
        if not args.dump:
            return 0
    config = load_config(args.check or args.config, args.overrides)
    print(dump_toml(config), end="")
    return 0
