"""The paper's Table 1, Table 2 and the findings of Figures 3–5 (its evaluation), ours beside theirs.

`tables(scenes)` gives the two tables as rows (paper value, our value); `findings(scenes)` checks
each of the paper's findings against our numbers and says whether we agree and, where we do not,
why; `report_markdown(...)` writes them up. The numbers come from `netsushisen.paper.analyse_scene`; the
figures and CSV files from `paper_plots`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from netsushisen.reports.paper_data import COUNTINGS, LOCAL_SHARES, SceneData

TABLE1_COLUMNS = ("primitives", "polygons", "spheres", "cones", "cylinders", "lights", "reflective",
                  "transparent")
PAPER_TABLE1 = {
    "tetra": (4096, 4096, 0, 0, 0, 1, False, False),
    "balls": (7382, 1, 7381, 0, 0, 3, True, False),
    "mount": (8196, 8192, 4, 0, 0, 1, True, True),
    "rings": (8401, 1, 4200, 0, 4200, 3, True, False),
}
PAPER_TABLE2 = {  # visible primitives, their share of all primitives, share of references to them
    "tetra": (2121, 0.51, 0.56),
    "balls": (3072, 0.42, 0.73),
    "mount": (1903, 0.23, 0.57),
    "rings": (2571, 0.29, 0.77),
}
PAPER_RES = 512


def _yn(v) -> str:
    return "yes" if v else "no"


def _pct(v: float | None, digits: int = 0) -> str:
    return "–" if v is None else f"{100 * v:.{digits}f} %"


def table1(scenes: list[SceneData]) -> list[dict]:
    rows = []
    for d in scenes:
        paper = PAPER_TABLE1.get(d.name)
        for i, col in enumerate(TABLE1_COLUMNS):
            ours = d.counts[col]
            theirs = paper[i] if paper else None
            rows.append({"scene": d.name, "column": col, "paper": theirs, "ours": ours,
                         "equal": None if theirs is None else theirs == ours})
    return rows


def table2(scenes: list[SceneData]) -> list[dict]:
    rows = []
    for d in scenes:
        p = PAPER_TABLE2.get(d.name, (None, None, None))
        rows.append({"scene": d.name, "primitives": d.n,
                     "visible_paper": p[0], "visible_ours": len(d.visible),
                     "visible_share_paper": p[1], "visible_share_ours": d.visible_share,
                     "reference_share_paper": p[2],
                     "reference_share_ours": d.visible_reference_share})
    return rows


# ------------------------------------------------------------------------------------------------
# Findings: each a threshold on a measured quantity


VERDICTS = ("agree", "partly", "differ", "not testable here", "not evaluated")


@dataclass
class Finding:
    figure: str
    paper: str
    test: str  # the threshold that decides the verdict
    ours: str
    verdict: str  # one of VERDICTS
    counting: str = ""  # which counting and sizing the numbers use
    why: str = ""  # a tested explanation, or "unexplained"
    margin: str = ""  # k of n cases passing and each case's margin to the threshold
    margins: dict = field(default_factory=dict)  # case -> margin (≥ 0 passes): the series' measure


def _by(scenes: list[SceneData]) -> dict[str, SceneData]:
    return {d.name: d for d in scenes}


def fig5_curve(d: SceneData, local: float, what: str = "ref") -> tuple[np.ndarray, np.ndarray]:
    rows = [r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9]
    return (np.array([r["resident_split"] for r in rows]),
            np.array([r[what]["t_measured"] / d.t_r for r in rows]))


def fig5_best(d: SceneData, local: float, what: str = "ref") -> tuple[float, float, dict]:
    """(resident split with the lowest t, that t, its row)."""
    rows = [r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9]
    best = min(rows, key=lambda r: (r[what]["t_measured"], r["resident_split"]))
    return best["resident_split"], best[what]["t_measured"] / d.t_r, best


def fig5_row(d: SceneData, local: float, split: float) -> dict:
    return next(r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9
                and abs(r["resident_split"] - split) < 1e-9)


def fig4_miss(d: SceneData, share: float, what: str = "ref") -> float:
    return next(r[what]["miss_rate"] for r in d.fig4 if abs(r["cache_share"] - share) < 1e-9)


def _context(scenes: list[SceneData]) -> str:
    res = scenes[0].res if scenes else 0
    samples = " corner rays" if scenes and scenes[0].corners else " pixel centres"
    if res == PAPER_RES:
        return f"{res}×{res}{samples}, the paper's resolution"
    return f"{res}×{res}{samples} against the paper's {PAPER_RES}×{PAPER_RES}"


def _sampling_why(corners: bool) -> str:
    """Table 2's visible share depends on where eye rays sample a pixel; the other sampling is
    the experiment (`paper --corners` against the default pixel centres)."""
    if corners:
        return ("unexplained with SPD corner rays (this run); where eye rays sample a pixel "
                "decides which small primitives some ray hits: the pixel-centre run (without "
                "--corners) is the other reading")
    return ("unexplained with pixel-centre rays (this run); where eye rays sample a pixel decides "
            "which small primitives some ray hits: `paper --corners` is the other reading")


def explain(scenes: list[SceneData], metric, target: dict[str, float], tolerance: float,
            measure: str = "", met=None, goal: str = "") -> str:
    """Which trace experiment (SceneData.experiments) brings `metric(scene data)` within
    `tolerance` of `target[scene]` in every differing scene — with the numbers — or
    "unexplained" with what each experiment gave. `met(value, scene)`: the finding's own test
    instead (a one-sided claim), described by `goal`."""
    met = met or (lambda v, n: abs(v - target[n]) <= tolerance)
    goal = goal or f"within {_pct(tolerance)} of the paper"
    off = [d for d in scenes if d.name in target and not met(metric(d), d.name)]
    if not off:
        return ""
    names = [k for k in off[0].experiments if k != "as rendered"]
    if not names:
        return "unexplained (no experiment available)"
    parts, fixes = [], []
    for k in names:
        vals = {d.name: metric(d.with_references(d.experiments[k])) for d in off}
        ok = all(met(vals[n], n) for n in vals)
        parts.append(f"{k}: "
                     + ", ".join(f"{n} {_pct(metric(_by(off)[n]))} → {_pct(v)}"
                                 for n, v in vals.items()))
        if ok:
            fixes.append(k)
    tested = "experiments on the reference trace" + (f" ({measure})" if measure
                                                     else "") + " — " + "; ".join(parts)
    if fixes:
        return f"explained by {' / '.join(fixes)} ({goal}); {tested}"
    return f"unexplained: no experiment brings it to {goal} ({tested})"


def findings(scenes: list[SceneData], counting: str = "ref") -> list[Finding]:
    """The paper's §6 findings, each decided by a threshold on our numbers. `counting`: "ref"
    (per primitive reference, the paper's) or "all" (per word) for Figures 4–5. Where the
    scenes carry candidate readings (`SceneData.readings`), every Figure 4–5 finding that is
    not "agree" says what each candidate makes of it."""
    return _with_candidates(_findings(scenes, counting), scenes, counting)


RAY_ORDER = "the machine's normal ray order"
"""The candidate reading `--on-machine` adds: Figures 4–5 replayed from IC's stream recorded on
the machine in the kernels' normal mode (several rays in flight) instead of the serial order."""


def common_readings(scenes: list[SceneData]) -> list[str]:
    """The candidate readings every scene carries, in the first scene's order."""
    if not scenes:
        return []
    return [k for k in scenes[0].readings if all(k in d.readings for d in scenes)]


def ray_order_rows(scenes: list[SceneData], counting: str = "ref") -> list[dict]:
    """Each Figure 4–5 finding in the serial order (the trace-driven path's) and in the
    machine's normal order (RAY_ORDER): verdicts and the numbers each gives."""
    if RAY_ORDER not in common_readings(scenes):
        return []
    serial = _findings(scenes, counting)
    normal = {(f.figure, f.paper): f
              for f in _findings([d.readings[RAY_ORDER] for d in scenes], counting)}
    out = []
    for f in serial:
        g = normal.get((f.figure, f.paper))
        if f.figure in ("Figure 4", "Figure 5") and g is not None:
            out.append({"figure": f.figure, "paper": f.paper, "serial": f.verdict,
                        "normal": g.verdict, "serial_ours": f.ours, "normal_ours": g.ours,
                        "flips": f.verdict != g.verdict})
    return out


PAPER_BLOCK_BYTES = 64
"""§5.1 states the cache's block: 「ブロック・サイズ：64B」. A reading with another block size
changes a parameter the paper fixes: it is shown as a sensitivity, never as an explanation."""


def stated_changes(d: SceneData) -> list[str]:
    """The parameters the paper states that reading `d` changes (empty: a reading of what the
    paper leaves open — resolution, ray order, pre-pass ranking, sizing, list placement, PEs).
    The cache's capacity rule (a share of the database, whole blocks) is the sweep's own
    (`paper_sweep.sized_config`) and no reading varies it; the block size is checked here."""
    return ([f"block size {d.block_bytes} B (the paper states {PAPER_BLOCK_BYTES} B)"]
            if d.block_bytes != PAPER_BLOCK_BYTES else [])


def split_readings(scenes: list[SceneData]) -> tuple[list[str], list[str]]:
    """(candidate readings, sensitivities): the common readings split by whether any scene's
    reading changes a parameter the paper states (`stated_changes`)."""
    labels = common_readings(scenes)
    sens = [k for k in labels if any(stated_changes(d.readings[k]) for d in scenes)]
    return [k for k in labels if k not in sens], sens


def _with_candidates(items: list[Finding], scenes: list[SceneData], counting: str) -> list[Finding]:
    """Rerun each differing Figure 4–5 finding under every candidate reading the scenes carry:
    a candidate that turns it to "agree" explains it; "unexplained" only after all were run.
    A reading that changes a stated parameter (`stated_changes`) is listed as a sensitivity
    and never explains."""
    labels, sens = split_readings(scenes)
    if not labels and not sens:
        return items
    alt = {k: {(f.figure, f.paper): f for f in _findings([d.readings[k] for d in scenes], counting)}
           for k in labels + sens}
    for f in items:
        if f.figure not in ("Figure 4", "Figure 5") or f.verdict not in ("partly", "differ"):
            continue
        runs = [(k, alt[k].get((f.figure, f.paper))) for k in labels]
        runs = [(k, g) for k, g in runs if g is not None]
        fixes = [k for k, g in runs if g.verdict == "agree"]
        done = "; ".join(f"{k}: {g.verdict} ({g.ours})" for k, g in runs)
        if RAY_ORDER not in labels:  # it needs the machine's normal-mode renders
            done += f"; not run: {RAY_ORDER} (`--on-machine`)"
        head = (f"explained by {' / '.join(fixes)}" if fixes else
                "unexplained after the candidates " + ", ".join(k for k, _ in runs))
        shown = [(k, alt[k].get((f.figure, f.paper))) for k in sens]
        shown = [(k, g) for k, g in shown if g is not None]
        if shown:
            done += ("; sensitivities, which change a parameter the paper states and so explain "
                     "nothing — " + "; ".join(f"{k}: {g.verdict} ({g.ours})" for k, g in shown))
        detail = f.why
        if detail.startswith("unexplained"):
            detail = detail.removeprefix("unexplained").lstrip(": ")
        f.why = f"{head} (candidates run — {done})" + (f"; {detail}" if detail else "")
    return items


def _findings(scenes: list[SceneData], counting: str) -> list[Finding]:
    """Every claim, judged (reports/paper_claims.py: `claims`)."""
    from netsushisen.reports.paper_claims import claims  # noqa: PLC0415 (it imports this module)

    return claims(scenes, counting)


def machine_findings(checks: list[dict]) -> list[Finding]:
    """§4.3's pre-pass finding (reports/paper_claims.py: `machine_findings`)."""
    from netsushisen.reports.paper_claims import machine_findings as judged  # noqa: PLC0415

    return judged(checks)


def verdict_counts(items: list[Finding]) -> dict[str, int]:
    out: dict[str, int] = {}
    for f in items:
        out[f.verdict] = out.get(f.verdict, 0) + 1
    return out
