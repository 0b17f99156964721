"""The outputs of `netsushisen accuracy`: terminal tables, accuracy.json, one CSV per axis,
report.md and a Pareto plot per axis (error against time, log scales).

The tables are `reports/tables.Section`s, so they print and turn into Markdown the way every
other report of the project does. A Pareto plot puts each setting where a researcher weighs it:
the further left the cheaper, the lower the closer to the truth; a step line per scene joins its
Pareto front (the settings no other beats in both); an error of exactly 0 cannot sit on a log
axis, so the error axis is linear below a tenth of the smallest error that is not 0 and an exact
setting sits at 0 itself, on a dashed line the legend names.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from netsushisen.isa.outputs import replacing, write_file, write_text
from netsushisen.reports.accuracy import AXES, RAY_KINDS, Row, axis_sentences, identical_runs
from netsushisen.reports.tables import Section, render_md, render_table

SCHEMA = {"name": "netsushisen-accuracy", "version": 1}

PLOT_METRIC = {"precision": ("rmse_u8", "image RMS error (8-bit levels)"),
               "depth": ("rmse_u8", "image RMS error against the truth depth (8-bit levels)"),
               "prepass": ("cycles", "relative error of machine cycles"),
               "fidelity": ("cycles", "relative error of total cycles")}
"""The error each axis's plot shows (the tables show them all)."""

TITLES = {"precision": "Precision: error against the golden model in fp64",
          "depth": "Ray depth: error against the converged truth depth",
          "prepass": "Pre-pass resolution: against the full-resolution ranking",
          "fidelity": "Simulation fidelity: against the full cycle-accurate run"}

HOW = {
    "precision": "Truth: the golden model in float64. `golden fp16` runs the golden model with "
                 "numpy float16 as its precision (every stored value and every operation rounded "
                 "to float16; Phong's pow is isa/libm.py's, in float64; SPD's shine 100000 "
                 "overflows to inf). `golden bf16 scene` rounds every number stored in the scene "
                 "(vertices, normals, centres, radii, cone ends, materials, lights, camera) to "
                 "bfloat16 and then computes in float32: only the stored values are bf16, not the "
                 "arithmetic. The machine rows run the kernels; their cost is machine cycles.",
    "depth": "Truth: the golden image at depth 10, 20, 40 until two consecutive ones are 8-bit "
             "identical (the row says which depth and whether it converged; 40 is the cap); the "
             "table says from which depth the 8-bit image stops changing. Seconds: the machine's "
             "(host preparation + run) at that depth. Rays are the golden model's (the machine's "
             "equal them; the `how` column says so per row), cycles the machine's at the same "
             "depth.",
    "prepass": "The pre-pass (paper §4.3) ranks primitives by references in a coarse golden render "
               "and makes the top ones resident. Each row is the main run on the machine with the "
               "ranking of one pre-pass size; truth is the ranking from the full resolution. "
               "Errors: ρ absolute, t and cycles relative. Cost: pre-pass eye rays and the "
               "pre-pass time as a share of the main machine run's.",
    "fidelity": "Truth: the whole render on the chosen engine. (a) analytic: ρ, μ from the "
                "pre-pass render's trace, t from the paper's formula, cycles scaled from an 8×8 "
                "machine run by pixels; (b) trace-driven: the full golden trace through the "
                "resident + cache model, cycles scaled from the 8×8 run by intersection tests; (c) "
                "sampled: tiles of consecutive eye samples drawn at random, 2 in each stratum of "
                "consecutive tiles, each simulated after the tile before it as warm-up, total "
                "cycles extrapolated with a 95 % interval from the tiles' spread within the strata "
                "(SMARTS; with every tile the sum is the full run's cycles within 0.1–0.3 % at "
                "32×32); (e) the reference engine, compared byte for byte (over a cycle budget on "
                "long runs, its time extrapolated and plotted so).",
}


def _g(row: Row, where: str, key: str):
    return getattr(row, where).get(key)


def _psnr(row: Row) -> str:
    v = row.values.get("psnr_db")
    return "∞" if v is None else f"{v:.1f}"


def spread_text(median: float, low: float, high: float, n: int, digits: int = 2) -> str:
    """`median (low–high)`, the spread left out for one run."""
    text = f"{median:.{digits}f}"
    return text + (f" ({low:.{digits}f}–{high:.{digits}f})" if n > 1 else "")


def _secs(row: Row) -> str:
    """A row's total seconds: median and (min–max) of its repeated runs; an emulated
    precision's marked so (its time is numpy's software emulation, not the setting's cost)."""
    t = row.timing
    text = spread_text(row.seconds, t.low, t.high, len(t.runs)) if t is not None else f"{row.seconds:.2f}"
    return text + (" emulation" if row.emulated else "")


def _compared(row: Row) -> str:
    """The seconds an axis compares (a machine row: its machine stage), with their spread."""
    t = row.timing
    if t is None:
        return ""
    m, lo, hi = t.spread()
    return spread_text(m, lo, hi, len(t.runs), 3)


def _stage(row: Row, stage: str) -> str:
    t = row.timing
    if t is None or stage not in t.parts:
        return ""
    m, lo, hi = t.spread([stage])
    return spread_text(m, lo, hi, len(t.runs), 3)


def compared_label(axis: str) -> str:
    """What the `compared s` column of an axis is."""
    return {"precision": "golden rows: the render; machine rows: the machine run",
            "depth": "the machine run",
            "prepass": "the pre-pass",
            "fidelity": "everything but the host preparation: engine load, machine run and "
                        "read-out (sampled rows: of every tile, plus the auxiliary golden "
                        "render); models: the model and its calibration run"}[axis]


def _ci(row: Row) -> str:
    if row.ci_low is None:
        return ""
    return f"{row.ci_low:,.0f} … {row.ci_high:,.0f}" + (" ✓" if row.values.get("covers") else " ✗")


def axis_section(axis: str, rows: list[Row]) -> Section:
    """One table per axis: the settings' errors and costs, scenes one after another."""
    if axis == "precision":
        cols = ["scene", "setting", "hit ids", "RMS", "max", ">1 off", "PSNR dB", "rays err",
                "compared s", "host s", "load s", "seconds", "rays", "cycles"]
        fmt = {"hit ids": "pct", "RMS": "f2", "max": "int", ">1 off": "pct", "rays err": "pct",
               "rays": "int", "cycles": "int"}
        body = [[r.scene, r.setting + (" (truth)" if r.truth else ""), r.error["hit_ids"],
                 r.error["rmse_u8"], r.error["max_u8"], r.error["channels_off"], _psnr(r),
                 max(r.error[f"rays_{k}"] for k in RAY_KINDS), _compared(r), _stage(r, "host"),
                 _stage(r, "load"), _secs(r), r.cost.get("rays"),
                 r.cost.get("cycles")] for r in rows]
    elif axis == "depth":
        cols = ["scene", "setting", "RMS", "max", ">1 off", "PSNR dB", "rays", "cycles",
                "machine s", "host s", "load s", "seconds"]
        fmt = {"RMS": "f2", "max": "int", ">1 off": "pct", "rays": "int", "cycles": "int"}
        body = [[r.scene, r.setting + (" (truth)" if r.truth else ""), r.error["rmse_u8"],
                 r.error["max_u8"],
                 r.error["channels_off"], _psnr(r), r.cost["rays"], r.cost["cycles"],
                 _stage(r, "machine"), _stage(r, "host"), _stage(r, "load"), _secs(r)] for r in rows]
    elif axis == "prepass":
        cols = ["scene", "setting", "ρ", "t", "cycles", "ρ err", "t err", "cycles err", "eye rays",
                "time share", "pre-pass s", "machine s", "seconds"]
        fmt = {"ρ": "f3", "t": "f3", "cycles": "int", "ρ err": "f3", "t err": "pct",
               "cycles err": "pct", "eye rays": "int", "time share": "pct"}
        body = [[r.scene, r.setting + (" (truth)" if r.truth else ""),
                 r.values["rho"], r.values["t"],
                 r.cost["cycles"], r.error["rho"], r.error["t"], r.error["cycles"], r.cost["rays"],
                 r.cost["time_share"], _compared(r), _stage(r, "machine"), _secs(r)] for r in rows]
    else:
        cols = ["scene", "setting", "cycles", "95 % interval", "ρ", "μ", "t", "cycles err", "ρ err",
                "μ err", "t err", "compared s", "auxiliary s", "seconds", "simulated"]
        fmt = {"cycles": "int", "ρ": "f3", "μ": "f3", "t": "f3",
               "cycles err": "pct", "ρ err": "pct",
               "μ err": "pct", "t err": "pct", "simulated": "int"}
        body = [[r.scene, r.setting + (" (truth)" if r.truth else ""), r.values["cycles"], _ci(r),
                 r.values["rho"], r.values["mu"], r.values["t"], r.error["cycles"], r.error["rho"],
                 r.error["mu"], r.error["t"], _compared(r), _stage(r, "auxiliary"), _secs(r),
                 r.cost.get("cycles")] for r in rows]
    return Section(axis, TITLES[axis], cols, body, fmt)


def tables_text(axes: dict[str, list[Row]], width: int = 140) -> str:
    return render_table([axis_section(a, rows) for a, rows in axes.items()], width=width)


def agreement_lines(axes: dict[str, list[Row]]) -> list[str]:
    """One line per configuration run on several axes: its machine seconds there, and whether
    they agree within their spread."""
    return [a.sentence() for a in identical_runs(axes)]


# ------------------------------------------------------------------------------------------------
# Files


def write_json(path: Path, axes: dict[str, list[Row]], meta: dict) -> None:
    data = {"schema": SCHEMA} | meta | {
        "axes": {a: [r.to_json() for r in rows] for a, rows in axes.items()},
        "notes": {a: axis_sentences(a, rows) for a, rows in axes.items()},
        "identical_runs": [{"scene": g.scene, "rows": [list(r) for r in g.rows],
                            "machine_seconds": [list(x) for x in g.spreads], "agree": g.agree}
                           for g in identical_runs(axes)]}
    write_text(path, json.dumps(data, indent=1, allow_nan=False, ensure_ascii=False) + "\n")


def write_csv(path: Path, rows: list[Row]) -> None:
    """Tidy: one line per scene × setting; every error, cost and value its own column."""
    keys = {w: list(dict.fromkeys(k for r in rows for k in getattr(r, w)))
            for w in ("error", "cost", "values")}
    header = ["scene", "setting", "truth", "seconds", "seconds_low", "seconds_high",
              "repeats", "emulated"] + [
        f"{w}_{k}" for w in keys for k in keys[w]] + ["ci_low", "ci_high", "how"]
    with replacing(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            t = r.timing
            w.writerow([r.scene, r.setting, r.truth, f"{r.seconds:.6f}",
                        "" if t is None else f"{t.low:.6f}", "" if t is None else f"{t.high:.6f}",
                        "" if t is None else len(t.runs), r.emulated]
                       + ["" if getattr(r, wh).get(k) is None else getattr(r, wh)[k]
                          for wh in keys for k in keys[wh]]
                       + ["" if r.ci_low is None else r.ci_low,
                          "" if r.ci_high is None else r.ci_high, r.how])


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


MARKERS = "osD^v<>phX*P8"


def plot_seconds(row: Row) -> float:
    """A row's time on the plot: the seconds its axis compares (`Timing.basis`), measured, or
    extrapolated to the whole run where it was cut."""
    t = row.timing
    if row.values.get("seconds_full"):
        return float(row.values["seconds_full"]) - (t.components.get("host", 0.0) if t else 0.0)
    return t.compared if t is not None else float(row.seconds)


def pareto_front(xs: list[float], ys: list[float]) -> tuple[list[float], list[float]]:
    """The settings no other beats in both time and error, by ascending time."""
    fx, fy = [], []
    for x, y in sorted(zip(xs, ys)):
        if not fy or y < fy[-1]:
            fx.append(x)
            fy.append(y)
    return fx, fy


def tick_text(v: float, _pos=None) -> str:
    """A tick label in plain digits (0.2, 1, 50, 1e-05 for the tiny): never '3×10⁻¹'."""
    if v == 0:
        return "0"
    return f"{v:g}"


def readable_log_axis(axis, values: list[float]) -> None:
    """Major ticks at 1, 2, 5 × 10^k in plain digits and no minor labels, so neighbouring labels
    cannot collide (matplotlib labels minor ticks of a short log range, '3×10⁻¹4×10⁻¹')."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    span = max(values) / min(values) if values and min(values) > 0 else 10.0
    subs = (1.0, 2.0, 5.0) if span < 1e3 else (1.0,)
    axis.set_major_locator(LogLocator(base=10, subs=subs))
    axis.set_major_formatter(FuncFormatter(tick_text))
    axis.set_minor_formatter(NullFormatter())


def write_plot(path: Path, axis: str, rows: list[Row], res: int) -> None:
    """Error against the seconds the axis compares. Errors of exactly 0 are drawn at 0: the
    y axis is logarithmic above `linear` (a tenth of the smallest error that is not 0) and
    linear below it, and the legend says so (a log axis has no 0)."""
    plt = _plt()
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter, NullFormatter, SymmetricalLogLocator

    metric, label = PLOT_METRIC[axis]
    settings = list(dict.fromkeys(r.setting for r in rows))
    scenes = list(dict.fromkeys(r.scene for r in rows))
    positive = [r.error[metric] for r in rows if r.error.get(metric)]
    # a power of ten at most a tenth of the smallest error that is not 0: round tick labels
    linear = 10.0 ** math.floor(math.log10(min(positive) / 10)) if positive else 1e-3
    fig, ax = plt.subplots(figsize=(9.5, 5.6), dpi=110)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    xs_all, has = [], {"spread": False, "interval": False, "emulated": False, "zero": False}
    for si, scene in enumerate(scenes):
        c = colours[si % len(colours)]
        mine = sorted((r for r in rows if r.scene == scene), key=plot_seconds)
        xs = [max(plot_seconds(r), 1e-4) for r in mine]
        ys = [float(r.error[metric]) for r in mine]
        xs_all += xs
        has["zero"] |= any(y == 0 for y in ys)
        # an emulated precision's wall time is not its cost: off the front, drawn hollow, labelled
        costed = [(x, y) for r, x, y in zip(mine, xs, ys) if not r.emulated]
        fx, fy = pareto_front([x for x, _ in costed], [y for _, y in costed])
        ax.step(fx, fy, where="post", color=c, alpha=0.45, lw=1.2)
        for r, x, y in zip(mine, xs, ys):
            m = MARKERS[settings.index(r.setting) % len(MARKERS)]
            if r.emulated:
                has["emulated"] = True
                ax.scatter([x], [y], marker=m, s=55, facecolors="none", edgecolors=c,
                           linewidths=1.2, zorder=3)
                ax.annotate("emulation", (x, y), textcoords="offset points",
                            xytext=(4, 4), fontsize=6, color=c)
            else:
                ax.scatter([x], [y], marker=m, s=130 if r.truth else 55, color=c,
                           edgecolors="black" if r.truth else "none", linewidths=1.6, zorder=3)
            if r.timing is not None and len(r.timing.runs) > 1:  # the spread of the repeated runs
                has["spread"] = True
                _, lo, hi = r.timing.spread()
                ax.plot([max(lo, 1e-4), max(hi, 1e-4)], [y, y], color=c, lw=0.8, alpha=0.6)
                xs_all += [max(lo, 1e-4), max(hi, 1e-4)]
            if r.ci_low is not None and axis == "fidelity":
                has["interval"] = True
                truth = next(t for t in rows if t.scene == scene and t.truth).values["cycles"]
                # the interval as the errors it allows: from its nearest to its farthest end, and
                # down to 0 when it contains the truth (an error of 0 is allowed)
                lo, hi = (r.ci_low - truth) / truth, (r.ci_high - truth) / truth
                near = 0.0 if lo <= 0 <= hi else min(abs(lo), abs(hi))
                ax.plot([x, x], [near, max(abs(lo), abs(hi))], color=c, lw=1.4, alpha=0.6)
    ax.set_xscale("log")
    readable_log_axis(ax.xaxis, xs_all)
    ax.set_yscale("symlog", linthresh=linear, linscale=0.4)
    ax.set_ylim(-0.15 * linear, 2.0 * max(positive) if positive else 10 * linear)
    ax.yaxis.set_major_locator(SymmetricalLogLocator(base=10, linthresh=linear))
    ax.yaxis.set_major_formatter(FuncFormatter(tick_text))
    ax.yaxis.set_minor_formatter(NullFormatter())
    if has["zero"]:
        ax.axhline(0, color="grey", ls="--", lw=0.8)
    ax.set_xlabel("seconds compared, median of the repeated runs (log): " + {
        "precision": "golden rows: the render; machine rows: the machine run",
        "depth": "the machine run at that depth",
        "prepass": "the pre-pass",
        "fidelity": "all but host preparation (sampled: every tile + auxiliary render)"}[axis])
    ax.set_ylabel(f"{label}\n(log above {tick_text(linear)}, linear below: 0 is exact)")
    ax.set_title(f"{TITLES[axis]} — {res}×{res}")
    scene_h = [Line2D([], [], color=colours[i % len(colours)], marker="o", ls="", label=s)
               for i, s in enumerate(scenes)]
    scene_h.append(Line2D([], [], color="grey", alpha=0.45, lw=1.2, label="Pareto front"))
    set_h = [Line2D([], [], color="black", marker=MARKERS[i % len(MARKERS)], ls="", label=s)
             for i, s in enumerate(settings)]
    set_h.append(Line2D([], [], color="white", marker="o", markeredgecolor="black", ms=10, ls="",
                        label="truth (black edge)"))
    if has["emulated"]:
        set_h.append(Line2D([], [], color="black", marker="o", markerfacecolor="none", ls="",
                            label="emulation (hollow: time is not its cost)"))
    if has["spread"]:
        set_h.append(Line2D([], [], color="black", lw=0.8, alpha=0.6,
                            label="min–max of the repeated runs"))
    if has["interval"]:
        set_h.append(Line2D([], [], color="black", alpha=0.6, marker="|", ms=14, mew=1.4, ls="",
                            label="95 % interval (sampled),\nas the errors it allows"))
    if has["zero"]:
        set_h.append(Line2D([], [], color="grey", ls="--", lw=0.8, label="error 0 (exact)"))
    first = ax.legend(handles=scene_h, loc="lower left", bbox_to_anchor=(1.01, 0), fontsize=8,
                      title="scene")
    ax.add_artist(first)
    ax.legend(handles=set_h, loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8,
              title="setting")
    ax.grid(True, which="major", alpha=0.3)
    fig.tight_layout()
    write_file(path, lambda p: fig.savefig(p, format=Path(path).suffix[1:] or None))
    plt.close(fig)


def report_markdown(axes: dict[str, list[Row]], meta: dict, files: list[str]) -> str:
    warm = meta.get("warm_up_seconds") or {}
    lines = ["# What accuracy costs", "",
             f"`{meta['command']}` — {meta['res']}×{meta['res']}, machine rows on the "
             f"`{meta['engine']}` engine, {meta['machine']}; {meta['seconds']:.0f} s in all.", "",
             f"Times: every row was run {meta.get('repeats', 1)} times, the settings of an axis "
             "round-robin (every setting once, then again), and each run split into stages: host "
             "preparation (golden rows build their grid; machine rows run `prepare` — grid, "
             "pre-pass, memory images, kernels), engine load, machine run (the cycle loop alone), "
             "read-out, and for sampled rows the auxiliary golden render. Each stage is shown as "
             "its median with the (min–max) spread; `compared s` is the stage an axis compares "
             "(a machine row's machine run; accuracy.json: `timing.basis`, `timing.parts`), "
             "`seconds` the whole. Settings whose compared spreads overlap cannot be told apart "
             "by time. Before any timed row each path was compiled and warmed once"
             + (" (" + ", ".join(f"{k} {v:.1f} s" for k, v in warm.items()) + ")" if warm else "")
             + ": no row carries numba's compile. Rows marked `emulation` (golden fp16, golden "
               "bf16 scene) are computed in software: their time is not the precision's cost "
               "(their cost is rays traced) and they are left off the plots' Pareto fronts.", "",
             "Each setting of each knob is one row: its error against that axis's truth and its "
             "cost (wall seconds on this machine, and rays traced or machine cycles, which do not "
             "depend on it). Every row's `how` (in accuracy.json and the CSV files) says how it "
             "was obtained.",
             ""]
    for axis, rows in axes.items():
        lines += [f"## {axis}", "", HOW[axis], "",
                  render_md([axis_section(axis, rows)]).rstrip(), ""]
        lines += [f"- {s}" for s in axis_sentences(axis, rows)] + [""]
        lines += [f"![{axis}](accuracy_{axis}.png)", ""]
    same = agreement_lines(axes)
    if same:
        lines += ["## Identical configurations", "",
                  "The same machine configuration (scene, configuration, size, engine) on several "
                  "axes is measured once per worker and reused; rows measured apart (several "
                  "workers, a cluster, a cached unit) must agree within their spread:", ""]
        lines += [f"- {line}" for line in same] + [""]
    lines += ["Files: " + ", ".join(f"`{f}`" for f in files), ""]
    return "\n".join(lines)


def write_all(out: Path, axes: dict[str, list[Row]], meta: dict) -> list[Path]:
    """accuracy.json, accuracy_<axis>.csv and .png per axis, report.md; the paths written."""
    paths = [out / "accuracy.json"]
    for axis in AXES:
        if axis in axes:
            paths.append(out / f"accuracy_{axis}.csv")
            write_csv(paths[-1], axes[axis])
            paths.append(out / f"accuracy_{axis}.png")
            write_plot(paths[-1], axis, axes[axis], meta["res"])
    write_json(out / "accuracy.json", axes, meta)
    report = out / "report.md"
    paths.append(report)
    write_text(report, report_markdown(axes, meta, [p.name for p in paths]))
    return paths
