"""Machine words in compiled code: a word is an int64 holding the raw bits (fp32: 0..2³²−1;
fp64: the 64-bit pattern), read as a 32-bit integer or as a float of the machine's precision
exactly as `isa.words` and core.Core.value / Core.word do in the reference engine.

The precision is carried by `F` (numpy.float32 or numpy.float64, passed into compiled code as a
number class), so one loop compiles once per precision.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic, overload

from netsushisen.isa.words import wrap32


@intrinsic
def _bits_to_f32(typingctx, w):
    def codegen(context, builder, sig, args):
        return builder.bitcast(builder.trunc(args[0], ir.IntType(32)), ir.FloatType())
    return types.float32(types.int64), codegen


@intrinsic
def _bits_to_f64(typingctx, w):
    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.DoubleType())
    return types.float64(types.int64), codegen


@intrinsic
def _f32_to_bits(typingctx, x):
    def codegen(context, builder, sig, args):
        return builder.zext(builder.bitcast(args[0], ir.IntType(32)), ir.IntType(64))
    return types.int64(types.float32), codegen


@intrinsic
def _f64_to_bits(typingctx, x):
    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.IntType(64))
    return types.int64(types.float64), codegen


@intrinsic
def ctz(typingctx, x):
    """Index of the lowest set bit of a non-zero int64 (LLVM's cttz)."""
    def codegen(context, builder, sig, args):
        return builder.cttz(args[0], ir.Constant(ir.IntType(1), 1))
    return types.int64(types.int64), codegen


def as_i(w):
    """The 32-bit integer a word holds."""
    return wrap32(int(w) & 0xFFFFFFFF)


@overload(as_i)
def _as_i(w):
    return lambda w: wrap32(np.int64(w) & 0xFFFFFFFF)


def _is32(F) -> bool:
    return F.instance_type == types.float32


def as_f(F, w):
    """The float of precision F a word holds (Python side: see isa.words.WordFormat)."""
    raise NotImplementedError("compiled code only")


@overload(as_f)
def _as_f(F, w):
    if _is32(F):
        return lambda F, w: _bits_to_f32(np.int64(w))
    return lambda F, w: _bits_to_f64(np.int64(w))


def word_i(F, v):
    raise NotImplementedError("compiled code only")


@overload(word_i)
def _word_i(F, v):
    if _is32(F):
        return lambda F, v: wrap32(np.int64(v)) & 0xFFFFFFFF
    return lambda F, v: wrap32(np.int64(v))


def word_f(F, v):
    raise NotImplementedError("compiled code only")


@overload(word_f)
def _word_f(F, v):
    if _is32(F):
        return lambda F, v: _f32_to_bits(np.float32(v))
    return lambda F, v: _f64_to_bits(np.float64(v))


def word_w(F, v):
    raise NotImplementedError("compiled code only")


@overload(word_w)
def _word_w(F, v):
    if _is32(F):
        return lambda F, v: np.int64(v) & 0xFFFFFFFF
    return lambda F, v: np.int64(v)
