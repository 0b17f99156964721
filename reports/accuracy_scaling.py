"""How accuracy costs scale with size: `netsushisen accuracy --sizes 16,32,64,128`.

At 16² or 32² a machine row is mostly fixed cost (host preparation, the engine's load), so a
study at the sizes a researcher runs (512² and up) cannot be read off them. Per setting, the
seconds its axis compares are fitted by least squares to seconds = a + b·rays over the measured
sizes (rays: the row's traced rays where it counts them, else its eye rays, res²), shown with R²,
and extrapolated to a larger size (rays scaled by pixels from the largest measured size). The
sampled rows' speed-up over the full cycle-accurate run is shown per size: sampling pays a load
per tile, so it wins only where the run is long. Pure arithmetic on the study's rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from netsushisen.reports.accuracy import Row


@dataclass
class Fit:
    """seconds = a + b·rays by least squares over `n` sizes; `r2` its coefficient of
    determination (1: every point on the line; None with two points, which any line fits)."""

    a: float
    b: float
    r2: float | None
    n: int

    def predict(self, rays: float) -> float:
        return self.a + self.b * rays


def fit_line(rays: list[float], seconds: list[float]) -> Fit:
    """The least-squares line through (rays, seconds); at least two distinct ray counts."""
    x, y = np.asarray(rays, np.float64), np.asarray(seconds, np.float64)
    if len(x) < 2 or np.ptp(x) == 0:
        raise ValueError("a line needs two sizes with different ray counts")
    b, a = np.polyfit(x, y, 1)
    resid = y - (a + b * x)
    ss = float(((y - y.mean()) ** 2).sum())
    r2 = (1 - float((resid ** 2).sum()) / ss if ss else 1.0) if len(x) > 2 else None
    return Fit(float(a), float(b), r2, len(x))


def row_rays(row: Row, res: int) -> int:
    """The rays a row's cost follows: its traced rays, else its eye rays (res²)."""
    return int(row.cost.get("rays") or res * res)


@dataclass
class Scaling:
    """One setting measured at several sizes: (res, rays, median, low, high) of the seconds
    compared (`stage`: the timing's basis, or one named stage), its fit, its prediction."""

    axis: str
    scene: str
    setting: str
    stage: str
    points: list[tuple[int, int, float, float, float]]
    fit: Fit
    predict_res: int
    predicted: float

    def to_json(self) -> dict:
        return {"axis": self.axis, "scene": self.scene, "setting": self.setting,
                "stage": self.stage,
                "points": [{"res": r, "rays": n, "median": m, "low": lo, "high": hi}
                           for r, n, m, lo, hi in self.points],
                "fit": {"a": self.fit.a, "b": self.fit.b, "r2": self.fit.r2, "n": self.fit.n},
                "predict_res": self.predict_res, "predicted_seconds": self.predicted}


def scalings(studies: dict[int, dict[str, list[Row]]], predict_res: int) -> list[Scaling]:
    """Every (axis, scene, setting) timed at two sizes or more, fitted on its compared seconds
    and, for machine rows, on the machine stage alone (the run a larger study repeats) and on
    its CPU seconds (`machine_cpu`: what a loaded, shared machine does not inflate)."""
    groups: dict[tuple[str, str, str, str], list[tuple[int, int, float, float, float]]] = {}
    for res, axes in sorted(studies.items()):
        for axis, rows in axes.items():
            for r in rows:
                if r.timing is None or r.emulated:
                    continue
                stages = [("compared", None)]
                if "machine" in r.timing.parts and r.timing.basis != ["machine"]:
                    stages.append(("machine", ["machine"]))
                if "machine_cpu" in r.timing.parts:  # immune to other processes' load
                    stages.append(("machine_cpu", ["machine_cpu"]))
                for name, which in stages:
                    m, lo, hi = r.timing.spread(which)
                    groups.setdefault((axis, r.scene, r.setting, name), []).append(
                        (res, row_rays(r, res), m, lo, hi))
    out = []
    for (axis, scene, setting, stage), points in groups.items():
        if len({p[1] for p in points}) < 2:
            continue
        fit = fit_line([p[1] for p in points], [p[2] for p in points])
        last = max(points)
        rays = last[1] * (predict_res / last[0]) ** 2
        out.append(Scaling(axis, scene, setting, stage, points, fit, predict_res,
                           fit.predict(rays)))
    return out


def sampled_speedups(studies: dict[int, dict[str, list[Row]]]) -> list[dict]:
    """Per scene, size and sampled share: the full run's compared seconds over the sampled
    row's (above 1: sampling is faster)."""
    out = []
    for res, axes in sorted(studies.items()):
        rows = axes.get("fidelity", [])
        for r in rows:
            if r.ci_low is None or r.timing is None:
                continue
            full = next((t for t in rows if t.scene == r.scene and t.truth), None)
            if full is None or full.timing is None or not r.timing.compared:
                continue
            out.append({"scene": r.scene, "res": res, "setting": r.setting,
                        "full_seconds": full.timing.compared, "sampled_seconds": r.timing.compared,
                        "speedup": full.timing.compared / r.timing.compared})
    return out


def scaling_markdown(fits: list[Scaling], speedups: list[dict], measured: dict | None = None
                     ) -> str:
    """The fits as a table (points as median (min–max)), the speed-ups, and a measured run at
    the predicted size beside its prediction when there is one (`measured`: setting, stage,
    seconds)."""
    lines = ["| axis | scene | setting | seconds (stage) | per size: median (min–max) s | "
             "fit a + b·rays | R² | predicted |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for s in fits:
        pts = "; ".join(f"{r}²: {m:.3f} ({lo:.3f}–{hi:.3f})" for r, _, m, lo, hi in s.points)
        r2 = "–" if s.fit.r2 is None else f"{s.fit.r2:.4f}"
        lines.append(f"| {s.axis} | {s.scene} | {s.setting} | {s.stage} | {pts} | "
                     f"{s.fit.a:.3f} + {s.fit.b * 1e6:.2f} µs·rays | {r2} | "
                     f"{s.predicted:.1f} s at {s.predict_res}² |")
    if speedups:
        lines += ["", "| scene | size | sampled | full s | sampled s | speed-up |",
                  "| --- | --- | --- | --- | --- | --- |"]
        lines += [f"| {u['scene']} | {u['res']}² | {u['setting']} | {u['full_seconds']:.2f} | "
                  f"{u['sampled_seconds']:.2f} | {u['speedup']:.2f}× |" for u in speedups]
    if measured:
        lines += ["", measured_sentence(fits, measured)]
    return "\n".join(lines) + "\n"


def measured_sentence(fits: list[Scaling], measured: dict) -> str:
    """The prediction beside a measured run: within 20 % or not."""
    s = next((f for f in fits if f.setting == measured["setting"] and f.stage == measured["stage"]
              and f.scene == measured["scene"]), None)
    if s is None:
        return f"no fit for {measured['scene']} {measured['setting']} ({measured['stage']})"
    err = s.predicted / measured["seconds"] - 1
    return (f"{measured['scene']} {measured['setting']} ({measured['stage']}) at {s.predict_res}²: "
            f"predicted {s.predicted:.1f} s, measured {measured['seconds']:.1f} s ({err:+.1%}: "
            + ("within" if abs(err) <= 0.2 else "NOT within") + " 20 %)")
