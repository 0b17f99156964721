"""The paper's Table 1, Table 2 and the findings of Figures 3–5 (its evaluation), ours beside theirs.

`tables(scenes)` gives the two tables as rows (paper value, our value); `findings(scenes)` checks
each of the paper's findings against our numbers and says whether we agree and, where we do not,
why; `report_markdown(...)` writes them up. The numbers come from `netsushisen.paper.analyse_scene`; the
figures and CSV files from `paper_plots`.
"""

from __future__ import annotations

from dataclasses import dataclass

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
TABLE2_TOLERANCE = 0.05  # absolute, on a share
FIG3_BAND = (0.70, 0.80)  # the paper's "20 % of the primitives take 70–80 %"
PAPER_UNREFERENCED = {"mount": 0.20, "rings": 0.67}  # Fig 3: never referenced (C = 1 at 1 − this)
FIG4_LOW = 0.10  # "miss rates are low": at most 10 % at every cache size
FIG4_SATURATION = 0.5  # hit-rate gain from 30 % to 100 % at most half the gain from 10 % to 30 %
FIG5_BEST = (0.6, 0.8)  # "lowest near 70 % resident"
FIG5_CLOSE = 0.10  # "30 % and 50 % differ little": best t within 10 % relative
FIG5_GAIN = 0.02  # "resident beats cache-only": the best split with resident memory ≥ 2 % below
FIG3_MOST = 0.8  # "references concentrate on 20–50 % of the primitives": 80 % of them there
FIG3_SPAN = (0.2, 0.5)
FIG5_FALL = 0.01  # "t falls as the resident share grows": no step up to the best split rises > 1 %
FIG5_FEW = 0.5  # "a small resident memory catches too few references": ρ < 50 % when all resident
PREPASS_SHARE = 0.01  # §4.3: the pre-pass costs about 1 % of the main pass
PREPASS_BAND = (0.005, 0.02)  # "about 1 %": within a factor of two
LOW_RHO, LITTLE_GAIN = 0.3, 0.10  # "helps little when ρ is low": gain < 10 % wherever 0 < ρ < 0.3


@dataclass
class Finding:
    figure: str
    paper: str
    test: str  # the threshold that decides the verdict
    ours: str
    verdict: str  # one of VERDICTS
    counting: str = ""  # which counting and sizing the numbers use
    why: str = ""  # a tested explanation, or "unexplained"


def _by(scenes: list[SceneData]) -> dict[str, SceneData]:
    return {d.name: d for d in scenes}


def _verdict(results: dict[str, bool]) -> str:
    if not results:
        return "not evaluated"
    held = sum(results.values())
    return "agree" if held == len(results) else ("differ" if held == 0 else "partly")


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
            measure: str = "") -> str:
    """Which trace experiment (SceneData.experiments) brings `metric(scene data)` within
    `tolerance` of `target[scene]` in every differing scene — with the numbers — or
    "unexplained" with what each experiment gave."""
    off = [d for d in scenes if d.name in target and abs(metric(d) - target[d.name]) > tolerance]
    if not off:
        return ""
    names = [k for k in off[0].experiments if k != "as rendered"]
    if not names:
        return "unexplained (no experiment available)"
    parts, fixes = [], []
    for k in names:
        vals = {d.name: metric(d.with_references(d.experiments[k])) for d in off}
        ok = all(abs(vals[n] - target[n]) <= tolerance for n in vals)
        parts.append(f"{k}: "
                     + ", ".join(f"{n} {_pct(metric(_by(off)[n]))} → {_pct(v)}"
                                 for n, v in vals.items()))
        if ok:
            fixes.append(k)
    tested = "experiments on the reference trace" + (f" ({measure})" if measure
                                                     else "") + " — " + "; ".join(parts)
    if fixes:
        return f"explained by {' / '.join(fixes)} (within {_pct(tolerance)} of the paper); {tested}"
    return f"unexplained: no experiment brings it within {_pct(tolerance)} of the paper ({tested})"


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
    by = _by(scenes)
    out: list[Finding] = []
    if not scenes:
        return out
    opts = scenes[0].options.describe()
    cnt = f"{COUNTINGS[counting]}; {opts}"
    per_test = "tests per primitive (every ray kind)"

    # Table 1 ----------------------------------------------------------------------------------
    rows1 = [r for r in table1(scenes) if r["equal"] is not None]
    diffs = [f"{r['scene']} {r['column']} {r['ours']} (paper {r['paper']})" for r in rows1
             if not r["equal"]]
    out.append(Finding("Table 1", "tetra 4096 polygons; balls 7381 spheres + 1 polygon; mount 8192 "
                                  "polygons + 4 spheres; rings 4200 spheres + 4200 cylinders + 1 "
                                  "polygon; lights 1/3/1/3; balls, mount, rings reflective; mount "
                                  "transparent",
                       "every column equal",
                       "every column equal" if not diffs else "; ".join(diffs),
                       "agree" if rows1 and not diffs
                       else ("not evaluated" if not rows1 else "differ"), "scene files",
                       "" if not diffs
                       else "unexplained: our SPD generators are ports of Haines's current "
                       "SPD; the paper may have used an older version (not tested)"))
    # Table 2 ----------------------------------------------------------------------------------
    rows = [r for r in table2(scenes) if r["visible_share_paper"] is not None]
    vis = {r["scene"]: abs(r["visible_share_ours"] - r["visible_share_paper"]) <= TABLE2_TOLERANCE for r in rows}
    out.append(Finding("Table 2", "visible primitives: " + ", ".join(
        f"{n} {_pct(PAPER_TABLE2[n][1])}"
        for n in vis), f"share within {_pct(TABLE2_TOLERANCE)} (absolute) "
        "of the paper's",
        "; ".join(f"{r['scene']} {r['visible_ours']} ({_pct(r['visible_share_ours'])})"
                                    for r in rows), _verdict(vis), "eye rays' hits",
        "" if all(vis.values()) else
        (f"at {scenes[0].res}×{scenes[0].res} fewer eye rays hit fewer primitives (not an "
         "experiment)"
         if scenes[0].res < PAPER_RES else _sampling_why(scenes[0].corners))))
    target = {n: PAPER_TABLE2[n][2] for n in vis}
    ref = {r["scene"]: abs(r["reference_share_ours"] - r["reference_share_paper"]) <= TABLE2_TOLERANCE for r in rows}
    out.append(Finding("Table 2", "share of references to visible primitives: " + ", ".join(
        f"{n} {_pct(target[n])}"
        for n in ref), f"within {_pct(TABLE2_TOLERANCE)} (absolute) of the paper's",
        ", ".join(f"{r['scene']} {_pct(r['reference_share_ours'])}" for r in rows),
        _verdict(ref), per_test,
        explain(scenes, lambda d: d.visible_reference_share, target, TABLE2_TOLERANCE)))
    # Figure 3 ---------------------------------------------------------------------------------
    c20 = {n: d.c_at(0.2) for n, d in by.items()}
    out.append(Finding("Figure 3", "references are skewed in every scene",
                       "C(20 %) ≥ 40 % (twice the uniform 20 %) in every scene",
                       "C(20 %): " + ", ".join(f"{n} {_pct(v)}" for n, v in c20.items()),
                       _verdict({n: v >= 0.4 for n, v in c20.items()}), per_test,
                       "" if all(v >= 0.4 for v in c20.values()) else "unexplained"))
    mr = [n for n in ("mount", "rings") if n in by]
    lo, hi = FIG3_BAND
    band = {n: lo <= c20[n] <= hi for n in mr}
    out.append(Finding("Figure 3",
                       "in mount and rings 20 % of the primitives take 70–80 % of the references",
                       f"C(20 %) in {_pct(lo)}..{_pct(hi)} for mount and rings",
                       ", ".join(f"{n} {_pct(c20[n])}" for n in mr)
                       or "mount and rings not rendered", _verdict(band), per_test,
                       explain([by[n] for n in mr], lambda d: d.c_at(0.2),
                               {n: 0.75 for n in mr}, 0.05)))
    unref = {n: by[n].unreferenced_share for n in mr}
    ok = {n: abs(unref[n] - PAPER_UNREFERENCED[n]) <= TABLE2_TOLERANCE for n in mr}
    out.append(Finding("Figure 3",
                       "primitives never referenced: 20 % in mount, 67 % in rings (C reaches 1 "
                       "at f = 80 % and 33 %)",
                       f"within {_pct(TABLE2_TOLERANCE)} (absolute) of the paper's",
                       "; ".join(f"{n} {_pct(unref[n])} never referenced (C reaches 0.99 / 0.999 / "
                                 f"1 at f = {_pct(by[n].f_reaching(0.99))} / "
                                 f"{_pct(by[n].f_reaching(0.999))} / "
                                 f"{_pct(by[n].f_reaching(1.0))})"
                                 for n in mr) or "mount and rings not rendered",
                       _verdict(ok), per_test,
                       explain([by[n] for n in mr], lambda d: d.unreferenced_share,
                               {n: PAPER_UNREFERENCED[n] for n in mr}, TABLE2_TOLERANCE)))
    c50 = {n: d.c_at(0.5) for n, d in by.items()}
    lo, hi = FIG3_SPAN
    most = {n: c20[n] <= FIG3_MOST <= c50[n] for n in by}
    out.append(Finding("Figure 3",
                       f"references concentrate on {_pct(lo)}–{_pct(hi)} of the primitives",
                       f"{_pct(FIG3_MOST)} of the references fall on between {_pct(lo)} and "
                       f"{_pct(hi)} of the primitives: C({_pct(lo)}) ≤ {_pct(FIG3_MOST)} ≤ "
                       f"C({_pct(hi)}) in every scene",
                       "C(20 %) / C(50 %): "
                       + ", ".join(f"{n} {_pct(c20[n])} / {_pct(c50[n])}" for n in by),
                       _verdict(most), per_test,
                       explain(scenes,
                               lambda d: max(d.c_at(lo) - FIG3_MOST, FIG3_MOST - d.c_at(hi), 0.0),
                               {n: 0.0 for n in by}, 0.0, "how far C misses 80 %")))
    # Figure 4 ---------------------------------------------------------------------------------
    if all(d.fig4 for d in scenes):
        worst = {d.name: max(r[counting]["miss_rate"] for r in d.fig4) for d in scenes}
        out.append(Finding("Figure 4", "cache miss rates are low in every scene",
                           f"miss rate ≤ {_pct(FIG4_LOW)} at every cache size in every scene",
                           "highest miss rate: "
                           + ", ".join(f"{n} {_pct(v, 2)}" for n, v in worst.items()),
                           _verdict({n: v <= FIG4_LOW for n, v in worst.items()}), cnt,
                           "" if all(v <= FIG4_LOW for v in worst.values()) else "unexplained"))
        m10 = {d.name: fig4_miss(d, 0.1, counting) for d in scenes}
        m30 = {d.name: fig4_miss(d, 0.3, counting) for d in scenes}
        m100 = {d.name: fig4_miss(d, 1.0, counting) for d in scenes}
        sat = {n: m30[n] - m100[n] <= FIG4_SATURATION * max(m10[n] - m30[n], 0.0) for n in m30}
        out.append(Finding("Figure 4",
                           "the hit rate saturates once the cache exceeds about 30 % of the "
                           "database",
                           "the hit-rate gain from 30 % to 100 % is at most "
                           f"{_pct(FIG4_SATURATION)} of the gain from 10 % to 30 % "
                           "(docs/databases.md argues it)",
                           "hit-rate gain 10→30 % / 30→100 %: " + ", ".join(
                               f"{n} {100 * (m10[n] - m30[n]):.2f} / "
                               f"{100 * (m30[n] - m100[n]):.2f} points"
                               for n in m30),
                           _verdict(sat), cnt,
                           "" if all(sat.values()) else _fig4_why(scenes, counting)))
    # Figure 5 ---------------------------------------------------------------------------------
    if all(d.fig5 for d in scenes):
        best = {(d.name, L): fig5_best(d, L, counting) for d in scenes for L in LOCAL_SHARES}
        t0 = {(d.name, L): fig5_curve(d, L, counting)[1][0] for d in scenes for L in LOCAL_SHARES}
        lo, hi = FIG5_BEST
        near = {f"{n} {_pct(L)}": lo <= best[(n, L)][0] <= hi for (n, L) in best if L >= 0.3}
        falls = {}
        for (n, L) in best:
            if L >= 0.3:
                x, t = fig5_curve(by[n], L, counting)
                k = int(np.searchsorted(x, best[(n, L)][0] - 1e-9))
                falls[f"{n} {_pct(L)}"] = k > 0 and bool(np.all(t[1:k
                                                                  + 1] <= t[:k] * (1 + FIG5_FALL)))
        out.append(Finding("Figure 5",
                           "for 30 % and 50 % local memory t falls as the resident share grows",
                           "the best split has resident memory, and no step from cache-only to it "
                           f"raises t by more than {_pct(FIG5_FALL)} (relative)",
                           "falls to the best split: "
                           + ", ".join(f"{k} {_yn(v)}" for k, v in falls.items()),
                           _verdict(falls), cnt, "" if all(falls.values()) else "unexplained"))
        out.append(Finding("Figure 5",
                           "for 30 % and 50 % local memory t is lowest near 70 % resident "
                           "(resident : cache ≈ 3 : 1)",
                           f"the lowest t lies at a resident share in {_pct(lo)}..{_pct(hi)}",
                           "lowest t at resident share " + ", ".join(
                               f"{n} {_pct(best[(n, 0.3)][0])}/{_pct(best[(n, 0.5)][0])}" for n in by)
                           + " (30 %/50 % local)", _verdict(near), cnt,
                           "" if all(near.values()) else "unexplained"))
        bigger = {d.name: best[(d.name, 0.1)][1] > best[(d.name, 0.3)][1] > best[(d.name, 0.5)][1]
                  for d in scenes}
        out.append(Finding("Figure 5", "a larger local memory lowers t",
                           "the best t falls from 10 % to 30 % to 50 % local memory in every scene",
                           "best t at 10/30/50 % local: " + ", ".join(
                               f"{n} "
                               + "/".join(f"{best[(n, L)][1]:.2f}"
                                          for L in LOCAL_SHARES) for n in by)
                           + " t_r", _verdict(bigger), cnt,
                           "" if all(bigger.values()) else "unexplained"))
        rise = {}
        for d in scenes:
            x, t = fig5_curve(d, 0.1, counting)
            rise[d.name] = bool(best[(d.name, 0.1)][0] < 0.5 and t[-2] > t[0])
        out.append(Finding("Figure 5", "for 10 % local memory t rises with the resident share",
                           "the best resident share at 10 % local is below 50 % and t at 90 % "
                           "resident exceeds the cache-only t",
                           "best share, t at 90 % vs cache-only: " + ", ".join(
                               f"{d.name} {_pct(best[(d.name, 0.1)][0])}, "
                               f"{fig5_curve(d, 0.1, counting)[1][-2]:.2f} vs "
                               f"{t0[(d.name, 0.1)]:.2f} t_r" for d in scenes), _verdict(rise), cnt,
                           "" if all(rise.values()) else "unexplained"))
        few = {d.name: fig5_row(d, 0.1, 1.0)[counting]["rho"] for d in scenes}
        out.append(Finding("Figure 5",
                           "for 10 % local memory a resident memory catches too few references "
                           "(the paper's reason t rises)",
                           f"ρ below {_pct(FIG5_FEW)} with all of the 10 % local memory resident, "
                           "in every scene",
                           "ρ at 10 % local, all resident: "
                           + ", ".join(f"{n} {v:.3f}" for n, v in few.items()),
                           _verdict({n: v < FIG5_FEW for n, v in few.items()}), cnt,
                           "" if all(v < FIG5_FEW for v in few.values()) else "unexplained"))
        diff = {d.name: (best[(d.name, 0.3)][1] - best[(d.name, 0.5)][1]) / best[(d.name, 0.5)][1]
                for d in scenes}
        out.append(Finding("Figure 5",
                           "30 % and 50 % local memory differ little: about 30 % of the "
                           "database is the cost-effective local memory size",
                           f"best t at 30 % within {_pct(FIG5_CLOSE)} (relative) of the best t at "
                           "50 %",
                           "best t at 30 % above the best at 50 % by " + ", ".join(
                               f"{n} {_pct(v, 1)}" for n, v in diff.items()),
                           _verdict({n: v <= FIG5_CLOSE for n, v in diff.items()}), cnt,
                           "" if all(v <= FIG5_CLOSE for v in diff.values()) else "unexplained"))
        with_res = {(d.name, L): min(t for x, t in zip(*fig5_curve(d, L, counting)) if x > 0)
                    for d in scenes for L in LOCAL_SHARES}
        gain = {k: 1 - with_res[k] / t0[k] for k in best}
        beat = {f"{n} {_pct(L)}": gain[(n, L)] >= FIG5_GAIN for (n, L) in gain if L >= 0.3}
        out.append(Finding("Figure 5", "resident memory beats a cache-only local memory",
                           "at 30 % and 50 % local the best split with resident memory has a t at "
                           f"least {_pct(FIG5_GAIN)} below the cache-only split's",
                           "t saved by the best split with resident memory: " + "; ".join(
                               f"{n} "
                               + "/".join(_pct(gain[(n, L)]) for L in LOCAL_SHARES) for n in by)
                           + " (10/30/50 % local)", _verdict(beat), cnt,
                           "" if all(beat.values()) else "unexplained"))
        low = []
        for d in scenes:
            for L in LOCAL_SHARES:
                for r in d.fig5:
                    if abs(r["local_share"] - L) < 1e-9 and r["resident_split"] > 0 \
                            and 0 < r[counting]["rho"] < LOW_RHO:
                        low.append((d.name, L, r["resident_split"], r[counting]["rho"],
                                    1 - r[counting]["t_measured"] / d.t_r / t0[(d.name, L)]))
        if not low:
            out.append(Finding("Figure 5",
                               "resident memory helps little when its reference share is low",
                               f"wherever 0 < ρ < {LOW_RHO}, t is less than {_pct(LITTLE_GAIN)} "
                               "below cache-only",
                               f"no configuration has 0 < ρ < {LOW_RHO} (lowest ρ with a resident "
                               "memory: "
                               + ", ".join(f"{d.name} "
                                           f"{min(r[counting]['rho'] for r in d.fig5 if r['resident_split'] > 0):.3f}"
                                           for d in scenes) + ")", "not testable here", cnt))
        else:
            held = {f"{n} {_pct(L)}/{_pct(s)}": g < LITTLE_GAIN for n, L, s, rho, g in low}
            worst_gain = max(low, key=lambda x: x[4])
            out.append(Finding("Figure 5",
                               "resident memory helps little when its reference share is low",
                               f"wherever 0 < ρ < {LOW_RHO}, t is less than {_pct(LITTLE_GAIN)} "
                               "below cache-only",
                               f"{len(low)} configurations with 0 < ρ < {LOW_RHO}; the largest "
                               f"gain among them: {worst_gain[0]} at {_pct(worst_gain[1])} local, "
                               f"{_pct(worst_gain[2])} resident (ρ {worst_gain[3]:.3f}): "
                               f"{_pct(worst_gain[4], 1)}", _verdict(held), cnt,
                               "" if all(held.values()) else "unexplained"))
    return out


def machine_findings(checks: list[dict]) -> list[Finding]:
    """The claims only the machine can test, from `--on-machine`'s checks: §4.3's pre-pass cost
    (the coarse render's machine cycles as a share of the main pass's, same serial mode)."""
    main = [c for c in checks if not c.get("point") and c.get("prepass")
            and c.get("status") in ("halted", "finished")]
    if not main:
        return []
    share = {c["scene"]: c["prepass"]["cycles"] / c["cycles"] for c in main}
    lo, hi = PREPASS_BAND
    ok = {n: lo <= v <= hi for n, v in share.items()}
    return [Finding("§4.3", f"the pre-pass costs about {_pct(PREPASS_SHARE)} of the main pass",
                    f"the pre-pass's machine cycles are {_pct(lo, 1)}..{_pct(hi)} of the main "
                    "pass's",
                    ", ".join(f"{c['scene']} {_pct(share[c['scene']], 2)} "
                              f"({c['prepass']['resolution']}² pre-pass: "
                              f"{c['prepass']['cycles']:,} of {c['cycles']:,} "
                              "cycles)" for c in main),
                    _verdict(ok), "machine cycles, serial ray-tree mode",
                    "" if all(ok.values()) else "unexplained")]


def _fig4_why(scenes: list[SceneData], counting: str) -> str:
    """What the misses past 30 % are: the 100 % cache holds the whole database, so its misses
    are cold misses plus direct-mapped conflicts; a 30 % cache adds capacity misses."""
    parts = []
    for d in scenes:
        m = [fig4_miss(d, s, counting) for s in (0.3, 0.5, 0.7, 1.0)]
        parts.append(f"{d.name} {' → '.join(_pct(v, 2) for v in m)}")
    return ("unexplained: the misses keep falling from 30 % to 50 %, 70 % and 100 % of the "
            "database ("
            + "; ".join(parts)
            + "): capacity misses persist past 30 %; neither the paper's curve nor "
            "an experiment here says why the paper's stopped")


def verdict_counts(items: list[Finding]) -> dict[str, int]:
    out: dict[str, int] = {}
    for f in items:
        out[f.verdict] = out.get(f.verdict, 0) + 1
    return out
