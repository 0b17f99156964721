"""The paper's findings are checks that can fail: on synthetic data built to match every claim
of the paper each finding agrees, and one perturbation per finding — a different outcome of the
measured quantity — flips that finding's verdict (reports/paper.py)."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from netsushisen.reports.paper import PAPER_TABLE1, PAPER_TABLE2, explain, findings
from netsushisen.reports.paper_data import (CACHE_SHARES, LOCAL_SHARES, RESIDENT_SPLITS, PaperOptions,
                                            SceneData)

N = {"tetra": 4096, "balls": 7382, "mount": 8196, "rings": 8401}
UNREFERENCED = {"tetra": 0.67, "balls": 0.67, "mount": 0.20, "rings": 0.67}
C20 = 0.78  # inside the paper's 70–80 %


def _refs(name: str) -> tuple[np.ndarray, np.ndarray]:
    """References and visible ids with the paper's Table 2 shares, C(20 %) = 78 % and the
    paper's never-referenced shares: group A (top 20 %) takes 78 %, group B the rest of the
    referenced; visible = part of A plus unreferenced ones."""
    n = N[name]
    vis_share, ref_share = PAPER_TABLE2[name][1:]
    na, nc = int(0.2 * n), int(round(UNREFERENCED[name] * n))
    nb = n - na - nc
    total = 10 ** 7
    refs = np.zeros(n, np.int64)
    refs[:na] = int(C20 * total / na)
    refs[na:na + nb] = int((1 - C20) * total / nb)
    xa = int(round(ref_share / C20 * na))
    visible = np.r_[np.arange(xa), np.arange(na + nb, na + nb + int(round(vis_share * n)) - xa)]
    return refs, visible


def _row(t: float, rho: float, miss: float) -> dict:
    return {"rho": rho, "mu": 1 - miss, "miss_rate": miss, "t_measured": t, "t_model": t, "loads": 1000,
            "resident": int(1000 * rho), "cache_accesses": 1000 - int(1000 * rho), "cache_hits": 0}


def paper_world_t(local: float, split: float) -> float:
    if local < 0.3:
        return 3.0 + split  # 10 % local: t rises with the resident share
    base = 2.0 if local < 0.4 else 1.9
    return base + 0.5 * abs(split - 0.7)  # lowest at 70 %


def paper_world_rho(local: float, split: float) -> float:
    return split * (0.4 + local)  # 10 % local: too small to catch many references; ρ grows with it


def paper_world_mu(local: float, split: float) -> float:
    return 0.9 - 0.2 * split + 0.1 * local  # §5.2.3: μ falls with the split, rises with the size


def scene(name: str, t=paper_world_t, miss=None, rho=paper_world_rho, mu=paper_world_mu) -> SceneData:
    refs, visible = _refs(name)
    miss = miss or (lambda share: {0.1: 0.05, 0.2: 0.03}.get(share, 0.0215 if share < 1 else 0.02))
    counts = dict(zip(("primitives", "polygons", "spheres", "cones", "cylinders", "lights", "reflective",
                       "transparent"), PAPER_TABLE1[name]))
    d = SceneData(name=name, res=512, corners=False, precision="fp32", counts=counts,
                  database_bytes={"primitive_list": 100, "shape_data": 200},
                  primitive_database_bytes=200, rays={}, references=refs, visible=visible,
                  prepass={"resolution": 51}, options=PaperOptions(), experiments={"as rendered": refs})
    for share in CACHE_SHARES:
        r = _row(1.0, 0.0, miss(share))
        d.fig4.append({"cache_share": share, "resident_count": 0, "cache_bytes": 64, "ref": r, "all": r, "shape": r})
    for L in LOCAL_SHARES:
        for s in RESIDENT_SPLITS:
            r = _row(t(L, s), rho(L, s), 1 - mu(L, s))
            d.fig5.append({"local_share": L, "resident_split": s, "resident_count": int(100 * s),
                           "cache_bytes": 64, "ref": r, "all": r, "shape": r})
    return d


def world(**kw) -> list[SceneData]:
    return [scene(n, **kw) for n in N]


def verdicts(scenes: list[SceneData]) -> dict[str, str]:
    return {f"{f.figure}: {f.paper}": f.verdict for f in findings(scenes, "ref")}


def key(scenes_verdicts: dict[str, str], start: str) -> str:
    (k,) = [k for k in scenes_verdicts if k.startswith(start)]
    return k


def test_the_papers_world_agrees_with_every_finding():
    v = verdicts(world())
    assert len(v) == 23
    assert all(x == "agree" for x in v.values()), {k: x for k, x in v.items() if x != "agree"}
    assert all(f.test and f.counting for f in findings(world(), "ref"))


def _changed(scenes: list[SceneData], name: str, **fields) -> list[SceneData]:
    out = []
    for d in scenes:
        if d.name == name:
            d = copy.copy(d)
            for k, val in fields.items():
                setattr(d, k, val)
        out.append(d)
    return out


def _uniform(name: str) -> np.ndarray:
    return np.full(N[name], 7, np.int64)


def _concentrated(name: str) -> np.ndarray:
    refs = np.zeros(N[name], np.int64)
    refs[: int(0.1 * N[name])] = 1000
    refs[int(0.1 * N[name]): int(0.8 * N[name])] = 1
    return refs


def _spread(name: str) -> np.ndarray:
    """C(20 %) = 50 %: the top fifth takes four times the rest's references per primitive."""
    refs = np.ones(N[name], np.int64)
    refs[: int(0.2 * N[name])] = 4
    return refs


def _only_at(split: float, dt: float):
    """The paper's world with t at 50 % local raised by `dt` at one split only."""
    return lambda L, s: paper_world_t(L, s) + (dt if L > 0.4 and abs(s - split) < 1e-9 else 0)


PERTURBATIONS = {
    "Table 1": lambda: _changed(world(), "rings", counts=dict(scene("rings").counts, cylinders=4199)),
    "Table 2: visible primitives": lambda: _changed(world(), "mount", visible=np.arange(3000)),
    "Table 2: share of references": lambda: _changed(world(), "tetra", visible=np.arange(4000, 4096)),
    "Figure 3: references are skewed": lambda: _changed(world(), "tetra", references=_uniform("tetra")),
    "Figure 3: in mount and rings": lambda: _changed(world(), "mount", references=_spread("mount")),
    "Figure 3: primitives never referenced": lambda: _changed(world(), "rings", references=_uniform("rings")),
    "Figure 4: cache miss rates are low": lambda: world(miss=lambda s: 0.2 if s < 0.2 else 0.02),
    "Figure 4: the hit rate saturates": lambda: world(miss=lambda s: 0.02 if s == 1.0 else 0.04),
    "Figure 3: references concentrate": lambda: _changed(world(), "balls", references=_uniform("balls")),
    "Figure 5: for 30 % and 50 % local memory t falls": lambda: world(
        t=lambda L, s: paper_world_t(L, s) if L < 0.3 else 2.0 + 0.3 * s - (0.5 if s == 0.7 else 0)),
    "Figure 5: for 30 % and 50 % local memory t is lowest": lambda: world(
        t=lambda L, s: paper_world_t(L, s) if L < 0.3 else 2.0 + 0.5 * abs(s - 0.3)),
    "Figure 5: a larger local memory": lambda: world(t=lambda L, s: paper_world_t(L, s) + (0.2 if L > 0.4 else 0)),
    "Figure 5: for 10 % local memory t rises": lambda: world(
        t=lambda L, s: 4.0 - s if L < 0.3 else paper_world_t(L, s)),
    "Figure 5: for 10 % local memory a resident": lambda: world(rho=lambda L, s: s),
    "Figure 5: 30 % and 50 %": lambda: world(t=lambda L, s: paper_world_t(L, s) - (1.0 if L > 0.4 else 0)),
    "Figure 5: resident memory beats": lambda: world(t=lambda L, s: 2.0 + s),
    "Figure 5: resident memory helps little": lambda: world(t=lambda L, s: paper_world_t(L, s) - (0.5 if 0 < s < 0.3 else 0)),
    "Table 2: the visible primitives take": lambda: _changed(world(), "tetra", visible=np.arange(4000, 4096)),
    "Table 2: scene order by visible share": lambda: _changed(world(), "mount", visible=np.arange(4000)),
    "Table 2: scene order by share of references": lambda: _changed(
        world(), "tetra", visible=np.arange(int(0.2 * N["tetra"]))),
    "Figure 5: μ falls as the resident share": lambda: world(mu=lambda L, s: 0.5 + 0.3 * s),
    "Figure 5: ρ rises with the local memory": lambda: world(rho=lambda L, s: 0.5 * s),
    "Figure 5: μ rises with the local memory": lambda: world(mu=lambda L, s: 0.9 - 0.2 * s),
    "Figure 5: a larger local memory lowers t (one split)": lambda: world(t=_only_at(0.3, 0.2)),
}


@pytest.mark.parametrize("start", list(PERTURBATIONS))
def test_each_finding_flips_on_data_that_violates_it(start):
    before = verdicts(world())
    after = verdicts(PERTURBATIONS[start]())
    k = key(after, start.removesuffix(" (one split)"))
    assert before[k] == "agree"
    assert after[k] in ("differ", "partly"), (k, after[k])
    # the perturbation violates its own finding (others may move along, e.g. a uniform scene)


def test_a_finding_without_its_premise_is_not_testable_here():
    """No configuration with a low ρ: 'helps little when ρ is low' is never agreement."""
    v = verdicts(world(rho=lambda L, s: 0.5 + 0.5 * s))
    assert v[key(v, "Figure 5: resident memory helps little")] == "not testable here"


def test_counting_is_chosen_per_finding():
    """Figures 4–5 read the counting asked for: per word data that violate Figure 4 flip only
    the per-word verdict."""
    scenes = world()
    for d in scenes:
        for r in d.fig4:
            r["all"] = _row(1.0, 0.0, 0.3)
    ref = {f.paper: f.verdict for f in findings(scenes, "ref")}
    word = {f.paper: f.verdict for f in findings(scenes, "all")}
    assert ref["cache miss rates are low in every scene"] == "agree"
    assert word["cache miss rates are low in every scene"] == "differ"
    assert "per word" in next(f.counting for f in findings(scenes, "all") if f.figure == "Figure 4")


def test_explanations_name_the_experiment_that_accounts_for_a_difference():
    scenes = _changed(world(), "rings", references=_uniform("rings"))
    d = next(x for x in scenes if x.name == "rings")
    fixed, _ = _refs("rings")
    d.experiments = {"as rendered": d.references, "no shadow rays": fixed, "eye rays only": _uniform("rings")}
    why = explain([d], lambda x: x.unreferenced_share, {"rings": 0.67}, 0.05)
    assert why.startswith("explained by no shadow rays") and "rings 0 % → 67 %" in why
    d.experiments = {"as rendered": d.references, "eye rays only": _uniform("rings")}
    assert explain([d], lambda x: x.unreferenced_share, {"rings": 0.67}, 0.05).startswith("unexplained")


def test_f_where_c_reaches_a_level():
    d = scene("rings")
    assert d.f_reaching(1.0) == pytest.approx(1 - d.unreferenced_share, abs=1 / d.n)
    assert d.f_reaching(0.78 - 1e-9) == pytest.approx(0.2, abs=1 / d.n)
    assert d.f_reaching(0.99) < d.f_reaching(0.999) <= d.f_reaching(1.0)


def _figure_checks(fig) -> None:
    """No point clipped (every data point inside its axes' limits), every legend outside every
    data area, and the visible panels of a row on one y-scale."""
    renderer = fig.canvas.get_renderer()
    axes = [ax for ax in fig.axes if ax.get_visible()]
    data_boxes = [ax.get_window_extent(renderer) for ax in axes]
    legends = [ax.get_legend() for ax in axes if ax.get_legend() is not None]
    assert legends
    for leg in legends:
        box = leg.get_window_extent(renderer)
        assert not any(box.overlaps(d) for d in data_boxes), "a legend covers a panel"
    for ax in axes:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        for line in ax.lines:
            for x, y in line.get_xydata():
                if line.get_marker() not in (None, "None", ""):
                    assert x0 <= x <= x1 and y0 <= y <= y1, (ax.get_title(), x, y)


def test_figure5_draws_every_point_on_one_scale_with_the_legend_outside():
    """The 100 %-resident points (no cache: t near t_g) are drawn, not clipped to the top edge;
    every panel shares one y-scale; the legend covers no panel (it used to hide a point)."""
    import matplotlib.pyplot as plt

    from netsushisen.reports.paper_plots import figure5_drawn, figure_rho_miss_drawn

    scenes = world(t=lambda L, s: 9.0 if s == 1.0 else paper_world_t(L, s))
    fig = figure5_drawn(scenes)
    _figure_checks(fig)
    limits = {ax.get_ylim() for ax in fig.axes if ax.get_visible()}
    assert len(limits) == 1 and max(limits)[1] > 9.0
    plt.close(fig)
    fig = figure_rho_miss_drawn(scenes)
    _figure_checks(fig)
    rows = {}
    for ax in fig.axes:
        if ax.get_visible() and ax.get_subplotspec() is not None:
            rows.setdefault(ax.get_subplotspec().rowspan.start, set()).add(ax.get_ylim())
    assert len(rows) == 2 and all(len(v) == 1 for v in rows.values())
    plt.close(fig)


def test_a_scene_has_one_colour_in_every_figure():
    """reports/palette.py: tetra is the same colour in Figures 3 and 4; a local-memory size the
    same in Figure 5 and the ρ plot."""
    import matplotlib.pyplot as plt

    from netsushisen.reports import paper_plots as pp
    from netsushisen.reports.palette import local_colour, scene_colour

    scenes = world()
    seen = {}

    def grab(fig):
        for ax in fig.axes:
            for line in ax.lines:
                if not line.get_label().startswith("_"):
                    seen.setdefault(line.get_label().split(" (")[0], set()).add(line.get_color())
        plt.close(fig)
    orig = pp._save
    pp._save = lambda fig, path: grab(fig)
    try:
        pp.figure3(scenes, Path("x.png"))
        pp.figure4(scenes, Path("x.png"))
        pp.figure5(scenes, Path("x.png"))
        grab(pp.figure_rho_miss_drawn(scenes))
    finally:
        pp._save = orig
    for i, d in enumerate(scenes):
        assert seen[d.name] == {scene_colour(i)}
    for i, L in enumerate(LOCAL_SHARES):
        assert seen[f"local {100 * L:.0f} %"] == {local_colour(i)}


@pytest.mark.parametrize("corners", [False, True])
def test_table2s_sampling_sentence_names_the_run_it_is_in(corners):
    """At the paper's resolution a visible-share difference points at the other eye-ray sampling:
    a --corners run must not say --corners was "not run here"."""
    scenes = [copy.copy(d) for d in _changed(world(), "mount", visible=np.arange(3000))]
    for d in scenes:
        d.corners = corners
    (f,) = [f for f in findings(scenes, "ref") if f.paper.startswith("visible primitives")]
    assert f.verdict == "partly"
    assert ("this run" in f.why) and ("not run here" not in f.why)
    assert ("corner rays (this run)" in f.why) == corners
    assert ("`paper --corners` is the other reading" in f.why) == (not corners)


def test_a_differing_finding_reports_every_candidate_and_which_explains_it():
    """Figure 4–5 findings that are not "agree" are rerun under each candidate reading the
    scenes carry: one that restores the claim is named as the explanation; none gives
    "unexplained after the candidates …" with each candidate's verdict."""
    broken = world(t=lambda L, s: 2.0 + s)  # resident memory never beats cache-only
    fixed, also_broken = world(), world(t=lambda L, s: 2.5 + s)
    for d, f, b in zip(broken, fixed, also_broken):
        d.readings = {"lists in the cache": f, "32-byte blocks": b}
    (beats,) = [f for f in findings(broken) if f.paper.startswith("resident memory beats")]
    assert beats.verdict == "differ"
    assert beats.why.startswith("explained by lists in the cache (candidates run")
    assert "32-byte blocks: differ" in beats.why and "lists in the cache: agree" in beats.why
    for d, b in zip(broken, also_broken):
        d.readings = {"32-byte blocks": b}
    (beats,) = [f for f in findings(broken) if f.paper.startswith("resident memory beats")]
    assert beats.why.startswith("unexplained after the candidates 32-byte blocks")
    assert "not run: the machine's normal ray order" in beats.why  # only --on-machine runs it
    # agreeing findings and scenes without readings are left alone
    assert all(f.why == "" for f in findings(world()))


def test_candidate_readings_survive_the_run_cache():
    """A cached paper run (DIR/runs/, plain JSON) must bring its candidate readings back, or a
    rerun from the cache would lose every finding's experiments."""
    import json

    from netsushisen.cluster import plain, unplain

    d = scene("tetra")
    d.readings = {"32-byte blocks": scene("tetra", t=lambda L, s: 2.0 + s)}
    back = SceneData.from_plain(unplain(json.loads(json.dumps(plain(d)))))
    assert list(back.readings) == ["32-byte blocks"]
    assert back.readings["32-byte blocks"].fig5 == d.readings["32-byte blocks"].fig5
    assert np.array_equal(back.references, d.references)


def _check(scene_name: str, cycles: int, prepass_cycles: int, point: str = "") -> dict:
    return {"scene": scene_name, "point": point, "cycles": cycles, "status": "finished",
            "prepass": {"resolution": 51, "cycles": prepass_cycles} if not point else None}


def test_the_prepass_cost_finding_flips_when_the_prepass_is_dear():
    """§4.3: the pre-pass costs about 1 % of the main pass, measured in machine cycles; a
    pre-pass at 5 % of the main pass's cycles makes it differ, and sweep points (no pre-pass)
    never count."""
    from netsushisen.reports.paper import machine_findings

    cheap = [_check(n, 1_000_000, 10_000) for n in N] + [_check("tetra", 9, 9, "cache-only 10 %")]
    (f,) = machine_findings(cheap)
    assert f.figure == "§4.3" and f.verdict == "agree"
    dear = [_check(n, 1_000_000, 50_000 if n == "rings" else 10_000) for n in N]
    assert machine_findings(dear)[0].verdict == "partly"
    assert machine_findings([_check(n, 1_000_000, 50_000) for n in N])[0].verdict == "differ"
    (absent,) = machine_findings([])  # without --on-machine: present, saying what evaluates it
    assert absent.verdict == "not evaluated" and "--on-machine" in absent.ours
    cheaper = [_check(n, 1_000_000, 900) for n in N]  # 0.09 %: cheaper than the paper's, agrees
    assert machine_findings(cheaper)[0].verdict == "agree"


def test_ray_order_study_shows_which_findings_flip_and_names_it_as_a_candidate():
    """The machine's normal ray order (RAY_ORDER) is a candidate reading: a finding it turns to
    "agree" says so in its *Why*, and the ray-order rows mark the flip with both sets of
    numbers; an order that changes nothing flips nothing."""
    from netsushisen.reports.paper import RAY_ORDER, ray_order_rows
    from netsushisen.reports.paper_report import _ray_order

    broken = world(t=lambda L, s: 2.0 + s)  # resident memory never beats cache-only
    for d, f in zip(broken, world()):
        d.readings = {RAY_ORDER: f}
    (beats,) = [f for f in findings(broken) if f.paper.startswith("resident memory beats")]
    assert beats.why.startswith(f"explained by {RAY_ORDER} (candidates run")
    assert "not run:" not in beats.why
    rows = {r["paper"]: r for r in ray_order_rows(broken)}
    r = rows["resident memory beats a cache-only local memory"]
    assert (r["serial"], r["normal"], r["flips"]) == ("differ", "agree", True)
    assert r["serial_ours"] != r["normal_ours"]
    md = "\n".join(_ray_order({"orders": [{"scene": "tetra", "cycles": 5, "loads": 7,
                                           "seconds": 1, "slots": 8}]}, broken))
    assert "## Ray order (on the machine)" in md and "agree (flips)" in md
    same = world()
    for d, f in zip(same, world()):
        d.readings = {RAY_ORDER: f}
    assert not any(r["flips"] for r in ray_order_rows(same))
    assert ray_order_rows(world()) == []  # no study: no rows


def test_a_reading_that_changes_a_stated_parameter_is_a_sensitivity_never_an_explanation():
    """The paper states 64-byte blocks: a 128-byte-block reading that restores a claim is listed
    as a sensitivity with its verdict, and the finding stays unexplained; the same data as a
    reading of an open choice (64-byte blocks) explains it."""
    broken = world(t=lambda L, s: 2.0 + s)  # resident memory never beats cache-only
    for d in broken:
        fixed = scene(d.name)
        fixed.block_bytes = 128
        d.readings = {"128-byte blocks": fixed}
    (beats,) = [f for f in findings(broken) if f.paper.startswith("resident memory beats")]
    assert beats.verdict == "differ"
    assert not beats.why.startswith("explained")
    assert "sensitivities" in beats.why and "128-byte blocks: agree" in beats.why
    for d in broken:
        d.readings["128-byte blocks"].block_bytes = 64
    (beats,) = [f for f in findings(broken) if f.paper.startswith("resident memory beats")]
    assert beats.why.startswith("explained by 128-byte blocks")


def test_partly_means_at_least_half_of_the_cases():
    """One definition of "partly", applied as defined: 1 of 4 scenes passing is "differ"."""
    from netsushisen.reports.paper_judge import verdict

    assert verdict({"a": True, "b": True}) == "agree"
    assert verdict({"a": True, "b": False, "c": False, "d": False}) == "differ"
    assert verdict({"a": True, "b": True, "c": False, "d": False}) == "partly"
    assert verdict({}) == "not evaluated"
    v = verdicts(world(miss=lambda s: 0.2 if s < 0.2 else 0.02))
    assert v[key(v, "Figure 4: cache miss rates are low")] == "differ"  # 0 of 4


def test_trend_p_is_the_exact_share_of_orderings():
    """Kendall's τ and its one-sided p equal a count over every ordering of the points."""
    import itertools

    from netsushisen.reports.paper_judge import kendall_tau, trend

    x = [0, 1, 2, 3, 4, 5]
    y = [5.0, 4.1, 4.3, 2.0, 1.0, 1.5]
    tau, p = trend(x, y, -1)
    perms = [kendall_tau(x, q) for q in itertools.permutations(y)]
    assert p == pytest.approx(sum(t <= tau + 1e-12 for t in perms) / len(perms))
    assert trend(x, y, +1)[1] == pytest.approx(sum(t >= tau - 1e-12 for t in perms) / len(perms))
    assert tau < 0 and p < 0.05


def test_a_one_sided_claim_passes_on_the_papers_side():
    """Figure 3's "20 % take 70–80 %" is a claim of concentration: 83 % (more concentrated, the
    paper's direction) agrees, 50 % does not."""
    def c20_of(frac_top: float) -> np.ndarray:
        n = N["mount"]
        refs = np.zeros(n, np.int64)
        top = int(0.2 * n)
        refs[:top] = int(frac_top * 10 ** 6 / top)
        refs[top:int(0.8 * n)] = int((1 - frac_top) * 10 ** 6 / (int(0.8 * n) - top))
        return refs
    for frac, want in ((0.83, "agree"), (0.66, "agree"), (0.62, "partly")):
        v = verdicts(_changed(world(), "mount", references=c20_of(frac)))
        assert v[key(v, "Figure 3: in mount and rings")] == want, frac


def test_tends_to_is_a_trend_not_a_per_step_limit():
    """t falling overall with one 3 % step up still "falls as the resident share grows" (the
    old 1 %-per-step rule failed it); a flat-then-rising curve does not."""
    wiggle = world(t=lambda L, s: paper_world_t(L, s) + (0.07 if L >= 0.3 and abs(s - 0.3) < 1e-9 else 0))
    v = verdicts(wiggle)
    assert v[key(v, "Figure 5: for 30 % and 50 % local memory t falls")] == "agree"
    flat = world(t=lambda L, s: paper_world_t(L, s) if L < 0.3 else 2.0 + 0.01 * (s > 0.5))
    v = verdicts(flat)
    assert v[key(v, "Figure 5: for 30 % and 50 % local memory t falls")] == "differ"


def test_every_finding_prints_its_margin_and_k_of_n():
    for f in findings(_changed(world(), "mount", references=_spread("mount")), "ref"):
        if f.verdict in ("agree", "partly", "differ"):
            assert " of " in f.margin and "pass; margin to the threshold:" in f.margin, f.paper
    (f,) = [f for f in findings(_changed(world(), "mount", references=_spread("mount")))
            if f.paper.startswith("in mount and rings")]
    assert f.margin.startswith("1 of 2 scenes pass") and "mount -15.0 points" in f.margin.replace("−", "-")


def test_every_threshold_has_its_reason_in_the_docs():
    """docs/databases.md's table of thresholds gives every number a finding is judged against,
    with a reason; a threshold added without one fails here."""
    from netsushisen.reports.paper_judge import THRESHOLDS

    docs = (Path(__file__).parents[1] / "docs" / "databases.md").read_text(encoding="utf-8")
    rows = {}
    for line in docs.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| `") and len(cells) >= 3:
            rows[cells[0].strip("`")] = cells
    for name, value in THRESHOLDS.items():
        assert name in rows, f"{name} has no row in docs/databases.md"
        assert float(rows[name][1].replace("%", "").strip()) / (100 if "%" in rows[name][1] else 1) \
            == pytest.approx(value), name
        assert len(rows[name][2]) > 40, f"{name}: the reason is missing or a stub"


def test_the_spread_names_a_verdict_that_changes_within_it():
    """--draws: each Figure 4–5 point gets its min–max over the run and the draws; a draw in
    which resident memory no longer beats cache-only makes that verdict unstable, and draws
    equal to the run change nothing."""
    from netsushisen.reports.paper_spread import point_spread, spread_markdown, stability

    scenes = world()

    def draws_of(worlds):
        return [{"scene": d.name, "draw": k, "fig4": d.fig4, "fig5": d.fig5}
                for k, w in enumerate(worlds, 1) for d in w]
    same = draws_of([world() for _ in range(5)])
    assert all(r["stable"] for r in stability(scenes, [[d for d in w] for w in [world()] * 5]))
    md = "\n".join(spread_markdown(scenes, same))
    assert "5 draws beside the run" in md and "**0 of 13 Figure 4–5 verdicts change" in md
    flipped = draws_of([world() for _ in range(4)] + [world(t=lambda L, s: 2.0 + s)])
    md = "\n".join(spread_markdown(scenes, flipped))
    assert "resident memory beats a cache-only local memory (agree → agree/differ)" in md
    from netsushisen.reports.paper_spread import draw_scenes

    spread = point_spread(scenes, draw_scenes(scenes, flipped))
    v, lo, hi = spread[("tetra", "fig5", 0.3, 0.7)]
    assert v == pytest.approx(2.0) and lo == pytest.approx(2.0) and hi == pytest.approx(2.7)


def test_the_error_table_gives_each_claims_error_and_table2s_mape():
    """Per numeric claim: ours, the paper's, absolute and relative error; MAPE over Table 2.
    Moving one visible share moves the MAPE by its relative error / 12."""
    from netsushisen.reports.paper_report import _errors, error_rows

    rows, mape = error_rows(world())
    assert len([r for r in rows if r["table2"]]) == 12 and mape < 0.02
    t = next(r for r in rows if r["scene"] == "tetra" and r["claim"] == "Table 2: visible share")
    assert t["rel"] == pytest.approx((t["ours"] - 0.51) / 0.51)
    moved, mape2 = error_rows(_changed(world(), "mount", visible=np.arange(4000)))
    m = next(r for r in moved if r["scene"] == "mount" and r["claim"] == "Table 2: visible share")
    assert m["rel"] == pytest.approx(4000 / N["mount"] / 0.23 - 1)
    assert mape2 > mape + 0.1
    assert "MAPE (mean absolute percentage error) over Table 2" in "\n".join(_errors(world()))
