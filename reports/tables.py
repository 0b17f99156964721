"""Report sections and their four output formats, and reading a statistics file.

A report is a list of `Section`s (title, columns, rows of raw values, per-column formats); the
same sections print as rich tables that fit 80 columns (`table`), JSON (`json`: raw values, rows
as objects), CSV (`csv`: one block per section, `# title` line first) or Markdown (`md`).
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path

from netsushisen.errors import Diagnostic, NetsushisenError

FORMATS = ("table", "json", "csv", "md")
SCHEMA_NAME = "netsushisen-stats"
SCHEMA_VERSION = 1


@dataclass
class Section:
    key: str
    title: str
    columns: list[str]
    rows: list[list] = field(default_factory=list)
    formats: dict[str, str] = field(default_factory=dict)  # column -> "int", "pct", "f2", "f3"
    caption: str = ""

    def cell(self, col: str, v) -> str:
        if v is None:
            return "-"
        f = self.formats.get(col)
        if f == "int":
            return f"{int(v):,}"
        if f == "pct":
            return f"{100 * v:.1f}%"
        if f and f.startswith("f"):
            return f"{v:.{int(f[1:])}f}"
        return str(v)


class StatsError(NetsushisenError):
    """A statistics file that cannot be read as `netsushisen-stats` v1."""


def load_stats(path: str | Path) -> dict:
    """Read and check a statistics JSON (`run --json`, `render --json`); one located error otherwise."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise StatsError(Diagnostic("no such statistics file", file=str(p))) from None
    except IsADirectoryError:
        raise StatsError(Diagnostic("this is a directory, not a statistics file", file=str(p))) from None
    except UnicodeDecodeError:
        raise StatsError(Diagnostic("not a text file (expected statistics JSON)", file=str(p))) from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise StatsError(Diagnostic(f"not valid JSON: {err.msg}", file=str(p), line=err.lineno,
                                    col=err.colno)) from None
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


def render_table(sections: list[Section], width: int = 80) -> str:
    from rich.console import Console
    from rich.table import Table

    console = Console(width=width, record=True, file=io.StringIO(), color_system=None)
    for s in sections:
        t = Table(title=s.title, title_justify="left", caption=s.caption or None, caption_justify="left",
                  pad_edge=False)
        for c in s.columns:
            numeric = c in s.formats
            t.add_column(c, justify="right" if numeric else "left", overflow="fold")
        for r in s.rows:
            t.add_row(*[s.cell(c, v) for c, v in zip(s.columns, r)])
        if not s.rows:
            t.add_row(*(["(none)"] + [""] * (len(s.columns) - 1)))
        console.print(t)
    return console.export_text()


def render_json(sections: list[Section], report: str, source: str) -> str:
    out = {"report": report, "source": source,
           "sections": [{"key": s.key, "title": s.title, "caption": s.caption, "columns": s.columns,
                         "rows": [dict(zip(s.columns, r)) for r in s.rows]} for s in sections]}
    return json.dumps(out, indent=1, allow_nan=False) + "\n"


def render_csv(sections: list[Section]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    for i, s in enumerate(sections):
        if i:
            buf.write("\n")
        buf.write(f"# {s.title}\n")
        w.writerow(s.columns)
        w.writerows([["" if v is None else v for v in r] for r in s.rows])
    return buf.getvalue()


def render_md(sections: list[Section]) -> str:
    lines = []
    for s in sections:
        lines += [f"### {s.title}", "", "| " + " | ".join(s.columns) + " |",
                  "|" + "|".join("---:" if c in s.formats else "---" for c in s.columns) + "|"]
        lines += ["| " + " | ".join(s.cell(c, v).replace("|", "\\|") for c, v in zip(s.columns, r)) + " |"
                  for r in s.rows]
        if s.caption:
            lines += ["", s.caption]
        lines.append("")
    return "\n".join(lines)


def render(sections: list[Section], fmt: str, report: str, source: str) -> str:
    if fmt == "json":
        return render_json(sections, report, source)
    if fmt == "csv":
        return render_csv(sections)
    if fmt == "md":
        return render_md(sections)
    return render_table(sections)


def present_processors(stats: dict) -> list[tuple[str, dict]]:
    """(name, processor statistics) of every processor that ran a program."""
    return [(n, p) for n, p in stats["processors"].items() if p.get("present", True)]
