"""Numbers read from files the toolchain wrote (statistics, object files), checked on load.

A statistics file or an object file is JSON (or a flat dump) that a user may have edited or a
fuzzer made: a 100,000-digit integer (Python's int() refuses past 4,300 digits, and a report
that multiplies one fails later), `1e999999` (a float infinity), `NaN`, a count of 10^400 that a
ratio cannot divide. Every number these files hold is a count, an address, a bit pattern or a
measured figure, so it must fit 64 bits (signed or unsigned) or be a finite float. The parse
bounds a decimal integer's digits *before* converting it, and a walk names the first number
that breaks the rule by its path (`processors.pe0.ic.stalls.branch: not a finite count`), so
the reader raises one located line instead of a report crashing on it.
"""

from __future__ import annotations

import json
import math

INT_MIN = -(1 << 63)
INT_MAX = (1 << 64) - 1
"""The range a file's integer may hold: a 64-bit signed or unsigned word."""

MAX_INT_DIGITS = 20
"""Decimal digits of the longest 64-bit integer (2^64 − 1 has 20): longer is refused before
int() sees it."""

OUT_OF_RANGE = "an integer outside the 64-bit range"
NOT_FINITE = "not a finite count"


class Unreadable:
    """A number the parse would not convert: stands in its place until the walk names it."""

    __slots__ = ("problem",)

    def __init__(self, problem: str):
        self.problem = problem

    def __repr__(self) -> str:
        return f"<{self.problem}>"


def integer(text: str) -> int | Unreadable:
    """A decimal integer's text as an int, or Unreadable when it cannot fit 64 bits (its
    digits counted first: no conversion of a 100,000-digit string)."""
    digits = text[1:] if text[:1] in "+-" else text
    if len(digits.lstrip("0")) > MAX_INT_DIGITS:
        return Unreadable(OUT_OF_RANGE)
    value = int(text)
    return value if INT_MIN <= value <= INT_MAX else Unreadable(OUT_OF_RANGE)


def real(text: str) -> float | Unreadable:
    """A decimal float's text as a float, or Unreadable when it is not finite (`1e999999`)."""
    value = float(text)
    return value if math.isfinite(value) else Unreadable(NOT_FINITE)


def _constant(text: str) -> Unreadable:
    return Unreadable(NOT_FINITE)  # NaN, Infinity, -Infinity


def loads(text: str, finite: bool = True) -> object:
    """JSON text parsed with every number bounded (json.JSONDecodeError and RecursionError
    pass through for the caller's own message); `finite=False` keeps NaN and infinities (a
    memory image's floats may be any word) and bounds only the integers."""
    if not finite:
        return json.loads(text, parse_int=integer)
    return json.loads(text, parse_int=integer, parse_float=real, parse_constant=_constant)


def check(value: object, finite: bool = True) -> str | None:
    """Why a parsed number cannot stand (None when it can): Unreadable, an int outside 64
    bits, a non-finite float."""
    if isinstance(value, Unreadable):
        return value.problem
    if isinstance(value, bool):
        return None
    if isinstance(value, int) and not INT_MIN <= value <= INT_MAX:
        return OUT_OF_RANGE
    if finite and isinstance(value, float) and not math.isfinite(value):
        return NOT_FINITE
    return None


def first_problem(doc: object, finite: bool = True) -> tuple[str, str] | None:
    """The first (path, problem) of a parsed document, walked without recursion (a deep
    document must not exhaust the stack), or None when every number stands."""
    stack: list[tuple[str, object]] = [("", doc)]
    while stack:
        path, value = stack.pop()
        if isinstance(value, dict):
            items = [(f"{path}.{k}" if path else str(k), v) for k, v in value.items()]
            stack.extend(reversed(items))
        elif isinstance(value, list):
            stack.extend(reversed([(f"{path}[{i}]", v) for i, v in enumerate(value)]))
        else:
            problem = check(value, finite)
            if problem:
                return path or "(top level)", problem
    return None
