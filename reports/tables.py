"""Report sections and their four output formats, and reading a statistics file.

A report is a list of `Section`s (key, title, columns, rows of raw values, per-column formats);
the same sections print as rich tables (`table`), JSON (`json`: raw values, rows as objects), CSV
(`csv`) or Markdown (`md`).

Tables fit the terminal (`report_width()`: its width, 80 when the output is not a terminal;
`COLUMNS` overrides) and wrap cells between words only: a table whose longest words cannot fit
is printed as wide as they need, never with a word cut in two. CSV is one table per file, the
header row first, so `pandas.read_csv` reads it as it is: a report of several tables writes
each to its own file (`write_csv_dir`: `DIR/<report>_<table>.csv`) or one chosen by key
(`select`, the command's `--table NAME`).
"""

from __future__ import annotations

import csv
import io
import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.outputs import write_text

FORMATS = ("table", "json", "csv", "md")
SCHEMA_NAME = "netsushisen-stats"
SCHEMA_VERSION = 1


@dataclass
class Section:
    key: str
    title: str
    columns: list[str]
    rows: list[list] = field(default_factory=list)
    formats: dict[str, str] = field(default_factory=dict)
    """column -> "int", "pct", "f2", "f3", or "num" (an int with separators, a float with three
    decimals: a column mixing counts and ratios); a leading "+" shows the sign (changes)."""
    caption: str = ""
    group_by: str | None = None
    """A column whose every value gets its own table in the table and Markdown formats (the
    value in the title, the column left out: narrower tables); JSON and CSV keep it."""
    panels: list[list[str]] = field(default_factory=list)
    """Column groups (each starting with the row's key columns) that the table format prints
    as tables of their own, one under the other, when the whole table would not fit the width;
    the other formats keep one table."""
    whole: tuple[str, ...] = ()
    """Columns whose cells are lists of items ("cache_miss 12%, branch 3%") the table format
    breaks only between items, never inside one."""

    def cell(self, col: str, v) -> str:
        if v is None:
            return "-"
        f = self.formats.get(col)
        sign = "+" if f and f.startswith("+") else ""
        f = f[1:] if sign else f
        if f == "num":
            f = "int" if isinstance(v, int) else "f3"
        if f == "int":
            return f"{int(v):{sign},}"
        if f == "pct":
            return f"{100 * v:{sign}.1f}%"
        if f and f.startswith("f"):
            return f"{v:{sign}.{int(f[1:])}f}"
        return str(v)


class StatsError(NetsushisenError):
    """A statistics file that cannot be read as `netsushisen-stats` v1."""


def load_stats(path: str | Path) -> dict:
    """Read and check a statistics file (`run --json`, `render --json`), JSON or a flat dump
    (`report flat`, reports/flat.py); one located error otherwise."""
    p = Path(path)
    try:
        from netsushisen.isa.limits import read_input

        text = read_input(p, "statistics file").decode("utf-8")
    except FileNotFoundError:
        raise StatsError(Diagnostic("no such statistics file", file=str(p))) from None
    except IsADirectoryError:
        raise StatsError(Diagnostic("this is a directory, not a statistics file", file=str(p))) from None
    except UnicodeDecodeError:
        raise StatsError(Diagnostic("not a text file (expected statistics JSON)", file=str(p))) from None
    from netsushisen.isa import numbers
    from netsushisen.reports.flat import is_flat, parse_flat

    try:
        data = parse_flat(text, str(p)) if is_flat(text) else numbers.loads(text)
    except json.JSONDecodeError as err:
        raise StatsError(Diagnostic(f"not valid JSON: {err.msg}", file=str(p), line=err.lineno,
                                    col=err.colno)) from None
    except RecursionError:
        raise StatsError(Diagnostic("not valid JSON: nested too deeply", file=str(p))) from None
    bad = numbers.first_problem(data)
    if bad:
        raise StatsError(Diagnostic(f"{bad[0]}: {bad[1]}", file=str(p)))
    schema = data.get("schema") if isinstance(data, dict) else None
    if not isinstance(schema, dict) or schema.get("name") != SCHEMA_NAME:
        raise StatsError(Diagnostic(f"not a {SCHEMA_NAME} statistics file (write one with "
                                    "`netsushisen run --json` or `netsushisen render --json`)", file=str(p)))
    if schema.get("version") != SCHEMA_VERSION:
        raise StatsError(Diagnostic(f"statistics schema version {schema.get('version')!r}; this report "
                                    f"reads version {SCHEMA_VERSION}", file=str(p)))
    for key in ("config", "processors", "memory"):
        if not isinstance(data.get(key), dict):
            raise StatsError(Diagnostic(f"malformed statistics: '{key}' is missing or not an object",
                                        file=str(p)))
    return data


MIN_WIDTH = 40


def report_width() -> int:
    """The terminal's width (`COLUMNS` first), 80 when standard output is not a terminal; never
    below MIN_WIDTH."""
    return max(MIN_WIDTH, shutil.get_terminal_size((80, 24)).columns)


def column_widths(natural: list[int], minimum: list[int], room: int,
                  body: list[int] | None = None) -> list[int]:
    """Content widths within `room`: every column at its natural width if they fit; else first
    the headers wider than their column's cells wrap (down to `body`, the cells' width), then
    the widest columns shrink one character at a time, never below their longest word
    (`minimum`); when the minimums alone exceed the room, the minimums."""
    widths = list(natural)
    for floor in ([max(b, m) for b, m in zip(body, minimum)] if body else [], minimum):
        while floor and sum(widths) > room:
            shrinkable = [i for i, w in enumerate(widths) if w > floor[i]]
            if not shrinkable:
                break
            widest = max(shrinkable, key=lambda i: (widths[i], -i))
            widths[widest] -= 1
    return widths


def rich_table(s: Section, width: int):
    """One section as a rich Table at most `width` wide (wider only if its longest words need
    it), and its width: columns apart by two spaces, no vertical rules (the llvm-mca / perf
    look, and room for the words), numbers right-aligned, text wrapped between words only.
    The column widths are chosen here (`column_widths`) because rich, short of room, narrows
    every column evenly and so cuts words."""
    from rich import box
    from rich.table import Table
    from rich.text import Text

    cells = [[s.cell(c, v) for c, v in zip(s.columns, r)] for r in s.rows] or \
        [["(none)"] + [""] * (len(s.columns) - 1)]
    body = [max(len(r[i]) for r in cells) for i in range(len(s.columns))]
    natural = [max(len(c), b) for c, b in zip(s.columns, body)]
    minimum = [max(len(w) for x in [c] + [r[i] for r in cells]
                   for w in (x.split(", ") if c in s.whole else x.split()) or [""])
               + (1 if c in s.whole else 0)  # the comma after an item
               for i, c in enumerate(s.columns)]
    gaps = 2 * (len(s.columns) - 1)
    widths = column_widths(natural, minimum, width - gaps, body)
    t = Table(box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, padding=(0, 1, 0, 0))
    for c, w in zip(s.columns, widths):
        t.add_column(Text(c), justify="right" if c in s.formats else "left", width=w)
    for r in cells:
        t.add_row(*[Text(x) for x in r])  # Text: a cell's "[r1 + 2]" is not rich markup
    return t, sum(widths) + gaps


def split_groups(sections: list[Section]) -> list[Section]:
    """Each section with a `group_by` column as one section per value of it, in first-seen
    order, the value in the title and the column left out."""
    out = []
    for s in sections:
        if s.group_by is None or s.group_by not in s.columns or not s.rows:
            out.append(s)
            continue
        k = s.columns.index(s.group_by)
        values = list(dict.fromkeys(r[k] for r in s.rows))
        for v in values:
            out.append(Section(s.key, f"{s.title}: {v}", s.columns[:k] + s.columns[k + 1:],
                               [r[:k] + r[k + 1:] for r in s.rows if r[k] == v], s.formats,
                               s.caption if v == values[-1] else "",
                               panels=[[c for c in p if c != s.group_by] for p in s.panels]))
    return out


def render_table(sections: list[Section], width: int | None = None) -> str:
    """Tables `width` wide at most (default: `report_width()`), wider only where a table's
    longest words need it, so that no word is ever split."""
    from rich.console import Console
    from rich.text import Text

    width = width or report_width()
    out = []
    for s in split_groups(sections):
        tables = [rich_table(s, width)]
        if tables[0][1] > width and s.panels:  # too wide: its column groups one under the other
            tables = [rich_table(Section(s.key, s.title, p, [[r[s.columns.index(c)] for c in p]
                                                              for r in s.rows], s.formats), width)
                      for p in s.panels]
        need = max(n for _, n in tables)
        console = Console(width=max(width, need), record=True, file=io.StringIO(), color_system=None)
        console.print(Text(s.title))  # title and caption wrap at the terminal, not the table
        for i, (t, _) in enumerate(tables):
            if i:
                console.print()
            console.print(t)
        if s.caption:
            console.print(Text(s.caption))
        console.print()
        out.append(console.export_text())
    return "".join(out)


def render_json(sections: list[Section], report: str, source: str) -> str:
    out = {"report": report, "source": source,
           "sections": [{"key": s.key, "title": s.title, "caption": s.caption, "columns": s.columns,
                         "rows": [dict(zip(s.columns, r)) for r in s.rows]} for s in sections]}
    return json.dumps(out, indent=1, allow_nan=False) + "\n"


def render_csv(section: Section) -> str:
    """One table: the header row, then raw values (empty for none)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(section.columns)
    w.writerows([["" if v is None else v for v in r] for r in section.rows])
    return buf.getvalue()


def write_csv_dir(sections: list[Section], report: str, folder: str | Path) -> list[Path]:
    """Every section to `folder/<report>_<key>.csv` (the folder is made); the paths written."""
    d = Path(folder)
    if d.exists() and not d.is_dir():
        raise StatsError(Diagnostic("CSV output of several tables needs a folder, and this is a "
                                    "file (choose one table with --table)", file=str(d)))
    d.mkdir(parents=True, exist_ok=True)
    paths = []
    for s in sections:
        path = d / f"{report}_{s.key}.csv"
        write_text(path, render_csv(s))
        paths.append(path)
    return paths


def select(sections: list[Section], key: str | None) -> list[Section]:
    """The section named `key` (all when None); an unknown key is an error listing the keys."""
    if key is None:
        return sections
    chosen = [s for s in sections if s.key == key]
    if not chosen:
        raise StatsError(f"--table {key}: this report's tables are "
                         f"{', '.join(s.key for s in sections)}")
    return chosen


def render_md(sections: list[Section]) -> str:
    lines = []
    for s in split_groups(sections):
        lines += [f"### {s.title}", "", "| " + " | ".join(s.columns) + " |",
                  "|" + "|".join("---:" if c in s.formats else "---" for c in s.columns) + "|"]
        lines += ["| " + " | ".join(s.cell(c, v).replace("|", "\\|") for c, v in zip(s.columns, r)) + " |"
                  for r in s.rows]
        if s.caption:
            lines += ["", s.caption]
        lines.append("")
    return "\n".join(lines)


def render(sections: list[Section], fmt: str, report: str, source: str, width: int | None = None) -> str:
    """The sections in one format; CSV takes exactly one section (`select`, `write_csv_dir`)."""
    if fmt == "json":
        return render_json(sections, report, source)
    if fmt == "csv":
        if len(sections) != 1:
            raise StatsError(f"report {report} has {len(sections)} tables "
                             f"({', '.join(s.key for s in sections)}); CSV holds one: choose it "
                             "with --table NAME, or write each to a folder with -o DIR")
        return render_csv(sections[0])
    if fmt == "md":
        return render_md(sections)
    return render_table(sections, width)


REPORTS: dict[str, tuple[str, str]] = {
    "ilp": ("netsushisen.reports.ilp", "ilp_sections"),
    "stalls": ("netsushisen.reports.stalls", "stall_sections"),
    "memory": ("netsushisen.reports.memory", "memory_sections"),
    "annotate": ("netsushisen.reports.annotate", "annotate_sections"),
    "diff": ("netsushisen.reports.diff", "diff_sections"),
    "floor": ("netsushisen.reports.floor", "floor_sections"),
    "bounds": ("netsushisen.reports.bounds", "bounds_report"),
}
"""The reports made of sections: name -> (module, function(stats, ...) -> [Section]). `report
KIND` and the Python API's `.table(KIND)` both read them through `report_sections` (`floor` is
`report bounds`'s last table, on its own for `.table("floor")`)."""


def report_sections(kind: str, stats: dict, *args, **options) -> list[Section]:
    """The sections of report `kind` on `stats` (`diff` takes the other statistics next);
    `options` are the report function's (`top`, `explain`, `proc`, `order`, `changed_only`)."""
    import importlib

    if kind not in REPORTS:
        raise StatsError(f"no report {kind!r} (reports: {', '.join(REPORTS)})")
    module, function = REPORTS[kind]
    return getattr(importlib.import_module(module), function)(stats, *args, **options)


def present_processors(stats: dict) -> list[tuple[str, dict]]:
    """(name, processor statistics) of every processor that ran a program."""
    return [(n, p) for n, p in stats["processors"].items() if p.get("present", True)]
