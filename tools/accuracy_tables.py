"""The README's four accuracy tables, from an `accuracy.json` (`netsushisen accuracy --res 32`).

    python tools/accuracy_tables.py DIR/accuracy.json [--write README.md]

Prints the precision, depth, pre-pass and fidelity tables in the README's condensed form (the
full tables are in DIR/report.md); `--write` replaces the four tables in the README in place
(each is found by the start of its header row), so the README quotes a run that a command made.
Times are the seconds each axis compares (a machine row: its machine run; `timing.basis` in
accuracy.json) as median (min–max) over the repeated runs.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HEADERS = {
    "precision": "| scene | golden fp32 | golden fp16 | golden bf16 scene | machine fp32 | "
                 "machine cycles fp32 → fp64 | machine run s fp32 → fp64 |",
    "depth": "| scene | depth 1 | depth 2 | depth 3 | depth 5 (SPD) | depth 8 | image settles at |",
    "prepass": "| scene | 3×3 (config: 1 %) | 8×8 | 16×16 | 32×32 (truth) |",
    "fidelity": "| scene | (d) compiled (truth) | (a) analytic | (b) trace-driven | (c) sampled 10 % | "
                "25 % | 50 % | (e) reference engine |",
}


STARTS = {axis: " | ".join(h.split(" | ")[:2]) for axis, h in HEADERS.items()}
"""Where each table starts: its header's first two cells (an older header with other columns is
found and replaced too)."""


def spread(row: dict, digits: int = 2) -> str:
    """The compared seconds of a row: `median (low–high)` (the median alone for one run)."""
    t = row.get("timing") or {}
    c = t.get("compared") or {"median": row["seconds"], "low": row["seconds"], "high": row["seconds"]}
    text = f"{c['median']:.{digits}f}"
    if len(t.get("runs", [])) > 1:
        text += f" ({c['low']:.{digits}f}–{c['high']:.{digits}f})"
    return text + " s"


def _by(rows: list[dict]) -> dict[str, dict[str, dict]]:
    out: dict[str, dict[str, dict]] = {}
    for r in rows:
        out.setdefault(r["scene"], {})[r["setting"]] = r
    return out


def _truth(rows: dict[str, dict]) -> dict:
    return next(r for r in rows.values() if r["truth"])


def precision(rows: list[dict]) -> list[list[str]]:
    out = []
    for scene, s in _by(rows).items():
        cell = [f"{s[k]['error']['rmse_u8']:.2f} / {100 * s[k]['error']['hit_ids']:.1f} %"
                for k in ("golden fp32", "golden fp16", "golden bf16 scene", "machine fp32")]
        out.append([scene, *cell, f"{s['machine fp32']['cost']['cycles']:,} → "
                                  f"{s['machine fp64']['cost']['cycles']:,}",
                    f"{spread(s['machine fp32'], 3)} → {spread(s['machine fp64'], 3)}"])
    return out


def depth(rows: list[dict]) -> list[list[str]]:
    out = []
    for scene, s in _by(rows).items():
        truth = _truth(s)
        tc = truth["cost"].get("cycles")
        cells = []
        for d in (1, 2, 3, 5, 8):
            r = s[f"depth {d}"]
            share = f"{100 * r['cost']['cycles'] / tc:.0f}%" if tc else "–"
            cells.append(f"{r['error']['rmse_u8']:.2f}, {share}, {spread(r, 3)}")
        settled = None
        for d in sorted((int(r["values"]["depth"]) for r in s.values() if not r["truth"]), reverse=True):
            if s[f"depth {d}"]["error"]["max_u8"] == 0:
                settled = d
            else:
                break
        td = int(truth["values"]["depth"])
        out.append([scene, *cells, str(settled) if settled else f"after 8 (truth: depth {td})"])
    return out


def prepass(rows: list[dict]) -> list[list[str]]:
    out = []
    for scene, s in _by(rows).items():
        truth = _truth(s)
        tc = truth["cost"]["cycles"]
        cells = [f"{100 * (s[k]['cost']['cycles'] / tc - 1):+.1f} %, ρ {s[k]['values']['rho']:.3f}, "
                 f"{spread(s[k], 3)}"
                 for k in ("pre-pass 3x3 (config share)", "pre-pass 8x8", "pre-pass 16x16")]
        out.append([scene, *cells, f"{tc:,} cycles, ρ {truth['values']['rho']:.3f}, "
                                   f"{spread(truth, 3)}"])
    return out


def fidelity(rows: list[dict]) -> list[list[str]]:
    out = []
    for scene, s in _by(rows).items():
        truth = _truth(s)
        cells = [f"{truth['cost']['cycles']:,} cycles, {spread(truth)}"]
        for k in ("(a) analytic", "(b) trace-driven"):
            cells.append(f"{100 * s[k]['error']['cycles']:.1f} %, {spread(s[k])}")
        for share in (10, 25, 50):
            r = s[f"(c) sampled {share} %"]
            mark = "✓" if r["values"].get("covers") else "✗"
            cells.append(f"{100 * r['error']['cycles']:.1f} % {mark}, {spread(r)}")
        e = s.get("(e) reference engine")
        if e is None:
            cells.append("–")
        else:
            v = e["values"]
            whole = not v.get("seconds_full") or abs(v["seconds_full"] - e["seconds"]) < 1e-9
            cells.append(("identical" if v.get("identical") else "DIFFERS") + f", {v['seconds_full']:.0f} s"
                         + ("" if whole else " (extrapolated)")
                         + (f" ({v['speedup']:.0f}×)" if v.get("speedup") else ""))
        out.append([scene, *cells])
    return out


def tables(data: dict) -> dict[str, str]:
    out = {}
    for axis, make in (("precision", precision), ("depth", depth), ("prepass", prepass), ("fidelity", fidelity)):
        rows = data["axes"].get(axis)
        if not rows:
            continue
        header = HEADERS[axis]
        sep = "|" + " --- |" * (header.count("|") - 1)
        out[axis] = "\n".join([header, sep] + ["| " + " | ".join(r) + " |" for r in make(rows)])
    return out


def write(readme: Path, made: dict[str, str]) -> None:
    text = readme.read_text(encoding="utf-8")
    for axis, table in made.items():
        start = text.find(STARTS[axis])
        if start < 0:
            raise SystemExit(f"{readme}: the {axis} table's header is not there")
        end = re.compile(r"\n(?!\|)").search(text, start)
        text = text[:start] + table + text[end.start():]
    readme.write_text(text, encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("json", help="accuracy.json of a `netsushisen accuracy` run")
    p.add_argument("--write", metavar="README", help="replace the tables in this file")
    args = p.parse_args(argv)
    made = tables(json.loads(Path(args.json).read_text()))
    if args.write:
        write(Path(args.write), made)
    else:
        sys.stdout.write("\n\n".join(made.values()) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
