"""Show or check the machine configuration.

    netsushisen config [--dump] [--config FILE] [--set KEY=VALUE ...]   print the TOML
    netsushisen config --check FILE [--set ...]                         validate a file

`--dump` prints the defaults (or FILE with the overrides applied) as TOML that `--config` reads
back, each field under a comment with its description, unit and default, and each processor's
latency table with every latency it can override at its default, commented out
(reports/descriptions.py); `--check` reports every problem of FILE as `FILE:LINE: error: ...` (exit 1) — unknown
sections and fields (with the closest known name), values of the wrong type (a TOML string is
never a bool or a number: `buffer_pool = "no"` is an error), impossible values — or prints `ok`.
"""

from __future__ import annotations

import argparse

from netsushisen.isa.config import dump_toml
from netsushisen.options import add_config_options, config_from_args


def configure(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("--dump", action="store_true", help="print the configuration as TOML "
                        "(the default action)")
    parser.add_argument("--check", metavar="FILE", help="validate a configuration file")
    add_config_options(parser)


def run(args: argparse.Namespace) -> int:
    if args.check:
        config = config_from_args(args, path=args.check, host=False)
        print(f"{args.check}: ok")
        if not args.dump:
            return 0
    else:
        config = config_from_args(args, host=False)
    from netsushisen.reports.descriptions import config_comment

    def describe(path: str, value) -> str | None:  # every field's default, set or not
        return config_comment(path)

    print(dump_toml(config, describe if args.dump or not args.check else None), end="")
    return 0
