"""What accuracy costs: the rows of `netsushisen accuracy` and the pure arithmetic behind them.

A researcher choosing how to run a study needs, per knob, the error a cheaper setting buys and
the time a dearer one costs. Every setting of every axis is one `Row`: what it is (`setting`),
whether it is the axis's truth, its error against that truth on named metrics (every error of a
truth row is 0), its wall seconds, a machine-independent cost (rays traced, machine cycles) and
`how` it was obtained. The measurements themselves (golden renders, machine runs) are made by
`netsushisen/accuracy.py`, which sits above both the host and the machine; this module only
compares numbers, so the metrics can be tested on numbers chosen to flip them.

Metrics, and why these:
  - images: the 8-bit images a user sees — root-mean-square and largest channel difference, the
    share of channels off by more than 1 (what survives quantisation), and PSNR (dB, 8-bit; None
    for identical images: it would be infinite, so it is a value, not an error);
  - hit ids: the share of eye samples whose first hit primitive differs (geometry, not shading);
  - ray counts: the relative error of each kind (eye hits, reflection, refraction, shadow);
  - memory: ρ (share of IC's shape-data loads served by resident memory), μ (cache hit rate of
    the others) and t (mean cycles per load with the run's t_r / t_c / t_g; the paper's
    t_r·{ρ + (1 − ρ)(8 − 6μ)} under its t_c = 2·t_r, t_g = 8·t_r);
  - cycles: relative error of the total.
A sampled estimate (SMARTS) extrapolates per-tile samples to the whole image with a 95 %
confidence interval computed from the samples' spread (`sampled_estimate`; stratified by position
in `stratified_estimate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

AXES = ("precision", "depth", "prepass", "fidelity")
RAY_KINDS = ("eye_hits", "reflection", "refraction", "shadow")


@dataclass
class Row:
    """One setting of one axis on one scene (the contract of `accuracy.json`)."""

    axis: str
    scene: str
    setting: str
    truth: bool
    error: dict[str, float]
    seconds: float
    cost: dict[str, float]
    how: str
    values: dict[str, float | None] = field(default_factory=dict)  # what was measured itself
    ci_low: float | None = None  # sampled rows: 95 % interval of total cycles
    ci_high: float | None = None
    timing: "Timing | None" = None  # the repeated runs behind `seconds` (their median)
    emulated: bool = False  # a precision computed in software: its seconds are not its cost
    run: str = ""  # a machine row's configuration key (accuracy_runs.run_key): same key, same run

    def to_json(self) -> dict:
        out = {"scene": self.scene, "setting": self.setting, "truth": self.truth,
               "error": {k: float(v) for k, v in self.error.items()},
               "seconds": float(self.seconds),
               "cost": {k: _num(v) for k, v in self.cost.items()}, "how": self.how,
               "values": {k: _num(v) for k, v in self.values.items()}}
        if self.ci_low is not None:
            out["ci_low"], out["ci_high"] = float(self.ci_low), float(self.ci_high)
        if self.timing is not None:
            out["timing"] = self.timing.to_json()
        if self.emulated:
            out["emulated"] = True
        if self.run:
            out["run"] = self.run
        return out


@dataclass
class Timing:
    """Wall seconds of a row over repeated runs: each run's total (`runs`), each stage's per-run
    seconds (`parts`: host, load, machine, readout, auxiliary, … as the row has them) and their
    medians (`components`). `basis` names the stages an axis compares (a machine row: its machine
    stage; empty: the whole run): the `compared` seconds, whose [low, high] spread decides
    whether two rows can be told apart by time (`indistinguishable`). The row's `seconds` is the
    median total."""

    runs: list[float]
    components: dict[str, float] = field(default_factory=dict)  # stage -> median seconds
    parts: dict[str, list[float]] = field(default_factory=dict)  # stage -> per-run seconds
    basis: list[str] = field(default_factory=list)

    @property
    def median(self) -> float:
        return float(np.median(self.runs)) if self.runs else 0.0

    @property
    def low(self) -> float:
        return float(min(self.runs)) if self.runs else 0.0

    @property
    def high(self) -> float:
        return float(max(self.runs)) if self.runs else 0.0

    def stage_runs(self, stages: list[str] | tuple[str, ...]) -> list[float]:
        """Per run, the sum of these stages' seconds (the totals when a stage is missing)."""
        if not stages or any(s not in self.parts for s in stages):
            return list(self.runs)
        return [sum(v) for v in zip(*(self.parts[s] for s in stages))]

    def spread(self, stages: list[str] | tuple[str, ...] | None = None) -> tuple[float, float, float]:
        """(median, low, high) of these stages per run (default: the basis)."""
        x = self.stage_runs(self.basis if stages is None else stages)
        return (float(np.median(x)), float(min(x)), float(max(x))) if x else (0.0, 0.0, 0.0)

    @property
    def compared(self) -> float:
        """The median seconds an axis compares (the basis stages)."""
        return self.spread()[0]

    def to_json(self) -> dict:
        m, lo, hi = self.spread()
        return {"runs": [float(x) for x in self.runs], "median": self.median, "low": self.low,
                "high": self.high, "components": {k: float(v) for k, v in self.components.items()},
                "parts": {k: [float(x) for x in v] for k, v in self.parts.items()},
                "basis": list(self.basis),
                "compared": {"median": m, "low": lo, "high": hi}}

    @staticmethod
    def of(runs: list[float], components: dict[str, list[float]] | None = None,
           basis: list[str] | tuple[str, ...] = ()) -> "Timing":
        """A timing from each run's total and each stage's per-run seconds."""
        components = components or {}
        return Timing(list(runs), {k: float(np.median(v)) for k, v in components.items()},
                      {k: [float(x) for x in v] for k, v in components.items()}, list(basis))

    @staticmethod
    def of_parts(parts: dict[str, list[float]], basis: list[str] | tuple[str, ...] = ()) -> "Timing":
        """A timing from each stage's per-run seconds; a run's total is their sum (`*_cpu`
        entries, CPU seconds of a stage already counted, are kept but not added)."""
        wall = [v for k, v in parts.items() if not k.endswith("_cpu")]
        runs = [sum(v) for v in zip(*wall)] if wall else []
        return Timing.of(runs, parts, basis)


def indistinguishable(a: Row, b: Row) -> bool:
    """Whether two rows' compared times overlap (min–max of their repeated runs), so neither is
    measurably cheaper."""
    if a.timing is None or b.timing is None:
        return False
    _, alo, ahi = a.timing.spread()
    _, blo, bhi = b.timing.spread()
    return alo <= bhi and blo <= ahi


def time_ties(rows: list[Row]) -> list[tuple[str, str]]:
    """Settings next to each other in compared time whose spreads overlap (one scene's rows)."""
    timed = sorted((r for r in rows if r.timing is not None and not r.emulated),
                   key=lambda r: r.timing.compared)
    return [(a.setting, b.setting) for a, b in zip(timed, timed[1:]) if indistinguishable(a, b)]


@dataclass
class Agreement:
    """Rows of one scene that ran the same machine configuration (one `Row.run` key) on
    different axes or settings, and whether their machine stages agree within their spread."""

    scene: str
    rows: list[tuple[str, str]]  # (axis, setting)
    spreads: list[tuple[float, float, float]]  # machine seconds: (median, low, high)
    agree: bool

    def sentence(self) -> str:
        parts = [f"{axis} {setting} {m:.3f} s ({lo:.3f}–{hi:.3f})"
                 for (axis, setting), (m, lo, hi) in zip(self.rows, self.spreads)]
        return (f"{self.scene}: the same configuration, machine seconds " + " = ".join(parts)
                + (": agree within their spread" if self.agree
                   else ": DISAGREE (their spreads do not overlap: the timing is not repeatable)"))


def identical_runs(axes: dict[str, list[Row]], stage: str = "machine") -> list[Agreement]:
    """Every group of rows (same scene, same run key, two or more rows) and whether their
    `stage` spreads overlap: identical work must time alike, or the ranking is noise."""
    groups: dict[tuple[str, str], list[tuple[str, Row]]] = {}
    for axis, rows in axes.items():
        for r in rows:
            if r.run and r.timing is not None and stage in r.timing.parts:
                groups.setdefault((r.scene, r.run), []).append((axis, r))
    out = []
    for (scene, _), members in groups.items():
        if len(members) < 2:
            continue
        spreads = [r.timing.spread([stage]) for _, r in members]
        agree = max(lo for _, lo, _ in spreads) <= min(hi for _, _, hi in spreads)
        out.append(Agreement(scene, [(a, r.setting) for a, r in members], spreads, agree))
    return out


def _num(v):
    if v is None or isinstance(v, (bool, int)):
        return v
    v = float(v)
    return v if math.isfinite(v) else None


# ------------------------------------------------------------------------------------------------
# Errors


def relative(value: float, truth: float) -> float:
    """|value − truth| / |truth| (the plain difference when the truth is 0)."""
    d = abs(float(value) - float(truth))
    return d / abs(float(truth)) if truth else d


def image_errors(u8: np.ndarray, truth_u8: np.ndarray) -> tuple[dict[str, float], float | None]:
    """(errors of an 8-bit image against the truth's, PSNR in dB or None when identical)."""
    d = u8.astype(np.int64) - truth_u8.astype(np.int64)
    mse = float(np.mean(d * d)) if d.size else 0.0
    errors = {"rmse_u8": math.sqrt(mse), "max_u8": float(np.abs(d).max()) if d.size else 0.0,
              "channels_off": float(np.mean(np.abs(d) > 1)) if d.size else 0.0}
    return errors, (10 * math.log10(255.0 ** 2 / mse) if mse else None)


def hit_id_share(ids: np.ndarray, truth_ids: np.ndarray) -> float:
    """Share of eye samples whose first-hit primitive differs from the truth's."""
    return float(np.mean(np.asarray(ids) != np.asarray(truth_ids)))


def ray_errors(rays: dict[str, int], truth: dict[str, int]) -> dict[str, float]:
    """Relative error of each ray count (eye hits, reflection, refraction, shadow)."""
    return {f"rays_{k}": relative(rays.get(k, 0), truth.get(k, 0)) for k in RAY_KINDS}


def traced_rays(rays: dict[str, int]) -> int:
    """Rays traced: eye, reflection, refraction and shadow rays (eye hits are not rays)."""
    return int(sum(rays.get(k, 0) for k in ("eye", "reflection", "refraction", "shadow")))


# ------------------------------------------------------------------------------------------------
# Memory: ρ, μ, t from counters


def ic_regions(stats: dict) -> dict:
    """IC's region counters summed over every PE (`stats["memory"]["pe*.ic"]["regions"]`)."""
    out: dict[str, dict[str, int]] = {}
    for name, mem in stats["memory"].items():
        if name.endswith(".ic"):
            for key, c in (mem.get("regions") or {}).items():
                acc = out.setdefault(key, {"accesses": 0, "hits": 0})
                acc["accesses"] += c.get("accesses", 0)
                acc["hits"] += c.get("hits", 0)
    return out


def memory_point(regions: dict, t_r: float = 1, t_c: float = 2, t_g: float = 8,
                 region: str = "shape_data") -> dict[str, float]:
    """ρ, μ, t (measured mean cycles per load) and the paper's t model from region counters
    (the emulator's or the trace-driven model's shape: "resident.R" / "global.R")."""
    res = regions.get(f"resident.{region}", {}).get("accesses", 0)
    acc = regions.get(f"global.{region}", {}).get("accesses", 0)
    hits = regions.get(f"global.{region}", {}).get("hits", 0)
    return point_from_counts(res, acc, hits, t_r, t_c, t_g)


def point_from_counts(resident: float, cache: float, hits: float, t_r: float = 1, t_c: float = 2,
                      t_g: float = 8) -> dict[str, float]:
    total = resident + cache
    rho = resident / total if total else 0.0
    mu = hits / cache if cache else 1.0
    t = (resident * t_r + hits * t_c + (cache - hits) * t_g) / total if total else 0.0
    return {"loads": total, "rho": rho, "mu": mu, "t": t,
            "t_model": t_r * (rho + (1 - rho) * (8 - 6 * mu))}


def fidelity_errors(values: dict, truth: dict) -> dict[str, float]:
    """Relative error of total cycles, ρ, μ and t against the full cycle-accurate run."""
    return {k: relative(values[k], truth[k]) for k in ("cycles", "rho", "mu", "t")}


# ------------------------------------------------------------------------------------------------
# Sampling (SMARTS): an estimate of a total and its 95 % interval from per-unit samples

_T975 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
         2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
         2.060, 2.056, 2.052, 2.048, 2.045, 2.042)
"""Student's t, 97.5 % quantile, 1..30 degrees of freedom (then 1.96): no scipy needed."""


def t_quantile(dof: float) -> float:
    """t's 97.5 % quantile (1.96 from 31 degrees of freedom on); a fractional `dof`
    (Satterthwaite's) interpolates linearly in 1/dof between the neighbouring integers."""
    table = lambda k: _T975[k - 1] if k <= len(_T975) else 1.96  # noqa: E731
    if dof <= 1:
        return _T975[0]
    lo = int(dof)
    if lo == dof:
        return table(lo)
    w = (1 / lo - 1 / dof) / (1 / lo - 1 / (lo + 1))
    return table(lo) + w * (table(lo + 1) - table(lo))


def sampled_estimate(samples, population: int) -> tuple[float, float, float]:
    """(estimate, low, high) of the total over `population` units from simple random samples
    of it: N·mean ± t(n−1)·N·s/√n·√(1 − n/N) (finite population: sampling every unit gives the
    exact total and a zero-width interval; a total of non-negative units never falls below the
    sampled units' own sum). One sample has no spread: the interval is unbounded."""
    x = np.asarray(samples, np.float64)
    n = len(x)
    if n == 0:
        raise ValueError("no samples")
    est = population * float(x.mean())
    if n == 1:
        return est, -math.inf, math.inf
    fpc = math.sqrt(max(0.0, 1 - n / population))
    half = t_quantile(n - 1) * population * float(x.std(ddof=1)) / math.sqrt(n) * fpc
    low = est - half
    if x.min() >= 0:  # a total of non-negative units is at least the sampled units' sum
        low = max(low, float(x.sum()))
    return est, low, est + half


def stratified_estimate(strata) -> tuple[float, float, float]:
    """(estimate, low, high) of a total from a stratified random sample: `strata` is a list of
    (samples, units) — each stratum's simple random sample and how many units it has. Estimate
    Σ N_h·mean_h; interval ± t(n − H)·√Σ N_h²·(1 − n_h/N_h)·s_h²/n_h (each stratum's spread from its
    own samples, so a stratum needs 2 samples unless all its units are sampled; degrees of freedom
    n − H, conservative). One stratum is `sampled_estimate`; sampling every unit gives the exact
    total and a zero-width interval; a total of non-negative units never falls below the sampled
    units' own sum."""
    if not strata or any(len(x) == 0 for x, _ in strata):
        raise ValueError("no samples")
    if len(strata) == 1:
        return sampled_estimate(*strata[0])
    est, var, n, low_sum, nonneg, spread = 0.0, 0.0, 0, 0.0, True, True
    for samples, units in strata:
        x = np.asarray(samples, np.float64)
        est += units * float(x.mean())
        n += len(x)
        low_sum += float(x.sum())
        nonneg = nonneg and x.min() >= 0
        if len(x) < units:
            if len(x) == 1:
                spread = False  # a stratum with one sample of several units: no interval
            else:
                var += units ** 2 * (1 - len(x) / units) * float(x.var(ddof=1)) / len(x)
    if not spread:
        return est, -math.inf, math.inf
    dof = n - len(strata)
    half = t_quantile(dof) * math.sqrt(var) if dof > 0 else 0.0
    low = est - half
    if nonneg:
        low = max(low, low_sum)
    return est, low, est + half


WARM_UP_ALLOWANCE = 0.0045
"""The warm-up residue as a standard uncertainty, relative to the estimate, added in quadrature
to the sampling half-width: with today's kernels and the 16-sample warm-up
(`netsushisen.accuracy.WARM_SAMPLES`) the 64 tiles' marginals sum to the full run within −0.00 %
(tetra 16²), +0.17 % (tetra 32²), −0.32 % (balls 16²) and +0.43 % (balls 32²), a bias no spread
of the tiles shows; the allowance is the largest of these, rounded up (0.2 % left balls 32² at
50 % covered 92.6 % of 4,000 redraws). In quadrature, not added: a wide interval (few tiles)
already covers it, a narrow one (half the tiles) needs it; added linearly it over-covered at
25 % (97.6 %). Rerun tools/interval_coverage.py after a kernel change: the residue moves."""


def _regression_total(strata) -> float:
    """Σ N_h·(ȳ_h + b·(X̄_h − x̄_h)) with b the slope pooled within the strata."""
    num = den = 0.0
    for y, x, xs in strata:
        if len(y) > 1:
            dx = x - x.mean()
            num += float((dx * (y - y.mean())).sum())
            den += float((dx * dx).sum())
    b = num / den if den > 0 else 0.0
    return sum(len(xs) * (float(y.mean()) + b * (float(xs.mean()) - float(x.mean())))
               for y, x, xs in strata)


def regression_estimate(strata, allowance: float = WARM_UP_ALLOWANCE) -> tuple[float, float, float]:
    """(estimate, low, high) of a total from a stratified sample with an auxiliary known for every
    unit: `strata` is a list of (sampled y, their x, every unit's x). The combined regression
    estimator Σ N_h·(ȳ_h + b·(X̄_h − x̄_h)) (b pooled within strata); its variance by the stratified
    delete-one jackknife V = Σ_h V_h, V_h = (1 − f_h)·(n_h − 1)/n_h·Σ_j (θ_(hj) − θ̄_h)² (it follows
    the slope's own uncertainty, which a residual variance misses); the half-width
    √((t(ν)·√V)² + (allowance·estimate)²) with ν = V² / Σ_h V_h²/(n_h − 1), Satterthwaite's
    effective degrees of freedom (Cochran 5A.42): when one stratum carries most of the variance
    the interval has its few degrees of freedom, not n − H; `allowance` is the warm-up residue.
    Every unit sampled: the exact total."""
    strata = [(np.asarray(y, np.float64), np.asarray(x, np.float64), np.asarray(xs, np.float64))
              for y, x, xs in strata]
    if not strata or any(len(y) == 0 for y, _, _ in strata):
        raise ValueError("no samples")
    est = _regression_total(strata)
    if all(len(y) == len(xs) for y, _, xs in strata):
        return est, est, est
    parts = []
    for h, (y, x, xs) in enumerate(strata):
        nh = len(y)
        if nh < 2:
            return est, -math.inf, math.inf
        reps = []
        for j in range(nh):
            keep = np.arange(nh) != j
            reps.append(_regression_total(strata[:h] + [(y[keep], x[keep], xs)] + strata[h + 1:]))
        r = np.asarray(reps)
        parts.append(((1 - nh / len(xs)) * (nh - 1) / nh * float(((r - r.mean()) ** 2).sum()), nh))
    var = sum(v for v, _ in parts)
    dof = var * var / sum(v * v / (nh - 1) for v, nh in parts) if var > 0 else \
        sum(nh for _, nh in parts) - len(parts)
    half = math.hypot(t_quantile(dof) * math.sqrt(var), allowance * abs(est))
    return est, est - half, est + half


PER_STRATUM = 3
"""Tiles drawn in each stratum of consecutive tiles. Three: with two the stratified jackknife's
spread within a stratum is too unstable (coverage 89–94 %); with four, 10 % of 64 tiles (6) is
one unstratified stratum, whose heavy tail (background tiles of zero cycles) covered 93.0 % on
tetra 32²; three gives 6 tiles two strata, and Satterthwaite's degrees of freedom in
`regression_estimate` account for the few samples per stratum (docs/accuracy.md)."""


def strata_bounds(n_tiles: int, n: int, per_stratum: int = PER_STRATUM) -> list[int]:
    """Bounds of the strata of an n-tile sample: n // per_stratum runs of consecutive tiles (DIS
    order), as equal as they come; [0, n_tiles] for fewer than 2·per_stratum tiles."""
    return np.linspace(0, n_tiles, max(1, n // per_stratum) + 1).round().astype(int).tolist()


def stratified_tiles(rng: np.random.Generator, n_tiles: int, n: int, per_stratum: int = PER_STRATUM
                     ) -> list[int]:
    """n tiles of n_tiles: n // H at random in each of the H strata of `strata_bounds` (the
    remainder one more each in the first strata with room), sorted.

    Why strata: a tile's cycles follow where it lies in the image (background rows against the
    objects; next tiles' cycles correlate 0.84 on tetra, 0.75 on balls at 32x32), so a simple
    random sample of the tiles can fall mostly on the cheap rows; spread over the strata, every
    part of the image is sampled in proportion."""
    bounds = strata_bounds(n_tiles, n, per_stratum)
    sizes = np.diff(bounds)
    take = np.minimum(n // len(sizes), sizes)
    while take.sum() < n:  # the remainder, one more each, to the first strata with room
        room = np.flatnonzero(take < sizes)
        take[room[:n - int(take.sum())]] += 1
    out = []
    for lo, size, k in zip(bounds, sizes, take):
        out += (lo + rng.choice(size, min(k, size), replace=False)).tolist()
    return sorted(out)


def coverage(cycles, aux, full: float, n: int, redraws: int, seed: int = 0,
             per_stratum: int | None = None) -> float:
    """Share of `redraws` stratified samples of n tiles whose interval covers `full` (the full
    run's cycles): the tiles' marginal cycles and auxiliary measured once, so this is arithmetic."""
    per_stratum = per_stratum or PER_STRATUM
    y, x = np.asarray(cycles, np.float64), np.asarray(aux, np.float64)
    rng = np.random.default_rng(seed)
    bounds = strata_bounds(len(y), n, per_stratum)
    hit = 0
    for _ in range(redraws):
        chosen = np.asarray(stratified_tiles(rng, len(y), n, per_stratum))
        strata = [(y[c], x[c], x[lo:hi]) for lo, hi in zip(bounds, bounds[1:])
                  for c in [chosen[(chosen >= lo) & (chosen < hi)]]]
        _, low, high = regression_estimate(strata)
        hit += low <= full <= high
    return hit / redraws


# ------------------------------------------------------------------------------------------------
# What the numbers mean: one sentence per axis and scene


def depth_settles(rows: list[Row]) -> int | None:
    """The first depth from which every depth row's image equals the truth's (None: never)."""
    settled = None
    for r in sorted((r for r in rows if not r.truth), key=lambda r: int(r.values["depth"]),
                    reverse=True):
        if r.error["max_u8"] == 0:
            settled = int(r.values["depth"])
        else:
            break
    return settled


def axis_sentences(axis: str, rows: list[Row]) -> list[str]:
    """What an axis's rows say, per scene, in words."""
    out = []
    for scene in dict.fromkeys(r.scene for r in rows):
        mine = [r for r in rows if r.scene == scene]
        truth = next((r for r in mine if r.truth), None)
        others = [r for r in mine if not r.truth]
        if truth is None or not others:
            continue
        ties = time_ties(mine)
        if ties:
            out.append(f"{scene}: indistinguishable in time (spreads of the repeated runs "
                       "overlap): "
                       + "; ".join(f"{a} ≈ {b}" for a, b in ties) + ".")
        if axis == "precision":
            m32 = next((r for r in mine if r.setting == "machine fp32"), None)
            m64 = next((r for r in mine if r.setting == "machine fp64"), None)
            if m32 and m64 and m32.timing and m64.timing and m32.cost.get("cycles"):
                time_ratio = m64.timing.compared / m32.timing.compared if m32.timing.compared else 0
                cycle_ratio = m64.cost["cycles"] / m32.cost["cycles"]
                out.append(f"{scene}: fp64 costs the machine {100 * (cycle_ratio - 1):+.1f} % "
                           f"cycles and {100 * (time_ratio - 1):+.1f} % machine-run time "
                           f"(medians; {100 * abs(time_ratio - cycle_ratio):.1f} points apart).")
            worst = max(others, key=lambda r: r.error["rmse_u8"])
            exact = [r.setting for r in others if not any(r.error.values())]
            out.append(f"{scene}: the largest image error is {worst.setting} (RMS "
                       f"{worst.error['rmse_u8']:.2f} of 255, hit ids differ on "
                       f"{100 * worst.error['hit_ids']:.1f} % of samples); "
                       + (f"{', '.join(exact)}: identical to the fp64 truth." if exact else
                          "no setting equals the fp64 truth exactly."))
        elif axis == "depth":
            d = depth_settles(mine)
            td = truth.values.get("truth_depth")
            if td is not None:
                out.append(f"{scene}: truth depth {td} — " + (
                    "its 8-bit image equals the one before it in 10, 20, 40 (converged)"
                    if truth.values.get("truth_converged") else
                    "the cap: the image still changed up to it (NOT converged)") + ".")
            if d == 1:
                out.append(f"{scene}: no change past depth 1 — nothing spawns secondary surface "
                           "rays (no mirrors or glass), so every depth gives the same image, rays "
                           "and cycles.")
            elif d is not None:
                r = next(r for r in others if int(r.values["depth"]) == d)
                share = (f"at {r.cost['cycles'] / truth.cost['cycles']:.0%} of the truth's cycles"
                         if r.cost.get("cycles") and truth.cost.get("cycles") else
                         "the machine did not run the truth's depth")
                out.append(f"{scene}: the image stops changing at depth {d} (8-bit identical to "
                           f"depth {int(truth.values['depth'])}), {share}.")
            else:
                out.append(f"{scene}: every depth up to 8 still differs from depth "
                           f"{int(truth.values['depth'])}.")
        elif axis == "prepass":
            best = min(others, key=lambda r: (r.error["cycles"], r.cost["rays"]))
            out.append(f"{scene}: " + _cheapest(others, "cycles", 0.01) + f"; the closest is "
                       f"{best.setting}, {100 * best.error['cycles']:.2f} % more or fewer cycles, "
                       f"ρ {best.values['rho']:.3f} against {truth.values['rho']:.3f}.")
        elif axis == "fidelity":
            parts = []
            for r in others:
                s = f"{r.setting} {100 * r.error['cycles']:.1f} % off in {r.seconds:.2f} s"
                if r.ci_low is not None:
                    s += " (interval " + ("covers" if r.values.get("covers")
                                          else "misses") + " the truth)"
                parts.append(s)
            out.append(f"{scene}: truth {int(truth.values['cycles']):,} cycles in "
                       f"{truth.seconds:.2f} s; "
                       + "; ".join(parts) + ".")
    return out


def _cheapest(rows: list[Row], metric: str, within: float) -> str:
    ok = [r for r in rows if r.error[metric] <= within]
    if not ok:
        return f"no smaller pre-pass comes within {within:.0%} of the full-resolution ranking's cycles"
    r = min(ok, key=lambda r: r.cost["rays"])
    return (f"the smallest pre-pass within {within:.0%} of the full-resolution ranking's cycles is "
            f"{r.setting} ({int(r.cost['rays']):,} eye rays)")
