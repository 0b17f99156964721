"""Constant expressions in immediates and directives (C operators and precedence).

Integers are exact while an expression is evaluated and wrap to 32 bits where they are used;
`/` and `%` on two integers truncate toward zero as in C; an operand that is a float makes the
result a float. `defined(NAME)`, `int(x)`, `float(x)`, `abs(x)`, `min(a, b)`, `max(a, b)` and the
names `inf` and `nan` are built in.
"""

from __future__ import annotations

import math
from typing import Callable

from netsushisen.asm.parser import Loc


class ExprError(Exception):
    def __init__(self, message: str, loc: Loc | None = None):
        super().__init__(message)
        self.message = message
        self.loc = loc


Number = int | float
Lookup = Callable[[str, Loc], Number]
"""Resolve a symbol or raise ExprError (undefined, a register where a value is wanted, ...)."""

BUILTIN_CONSTANTS: dict[str, float] = {"inf": math.inf, "nan": math.nan}


def _cdiv(a: int, b: int) -> int:
    q = abs(a) // abs(b)
    return q if (a < 0) == (b < 0) else -q


def _need_ints(op: str, a: Number, b: Number) -> None:
    if isinstance(a, float) or isinstance(b, float):
        raise ExprError(f"operator '{op}' needs integers")


_BIN_SYMBOL = {"add": "+", "sub": "-", "mul": "*", "div": "/", "mod": "%", "shl": "<<",
               "shr": ">>", "and": "&", "or": "|", "xor": "^", "eq": "==", "ne": "!=",
               "lt": "<", "le": "<=", "gt": ">", "ge": ">=", "land": "&&", "lor": "||"}


def evaluate(expr, lookup: Lookup, is_defined: Callable[[str], bool] | None = None) -> Number:
    kind = expr[0]
    if kind in ("int", "float"):
        return expr[1]
    if kind == "name":
        return lookup(expr[1], expr[2])
    if kind == "un":
        v = evaluate(expr[2], lookup, is_defined)
        if expr[1] == "-":
            return -v
        if expr[1] == "!":
            return int(not v)
        if isinstance(v, float):
            raise ExprError("operator '~' needs an integer")
        return ~v
    if kind == "bin":
        op = expr[1]
        a = evaluate(expr[2], lookup, is_defined)
        if op == "land":
            return int(bool(a) and bool(evaluate(expr[3], lookup, is_defined)))
        if op == "lor":
            return int(bool(a) or bool(evaluate(expr[3], lookup, is_defined)))
        b = evaluate(expr[3], lookup, is_defined)
        try:
            if op == "add":
                return _bounded(a + b)
            if op == "sub":
                return _bounded(a - b)
            if op == "mul":
                return _bounded(a * b)
            if op in ("div", "mod"):
                if b == 0:
                    raise ExprError("division by zero in a constant expression", _loc_of(expr[3]))
                if isinstance(a, float) or isinstance(b, float):
                    return a / b if op == "div" else math.fmod(a, b)
                q = _cdiv(a, b)
                return q if op == "div" else a - q * b
            if op in ("shl", "shr", "and", "or", "xor"):
                _need_ints(_BIN_SYMBOL[op], a, b)
                if op in ("shl", "shr") and b < 0:
                    raise ExprError("negative shift count")
                if op == "shl" and b > 64:
                    raise ExprError(f"shift count {b} is too large")
                return {"shl": lambda: a << b, "shr": lambda: a >> b, "and": lambda: a & b,
                        "or": lambda: a | b, "xor": lambda: a ^ b}[op]()
            return int({"eq": a == b, "ne": a != b, "lt": a < b, "le": a <= b,
                        "gt": a > b, "ge": a >= b}[op])
        except OverflowError:
            raise ExprError("number too large in a constant expression") from None
    if kind == "call":
        name, args, loc = expr[1], expr[2], expr[3]
        if name == "defined":
            if len(args) != 1 or args[0][0] != "name":
                raise ExprError("defined() takes one symbol name", loc)
            return int(bool(is_defined and is_defined(args[0][1])))
        funcs = {"int": (1, lambda x: int(x) if not isinstance(x, float) else _float_to_int(x, loc)),
                 "float": (1, float), "abs": (1, abs), "min": (2, min), "max": (2, max)}
        if name not in funcs:
            raise ExprError(f"unknown function {name}(); known: defined, int, float, abs, min, max", loc)
        arity, fn = funcs[name]
        if len(args) != arity:
            raise ExprError(f"{name}() takes {arity} argument{'s' if arity > 1 else ''}", loc)
        return fn(*(evaluate(a, lookup, is_defined) for a in args))
    raise ExprError(f"not an expression: {kind}")  # pragma: no cover


def _bounded(v: Number) -> Number:
    """An integer result within limits.MAX_CONSTANT_BITS: `.equ`s that square the previous one
    would otherwise grow without end (2^40 squarings) and hang the assembler."""
    from netsushisen.isa.limits import MAX_CONSTANT_BITS

    if isinstance(v, int) and v.bit_length() > MAX_CONSTANT_BITS:
        raise ExprError(f"integer of more than {MAX_CONSTANT_BITS} bits in a constant expression "
                        "(limits.MAX_CONSTANT_BITS)")
    return v


def _float_to_int(x: float, loc: Loc) -> int:
    if math.isnan(x) or math.isinf(x):
        raise ExprError(f"int() of {x}", loc)
    return int(x)


def _loc_of(expr) -> Loc | None:
    from netsushisen.asm.parser import _expr_loc
    return _expr_loc(expr)


def names_in(expr) -> list[tuple[str, Loc]]:
    """Every symbol an expression mentions (for finding register names in memory operands)."""
    if not isinstance(expr, tuple):
        return []
    if expr[0] == "name":
        return [(expr[1], expr[2])]
    out = []
    for part in expr[1:]:
        if isinstance(part, tuple):
            out.extend(names_in(part))
        elif isinstance(part, list):
            for p in part:
                out.extend(names_in(p))
    return out
