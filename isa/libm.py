"""pow as the machine defines it, for every engine and the golden model: the same bits on every
x86-64 CPU and every library version.

`fpow` used to be C's `powf` / `pow`. The C library picks its pow at load time by the CPU's
features (glibc has FMA and non-FMA variants that round some results differently), and numpy's
power loops differ again, so the same scene could shade a highlight one level apart on two
machines. `fpow` is therefore defined here with IEEE 754's basic operations only (+, −, ×, ÷,
exact scaling by powers of two), in a fixed order, in float64; an fp32 result is that float64
value rounded once to float32:

* C99 Annex F's special cases (`x**0 = 1` even for NaN, `1**y = 1`, signed zeros and
  infinities, a negative base with a non-integer exponent is NaN, odd integer exponents keep
  the sign);
* an integer exponent of magnitude at most 2**20: binary powering (square-and-multiply from the
  low bit, then one division for a negative exponent) — exact whenever the result is
  representable in float64 (3**2 = 9, 2**10 = 1024), within ~2·log2|y| float64 ulps otherwise —
  unless the result (or the power before the division) leaves the normal range, which takes
  the next path;
* any other exponent: `2**(y·log2 x)`, log2 from frexp and the series of atanh for the mantissa
  in [√½, √2), the power of two split off by rounding, the rest by exp's Taylor series
  (relative error about |y·log2 x|·2⁻⁵³: far below float32's rounding; a few float64 ulps).

So fp32's `fpow` is correctly rounded except within ~10⁻¹⁴ of a rounding boundary (closer to the
true value than glibc's powf, which is not correctly rounded); fp64's relative error is about
|y·log2 x|·2⁻⁵² (a few ulps for results between 2⁻⁸ and 2⁸, ~100 ulps where |y·log2 x| ≈ 300);
both are deterministic. The reference engine and the golden
model call `machine_pow`; the compiled engine compiles the very same function (isa/jit.py).
"""

from __future__ import annotations

import math

import numpy as np

from netsushisen.isa.jit import jitable, overload

SQRT_HALF = 0.70710678118654752440
INV_LN2 = 1.44269504088896340736
LN2 = 0.69314718055994530942
FLT_MAX = float(np.finfo(np.float32).max)
DBL_MIN = 2.2250738585072014e-308  # the smallest normal float64
TWO_1022 = 4.49423283715579e+307  # 2**1022: a larger power's reciprocal is subnormal
INTEGER_POWERING_LIMIT = 1048576.0  # 2**20: larger integer exponents take the log/exp path
# 1/(2k+1) for the atanh series, k = 11 … 0 (Horner order): |s| ≤ 0.1716, s² ≤ 0.0295, so the
# first omitted term is below 2⁻⁶⁰ of the sum.
_ATANH = (1.0 / 23, 1.0 / 21, 1.0 / 19, 1.0 / 17, 1.0 / 15, 1.0 / 13, 1.0 / 11, 1.0 / 9,
          1.0 / 7, 1.0 / 5, 1.0 / 3, 1.0)
# 1/k! for exp's Taylor series, k = 14 … 0: |r| ≤ 0.3466, so the first omitted term is < 2⁻⁶².
_EXP = (1.0 / 87178291200, 1.0 / 6227020800, 1.0 / 479001600, 1.0 / 39916800, 1.0 / 3628800,
        1.0 / 362880, 1.0 / 40320, 1.0 / 5040, 1.0 / 720, 1.0 / 120, 1.0 / 24, 1.0 / 6, 0.5,
        1.0, 1.0)


@jitable
def _log2(x: float) -> float:
    """log2 of a positive finite float64 (subnormals included: frexp normalises them)."""
    m, e = math.frexp(x)
    if m < SQRT_HALF:
        m = m * 2.0
        e = e - 1
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    p = 0.0
    for c in _ATANH:
        p = p * s2 + c
    return float(e) + (2.0 * s * p) * INV_LN2


@jitable
def _exp2(t: float) -> float:
    """2**t for a finite float64 t: the nearest integer split off exactly, exp's series for the
    rest, then an exact scaling (which rounds once where the result is subnormal)."""
    if t >= 1025.0:
        return math.inf
    if t <= -1100.0:
        return 0.0
    n = math.floor(t + 0.5)
    r = (t - n) * LN2
    p = 0.0
    for c in _EXP:
        p = p * r + c
    return math.ldexp(p, int(n))


@jitable
def _is_integer(y: float) -> bool:
    return math.floor(y) == y


@jitable
def _is_odd_integer(y: float) -> bool:
    return math.floor(y) == y and math.floor(y * 0.5) != y * 0.5


@jitable
def pow64(x: float, y: float) -> float:
    """`fpow` in float64 (the module's docstring is the definition)."""
    if y == 0.0:
        return 1.0
    if x == 1.0:
        return 1.0
    if math.isnan(x) or math.isnan(y):
        return math.nan
    if x == 0.0:
        negative = math.copysign(1.0, x) < 0.0 and _is_odd_integer(y)
        if y < 0.0:
            return -math.inf if negative else math.inf
        return -0.0 if negative else 0.0
    if math.isinf(y):
        if x == -1.0:
            return 1.0
        if (abs(x) < 1.0) == (y > 0.0):
            return 0.0
        return math.inf
    if math.isinf(x):
        if x < 0.0 and _is_odd_integer(y):
            return -0.0 if y < 0.0 else -math.inf
        return 0.0 if y < 0.0 else math.inf
    sign = 1.0
    if x < 0.0:
        if not _is_integer(y):
            return math.nan
        if _is_odd_integer(y):
            sign = -1.0
        x = -x
    if _is_integer(y) and abs(y) <= INTEGER_POWERING_LIMIT:
        n = int(abs(y))
        result = 1.0
        square = x
        while n > 0:
            if n & 1:
                result = result * square
            n = n >> 1
            if n > 0:
                square = square * square
        if y < 0.0:
            result = 1.0 / result if result <= TWO_1022 else 0.0
        if DBL_MIN <= result < math.inf:  # else an intermediate over- or underflowed: the
            return sign * result          # log/exp path rounds the result once instead
    return sign * _exp2(y * _log2(x))


def machine_pow(a, b):
    """`fpow`: float32 operands give `float32(pow64(a, b))`, float64 ones `pow64(a, b)`; the result
    has a's type."""
    value = pow64(float(a), float(b))
    if isinstance(a, np.float32):
        if abs(value) > FLT_MAX:  # beyond float32's range: the cast would round to ±inf (or be
            with np.errstate(over="ignore"):  # FLT_MAX itself), without numpy's warning
                return np.float32(value)
        return np.float32(value)
    return np.float64(value)


@overload(machine_pow)
def _machine_pow_numba(a, b):
    from numba.core import types

    if a == types.float32:
        return lambda a, b: np.float32(pow64(np.float64(a), np.float64(b)))
    return lambda a, b: np.float64(pow64(np.float64(a), np.float64(b)))


_pow64_array = np.frompyfunc(pow64, 2, 1)


def machine_pow_array(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Elementwise `machine_pow` over arrays (the golden model's Phong highlights)."""
    a = np.asarray(a)
    dtype = np.float32 if a.dtype == np.float32 else np.float64
    wide = _pow64_array(a.astype(np.float64), np.asarray(b).astype(np.float64))
    with np.errstate(over="ignore"):  # beyond float32's range: ±inf, as machine_pow
        return np.asarray(wide, dtype=np.float64).astype(dtype)
