"""Every claim of the paper's §4.3, §5 and §6 as a `Finding`: a measured quantity, the
threshold that decides it (reports/paper_judge.py: one tolerance rule, one "partly", trend tests
for "tends to" claims), the margin to that threshold per case and k of n cases passing.

Split from reports/paper.py (tables, helpers, candidate readings), which calls `claims` from its
`findings`. Each threshold's reason is in docs/databases.md ("How the findings are judged").
"""

from __future__ import annotations

from netsushisen.reports.paper import (PAPER_RES, PAPER_TABLE2, Finding, _by, _pct, _sampling_why,
                                       explain, fig4_miss, fig5_best, fig5_curve, fig5_row, table1,
                                       table2)
from netsushisen.reports.paper_data import COUNTINGS, LOCAL_SHARES, SceneData
from netsushisen.reports.paper_judge import (THRESHOLDS, band_margin, margin_text, passes, plain,
                                             points, relative, trend_margin, verdict,
                                             alpha_less_p)

T = THRESHOLDS
PAPER_UNREFERENCED = {"mount": 0.20, "rings": 0.67}  # Fig 3: never referenced (C = 1 at 1 − this)
PAPER_PREPASS = 0.01  # §4.3: the pre-pass costs about 1 % of the main pass
SPLIT_STEP = 0.1  # Figure 5's grid of resident splits (the tolerance rule's "one step")
VISIBLE_GROUPS = (("tetra", "balls"), ("mount", "rings"))  # §5: visible share higher in the first
REFERENCE_GROUPS = (("balls", "rings"), ("tetra", "mount"))  # §5: reference share higher in the first


def _finding(figure: str, paper: str, test: str, ours: str, margins: dict[str, float],
             counting: str, why=lambda: "unexplained", fmt=points, what: str = "scenes",
             strict: bool = False) -> Finding:
    """One finding judged by the rules of paper_judge: verdict from the margins, the margin text,
    and `why()` (evaluated only when the finding does not agree)."""
    v = verdict(passes(margins, strict))
    return Finding(figure, paper, test, ours, v, counting,
                   why() if v not in ("agree", "not evaluated") else "",
                   margin=margin_text(margins, fmt, what) if margins else "",
                   margins=dict(margins))


def _over_splits(d: SceneData, local: float, key: str, counting: str, top: float
                 ) -> tuple[list[float], list[float]]:
    rows = [r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9
            and r["resident_split"] <= top + 1e-9
            and (key != "mu" or r[counting]["cache_accesses"] > 0)]  # μ needs cache accesses
    x = [r["resident_split"] for r in rows]
    y = [r[counting][key] / (d.t_r if key == "t_measured" else 1) for r in rows]
    return x, y


def _groups(values: dict[str, float], groups) -> dict[str, float]:
    """Margins of "every scene of the first group above every scene of the second", per pair."""
    first, second = groups
    if not all(n in values for n in first + second):
        return {}
    return {f"{a} > {b}": values[a] - values[b] for a in first for b in second}


def claims(scenes: list[SceneData], counting: str) -> list[Finding]:  # noqa: C901 (one per claim)
    by = _by(scenes)
    out: list[Finding] = []
    if not scenes:
        return out
    cnt = f"{COUNTINGS[counting]}; {scenes[0].options.describe()}"
    per_test = "tests per primitive (every ray kind)"
    tol = f"within {100 * T['TOLERANCE']:.0f} points (the tolerance rule)"

    # Table 1 ----------------------------------------------------------------------------------
    rows1 = [r for r in table1(scenes) if r["equal"] is not None]
    diffs = [f"{r['scene']} {r['column']} {r['ours']} (paper {r['paper']})" for r in rows1
             if not r["equal"]]
    m1 = {n: 0.0 - sum(1 for r in rows1 if r["scene"] == n and not r["equal"])
          for n in dict.fromkeys(r["scene"] for r in rows1)}
    out.append(_finding("Table 1", "tetra 4096 polygons; balls 7381 spheres + 1 polygon; mount 8192 "
                                   "polygons + 4 spheres; rings 4200 spheres + 4200 cylinders + 1 "
                                   "polygon; lights 1/3/1/3; balls, mount, rings reflective; mount "
                                   "transparent", "every column equal",
                        "every column equal" if not diffs else "; ".join(diffs), m1,
                        "scene files", lambda: "unexplained: our SPD generators are ports of "
                        "Haines's current SPD; the paper may have used an older version (not "
                        "tested)", fmt=lambda m: f"{-m:.0f} columns differ"))
    # Table 2 ----------------------------------------------------------------------------------
    rows = [r for r in table2(scenes) if r["visible_share_paper"] is not None]
    vis = {r["scene"]: band_margin(r["visible_share_ours"], r["visible_share_paper"],
                                   r["visible_share_paper"]) for r in rows}
    out.append(_finding("Table 2", "visible primitives: " + ", ".join(
        f"{n} {_pct(PAPER_TABLE2[n][1])}" for n in vis), f"share {tol} of the paper's",
        "; ".join(f"{r['scene']} {r['visible_ours']} ({_pct(r['visible_share_ours'])})"
                  for r in rows), vis, "eye rays' hits",
        lambda: (f"at {scenes[0].res}×{scenes[0].res} fewer eye rays hit fewer primitives (not "
                 "an experiment)" if scenes[0].res < PAPER_RES
                 else _sampling_why(scenes[0].corners))))
    target = {n: PAPER_TABLE2[n][2] for n in vis}
    ref = {r["scene"]: band_margin(r["reference_share_ours"], r["reference_share_paper"],
                                   r["reference_share_paper"]) for r in rows}
    out.append(_finding("Table 2", "share of references to visible primitives: " + ", ".join(
        f"{n} {_pct(target[n])}" for n in ref), f"{tol} of the paper's",
        ", ".join(f"{r['scene']} {_pct(r['reference_share_ours'])}" for r in rows), ref, per_test,
        lambda: explain(scenes, lambda d: d.visible_reference_share, target, T["TOLERANCE"])))
    share = {d.name: (d.visible_share, d.visible_reference_share) for d in scenes}
    ratio = {n: r - T["VISIBLE_RATIO"] * v for n, (v, r) in share.items()}
    out.append(_finding("Table 2", "the visible primitives take a larger share of the references "
                        "than their share of the primitives (the paper's support for ranking "
                        "by visibility)",
                        "share of references to visible primitives > their share of all "
                        "primitives, in every scene (ratio > 1: equal references per primitive "
                        "give ratio 1)",
                        ", ".join(f"{n} {_pct(r)} of references / {_pct(v)} of primitives "
                                  f"(ratio {r / v if v else float('inf'):.2f})"
                                  for n, (v, r) in share.items()),
                        ratio, per_test, strict=True))
    for groups, i, name in ((VISIBLE_GROUPS, 0, "visible share"),
                            (REFERENCE_GROUPS, 1, "share of references to visible primitives")):
        m = _groups({n: s[i] for n, s in share.items()}, groups)
        a, b = groups
        out.append(_finding("Table 2", f"scene order by {name}: {' and '.join(a)} above "
                            f"{' and '.join(b)}",
                            f"every scene of {'/'.join(a)} above every scene of {'/'.join(b)}",
                            ", ".join(f"{n} {_pct(s[i])}" for n, s in share.items())
                            if m else f"needs all of {', '.join(a + b)}", m,
                            "eye rays' hits" if i == 0 else per_test, what="pairs", strict=True))
    # Figure 3 ---------------------------------------------------------------------------------
    c20 = {n: d.c_at(0.2) for n, d in by.items()}
    out.append(_finding("Figure 3", "references are skewed in every scene",
                        f"C(20 %) ≥ {_pct(T['SKEW'])} (twice the uniform 20 %) in every scene",
                        "C(20 %): " + ", ".join(f"{n} {_pct(v)}" for n, v in c20.items()),
                        {n: v - T["SKEW"] for n, v in c20.items()}, per_test))
    mr = [n for n in ("mount", "rings") if n in by]
    lo = T["FIG3_LEVEL"]
    out.append(_finding("Figure 3",
                        "in mount and rings 20 % of the primitives take 70–80 % of the references",
                        f"one-sided (the claim is concentration): C(20 %) ≥ {_pct(lo)} less the "
                        "tolerance, for mount and rings",
                        ", ".join(f"{n} {_pct(c20[n])}" for n in mr)
                        or "mount and rings not rendered",
                        {n: band_margin(c20[n], lo=lo) for n in mr}, per_test,
                        lambda: explain([by[n] for n in mr], lambda d: d.c_at(0.2),
                                        {n: lo for n in mr}, 0.0, "C(20 %)",
                                        met=lambda v, n: band_margin(v, lo=lo) >= 0,
                                        goal=f"C(20 %) ≥ {_pct(lo - T['TOLERANCE'])}")))
    unref = {n: by[n].unreferenced_share for n in mr}
    out.append(_finding("Figure 3",
                        "primitives never referenced: 20 % in mount, 67 % in rings (C reaches 1 "
                        "at f = 80 % and 33 %)", f"{tol} of the paper's",
                        "; ".join(f"{n} {_pct(unref[n])} never referenced (C reaches 0.99 / 0.999 "
                                  f"/ 1 at f = {_pct(by[n].f_reaching(0.99))} / "
                                  f"{_pct(by[n].f_reaching(0.999))} / "
                                  f"{_pct(by[n].f_reaching(1.0))})"
                                  for n in mr) or "mount and rings not rendered",
                        {n: band_margin(unref[n], PAPER_UNREFERENCED[n], PAPER_UNREFERENCED[n])
                         for n in mr}, per_test,
                        lambda: explain([by[n] for n in mr], lambda d: d.unreferenced_share,
                                        {n: PAPER_UNREFERENCED[n] for n in mr}, T["TOLERANCE"])))
    hi = T["FIG3_SPAN_HIGH"]
    f70 = {n: d.f_reaching(lo) for n, d in by.items()}
    out.append(_finding("Figure 3",
                        "references concentrate on 20–50 % of the primitives (§6: 30–50 %)",
                        f"one-sided, the upper end both versions share: the primitives that take "
                        f"{_pct(lo)} of the references (the paper's own Figure 3 level) are at "
                        f"most {_pct(hi)} of them, plus the tolerance, in every scene",
                        f"f where C reaches {_pct(lo)}: "
                        + ", ".join(f"{n} {_pct(v)}" for n, v in f70.items()),
                        {n: band_margin(v, hi=hi) for n, v in f70.items()}, per_test,
                        lambda: explain(scenes, lambda d: d.f_reaching(lo), {n: hi for n in by},
                                        0.0, f"f where C reaches {_pct(lo)}",
                                        met=lambda v, n: band_margin(v, hi=hi) >= 0,
                                        goal=f"f ≤ {_pct(hi + T['TOLERANCE'])}")))
    if all(d.fig4 for d in scenes):
        out += _figure4(scenes, counting, cnt)
    if all(d.fig5 for d in scenes):
        out += _figure5(scenes, counting, cnt)
    return out


def _figure4(scenes: list[SceneData], counting: str, cnt: str) -> list[Finding]:
    out = []
    worst = {d.name: max(r[counting]["miss_rate"] for r in d.fig4) for d in scenes}
    out.append(_finding("Figure 4", "cache miss rates are low in every scene",
                        f"miss rate ≤ {_pct(T['FIG4_LOW'])} at every cache size in every scene",
                        "highest miss rate: "
                        + ", ".join(f"{n} {_pct(v, 2)}" for n, v in worst.items()),
                        {n: T["FIG4_LOW"] - v for n, v in worst.items()}, cnt))
    m10 = {d.name: fig4_miss(d, 0.1, counting) for d in scenes}
    m30 = {d.name: fig4_miss(d, 0.3, counting) for d in scenes}
    m100 = {d.name: fig4_miss(d, 1.0, counting) for d in scenes}
    sat = T["FIG4_SATURATION"]
    out.append(_finding("Figure 4",
                        "the hit rate saturates once the cache exceeds about 30 % of the database",
                        f"the hit-rate gain from 30 % to 100 % is at most {_pct(sat)} of the gain "
                        "from 10 % to 30 % (docs/databases.md argues it; changed 2026-11-26, "
                        "recorded there)",
                        "hit-rate gain 10→30 % / 30→100 %: " + ", ".join(
                            f"{n} {100 * (m10[n] - m30[n]):.2f} / "
                            f"{100 * (m30[n] - m100[n]):.2f} points" for n in m30),
                        {n: sat * max(m10[n] - m30[n], 0.0) - (m30[n] - m100[n]) for n in m30},
                        cnt, lambda: fig4_why(scenes, counting)))
    return out


def _figure5(scenes: list[SceneData], counting: str, cnt: str) -> list[Finding]:  # noqa: C901
    out = []
    by = _by(scenes)
    best = {(d.name, L): fig5_best(d, L, counting) for d in scenes for L in LOCAL_SHARES}
    t0 = {(d.name, L): fig5_curve(d, L, counting)[1][0] for d in scenes for L in LOCAL_SHARES}
    near = T["FIG5_NEAR"]
    falls, falls_text = {}, []
    for d in scenes:
        for L in (0.3, 0.5):
            m, text = trend_margin(*_over_splits(d, L, "t_measured", counting, near), -1)
            falls[f"{d.name} {_pct(L)}"] = m
            falls_text.append(f"{d.name} {_pct(L)} {text}")
    trend_rule = (f"Kendall's τ < 0 at one-sided p ≤ {_pct(T['TREND_ALPHA'])}")
    out.append(_finding("Figure 5", "for 30 % and 50 % local memory t falls as the resident share "
                        "grows", f"a trend: over the splits 0–{_pct(near)} (up to the paper's "
                        f"best) {trend_rule}, per scene and local size",
                        "t against the split: " + "; ".join(falls_text), falls, cnt,
                        fmt=alpha_less_p, what="scene × local cases"))
    out.append(_finding("Figure 5", "for 30 % and 50 % local memory t is lowest near 70 % resident "
                        "(resident : cache ≈ 3 : 1)",
                        f"the lowest t lies at {_pct(near)} resident within the tolerance rule "
                        f"(one step of the {_pct(SPLIT_STEP)} grid)",
                        "lowest t at resident share " + ", ".join(
                            f"{n} {_pct(best[(n, 0.3)][0])}/{_pct(best[(n, 0.5)][0])}" for n in by)
                        + " (30 %/50 % local)",
                        {f"{n} {_pct(L)}": band_margin(best[(n, L)][0], near, near, SPLIT_STEP)
                         for (n, L) in best if L >= 0.3}, cnt, what="scene × local cases"))
    lowers, worst = {}, {}
    for d in scenes:
        curves = [fig5_curve(d, L, counting) for L in LOCAL_SHARES]
        drops = [(min((a - b) / b for a, b in zip(ts[:-1], ts[1:])), x, ts)
                 for x, ts in zip(curves[0][0], zip(*(c[1] for c in curves)))]
        lowers[d.name], *worst[d.name] = min(drops, key=lambda r: r[0])
    out.append(_finding("Figure 5", "a larger local memory lowers t",
                        "per split: t falls from 10 % to 30 % to 50 % local memory at every "
                        "resident split (not only the best t)",
                        "smallest drop, at its split (t at 10/30/50 % local): " + ", ".join(
                            f"{n} {_pct(lowers[n], 1)} at {_pct(worst[n][0])} resident ("
                            + "/".join(f"{v:.3f}" for v in worst[n][1]) + " t_r)"
                            for n in lowers), lowers, cnt, fmt=relative, strict=True))
    rise, rise_text = {}, []
    for d in scenes:
        m, text = trend_margin(*_over_splits(d, 0.1, "t_measured", counting, 0.9), +1)
        rise[d.name] = m
        rise_text.append(f"{d.name} {text}")
    out.append(_finding("Figure 5", "for 10 % local memory t rises with the resident share",
                        "a trend: over the splits 0–90 % (with a cache) Kendall's τ > 0 at "
                        f"one-sided p ≤ {_pct(T['TREND_ALPHA'])}, per scene",
                        "t against the split at 10 % local: " + "; ".join(rise_text), rise, cnt,
                        fmt=alpha_less_p))
    few, star = {}, {}
    for d in scenes:
        tg = d.t_g / d.t_r
        star[d.name] = (tg - t0[(d.name, 0.1)]) / (tg - 1)
        few[d.name] = star[d.name] - fig5_row(d, 0.1, 1.0)[counting]["rho"]
    out.append(_finding("Figure 5", "for 10 % local memory a resident memory catches too few "
                        "references (the paper's reason t rises)",
                        "with all of the 10 % local memory resident, ρ is below ρ* = (t_g − t0) / "
                        "(t_g − t_r), the ρ at which an all-resident memory would match the "
                        "cache-only t0 (the paper's formula), in every scene",
                        "ρ vs ρ* at 10 % local, all resident: " + ", ".join(
                            f"{n} {fig5_row(by[n], 0.1, 1.0)[counting]['rho']:.3f} vs "
                            f"{star[n]:.3f}" for n in few), few, cnt, fmt=plain, strict=True))
    diff = {d.name: (best[(d.name, 0.3)][1] - best[(d.name, 0.5)][1]) / best[(d.name, 0.5)][1]
            for d in scenes}
    out.append(_finding("Figure 5", "30 % and 50 % local memory differ little: about 30 % of the "
                        "database is the cost-effective local memory size",
                        f"best t at 30 % within {_pct(T['FIG5_CLOSE'])} (relative) of the best t "
                        "at 50 %", "best t at 30 % above the best at 50 % by " + ", ".join(
                            f"{n} {_pct(v, 1)}" for n, v in diff.items()),
                        {n: T["FIG5_CLOSE"] - v for n, v in diff.items()}, cnt, fmt=relative))
    with_res = {(d.name, L): min(t for x, t in zip(*fig5_curve(d, L, counting)) if x > 0)
                for d in scenes for L in LOCAL_SHARES}
    gain = {k: 1 - with_res[k] / t0[k] for k in best}
    out.append(_finding("Figure 5", "resident memory beats a cache-only local memory",
                        "at 30 % and 50 % local the best split with resident memory has a t at "
                        f"least {_pct(T['FIG5_GAIN'])} below the cache-only split's",
                        "t saved by the best split with resident memory: " + "; ".join(
                            f"{n} " + "/".join(_pct(gain[(n, L)]) for L in LOCAL_SHARES)
                            for n in by) + " (10/30/50 % local)",
                        {f"{n} {_pct(L)}": gain[(n, L)] - T["FIG5_GAIN"]
                         for (n, L) in gain if L >= 0.3}, cnt, fmt=relative,
                        what="scene × local cases"))
    low_rho, little = T["LOW_RHO"], T["LITTLE_GAIN"]
    low = {}
    for d in scenes:
        for r in d.fig5:
            if r["resident_split"] > 0 and 0 < r[counting]["rho"] < low_rho:
                L, s = r["local_share"], r["resident_split"]
                low[f"{d.name} {_pct(L)}/{_pct(s)} (ρ {r[counting]['rho']:.2f})"] = (
                    little - (1 - r[counting]["t_measured"] / d.t_r / t0[(d.name, L)]))
    test = f"wherever 0 < ρ < {low_rho}, t is less than {_pct(little)} below cache-only"
    if not low:
        out.append(Finding("Figure 5", "resident memory helps little when its reference share is "
                           "low", test, f"no configuration has 0 < ρ < {low_rho}",
                           "not testable here", cnt))
    else:
        out.append(_finding("Figure 5", "resident memory helps little when its reference share "
                            "is low", test, f"{len(low)} configurations with 0 < ρ < {low_rho}",
                            low, cnt, fmt=relative, what="configurations", strict=True))
    # §5.2.3's mechanisms ------------------------------------------------------------------
    mu, mu_text = {}, []
    for d in scenes:
        for L in LOCAL_SHARES:
            m, text = trend_margin(*_over_splits(d, L, "mu", counting, 0.9), -1)
            mu[f"{d.name} {_pct(L)}"] = m
            mu_text.append(f"{d.name} {_pct(L)} {text}")
    out.append(_finding("Figure 5", "μ falls as the resident share grows (§5.2.3: the resident "
                        "memory takes the most-referenced primitives from the cache)",
                        "a trend: over the splits 0–90 % (with a cache) Kendall's τ < 0 at "
                        f"one-sided p ≤ {_pct(T['TREND_ALPHA'])}, per scene and local size",
                        "μ against the split: " + "; ".join(mu_text), mu, cnt, fmt=alpha_less_p,
                        what="scene × local cases"))
    for key, name, splits in (("rho", "ρ", (0.1, 1.0)), ("mu", "μ", (0.0, 0.9))):
        grows, where = {}, {}
        for d in scenes:
            steps = []
            for r in d.fig5:
                s = r["resident_split"]
                if abs(r["local_share"] - LOCAL_SHARES[0]) < 1e-9 and \
                        splits[0] - 1e-9 <= s <= splits[1] + 1e-9:
                    rs = [fig5_row(d, L, s)[counting] for L in LOCAL_SHARES]
                    if key == "mu" and any(r["cache_accesses"] == 0 for r in rs):
                        continue  # no reference went through the cache: μ is undefined
                    v = [r[key] for r in rs]
                    steps.append((min(b - a for a, b in zip(v[:-1], v[1:])), s))
            if steps:
                grows[d.name], where[d.name] = min(steps)
        out.append(_finding("Figure 5", f"{name} rises with the local memory size (§5.2.3)",
                            f"per split ({_pct(splits[0])}–{_pct(splits[1])}): {name} rises from "
                            "10 % to 30 % to 50 % local memory at every split",
                            "smallest rise, at its split: " + ", ".join(
                                f"{n} {grows[n]:+.3f} at {_pct(where[n])} resident"
                                for n in grows), grows, cnt, fmt=plain, strict=True))
    return out


def machine_findings(checks: list[dict]) -> list[Finding]:
    """§4.3's pre-pass cost from `--on-machine`'s checks (the coarse render's machine cycles as a
    share of the main pass's, same serial mode); without them the finding says what would
    evaluate it. One-sided: a pre-pass cheaper than the paper's agrees."""
    paper = f"the pre-pass costs about {_pct(PAPER_PREPASS)} of the main pass"
    most = T["PREPASS_MAX"]
    test = (f"one-sided: the pre-pass's machine cycles are at most {_pct(most)} of the main "
            "pass's (twice the paper's)")
    main = [c for c in checks if not c.get("point") and c.get("prepass")
            and c.get("status") in ("halted", "finished")]
    if not main:
        return [Finding("§4.3", paper, test, "not run here: `paper --on-machine` renders the "
                        "pre-pass and the main pass on the machine and compares their cycles",
                        "not evaluated", "machine cycles, serial ray-tree mode")]
    share = {c["scene"]: c["prepass"]["cycles"] / c["cycles"] for c in main}
    return [_finding("§4.3", paper, test,
                     ", ".join(f"{c['scene']} {_pct(share[c['scene']], 2)} "
                               f"({c['prepass']['resolution']}² pre-pass: "
                               f"{c['prepass']['cycles']:,} of {c['cycles']:,} cycles)"
                               for c in main),
                     {n: most - v for n, v in share.items()},
                     "machine cycles, serial ray-tree mode", fmt=relative)]


def fig4_why(scenes: list[SceneData], counting: str) -> str:
    """What the misses past 30 % do, read off the curve (they need not fall: a direct-mapped
    cache can miss more at a larger size when the records' blocks collide differently)."""
    parts, rising = [], []
    for d in scenes:
        m = [fig4_miss(d, s, counting) for s in (0.3, 0.5, 0.7, 1.0)]
        parts.append(f"{d.name} {' → '.join(_pct(v, 2) for v in m)}")
        if any(b > a for a, b in zip(m[:-1], m[1:])):
            rising.append(d.name)
    return ("unexplained: from 30 % to 50 %, 70 % and 100 % of the database the miss rate goes "
            + "; ".join(parts)
            + (f" (in {', '.join(rising)} it rises at some step: direct-mapped conflicts)"
               if rising else "")
            + "; the drop past 30 % is more than the test allows; neither the paper's curve nor "
            "an experiment here says why the paper's stopped")
