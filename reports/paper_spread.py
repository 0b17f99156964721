"""The spread of Figures 4–5 over what the paper leaves to chance (`paper --draws N`): each
draw jitters the main pass's eye rays within their pixels, the pre-pass's too, and orders the
primitives with equal pre-pass counts at random (their records' order in ICGM)
(`netsushisen.paper.sample_draw`). Every Figure 4–5 point gets its min–max over the run and its
draws; every Figure 4–5 finding is judged again on each draw, and a verdict that changes within
the spread is named: it is not stable at this resolution.
"""

from __future__ import annotations

import copy
import csv
from pathlib import Path

from netsushisen.isa.outputs import replacing
from netsushisen.reports.paper import Finding, _pct, findings
from netsushisen.reports.paper_data import SceneData


def draw_scenes(scenes: list[SceneData], draws: list[dict]) -> list[list[SceneData]]:
    """Per draw, the scenes with that draw's Figure 4–5 rows (draws every scene finished)."""
    by: dict[int, dict[str, dict]] = {}
    for d in draws:
        by.setdefault(d["draw"], {})[d["scene"]] = d
    out = []
    for k in sorted(by):
        if all(s.name in by[k] for s in scenes):
            row = []
            for s in scenes:
                v = copy.copy(s)
                v.fig4, v.fig5 = by[k][s.name]["fig4"], by[k][s.name]["fig5"]
                v.readings, v.experiments = {}, {}
                row.append(v)
            out.append(row)
    return out


def point_spread(scenes: list[SceneData], per_draw: list[list[SceneData]],
                 what: str = "ref") -> dict[tuple, tuple[float, float, float]]:
    """(scene, figure, local share, split or cache share) → (run's value, min, max) over the run
    and every draw: the Figure 4 miss rate and the Figure 5 t (units of t_r)."""
    out = {}
    for i, d in enumerate(scenes):
        runs = [d] + [row[i] for row in per_draw]
        for j, r in enumerate(d.fig4):
            v = [x.fig4[j][what]["miss_rate"] for x in runs]
            out[(d.name, "fig4", 0.0, r["cache_share"])] = (v[0], min(v), max(v))
        for j, r in enumerate(d.fig5):
            v = [x.fig5[j][what]["t_measured"] / d.t_r for x in runs]
            out[(d.name, "fig5", r["local_share"], r["resident_split"])] = (v[0], min(v), max(v))
    return out


def stability(scenes: list[SceneData], per_draw: list[list[SceneData]],
              counting: str = "ref") -> list[dict]:
    """Each Figure 4–5 finding's verdict in the run and in every draw; `stable` when they are
    all the same."""
    base = [f for f in findings(scenes, counting) if f.figure in ("Figure 4", "Figure 5")]
    drawn: list[dict[tuple, Finding]] = [
        {(f.figure, f.paper): f for f in findings(row, counting)} for row in per_draw]
    rows = []
    for f in base:
        vs = [g[(f.figure, f.paper)].verdict for g in drawn if (f.figure, f.paper) in g]
        worst = [min(g[(f.figure, f.paper)].margins.values()) for g in drawn
                 if (f.figure, f.paper) in g and g[(f.figure, f.paper)].margins]
        rows.append({"figure": f.figure, "paper": f.paper, "verdict": f.verdict, "draws": vs,
                     "stable": all(v == f.verdict for v in vs),
                     "worst": (min(worst), max(worst)) if worst else None})
    return rows


def spread_markdown(scenes: list[SceneData], draws: list[dict]) -> list[str]:
    per_draw = draw_scenes(scenes, draws)
    if not per_draw:
        return []
    n = len(per_draw)
    spread = point_spread(scenes, per_draw)
    lines = ["## Spread over sampling", "",
             f"{n} draws beside the run (`--draws {n}`): each jitters the main pass's eye rays "
             "within their pixels, the pre-pass's eye rays too, and orders the primitives with "
             "equal pre-pass counts at random (their records' order in ICGM); Figures 4–5 "
             "replayed for each. Every point's min–max over the run and its draws is in "
             "`fig4_spread.csv` / `fig5_spread.csv` and drawn as a band on the figures. Per "
             "scene, the widest spread (per primitive reference):", ""]
    rows = []
    for d in scenes:
        f4 = max((v for k, v in spread.items() if k[0] == d.name and k[1] == "fig4"),
                 key=lambda v: v[2] - v[1])
        f5 = max((v for k, v in spread.items() if k[0] == d.name and k[1] == "fig5"
                  and k[3] < 0.999), key=lambda v: v[2] - v[1])
        rows.append(f"| {d.name} | {_pct(f4[1], 2)}–{_pct(f4[2], 2)} (run {_pct(f4[0], 2)}) | "
                    f"{f5[1]:.3f}–{f5[2]:.3f} (run {f5[0]:.3f}) t_r |")
    lines += ["| scene | Figure 4 miss rate, widest point | Figure 5 t, widest point with a "
              "cache |", "| --- | --- | --- |", *rows, ""]
    st = stability(scenes, per_draw)
    lines += ["| finding | run | verdicts over the draws | worst margin over the draws | "
              "stable |", "| --- | --- | --- | --- | --- |"]
    for r in st:
        w = "–" if r["worst"] is None else f"{r['worst'][0]:+.3f} … {r['worst'][1]:+.3f}"
        lines.append(f"| {r['figure']}: {r['paper']} | {r['verdict']} | {', '.join(r['draws'])} "
                     f"| {w} | {'yes' if r['stable'] else '**no**'} |")
    moving = [r for r in st if not r["stable"]]
    lines += ["", f"**{len(moving)} of {len(st)} Figure 4–5 verdicts change within the spread**"
              + (": " + "; ".join(f"{r['figure']}: {r['paper']} ({r['verdict']} → "
                                  f"{'/'.join(sorted(set(r['draws'])))})" for r in moving)
                 if moving else "."), ""]
    return lines


def write_spread_csvs(scenes: list[SceneData], draws: list[dict], out: Path) -> list[Path]:
    per_draw = draw_scenes(scenes, draws)
    if not per_draw:
        return []
    spread = point_spread(scenes, per_draw)
    paths = []
    for fig, header in (("fig4", ["scene", "cache_share", "miss_rate", "min", "max"]),
                        ("fig5", ["scene", "local_share", "resident_split", "t", "min", "max"])):
        p = out / f"{fig}_spread.csv"
        with replacing(p, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(header + ["draws"])
            for (name, g, local, x), (v, lo, hi) in spread.items():
                if g == fig:
                    w.writerow([name, *([] if fig == "fig4" else [local]), x,
                                f"{v:.6f}", f"{lo:.6f}", f"{hi:.6f}", len(per_draw)])
        paths.append(p)
    return paths
