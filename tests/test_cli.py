"""One command-line convention for every command (issue 25, item 5), checked by walking every
subcommand's parser — whatever subcommands exist, so a command or option added later is held to
the same rules:

- a usage error is one line `netsushisen CMD: error: ...` on standard error, exit 1 (argparse's
  usage dump and exit 2 are gone); `--help` still prints the usage;
- an unknown option names the (sub)command and the closest option it takes;
- an option name has one meaning: every parser that takes it stores it in the same place with
  the same action, arity and type; `-o` is `--out` and `-q` is `--quiet` wherever they appear;
  old spellings (`--output`) are hidden aliases only;
- every table a command prints fits 80 columns when the output is not a terminal.
"""

from __future__ import annotations

import argparse
import re

import pytest

from netsushisen.cli import build_parser, main
from netsushisen.options import Parser, option_names


def _subparsers(parser):
    return next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)


def walk(parser=None, path=()):
    """(command words, parser) of every command and subcommand."""
    if parser is None:
        parser, _ = build_parser()
    sub = _subparsers(parser)
    if path:
        yield path, parser
    if sub is not None:
        for name, child in sub.choices.items():
            yield from walk(child, (*path, name))


PARSERS = list(walk())
LEAVES = [(path, p) for path, p in PARSERS if _subparsers(p) is None]
IDS = [" ".join(path) for path, _ in LEAVES]


def test_the_walk_sees_every_command():
    from netsushisen.cli import COMMANDS

    top = {path[0] for path, _ in PARSERS}
    assert top == set(COMMANDS)
    assert ("report", "flat") in {path for path, _ in LEAVES}


def test_every_parser_reports_errors_in_one_line():
    for path, parser in PARSERS:
        assert isinstance(parser, Parser), path


def _signature(action: argparse.Action) -> tuple:
    return (action.dest, type(action).__name__, action.nargs, getattr(action.type, "__name__", action.type),
            action.const)


def test_an_option_has_one_meaning_everywhere():
    seen: dict[str, tuple[tuple, str]] = {}
    for path, parser in LEAVES:
        for action in parser._actions:
            for option in action.option_strings:
                sig = _signature(action)
                if option in seen:
                    assert seen[option][0] == sig, (f"{option}: {' '.join(path)} {sig} but "
                                                    f"{seen[option][1]} {seen[option][0]}")
                else:
                    seen[option] = (sig, " ".join(path))


@pytest.mark.parametrize("path, parser", LEAVES, ids=IDS)
def test_short_and_long_spellings_go_together(path, parser):
    visible = set(option_names(parser, hidden=False))
    for short, long in (("-o", "--out"), ("-q", "--quiet")):
        assert (short in visible) == (long in visible), (path, short, long)
    assert "--output" not in visible, f"{' '.join(path)}: -o/--out is the output option"
    if "--engine" in visible:  # a command that runs the machine can be quiet
        assert "--quiet" in visible, path


@pytest.mark.parametrize("path, parser", LEAVES, ids=IDS)
def test_unknown_option_is_one_line_naming_the_command_and_the_closest_option(cli, path, parser):
    prog = "netsushisen " + " ".join(path)
    code, out, err = cli(*path, "--no-such-option-at-all")
    assert code == 1 and out == ""
    assert err.splitlines() == [f"{prog}: error: unrecognized option '--no-such-option-at-all' "
                                f"(see {prog} --help)"]
    longs = [o for o in option_names(parser, hidden=False) if o.startswith("--") and o != "--help"]
    for option in longs:  # a near miss: the option with its last letter doubled
        near = option + option[-1]
        if not any(o.startswith(near) for o in option_names(parser)):
            break
    else:
        return  # (no long option: nothing to be near)
    code, _, err = cli(*path, near)
    assert code == 1 and len(err.splitlines()) == 1, err
    m = re.fullmatch(rf"{re.escape(prog)}: error: unrecognized option '{re.escape(near)}' "
                     r"\(did you mean '(--[\w-]+)'\?\)", err.strip())
    assert m and m[1] in option_names(parser), err


@pytest.mark.parametrize("path, parser", LEAVES, ids=IDS)
def test_a_bad_value_is_one_line_exit_1(cli, path, parser):
    prog = "netsushisen " + " ".join(path)
    ints = [a.option_strings[-1] for a in parser._actions if a.type is int and a.option_strings]
    for option in ints:
        code, out, err = cli(*path, option, "abc")
        assert code == 1 and out == ""
        assert err.splitlines() == [f"{prog}: error: argument {'/'.join(_action(parser, option).option_strings)}: "
                                    "invalid int value: 'abc'"], err


def _action(parser, option):
    return next(a for a in parser._actions if option in a.option_strings)


@pytest.mark.parametrize("path, parser", LEAVES, ids=IDS)
def test_help_still_prints_the_usage(capsys, path, parser):
    with pytest.raises(SystemExit) as stop:
        main([*path, "--help"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: netsushisen {' '.join(path)}")


def test_render_res_abc_is_one_line_exit_1(cli):
    code, out, err = cli("render", "tetra", "--res", "abc")
    assert (code, out, err) == (1, "", "netsushisen render: error: argument --res: invalid int "
                                       "value: 'abc'\n")


def test_unknown_command_and_missing_arguments(cli):
    code, _, err = cli("rendr", "tetra")
    assert code == 1 and len(err.splitlines()) == 1
    assert err.startswith("netsushisen: error: unknown command 'rendr' (did you mean 'render'?)")
    code, _, err = cli("report", "ilp")
    assert (code, err) == (1, "netsushisen report ilp: error: the following arguments are "
                              "required: STATS.json\n")
    code, out, _ = cli()
    assert code == 1 and out.startswith("usage: netsushisen")


def test_report_rejects_an_unknown_kind(cli, tmp_path):
    code, out, err = cli("report", "stall", tmp_path / "s.json")
    assert (code, out) == (1, "") and len(err.splitlines()) == 1
    assert err.startswith("netsushisen report: error: argument REPORT: invalid choice: 'stall' "
                          "(did you mean 'stalls'?) (choose from ilp, stalls, memory, annotate,")
    code, _, err = cli("report", "zzz", tmp_path / "s.json")
    assert code == 1 and "'zzz' (choose from ilp, stalls" in err and "did you mean" not in err
    # and the dispatch behind the parser names the kinds too, instead of falling through
    from netsushisen.commands.report import sections_for
    from netsushisen.reports.tables import StatsError

    with pytest.raises(StatsError, match=r"unknown report 'memroy' \(did you mean 'memory'\?\) "
                                         r"\(reports: ilp, stalls, memory"):
        sections_for(argparse.Namespace(kind="memroy"), {})


def test_a_command_that_does_not_import_is_reported_not_hidden(cli, monkeypatch, tmp_path):
    from netsushisen.cli import COMMANDS

    (tmp_path / "broken_cmd.py").write_text("import no_such_dependency_of_netsushisen\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(COMMANDS, "broken", ("broken_cmd", "a command whose dependency is gone"))
    monkeypatch.setitem(COMMANDS, "ghost", ("netsushisen.commands.ghost",
                                            "a command not installed"))
    code, out, err = cli()  # the usage and the list of commands
    assert "broken" in out and "ghost" in out and err == ""  # listed, not hidden
    code, out, err = cli("broken", "x")
    assert (code, out) == (1, "") and err.splitlines() == [
        "netsushisen broken: error: the broken command is unavailable here: broken_cmd does not "
        "import (ModuleNotFoundError: No module named 'no_such_dependency_of_netsushisen'); "
        "reinstall netsushisen with its dependencies (pip install netsushisen)"]
    code, _, err = cli("ghost", "--help")
    assert code == 1 and len(err.splitlines()) == 1 and err.startswith(
        "netsushisen ghost: error: the ghost command is unavailable here: "
        "netsushisen.commands.ghost does not import (ModuleNotFoundError: ")
    code, _, _ = cli("kernels", "list")  # the others are untouched
    assert code == 0


def test_an_error_inside_a_command_names_it(cli):
    code, _, err = cli("render", "tetra", "--res", "0")
    assert code == 1 and err.startswith("netsushisen render: error: --res 0: ") and \
        len(err.splitlines()) == 1


def test_old_spellings_are_hidden_aliases(cli, tmp_path):
    code, _, _ = cli("scene", "nff", "tetra:1", "--output", tmp_path / "a.nff")
    assert code == 0 and "\nv\nfrom " in (tmp_path / "a.nff").read_text()
    code, _, _ = cli("scene", "nff", "tetra:1", "--out", tmp_path / "b.nff")
    assert (tmp_path / "b.nff").read_text() == (tmp_path / "a.nff").read_text()


def test_render_takes_depth_and_max_cycles(cli, tmp_path):
    code, _, _ = cli("render", "tetra:1", "--res", "2", "--depth", "2", "--max-cycles", "100",
                     "-q", "-o", tmp_path / "t.png", "--json", tmp_path / "s.json")
    import json

    stats = json.loads((tmp_path / "s.json").read_text())
    assert stats["config"]["render"]["max_depth"] == 2 and stats["config"]["max_cycles"] == 100
    assert code == 4 and stats["run"]["status"] == "max_cycles"


# ---------------------------------------------------------------------------------------------
# Every table fits 80 columns when standard output is not a terminal


@pytest.fixture(scope="module")
def stats_file(tmp_path_factory):
    from netsushisen.cli import main as run_main

    d = tmp_path_factory.mktemp("render")
    assert run_main(["render", "tetra", "--res", "4", "-q", "-o", str(d / "t.png"),
                     "--json", str(d / "s.json")]) == 0
    return d / "s.json"


def test_every_table_fits_80_columns(cli, monkeypatch, tmp_path, stats_file):
    monkeypatch.delenv("COLUMNS", raising=False)
    commands = [
        ("render", "tetra", "--res", "2", "-o", tmp_path / "t.png"),
        ("scene", "info", "tetra"), ("scene", "list"), ("kernels", "list"),
        ("asm", "--scene", "tetra", "--proc", "ic", "--stats"),
        ("golden", "tetra", "--res", "4"),
        *(("report", kind, stats_file) for kind in ("ilp", "stalls", "memory", "annotate")),
        ("report", "stalls", stats_file, "--explain"), ("report", "stalls", "--explain"),
        ("report", "diff", stats_file, stats_file),
    ]
    for argv in commands:
        code, out, err = cli(*argv)
        assert code == 0, (argv, err)
        wide = [line for line in out.split("\n") if len(line) > 80]
        assert not wide, (argv, wide[:3])


@pytest.mark.parametrize("kind", ["flat", "ilp", "stalls", "memory", "annotate"])
def test_a_statistics_table_of_the_wrong_shape_is_one_located_line(cli, tmp_path, stats_file, kind):
    """A table that is null (the fuzz corpus's stats-23: `fifos.<fifo>` = null) was an internal
    error in `report flat`: every report says 'malformed statistics' at the file."""
    import json

    stats = json.loads(stats_file.read_text())
    fifo = next(iter(stats["fifos"]))
    stats["fifos"][fifo] = None
    stats["processors"]["pe0.ic"] = stats["memory"]["pe0.ic"] = 5
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(stats))
    code, _, err = cli("report", kind, path)
    assert code == 1 and "Traceback" not in err and "internal error" not in err, err
    assert err.strip().startswith(f"{path}: error: malformed statistics"), err
