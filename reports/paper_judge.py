"""How a finding of `netsushisen paper` is judged: one tolerance rule for every band, one
definition of "partly", a trend test for the "tends to" claims, and the margin every finding
prints (docs/databases.md, "How the findings are judged", lists every threshold here with the
reason it has that value; tests/test_paper_findings.py checks each one is documented).

Why a module of its own: the rules are stated once and every finding in reports/paper.py uses
them, so a reader checks one place, not seventeen inline comparisons.
"""

from __future__ import annotations

import math
from functools import lru_cache

TOLERANCE = 0.05
"""Every value or band the paper states on a share is met within 5 points (absolute), or one
step of the sweep's grid where that grid is coarser (`band_margin`)."""
PARTLY = 0.5
"""A finding is "agree" when every case passes, "partly" when at least half do, else "differ"."""
TREND_ALPHA = 0.05
"""A "tends to" claim holds when Kendall's τ has the claimed sign at one-sided p ≤ 5 %."""

THRESHOLDS: dict[str, float] = {
    "TOLERANCE": TOLERANCE, "PARTLY": PARTLY, "TREND_ALPHA": TREND_ALPHA,
    "SKEW": 0.4, "FIG3_LEVEL": 0.70, "FIG3_SPAN_HIGH": 0.5, "FIG4_LOW": 0.10,
    "FIG4_SATURATION": 0.5, "FIG5_NEAR": 0.7, "FIG5_CLOSE": 0.10, "FIG5_GAIN": 0.02,
    "LOW_RHO": 0.3, "LITTLE_GAIN": 0.10, "PREPASS_MAX": 0.02, "VISIBLE_RATIO": 1.0,
}
"""Every number a finding is judged against, by name (reports/paper.py reads them from here;
docs/databases.md gives each one's reason in its table of thresholds)."""


def band_margin(value: float, lo: float | None = None, hi: float | None = None,
                step: float = 0.0) -> float:
    """Signed distance of `value` inside [lo − tol, hi + tol] (positive: inside), tol =
    max(TOLERANCE, step); a one-sided claim gives only the bound it states."""
    tol = max(TOLERANCE, step)
    m = math.inf
    if lo is not None:
        m = min(m, value - (lo - tol))
    if hi is not None:
        m = min(m, (hi + tol) - value)
    return 0.0 if abs(m) < 1e-9 else m  # on the bound: 0.8 − (0.7 + 0.1) is not below it


def verdict(passed: dict[str, bool]) -> str:
    """The one rule: all cases pass → agree; at least PARTLY of them → partly; else differ."""
    if not passed:
        return "not evaluated"
    k, n = sum(passed.values()), len(passed)
    return "agree" if k == n else ("partly" if k >= PARTLY * n else "differ")


def passes(margins: dict[str, float], strict: bool = False) -> dict[str, bool]:
    """Each case passes when its margin is ≥ 0 (> 0 for a strict claim: "rises", "lowers")."""
    return {k: (m > 0 if strict else m >= 0) for k, m in margins.items()}


def kendall_tau(x, y) -> float:
    """Kendall's τ-a of (x, y): (concordant − discordant pairs) / all pairs."""
    n = len(x)
    s = 0
    for i in range(n):
        for j in range(i + 1, n):
            a, b = x[j] - x[i], y[j] - y[i]
            s += (a > 0) - (a < 0) if b > 0 else ((a < 0) - (a > 0) if b < 0 else 0)
    return s / (n * (n - 1) / 2) if n > 1 else 0.0


@lru_cache(maxsize=None)
def _inversions(n: int) -> tuple[int, ...]:
    """How many permutations of n items have k inversions, k = 0..n(n−1)/2 (Mahonian numbers):
    the exact null distribution of Kendall's τ without ties."""
    counts = [1]
    for m in range(2, n + 1):
        new = [0] * (len(counts) + m - 1)
        for k, c in enumerate(counts):
            for j in range(m):
                new[k + j] += c
        counts = new
    return tuple(counts)


def trend(x, y, sign: int) -> tuple[float, float]:
    """(τ, one-sided p) for the claim that y moves with x in direction `sign` (+1 rises, −1
    falls): p is the exact share of orderings with a τ at least as far in that direction."""
    n = len(x)
    tau = kendall_tau(x, y)
    if n < 3:
        return tau, 1.0
    counts = _inversions(n)
    pairs = n * (n - 1) // 2
    s = round(tau * pairs)  # concordant − discordant
    total = math.factorial(n)
    # s = pairs − 2·inversions: τ ≥ t ⇔ inversions ≤ (pairs − s)/2
    if sign > 0:
        k = math.floor((pairs - s) / 2 + 1e-9)
        tail = sum(counts[: k + 1])
    else:
        k = math.ceil((pairs - s) / 2 - 1e-9)
        tail = sum(counts[k:])
    return tau, tail / total


def trend_margin(x, y, sign: int) -> tuple[float, str]:
    """(margin, text) of a trend claim: TREND_ALPHA − p when τ has the claimed sign, else −p."""
    tau, p = trend(x, y, sign)
    m = TREND_ALPHA - p if tau * sign > 0 else -max(p, TREND_ALPHA)
    return m, f"τ {tau:+.2f}, p {p:.3g}"


def margin_text(margins: dict[str, float], fmt, what: str = "cases") -> str:
    """k of n cases passing and each case's margin (the worst few when there are many): what a
    reader needs to judge with another threshold."""
    ok = passes(margins)
    k, n = sum(ok.values()), len(margins)
    items = sorted(margins.items(), key=lambda kv: kv[1])
    shown = items if n <= 8 else items[:4]
    body = ", ".join(f"{name} {fmt(m)}" for name, m in shown)
    more = "" if n <= 8 else f" (the {len(shown)} smallest of {n})"
    return f"{k} of {n} {what} pass; margin to the threshold: {body}{more}"


def points(m: float) -> str:
    """A margin on a share, in percentage points."""
    return "∞" if math.isinf(m) else f"{100 * m:+.1f} points"


def relative(m: float) -> str:
    return f"{100 * m:+.1f} %"


def plain(m: float) -> str:
    return f"{m:+.3f}"


def alpha_less_p(m: float) -> str:
    """A trend's margin: TREND_ALPHA − p (negative: not significant or the wrong sign)."""
    return f"{m:+.3f} (α − p)"
