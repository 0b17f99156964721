"""report.md of `netsushisen paper`: how the numbers were made (and why these countings and
sizes are the paper's), both tables, the figures' key numbers in both countings, the trace
experiments, every finding with its threshold, and the on-machine check when it ran.

Split from `paper.py` (which decides the findings) so that each stays readable."""

from __future__ import annotations

import numpy as np

from netsushisen.reports.paper import (PAPER_RES, PAPER_TABLE1, RAY_ORDER, TABLE1_COLUMNS,
                                       VERDICTS, Finding, _pct, _yn, common_readings, fig4_miss,
                                       fig5_best, fig5_curve, fig5_row, findings, ray_order_rows,
                                       split_readings, stated_changes, table2)
from netsushisen.reports.paper_data import (COUNTINGS, FINDINGS_LOCAL_WORDS, FINDINGS_POINT,
                                            LOCAL_SHARES, SceneData)
from netsushisen.reports.paper_judge import PARTLY, TOLERANCE, TREND_ALPHA

DEFAULTS_ARGUED = [
    "- **Per primitive reference is the paper's counting.** Figure 3 counts references per "
    "primitive (REF(i)), and §6 reads ρ — \"the share of references served by resident memory\" — "
    "off that curve: resident memory holds whole primitives chosen by their reference counts, so "
    "its ρ is a share of primitive references. The formula t = ρ·t_r + (1 − ρ)·{μ·t_c + (1 − "
    "μ)·t_g} charges one access time per reference. Per word, one test reads 2 list words and 5–13 "
    "record words that share 64-byte blocks, so most words hit because their neighbour missed; "
    "that counting is shown beside, never as the paper's.",
    "- **Sizing against the shape records.** The paper lists the primitive list and the primitive "
    "shape data as separate databases; resident memory receives \"primitive data\" in priority "
    "order (§4.4, the pre-pass). Figures 4–5 size local memory as a share of the scene's primitive "
    "database; we read that as the data the pre-pass ranks — one record per primitive — not our "
    "list cells, whose count is an artefact of our grid (39–63 % of lists + records).",
    "- **List cells in local memory.** §4.4 has IC read primitive i's priority P_i *from resident "
    "memory* and compare it with M before it chooses resident memory or the cache; the priority "
    "lives in the list cell, so the paper's list cells are read locally, not through the cache. "
    "The machine's IC kernel reads them from ICGM by default (docs/databases.md): `--lists cache` "
    "evaluates that; `--on-machine` also runs the machine in this reading (\"On the machine\").",
    "- **Whole primitives resident by priority.** The resident fill copies records in priority "
    "order until the next one does not fit (M records), as §4.4 describes; IC tests P_i ≤ M.",
]


def prepass_line(d: SceneData, share: float | None) -> str:
    """The pre-pass this run used, from its configuration and the eye rays it shot (never a fixed
    sentence: `--set prepass.share=1.0` ranks by the full-resolution render)."""
    r = d.prepass["resolution"]
    main, pre = d.rays.get("eye"), d.prepass.get("eye_rays")
    shot = f"{_pct(pre / main, 2)} of the main pass's eye rays" if main and pre else \
        f"{r}×{r} eye rays"
    asked = "" if share is None else f"`prepass.share = {share:g}`, "
    paper = ("as the paper's" if share is not None and abs(share - 0.01) < 1e-12
             else "the paper's is about 1 %")
    ranking = ("the full-resolution ranking: the pre-pass is the main pass's render"
               if r >= d.res else "a coarse ranking")
    return (f"- Pre-pass (resident priorities): the golden model at {r}×{r}, {shot} ({asked}"
            f"{paper}); primitives ranked by their references in that render, most first, ties "
            f"by id ({ranking}).")


def error_rows(scenes: list[SceneData]) -> tuple[list[dict], float | None]:
    """Per numeric claim of the paper that a scene answers (Table 2's three columns, Figure 3's
    never-referenced shares): our value, the paper's, the absolute and relative error; and the
    mean absolute percentage error (MAPE) over Table 2's numbers."""
    from netsushisen.reports.paper_claims import PAPER_UNREFERENCED  # noqa: PLC0415 (cycle)

    rows = []
    for r in table2(scenes):
        if r["visible_paper"] is None:
            continue
        for what, ours, paper in (("Table 2: visible primitives", r["visible_ours"],
                                   r["visible_paper"]),
                                  ("Table 2: visible share", r["visible_share_ours"],
                                   r["visible_share_paper"]),
                                  ("Table 2: share of references to visible",
                                   r["reference_share_ours"], r["reference_share_paper"])):
            rows.append({"claim": what, "scene": r["scene"], "ours": ours, "paper": paper,
                         "abs": ours - paper, "rel": (ours - paper) / paper, "table2": True})
    for d in scenes:
        if d.name in PAPER_UNREFERENCED:
            p, o = PAPER_UNREFERENCED[d.name], d.unreferenced_share
            rows.append({"claim": "Figure 3: never referenced", "scene": d.name, "ours": o,
                         "paper": p, "abs": o - p, "rel": (o - p) / p, "table2": False})
    t2 = [abs(r["rel"]) for r in rows if r["table2"]]
    return rows, (sum(t2) / len(t2) if t2 else None)


def _errors(scenes: list[SceneData]) -> list[str]:
    rows, mape = error_rows(scenes)
    if not rows:
        return []

    def fmt(v) -> str:
        return f"{v:,}" if isinstance(v, (int, np.integer)) else f"{100 * v:.1f} %"

    def fabs(r) -> str:
        return (f"{r['abs']:+,}" if isinstance(r["ours"], (int, np.integer))
                else f"{100 * r['abs']:+.1f} points")
    return (["## Error against the paper", "",
             "Every numeric claim a scene answers, ours against the paper's (relative error = "
             "(ours − paper) / paper); the MAPE (mean absolute percentage error) over Table 2's "
             f"numbers is **{_pct(mape, 1)}** at {scenes[0].res}×{scenes[0].res}"
             + (" (the paper's resolution)." if scenes[0].res == PAPER_RES
                else f" (the paper rendered {PAPER_RES}×{PAPER_RES}: provisional)."), ""]
            + _md_table(["claim", "scene", "ours", "paper", "absolute error", "relative error"],
                        [[r["claim"], r["scene"], fmt(r["ours"]), fmt(r["paper"]), fabs(r),
                          f"{100 * r['rel']:+.1f} %"] for r in rows]) + [""])


def _md_table(header: list[str], rows: list[list]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return out


def _pair(paper, ours, fmt=str) -> str:
    if paper is None:
        return f"{fmt(ours)} (paper –)"
    return f"{fmt(ours)} (paper {fmt(paper)})"


def verdict_counts(items: list[Finding]) -> dict[str, int]:
    out: dict[str, int] = {}
    for f in items:
        out[f.verdict] = out.get(f.verdict, 0) + 1
    return {k: out[k] for k in VERDICTS if k in out}


def _counts_text(items: list[Finding]) -> str:
    return ", ".join(f"{v} {k}"
                     for k, v in verdict_counts(items).items()) + f" (of {len(items)} findings)"


def _experiments(scenes: list[SceneData]) -> list[str]:
    rows = []
    for d in scenes:
        for name, refs in d.experiments.items():
            v = d.with_references(refs)
            rows.append([d.name, name, f"{int(refs.sum()):,}", _pct(v.visible_reference_share),
                         _pct(v.unreferenced_share), _pct(v.c_at(0.2))])
    return _md_table(["scene", "variant", "tests", "share of tests to visible primitives",
                      "never referenced", "C at f = 20 %"], rows)


def _fig5_rows(scenes: list[SceneData], what: str) -> list[str]:
    rows = []
    for d in scenes:
        for L in LOCAL_SHARES:
            split, t, row = fig5_best(d, L, what)
            t0 = fig5_curve(d, L, what)[1][0]
            rows.append([d.name, f"{100 * L:.0f} %", f"{t0:.3f}",
                         f"{100 * split:.0f} %", f"{t:.3f}",
                         f"{row[what]['rho']:.3f}", f"{row[what]['mu']:.4f}",
                         row["resident_count"]])
    return _md_table(["scene", "local memory", "t cache-only", "best resident share", "t there",
                      "ρ there", "μ there", "M there"], rows)


def _on_machine(check: dict) -> list[str]:
    lines = ["## On the machine", "",
             f"`--on-machine`: each scene rendered by the emulated machine ({check['engine']} "
             "engine, serial ray-tree mode SERIAL_TREES=1, one slot) at "
             f"{check['res']}×{check['res']} with the default memory configuration "
             f"({check['memory']}) and at the sweep points below, {check['workers']}; IC's "
             "per-word counters (loads by memory and by region, loads per primitive, and the "
             "per-word ρ and μ) compared with the trace-driven path's for the same images, and "
             "the per-reference counts the findings use (references served by resident memory, "
             "through the cache, and cache hits: a reference hits when every load of it hit) — "
             "on the machine from IC's recorded load stream with the machine's own per-load hit "
             "flags, on the trace-driven path from the sweep's replay of the golden trace for "
             "the same configuration. The points size IC's memories as shares of the machine's "
             "own database (list cells + shape records, list cells through the cache: "
             "`--sizing records+lists --lists cache`). The row \"" + FINDINGS_POINT + "\" runs "
             "the machine in the reading the findings use (`--sizing records --lists local`): IC "
             "built with LISTS_LOCAL reads the list cells from its local memory (ic.local_words "
             f"raised to {FINDINGS_LOCAL_WORDS:,} to hold them), never through the cache, its "
             "shares sized against the shape records (sizes in bytes as given); its list-cell "
             "loads are compared with the sweep's `local.primitive_list` count.",
             ""]
    rows = [[r["scene"], r.get("point") or "default", f"{r['cycles']:,}", f"{r['seconds']:.0f}",
             r["rho"], r["mu"], "equal" if r["equal"] else "DIFFERENT: " + r["difference"],
             r.get("ref_rho", "–"), r.get("ref_mu", "–"),
             "equal" if r.get("ref_equal") else "DIFFERENT: " + r.get("ref_difference", "")]
            for r in check["scenes"]]
    lines += _md_table(["scene", "memory", "machine cycles", "wall s", "ρ (per word)",
                        "μ (per word)", "per-word counters", "ρ (per reference)",
                        "μ (per reference)", "per-reference counts"], rows)
    same = all(r["equal"] and r.get("ref_equal") for r in check["scenes"])
    scenes = sorted({r["scene"] for r in check["scenes"]})
    lines += ["", f"**{'All counters equal' if same else 'Counters differ'}** "
              f"({len(check['scenes'])} runs of {len(scenes)} scenes; wall time "
              f"{check['seconds']:.0f} s).", ""]
    pre = [r for r in check["scenes"] if r.get("prepass")]
    if pre:
        lines += ["The pre-pass on the machine (§4.3: about 1 % of the main pass), same mode:", ""]
        lines += _md_table(["scene", "pre-pass", "its cycles", "main pass cycles", "share"],
                           [[r["scene"],
                             f"{r['prepass']['resolution']}×{r['prepass']['resolution']}",
                             f"{r['prepass']['cycles']:,}", f"{r['cycles']:,}",
                             f"{100 * r['prepass']['cycles'] / r['cycles']:.2f} %"] for r in pre]) + [""]
    return lines


def _ray_order(check: dict, scenes: list[SceneData]) -> list[str]:
    """The ray-order study: each Figure 4–5 finding with the serial order and with the machine's
    normal order (`reports.paper.ray_order_rows`)."""
    orders = check.get("orders") or []
    rows = ray_order_rows(scenes)
    if not orders:
        return []
    lines = ["## Ray order (on the machine)", "",
             "Which order did the paper's measurements use? The trace-driven path replays the "
             "rays in the machine's serial order (one ray tree in flight). Here each scene was "
             "rendered on the machine in the kernels' normal mode "
             f"({orders[0].get('slots')} rays in flight; the paper's load order, so only the "
             "rays' order differs), IC's load stream recorded, mapped back "
             "to the sweep's reference layout (every record in ICGM: address → primitive and "
             "offset → reference address) and replayed through every configuration of Figures "
             "4–5; the findings below are recomputed from it (per primitive reference). The "
             "normal order also enters every differing finding's candidates (*Why*: "
             f"\"{RAY_ORDER}\").", ""]
    lines += _md_table(["scene", "machine cycles (normal mode)", "IC loads", "wall s"],
                       [[o["scene"], f"{o['cycles']:,}", f"{o.get('loads', 0):,}",
                         f"{o['seconds']:.0f}"] for o in orders]) + [""]
    if not rows:
        return lines + ["(Not every scene's study finished: no findings recomputed.)", ""]
    moved = []
    for d in scenes:
        n = d.readings[RAY_ORDER]
        cells = [d.name]
        for local in (0.3, 0.5):
            a, b = fig5_row(d, local, 0.7)["ref"]["mu"], fig5_row(n, local, 0.7)["ref"]["mu"]
            cells.append(f"{a:.3f} → {b:.3f}")
        for local in (0.3, 0.5):
            (sa, ta, _), (sb, tb, _) = fig5_best(d, local), fig5_best(n, local)
            cells.append(f"{_pct(sa)}, {ta:.2f} → {_pct(sb)}, {tb:.2f} t_r")
        cells.append(f"{_pct(fig4_miss(d, 0.3), 2)} → {_pct(fig4_miss(n, 0.3), 2)}")
        moved.append(cells)
    lines += ["Per scene (per primitive reference; serial → normal order):", ""]
    lines += _md_table(["scene", "μ at 30 % local, 70 % resident", "μ at 50 % local, 70 % resident",
                        "lowest t at 30 % local (split, t)", "lowest t at 50 % local (split, t)",
                        "miss rate, 30 % cache-only"], moved) + [""]
    lines += _md_table(["finding", "serial order", "machine's normal order", "numbers (serial)",
                        "numbers (normal order)"],
                       [[f"{r['figure']}: {r['paper']}", r["serial"],
                         r["normal"] + (" (flips)" if r["flips"] else ""), r["serial_ours"],
                         r["normal_ours"] if r["normal_ours"] != r["serial_ours"]
                         else "same"] for r in rows])
    flips = [r for r in rows if r["flips"]]
    lines += ["", f"**{len(flips)} of {len(rows)} Figure 4–5 findings change verdict under the "
              "machine's normal ray order**" + (": " + "; ".join(
                  f"{r['figure']} ({r['serial']} → {r['normal']})" for r in flips) if flips
                  else "."), ""]
    return lines


def report_markdown(scenes: list[SceneData], items: list[Finding], settings: dict,
                    files: list[str], missing: list[str] | None = None,
                    word_items: list[Finding] | None = None, machine: dict | None = None,
                    spread: list[str] | None = None) -> str:
    """The whole report.md. `items`: findings per primitive reference (the paper's counting);
    `word_items`: the same findings per word; `machine`: the `--on-machine` check."""
    res = settings["res"]
    lines = ["# Netsushisen paper reproduction: Table 1, Table 2, Figures 3–5", "",
             f"Generated by `{settings['command']}`. Murata, Gwun, Murakami, Tomita, "
             "\"Netsushisen: a parallel rendering machine for high-speed ray tracing — memory "
             "structure and its evaluation\" (Kyushu University, about 1992); their numbers are "
             "its Tables 1–2 and Figures 3–5.", ""]
    if missing:
        lines += [f"**Incomplete run:** interrupted before {', '.join(missing)} finished; only the "
                  "scenes below are evaluated.", ""]
    if not scenes:
        return "\n".join(lines + ["No scene finished.", ""])
    d0 = scenes[0]
    lists = ", ".join(f"{d.name} "
                      f"{_pct(d.database_bytes['primitive_list'] / (d.database_bytes['primitive_list'] + d.database_bytes['shape_data']))}"
                      for d in scenes)
    lines += [
        "## How these numbers were made", "",
        f"- Main pass: the golden model at {res}×{res} "
        f"({'SPD corner rays, (N+1)² eye rays' if d0.corners else 'one eye ray per pixel centre'}), "
        f"{d0.precision}, ray-tree depth ≤ {settings.get('max_depth', 5)}; the paper rendered "
        f"{PAPER_RES}×{PAPER_RES}.",
        prepass_line(d0, settings.get("prepass_share")),
        "- IC's loads: the IC access protocol (docs/databases.md) replayed from the golden model's "
        "reference trace, rays in the machine's serial order (pixel by pixel, each ray tree in "
        "level order), through a trace-driven resident memory + direct-mapped cache with the "
        f"emulator's rules ({d0.block_bytes}-byte blocks, t_c = 2·t_r, t_g = 8·t_r).",
        f"- **Counting, sizing, lists** (every figure and Figure 4–5 finding says which): "
        f"{d0.options.describe()} (`--sizing {d0.options.sizing} --lists {d0.options.lists}`). "
        f"Figures 4–5 and their findings count {COUNTINGS['ref']} (primary); the tables below and "
        f"the CSV files give {COUNTINGS['all']} beside. List cells are {lists} of lists + records.",
        "", "### Why these defaults are the paper's", "", *DEFAULTS_ARGUED, ""]
    lines += ["## Verdict", "",
              f"- {COUNTINGS['ref']} (the paper's counting): {_counts_text(items)}."]
    if word_items is not None:
        lines += [f"- {COUNTINGS['all']}: {_counts_text(word_items)}."]
    if common_readings(scenes):
        readings, sens = split_readings(scenes)
        lines += [f"- {COUNTINGS['ref']}, under the candidate reading *{k}* (Figures 4–5 rerun): "
                  f"{_counts_text(findings([d.readings[k] for d in scenes], 'ref'))}."
                  for k in readings]
        lines += [f"- {COUNTINGS['ref']}, sensitivity *{k}* (changes "
                  f"{'; '.join(stated_changes(scenes[0].readings[k]))}: never an explanation): "
                  f"{_counts_text(findings([d.readings[k] for d in scenes], 'ref'))}."
                  for k in sens]
        lines += ["",
                  "Every Figure 4–5 finding that is not \"agree\" names what each candidate "
                  "reading makes of it (*Why*)"
                  + ("; `--on-machine` adds the machine's normal ray order and the trace split "
                     "among PEs as the machine splits the pixels (checked on the machine: "
                     "\"On the machine\")." if RAY_ORDER in common_readings(scenes) else
                     "; ray order and PE count need the machine (`--on-machine`).")]
    lines += [""]
    if machine:
        lines += _on_machine(machine) + _ray_order(machine, scenes)
    # Table 1
    lines += ["## Table 1: benchmark scenes (ours, paper's in brackets where they differ)", ""]
    rows = []
    for d in scenes:
        paper = PAPER_TABLE1.get(d.name)
        cells = [d.name]
        for i, col in enumerate(TABLE1_COLUMNS):
            v = d.counts[col]
            shown = _yn(v) if isinstance(v, bool) else str(v)
            if paper is not None and paper[i] != v:
                shown += f" ({_yn(paper[i]) if isinstance(paper[i], bool) else paper[i]})"
            cells.append(shown)
        rows.append(cells)
    lines += _md_table(["scene", *TABLE1_COLUMNS], rows) + [""]
    # Table 2
    lines += [f"## Table 2: primitives visible from the eye (ours at {res}×{res}, paper at "
              f"{PAPER_RES}×{PAPER_RES})", ""]
    rows = [[r["scene"], _pair(r["visible_paper"], r["visible_ours"]),
             _pair(r["visible_share_paper"], r["visible_share_ours"], _pct),
             _pair(r["reference_share_paper"], r["reference_share_ours"],
                   _pct)] for r in table2(scenes)]
    lines += _md_table(["scene", "visible primitives", "share of all primitives",
                        "share of references to visible primitives"], rows) + [""]
    # Figure 3
    lines += ["## Figure 3: locality (tests per primitive, every ray kind)", "",
              "![Figure 3](fig3_locality.png)", ""]
    lines += _md_table(["scene", "C at f = 10 %", "C at f = 20 %", "C at f = 50 %",
                        "never referenced",
                        "f where C ≥ 0.99", "f where C ≥ 0.999", "f where C = 1"],
                       [[d.name, _pct(d.c_at(0.1)), _pct(d.c_at(0.2)), _pct(d.c_at(0.5)),
                         _pct(d.unreferenced_share), _pct(d.f_reaching(0.99), 1),
                         _pct(d.f_reaching(0.999), 1),
                         _pct(d.f_reaching(1.0), 1)] for d in scenes]) + [""]
    lines += ["The paper reads \"C = 1\" off its plot at f = 80 % (mount) and 33 % (rings); C "
              "reaches 1 exactly at 1 − (never-referenced share), and 0.99 / 0.999 say how much of "
              "that tail carries almost no references.", ""]
    lines += ["### Experiments on the reference trace", "",
              "Variants of the main pass that the trace alone answers (no new render); the "
              "findings' explanations cite them.", ""]
    lines += _experiments(scenes) + [""]
    # Figure 4
    lines += [f"## Figure 4: cache miss rate, cache-only local memory ({d0.options.describe()})", "",
              "![Figure 4](fig4_miss_rate.png)", ""]
    shares = [r["cache_share"] for r in d0.fig4]
    for what in ("ref", "all"):
        lines += [f"{COUNTINGS[what].capitalize()}:", ""]
        lines += _md_table(["scene", *[f"{100 * s:.0f} %" for s in shares]],
                           [[d.name, *[_pct(r[what]["miss_rate"], 2) for r in d.fig4]]
                            for d in scenes]) + [""]
    # Figure 5
    lines += ["## Figure 5: effective access time against the resident share "
              f"({d0.options.describe()})", "",
              "![Figure 5](fig5_access_time.png)", "",
              "ρ and the cache's miss rate against the split (§5.1: the paper measured both; "
              "§5.2.3's mechanisms are findings below):", "",
              "![ρ and miss rate](fig5_rho_miss_rate.png)", ""]
    for what in ("ref", "all"):
        lines += [f"{COUNTINGS[what].capitalize()} (t in units of t_r):",
                  ""] + _fig5_rows(scenes, what) + [""]
    lines += _errors(scenes)
    lines += spread or []
    # Findings
    lines += ["## The paper's findings and ours", "",
              "Each finding is decided by the threshold in *Test*; \"not testable here\" means the "
              "premise never occurs in our data. Figures 4–5 count per primitive reference. "
              f"One rule for every finding (docs/databases.md, \"How the findings are judged\"): "
              f"a value or band the paper states is met within {_pct(TOLERANCE)} points (or one "
              "step of the sweep's grid where it is coarser), one-sided where the claim is; "
              "\"tends to\" claims are trends (Kendall's τ with its one-sided p ≤ "
              f"{_pct(TREND_ALPHA)}); **agree** when every case passes, **partly** when at least "
              f"{_pct(PARTLY)} of them do, **differ** otherwise. *Margin* gives k of n cases "
              "passing and each case's distance to its threshold (positive: passes).", ""]
    for i, f in enumerate(items, 1):
        lines += [f"{i}. **{f.figure}: {f.paper}.** *Test:* {f.test}. *Ours* ({f.counting}): "
                  f"{f.ours}. "
                  f"**{f.verdict.capitalize()}.**"
                  + (f" *Margin:* {f.margin}." if f.margin else "")
                  + (f" *Why:* {f.why}." if f.why else ""), ""]
    if word_items is not None:
        lines += ["### The same findings counted per word", ""]
        rows = [[i, f"{f.figure}: {f.paper}", f.verdict, w.verdict, w.ours]
                for i, (f, w) in enumerate(zip(items, word_items), 1)
                if f.figure in ("Figure 4", "Figure 5")]
        lines += _md_table(["#", "finding", "per reference", "per word",
                            "per word, ours"], rows) + [""]
    lines += ["## Files and times", ""]
    lines += [f"- `{f}`" for f in files]
    timing = [[d.name, f"{d.loads:,}", f"{d.seconds.get('golden', 0):.1f}",
               f"{d.seconds.get('prepass', 0):.1f}", f"{d.seconds.get('replay', 0):.1f}",
               f"{d.seconds.get('candidates', 0):.1f}"] for d in scenes]
    lines += [""] + _md_table(["scene", "loads replayed", "golden (s)",
                               "pre-pass (s)", "replay (s)", "candidate readings (s)"], timing)
    lines += ["", f"Total {settings.get('seconds', 0):.0f} s.", ""]
    return "\n".join(lines)
