"""The flat statistics dump: one statistic per line, `name value # description (unit)`.

gem5's `stats.txt`, for a statistics file (`run --json`, `render --json`): greppable, diffable
with any tool, each name dotted and stable —

    pe0.ic.cycles                          23295  # cycles simulated on the processor: ... (cycles)
    pe0.ic.stalls.cache_hit                 3600  # stall cycles: an `ldg` that hit ... (cycles)
    config.ic_memory.t_g                       8  # Global memory access time ... (cycles; default 8)

Names are the statistics file's keys joined by dots, with the `processors` and `memory`
sections keyed by the processor (`pe0.ic.cycles`, `pe0.ic.cache.hits`,
`pe0.ic.regions.global.shape_data.accesses`); a list's items are numbered
(`dis.messages_per_pe.0`). Booleans are 1 / 0, an unset value is `none`, text that is not one
word is a JSON string. The programs' listings are left out (text, not statistics; `report
annotate` needs the JSON). Descriptions and units are reports/descriptions.py's.

`parse_flat` reads a dump back into the statistics file's structure, so every report that reads
statistics reads a flat dump too (`load_stats` in reports/tables.py; `report diff A.txt B.txt`).
"""

from __future__ import annotations

import json

from netsushisen.reports.descriptions import describe
from netsushisen.reports.diff import flatten

MEMORY_KEYS = frozenset({"local", "resident", "cache", "global", "regions", "primitives"})
"""A processor's keys of the statistics' `memory` section (the rest are `processors`')."""

LISTS = frozenset({"dis.messages_per_pe"})
"""Statistics that are lists (numbered in the dump)."""

SKIPPED = ("listing",)
"""Keys of `programs.<stage>` left out of the dump."""


def flat_items(stats: dict) -> list[tuple[str, object]]:
    """(name, value) of every statistic, in the statistics file's order."""
    out: list[tuple[str, object]] = []
    for section, value in stats.items():
        if section in ("processors", "memory"):
            for proc, body in value.items():
                for key, v in body.items():
                    if key == "regions":  # region keys hold a dot: "global.shape_data"
                        for region, counts in v.items():
                            out += [(f"{proc}.regions.{region}.{k}", x) for k, x in counts.items()]
                    else:
                        out += list(flatten({f"{proc}.{key}": v}).items())
        elif section == "fifos":
            for fifo, counts in value.items():
                out += [(f"fifos.{fifo}.{k}", x) for k, x in counts.items()]
        elif section == "programs":
            for stage, body in (value or {}).items():
                if body is None:
                    continue
                out += list(flatten({f"programs.{stage}": {k: v for k, v in body.items()
                                                           if k not in SKIPPED}}).items())
        else:
            out += list(flatten({section: value}).items())
    items = []
    for name, v in out:
        if name in LISTS and isinstance(v, list):
            items += [(f"{name}.{i}", x) for i, x in enumerate(v)]
        else:
            items.append((name, v))
    return items


def format_value(v: object) -> str:
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, (int, float)):
        return repr(v)
    text = str(v)
    if not text or any(c.isspace() for c in text) or "#" in text or text[0] in "\"'" or \
            text == "none" or _number(text) is not None:
        return json.dumps(text, ensure_ascii=False)
    return text


def format_flat(stats: dict) -> str:
    """The dump: a line per statistic, names padded to a column, values right-aligned."""
    rows = [(name, format_value(v)) for name, v in flat_items(stats)]
    w_name = min(max((len(n) for n, _ in rows), default=0), 56)
    w_value = min(max((len(v) for _, v in rows), default=0), 20)
    lines = []
    for name, value in rows:
        q = describe(name)
        comment = q.comment() if q is not None else "(not in the table of descriptions)"
        lines.append(f"{name:<{w_name}} {value:>{w_value}}  # {comment}")
    return "\n".join(lines) + "\n"


def _number(text: str) -> int | float | None:
    """A value's number (its digits bounded before conversion: isa/numbers.py), None when it
    is not one."""
    from netsushisen.isa import numbers

    try:
        return numbers.integer(text)
    except ValueError:
        pass
    try:
        return numbers.real(text)
    except ValueError:
        return None


def parse_value(text: str) -> object:
    if text == "none":
        return None
    n = _number(text)
    return text if n is None else n


def is_flat(text: str) -> bool:
    """Whether a statistics file's text is a flat dump (not JSON)."""
    return not text.lstrip().startswith("{")


def parse_flat(text: str, source: str = "<flat>") -> dict:
    """A flat dump back into the statistics file's structure (the listings aside)."""
    from netsushisen.isa import numbers
    from netsushisen.isa.errors import Diagnostic
    from netsushisen.reports.tables import StatsError

    stats: dict = {}
    for number, line in enumerate(text.splitlines(), 1):
        body = line.strip()
        if not body or body.startswith("#"):
            continue
        name, _, rest = body.partition(" ")
        rest = rest.strip()
        if not rest:
            raise StatsError(Diagnostic("expected `name value # description`", file=source,
                                        line=number))
        if rest.startswith('"'):
            try:
                value, _ = json.JSONDecoder().raw_decode(rest)
            except json.JSONDecodeError as err:
                raise StatsError(Diagnostic(f"bad quoted value: {err.msg}", file=source,
                                            line=number)) from None
        else:
            value = parse_value(rest.split()[0])
        problem = numbers.check(value) or _place(stats, name, value)
        if problem:
            raise StatsError(Diagnostic(f"{name}: {problem}", file=source, line=number))
    for name in LISTS:
        section, key = name.split(".")
        d = stats.get(section, {}).get(key)
        if isinstance(d, dict):
            if not all(k.isdigit() and len(k) < 10 for k in d):
                raise StatsError(Diagnostic(f"{name}: a list's entries are named by their index "
                                            "(0, 1, ...)", file=source))
            stats[section][key] = [d[k] for k in sorted(d, key=int)]
    return stats


def _set(d: dict, keys: list[str], value: object) -> str | None:
    """Place a value at its path; why not when the names do not form a tree (a value where a
    group of names is, or a group under a value)."""
    for i, k in enumerate(keys[:-1]):
        d = d.setdefault(k, {})
        if not isinstance(d, dict):
            return f"'{'.'.join(keys[:i + 1])}' is a value, not a group of statistics"
    if isinstance(d.get(keys[-1]), dict):
        return f"'{'.'.join(keys)}' is a group of statistics, not a value"
    d[keys[-1]] = value
    return None


def _place(stats: dict, name: str, value: object) -> str | None:
    parts = name.split(".")
    if parts[0].startswith("pe") and parts[0][2:].isdigit() and len(parts) >= 3:
        proc, key = f"{parts[0]}.{parts[1]}", parts[2]
        if key == "regions":
            return _set(stats, ["memory", proc, "regions", ".".join(parts[3:5]), *parts[5:]],
                        value)
        if key in MEMORY_KEYS:
            return _set(stats, ["memory", proc, *parts[2:]], value)
        return _set(stats, ["processors", proc, *parts[2:]], value)
    if parts[0] == "fifos":
        return _set(stats, ["fifos", ".".join(parts[1:-1]), parts[-1]], value)
    return _set(stats, parts, value)
