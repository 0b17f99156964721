"""Operation semantics as executed by every engine (`engine_name`, tests/conftest.py): they come
from the opcode table (isa/opcodes.py), applied to raw words of the machine's precision (fp32 or
fp64). Registers are read through the engine interface."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from netsushisen.asm.assembler import assemble_text
from netsushisen.isa.images import image_from_json
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.isa.config import load_config
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.words import INT_MAX, INT_MIN, word_format, wrap32


class Regs(ProcessorView):
    def float(self, r):
        return float(super().float(r))


def run_sc(engine, src, precision="fp32", image=None):
    m = run_machine(engine, load_config(None, [f"precision={precision}"]),
                    {"sc": assemble_text(src, proc="sc")}, image_from_json(image or {}),
                    max_cycles=10_000)
    r = m.result()
    assert r.status == "halted", r.error
    return Regs(m, "pe0.sc")


def test_integer_wrap_and_shifts(engine_name):
    r = run_sc(engine_name, """
        li r1, 0x7fffffff
        addi r2, r1, 1          # INT_MAX + 1 wraps to INT_MIN
        li r3, 0x10000
        mul r4, r3, r3          # 2^32 wraps to 0
        sub r5, r2, r3
        li r6, 33
        li r7, 1
        sll r8, r7, r6          # shift amount uses its low 5 bits: 1 << 1
        li r9, -1
        srli r10, r9, 28        # logical: 15
        li r11, -16
        srai r12, r11, 2        # arithmetic: -4
        sltu r13, r7, r9        # 1 < 0xffffffff unsigned
        slt r14, r7, r9         # 1 < -1 signed: no
        halt
    """)
    assert r.int(2) == INT_MIN and r.int(4) == 0
    assert r.int(5) == wrap32(INT_MIN - 0x10000)
    assert r.int(8) == 2 and r.int(10) == 15 and r.int(12) == -4
    assert (r.int(13), r.int(14)) == (1, 0)


def test_division_corner_cases(engine_name):
    r = run_sc(engine_name, """
        li r1, 7
        div r2, r1, r0          # x / 0 = -1
        rem r3, r1, r0          # x % 0 = x
        li r4, 0x80000000
        li r5, -1
        div r6, r4, r5          # INT_MIN / -1 = INT_MIN
        rem r7, r4, r5          # INT_MIN % -1 = 0
        li r8, -7
        li r9, 2
        div r10, r8, r9         # truncates toward zero: -3
        rem r11, r8, r9         # sign of the dividend: -1
        halt
    """)
    assert (r.int(2), r.int(3), r.int(6), r.int(7), r.int(10), r.int(11)) == \
        (-1, 7, INT_MIN, 0, -3, -1)


def _bits(x, precision):
    return word_format(precision).from_float(x)


@pytest.mark.parametrize("precision", ["fp32", "fp64"])
def test_fp_corner_cases(precision, engine_name):
    r = run_sc(engine_name, """
        lf r1, 1.0
        lf r2, 0.0
        lf r3, -0.0
        lf r4, -1.0
        fdiv r5, r1, r2         # +inf
        fdiv r6, r4, r2         # -inf
        fdiv r7, r2, r2         # NaN
        fsqrt r8, r4            # NaN
        fsqrt r9, r3            # -0
        fmin r10, r3, r2        # -0
        fmax r11, r3, r2        # +0
        flt r12, r7, r1         # NaN compares false
        ftoi r13, r7            # NaN -> 0
        lf r14, 1e10
        ftoi r15, r14           # saturates
        lf r16, -1.5
        floor r17, r16          # -2
        ftoi r18, r16           # -1 (truncates)
        li r19, 16777217
        itof r20, r19           # fp32 rounds to 16777216
        lf r21, 0.1
        lf r22, 3e38
        fadd r23, r22, r22      # fp32 overflows to inf
        fmin r24, r7, r1        # NaN if either is NaN
        halt
    """, precision)
    assert r.float(5) == math.inf and r.float(6) == -math.inf
    assert math.isnan(r.float(7)) and math.isnan(r.float(8)) and math.isnan(r.float(24))
    assert r.raw(9) == _bits(-0.0, precision) and r.raw(10) == _bits(-0.0, precision)
    assert r.raw(11) == _bits(0.0, precision)
    assert (r.int(12), r.int(13), r.int(15), r.int(17), r.int(18)) == (0, 0, INT_MAX, -2, -1)
    if precision == "fp32":
        assert r.float(20) == 16777216.0 and r.raw(21) == 0x3DCCCCCD
        assert r.float(23) == math.inf
    else:
        assert r.float(20) == 16777217.0 and r.raw(21) == 0x3FB999999999999A
        assert r.float(23) == 6e38


@pytest.mark.parametrize("precision, word, width", [("fp32", "0x7fc00123", 32),
                                                    ("fp64", "0x7ff0000000000123", 64)])
def test_raw_word_moves_keep_every_bit(precision, word, width, engine_name):
    r = run_sc(engine_name, """
        ld r1, [r0]             # a NaN with a payload
        mov r2, r1
        fmov r3, r1
        li r5, 1
        sel r4, r5, r1, r0
        fsel r6, r0, r0, r1
        st r1, [r0 + 1]
        ld r7, [r0 + 1]
        halt
    """, precision, {"sc.local": [word]})
    expected = int(word, 16)
    assert all(r.raw(i) == expected for i in (1, 2, 3, 4, 6, 7))
    assert expected < (1 << width)


@pytest.mark.parametrize("precision, raw", [("fp32", 0xFFFFFFFF), ("fp64", 0xFFFFFFFFFFFFFFFF)])
def test_integers_are_sign_extended_words(precision, raw, engine_name):
    r = run_sc(engine_name, "li r1, -1\nhalt", precision)
    assert r.raw(1) == raw and r.int(1) == -1


def test_fpow_and_conversions_follow_the_table(engine_name):
    r = run_sc(engine_name, """
        lf r1, 2.0
        lf r2, 10.0
        fpow r3, r1, r2
        halt
    """)
    assert r.float(3) == 1024.0


INT3 = [m for m, o in OPCODES.items()
        if o.kind == "alu" and [x.kind for x in o.operands] == ["rd", "rs", "rs"]
        and o.source_types == ("i", "i") and "sc" in o.procs]


def _u(x):
    return x & 0xFFFFFFFF


def _s(x):
    x &= 0xFFFFFFFF
    return x - (1 << 32) if x >> 31 else x


def _div(a, b):
    if b == 0:
        return -1
    if a == INT_MIN and b == -1:
        return INT_MIN
    q = abs(a) // abs(b)
    return q if (a < 0) == (b < 0) else -q


INT_MODEL = {
    # the ISA's integer operations (isa/opcodes.py docstring, docs/isa.md) written out again on
    # Python integers: 32-bit two's complement, shift amounts masked to their low 5 bits
    "add": lambda a, b: _s(a + b),
    "sub": lambda a, b: _s(a - b),
    "mul": lambda a, b: _s(a * b),
    "div": _div,
    "rem": lambda a, b: a if b == 0 else _s(a - _div(a, b) * b),
    "and": lambda a, b: _s(_u(a) & _u(b)),
    "or": lambda a, b: _s(_u(a) | _u(b)),
    "xor": lambda a, b: _s(_u(a) ^ _u(b)),
    "sll": lambda a, b: _s(_u(a) << (_u(b) % 32)),
    "srl": lambda a, b: _s(_u(a) >> (_u(b) % 32)),
    "sra": lambda a, b: a >> (_u(b) % 32),
    "slt": lambda a, b: int(a < b),
    "sltu": lambda a, b: int(_u(a) < _u(b)),
    "seq": lambda a, b: int(a == b),
    "sne": lambda a, b: int(a != b),
}


def test_the_integer_model_covers_every_integer_op():
    assert sorted(INT_MODEL) == sorted(INT3)


@settings(max_examples=15, deadline=None)
@given(st.integers(INT_MIN, INT_MAX), st.integers(INT_MIN, INT_MAX))
@example(INT_MIN, 32).via("shift by 32: the low 5 bits are 0")
@example(-16, 63).via("shift by 63: 31")
@example(INT_MIN, -1).via("INT_MIN / -1, INT_MIN % -1")
@example(7, 0).via("division by zero")
def test_every_integer_op_matches_an_independent_model(engine_name, a, b):
    lines = [f"li r1, {a}", f"li r2, {b}"]
    lines += [f"{m} r{3 + i}, r1, r2" for i, m in enumerate(INT3)]
    r = run_sc(engine_name, "\n".join(lines + ["halt"]))
    got = {m: r.int(3 + i) for i, m in enumerate(INT3)}
    assert got == {m: INT_MODEL[m](a, b) for m in INT3}


def _same_word(got: int, want, precision: str) -> bool:
    """Bit for bit (so -0 and +0 differ); any NaN matches a NaN."""
    if np.isnan(want):
        return math.isnan(float(word_format(precision).to_float(got)))
    dtype = np.uint32 if precision == "fp32" else np.uint64
    return got == int(np.asarray(want).view(dtype))


@settings(max_examples=10, deadline=None)
@given(st.floats(width=32), st.floats(width=32))
@example(-0.0, -0.0).via("-0 + -0 = -0; -0 * -0 = +0; -0 - -0 = +0")
@example(0.0, -0.0).via("+0 + -0 = +0; +0 * -0 = -0; +0 - -0 = +0")
@example(-0.0, 0.0).via("-0 - +0 = -0")
@example(1.0, -1.0).via("1 + -1 = +0")
def test_fp32_arithmetic_matches_numpy_float32(engine_name, x, y):
    fx = struct.unpack("<I", struct.pack("<f", x))[0]
    fy = struct.unpack("<I", struct.pack("<f", y))[0]
    r = run_sc(engine_name, """
        ld r1, [r0]
        ld r2, [r0 + 1]
        fadd r3, r1, r2
        fmul r4, r1, r2
        fsub r5, r1, r2
        fdiv r6, r1, r2
        halt
    """, "fp32", {"sc.local": [hex(fx), hex(fy)]})
    a, b = np.float32(x), np.float32(y)
    with np.errstate(all="ignore"):
        want = [a + b, a * b, a - b, a / b]
    for reg, w in zip((3, 4, 5, 6), want):
        assert _same_word(r.raw(reg), w, "fp32"), (reg, hex(r.raw(reg)), w)


@settings(max_examples=10, deadline=None)
@given(st.floats(), st.floats())
@example(-0.0, -0.0).via("signs of zero")
@example(0.0, -0.0).via("signs of zero")
@example(-1.0, 0.0).via("-1 / +0 = -inf")
@example(1.0, -0.0).via("1 / -0 = -inf")
def test_fp64_arithmetic_matches_numpy_float64(engine_name, x, y):
    fx = struct.unpack("<Q", struct.pack("<d", x))[0]
    fy = struct.unpack("<Q", struct.pack("<d", y))[0]
    r = run_sc(engine_name, """
        ld r1, [r0]
        ld r2, [r0 + 1]
        fadd r3, r1, r2
        fmul r4, r1, r2
        fsub r5, r1, r2
        fdiv r6, r1, r2
        halt
    """, "fp64", {"sc.local": [hex(fx), hex(fy)]})
    a, b = np.float64(x), np.float64(y)
    with np.errstate(all="ignore"):
        want = [a + b, a * b, a - b, a / b]
    for reg, w in zip((3, 4, 5, 6), want):
        assert _same_word(r.raw(reg), w, "fp64"), (reg, hex(r.raw(reg)), w)
