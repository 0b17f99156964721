"""Every opcode against independent corner-case vectors, in fp32 and fp64, on every engine.

The opcode table (isa/opcodes.py) decides each instruction's semantics and pins the corner
cases in its docstring. This file is the guard that those results do not change when the
semantics are rewritten, and the yardstick a second engine is held to: every vector runs ON THE
MACHINE (SC, which has every opcode) through the engine interface (`make_engine`), and every
expected result is a raw word written down here independently of the table — hand-computed
integers and IEEE 754 bit patterns as hex literals, or values the test encodes itself with
`struct` (only values exactly representable in binary32, so no rounding is hidden there).

One program per opcode and precision: for each vector it loads the input words from local
memory, executes the operation once, stores the result word at OUT + i; then every vector is
compared at once and every mismatch is reported (opcode, inputs, expected, got, in hex).
Branches store which of two `li` instructions ran. The other kinds (memory, FIFOs, control
transfers, halt, nop) are checked by small programs at the end of the file.

Words are 4 bytes in fp32 and 8 in fp64; in fp64 an integer is sign-extended to the whole word
(-1 is 0xFFFFFFFFFFFFFFFF, INT_MIN is 0xFFFFFFFF80000000).
"""

from __future__ import annotations

import math
import random
import struct
from dataclasses import dataclass
from fractions import Fraction

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.engine import make_engine
from netsushisen.isa.config import load_config
from netsushisen.isa.images import image_from_json
from netsushisen.isa.opcodes import OPCODES

PRECISIONS = ("fp32", "fp64")
MASK = {"fp32": 0xFFFF_FFFF, "fp64": 0xFFFF_FFFF_FFFF_FFFF}
INT_MIN = -(2**31)
INT_MAX = 2**31 - 1
OUT = 1024  # results go to local[OUT + i]; inputs start at local[0]
SENTINEL = {"fp32": 0xA5A5_A5A5, "fp64": 0xA5A5_A5A5_A5A5_A5A5}  # "never stored"


def no_tandem(engine_name: str) -> None:
    """`engine_name` (tests/conftest.py) runs a test once per engine. The vectors hold each
    engine to them on its own; tandem (both in lock step) would only repeat them."""
    if engine_name == "tandem":
        pytest.skip("tandem: the vectors check the reference and compiled engines one by one")


# ---------------------------------------------------------------------------------------------
# Values: how a vector's inputs and expected results become raw words of a precision


class Val:
    def word(self, p: str) -> int | None:
        """The raw word in precision p; None: this vector does not apply in p."""
        raise NotImplementedError


@dataclass(frozen=True)
class I(Val):
    """A 32-bit integer, written signed or as its unsigned 32-bit pattern; the word holds it
    sign-extended to the word width."""

    v: int

    def __post_init__(self):
        assert INT_MIN <= self.v < 2**32, self.v

    def word(self, p):
        s = self.v - 2**32 if self.v > INT_MAX else self.v
        return s & MASK[p]

    def __str__(self):
        s = self.v - 2**32 if self.v > INT_MAX else self.v
        return f"int {s}"


@dataclass(frozen=True)
class F(Val):
    """A finite float exactly representable in binary32 (checked), so the same value in both
    precisions: the word is its IEEE encoding, by `struct`."""

    x: float

    def __post_init__(self):
        assert struct.unpack("<f", struct.pack("<f", self.x))[0] == self.x, self.x

    def word(self, p):
        if p == "fp32":
            return struct.unpack("<I", struct.pack("<f", self.x))[0]
        return struct.unpack("<Q", struct.pack("<d", self.x))[0]

    def __str__(self):
        return f"float {self.x!r}"


@dataclass(frozen=True)
class W(Val):
    """Raw words as hex literals, per precision (None: the vector is for the other one)."""

    w32: int | None
    w64: int | None
    name: str = ""

    def word(self, p):
        return self.w32 if p == "fp32" else self.w64

    def __str__(self):
        return self.name or "raw"


class AnyNaN(Val):
    """Expected: some NaN (the bits are the hardware's default NaN, not pinned by the table)."""

    def word(self, p):
        return 0  # placeholder: compared with is_nan

    def __str__(self):
        return "any NaN"


@dataclass(frozen=True)
class Imm:
    """An `imm` / `fimm` operand: source text written into the instruction."""

    text: str

    def __str__(self):
        return f"imm {self.text}"


NAN = AnyNaN()
P0 = W(0x0000_0000, 0x0000_0000_0000_0000, "+0.0")
N0 = W(0x8000_0000, 0x8000_0000_0000_0000, "-0.0")
PINF = W(0x7F80_0000, 0x7FF0_0000_0000_0000, "+inf")
NINF = W(0xFF80_0000, 0xFFF0_0000_0000_0000, "-inf")
QNAN = W(0x7FC0_0000, 0x7FF8_0000_0000_0000, "canonical quiet NaN")
PNAN = W(0x7FC0_0123, 0x7FF8_0000_0000_0123, "+NaN with payload")
NNAN = W(0xFFC0_0123, 0xFFF8_0000_0000_0123, "-NaN with payload")
SNAN = W(0x7F80_0001, 0x7FF0_0000_0000_0001, "signalling NaN")
MAX32 = W(0x7F7F_FFFF, 0x47EF_FFFF_E000_0000, "FLT_MAX")  # the same value in both
NMAX32 = W(0xFF7F_FFFF, 0xC7EF_FFFF_E000_0000, "-FLT_MAX")
TINY = W(0x0000_0001, 0x36A0_0000_0000_0000, "2**-149")  # smallest binary32 subnormal
NTINY = W(0x8000_0001, 0xB6A0_0000_0000_0000, "-2**-149")
RAW = W(0x89AB_CDEF, 0x0123_4567_89AB_CDEF, "raw word")  # fp64: not an integer's sign extension
TAKEN, NOT_TAKEN = I(0x7A), I(0x0F)


def is_nan(w: int, p: str) -> bool:
    if p == "fp32":
        return (w >> 23) & 0xFF == 0xFF and w & 0x7F_FFFF != 0
    return (w >> 52) & 0x7FF == 0x7FF and w & 0xF_FFFF_FFFF_FFFF != 0


@dataclass(frozen=True)
class V:
    args: tuple
    expect: Val
    xfail: str | None = None
    """Reason, when the current semantics disagree with the pinned docstring."""

    def applies(self, p: str) -> bool:
        return all(a.word(p) is not None for a in self.args if isinstance(a, Val)) \
            and self.expect.word(p) is not None


def rows(*table) -> list[V]:
    """(arg, ..., expected) tuples as vectors."""
    return [t if isinstance(t, V) else V(tuple(t[:-1]), t[-1]) for t in table]


# ---------------------------------------------------------------------------------------------
# The vectors

VECTORS: dict[str, list[V]] = {}

# -- integer ALU (32-bit two's complement, wrap-around) -----------------------------------------

VECTORS["add"] = rows(
    (I(INT_MAX), I(1), I(INT_MIN)),                  # overflow wraps
    (I(INT_MIN), I(-1), I(INT_MAX)),
    (I(INT_MIN), I(INT_MIN), I(0)),
    (I(0xFFFF_FFFF), I(1), I(0)),
    (I(-1), I(-1), I(-2)),
    (I(5), I(-7), I(-2)),
    (I(123456789), I(987654321), I(1111111110)),
)
VECTORS["sub"] = rows(
    (I(INT_MIN), I(1), I(INT_MAX)),                  # wraps
    (I(INT_MAX), I(-1), I(INT_MIN)),
    (I(0), I(INT_MIN), I(INT_MIN)),
    (I(3), I(5), I(-2)),
    (I(-1), I(-1), I(0)),
    (I(0), I(1), I(0xFFFF_FFFF)),
)
VECTORS["mul"] = rows(
    (I(0x10000), I(0x10000), I(0)),                  # 2**32: low 32 bits
    (I(INT_MIN), I(-1), I(INT_MIN)),
    (I(INT_MAX), I(2), I(-2)),
    (I(-1), I(-1), I(1)),
    (I(-3), I(7), I(-21)),
    (I(46341), I(46341), I(-2147479015)),           # 2147488281 wraps
    (I(123456789), I(1000), I(-1097262584)),         # 123456789000 mod 2**32, signed
)
VECTORS["div"] = rows(
    (I(7), I(2), I(3)),
    (I(-7), I(2), I(-3)),                            # truncates toward zero
    (I(7), I(-2), I(-3)),
    (I(-7), I(-2), I(3)),
    (I(-1), I(2), I(0)),
    (I(7), I(0), I(-1)),                             # x/0 = -1
    (I(-7), I(0), I(-1)),
    (I(0), I(0), I(-1)),
    (I(INT_MIN), I(0), I(-1)),
    (I(INT_MIN), I(-1), I(INT_MIN)),                 # overflow: INT_MIN
    (I(INT_MIN), I(1), I(INT_MIN)),
    (I(INT_MIN), I(2), I(-1073741824)),
    (I(INT_MAX), I(-1), I(-INT_MAX)),
    (I(INT_MIN), I(INT_MIN), I(1)),
    (I(1), I(INT_MIN), I(0)),
)
VECTORS["rem"] = rows(
    (I(7), I(2), I(1)),
    (I(-7), I(2), I(-1)),                            # sign of the dividend
    (I(7), I(-2), I(1)),
    (I(-7), I(-2), I(-1)),
    (I(-1), I(2), I(-1)),
    (I(7), I(0), I(7)),                              # x%0 = x
    (I(-7), I(0), I(-7)),
    (I(0), I(0), I(0)),
    (I(INT_MIN), I(0), I(INT_MIN)),
    (I(INT_MIN), I(-1), I(0)),                       # INT_MIN % -1 = 0
    (I(INT_MIN), I(3), I(-2)),
    (I(INT_MAX), I(INT_MIN), I(INT_MAX)),
    (I(INT_MIN), I(INT_MAX), I(-1)),
)
VECTORS["and"] = rows(
    (I(0xF0F0_F0F0), I(0xFF00_FF00), I(0xF000_F000)),
    (I(-1), I(0x1234_5678), I(0x1234_5678)),
    (I(INT_MIN), I(-1), I(INT_MIN)),
    (I(0x0F0F_0F0F), I(0xF0F0_F0F0), I(0)),
)
VECTORS["or"] = rows(
    (I(0xF0F0_F0F0), I(0x0F0F_0F0F), I(-1)),
    (I(0), I(INT_MIN), I(INT_MIN)),
    (I(0x1234_0000), I(0x5678), I(0x1234_5678)),
)
VECTORS["xor"] = rows(
    (I(-1), I(0x0F0F_0F0F), I(0xF0F0_F0F0)),
    (I(0x1234_5678), I(0x1234_5678), I(0)),
    (I(INT_MIN), I(INT_MAX), I(-1)),
    (I(INT_MIN), I(-1), I(INT_MAX)),
)
# Shift amounts use their low 5 bits: 32 -> 0, 33 -> 1, -1 -> 31, 36 -> 4, 62 -> 30.
# (With `& 63` instead, 32 and 62 and 36 give different answers.)
VECTORS["sll"] = rows(
    (I(1), I(31), I(INT_MIN)),
    (I(1), I(32), I(1)),
    (I(1), I(33), I(2)),
    (I(1), I(-1), I(INT_MIN)),
    (I(1), I(INT_MIN), I(1)),
    (I(0x1234_5678), I(-28), I(0x2345_6780)),
    (I(3), I(31), I(INT_MIN)),                       # bits shifted out are lost
    (I(-1), I(4), I(-16)),
    (I(0x4000_0000), I(1), I(INT_MIN)),
    (I(5), I(0), I(5)),
)
VECTORS["srl"] = rows(
    (I(-1), I(28), I(15)),                           # logical: zeros come in
    (I(-1), I(0), I(-1)),
    (I(-1), I(1), I(INT_MAX)),
    (I(INT_MIN), I(31), I(1)),
    (I(INT_MIN), I(32), I(INT_MIN)),
    (I(INT_MIN), I(33), I(0x4000_0000)),
    (I(-16), I(2), I(0x3FFF_FFFC)),
    (I(-1), I(-1), I(1)),
    (I(0x1234_5678), I(36), I(0x0123_4567)),
)
VECTORS["sra"] = rows(
    (I(-16), I(2), I(-4)),                           # arithmetic: the sign comes in
    (I(INT_MIN), I(31), I(-1)),
    (I(INT_MIN), I(32), I(INT_MIN)),
    (I(INT_MIN), I(33), I(0xC000_0000)),
    (I(-5), I(1), I(-3)),                            # rounds toward -inf
    (I(-16), I(-1), I(-1)),
    (I(0x7FFF_FFFF), I(30), I(1)),
    (I(0x4000_0000), I(62), I(1)),
)
VECTORS["slt"] = rows(
    (I(-1), I(1), I(1)),
    (I(1), I(-1), I(0)),
    (I(INT_MIN), I(INT_MAX), I(1)),
    (I(INT_MAX), I(INT_MIN), I(0)),
    (I(5), I(5), I(0)),
    (I(-2), I(-1), I(1)),
)
VECTORS["sltu"] = rows(
    (I(-1), I(1), I(0)),                             # 0xFFFFFFFF is the largest
    (I(1), I(-1), I(1)),
    (I(INT_MIN), I(INT_MAX), I(0)),
    (I(INT_MAX), I(INT_MIN), I(1)),
    (I(0), I(-1), I(1)),
    (I(-1), I(-1), I(0)),
    (I(-2), I(-1), I(1)),
    (I(0), I(0), I(0)),
)
VECTORS["seq"] = rows(
    (I(-1), I(0xFFFF_FFFF), I(1)),
    (I(0), I(INT_MIN), I(0)),
    (I(INT_MIN), I(INT_MIN), I(1)),
    (I(1), I(2), I(0)),
    (I(0), I(0), I(1)),
)
VECTORS["sne"] = rows(
    (I(-1), I(0xFFFF_FFFF), I(0)),
    (I(0), I(INT_MIN), I(1)),
    (I(INT_MIN), I(INT_MIN), I(0)),
    (I(1), I(2), I(1)),
    (I(0), I(0), I(0)),
)
VECTORS["addi"] = rows(
    (I(INT_MAX), Imm("1"), I(INT_MIN)),               # wraps
    (I(INT_MIN), Imm("-1"), I(INT_MAX)),
    (I(5), Imm("0xFFFFFFFF"), I(4)),                  # the immediate is -1
    (I(-1), Imm("1"), I(0)),
    (I(0x7FFF_FFF0), Imm("0x7FFFFFFF"), I(-17)),
    (I(INT_MIN), Imm("0x80000000"), I(0)),
)
VECTORS["andi"] = rows(
    (I(-1), Imm("0xFF"), I(255)),
    (I(0x1234_5678), Imm("-16"), I(0x1234_5670)),
    (I(INT_MIN), Imm("0x80000000"), I(INT_MIN)),
    (I(0x0F0F_0F0F), Imm("0xF0F0F0F0"), I(0)),
)
VECTORS["ori"] = rows(
    (I(0), Imm("-1"), I(-1)),
    (I(0x1234_0000), Imm("0x5678"), I(0x1234_5678)),
    (I(0x7FFF_FFFF), Imm("0x80000000"), I(-1)),
)
VECTORS["xori"] = rows(
    (I(0x1234_5678), Imm("-1"), I(0xEDCB_A987)),
    (I(-1), Imm("0x7FFFFFFF"), I(INT_MIN)),
    (I(5), Imm("5"), I(0)),
)
VECTORS["slli"] = rows(
    (I(1), Imm("31"), I(INT_MIN)),
    (I(1), Imm("32"), I(1)),
    (I(1), Imm("33"), I(2)),
    (I(1), Imm("-1"), I(INT_MIN)),
    (I(3), Imm("63"), I(INT_MIN)),
    (I(-1), Imm("4"), I(-16)),
    (I(0x1234_5678), Imm("36"), I(0x2345_6780)),
    (I(7), Imm("0"), I(7)),
)
VECTORS["srli"] = rows(
    (I(-1), Imm("28"), I(15)),
    (I(-1), Imm("0"), I(-1)),
    (I(INT_MIN), Imm("32"), I(INT_MIN)),
    (I(INT_MIN), Imm("33"), I(0x4000_0000)),
    (I(-16), Imm("2"), I(0x3FFF_FFFC)),
    (I(-1), Imm("-1"), I(1)),
    (I(0x1234_5678), Imm("36"), I(0x0123_4567)),
)
VECTORS["srai"] = rows(
    (I(-16), Imm("2"), I(-4)),
    (I(INT_MIN), Imm("32"), I(INT_MIN)),
    (I(INT_MIN), Imm("33"), I(0xC000_0000)),
    (I(INT_MIN), Imm("-1"), I(-1)),
    (I(-5), Imm("1"), I(-3)),
    (I(0x7FFF_FFFF), Imm("30"), I(1)),
    (I(0x4000_0000), Imm("62"), I(1)),
)
VECTORS["slti"] = rows(
    (I(-1), Imm("0"), I(1)),
    (I(0), Imm("-1"), I(0)),
    (I(INT_MIN), Imm("0x7FFFFFFF"), I(1)),
    (I(INT_MAX), Imm("0xFFFFFFFF"), I(0)),            # the immediate is -1 (signed)
    (I(5), Imm("5"), I(0)),
    (I(-2), Imm("-1"), I(1)),
)
VECTORS["li"] = rows(
    (Imm("0xFFFFFFFF"), W(0xFFFF_FFFF, 0xFFFF_FFFF_FFFF_FFFF)),
    (Imm("-1"), W(0xFFFF_FFFF, 0xFFFF_FFFF_FFFF_FFFF)),
    (Imm("0x80000000"), W(0x8000_0000, 0xFFFF_FFFF_8000_0000)),
    (Imm("-2147483648"), W(0x8000_0000, 0xFFFF_FFFF_8000_0000)),
    (Imm("0x7FFFFFFF"), W(0x7FFF_FFFF, 0x0000_0000_7FFF_FFFF)),
    (Imm("0xDEADBEEF"), W(0xDEAD_BEEF, 0xFFFF_FFFF_DEAD_BEEF)),
    (Imm("0x12345678"), W(0x1234_5678, 0x0000_0000_1234_5678)),
    (Imm("0"), W(0, 0)),
)
VECTORS["mov"] = rows(
    (SNAN, SNAN),                                     # raw words: every bit kept
    (RAW, RAW),
    (NNAN, NNAN),
    (N0, N0),
    (I(-1), I(-1)),
)
VECTORS["sel"] = rows(
    (I(1), SNAN, PNAN, SNAN),
    (I(0), SNAN, PNAN, PNAN),
    (I(-1), RAW, N0, RAW),
    (I(INT_MIN), N0, RAW, N0),                         # any non-zero condition
    (I(0), RAW, I(-1), I(-1)),
)

# -- FP (IEEE 754, round to nearest even, no flush to zero) -----------------------------------

VECTORS["fadd"] = rows(
    (F(1.5), F(2.25), F(3.75)),
    (N0, N0, N0),
    (N0, P0, P0),
    (P0, N0, P0),
    (F(1.0), F(-1.0), P0),                             # an exact zero sum is +0
    (F(-1.0), F(1.0), P0),
    (MAX32, MAX32, W(0x7F80_0000, 0x47FF_FFFF_E000_0000)),   # fp32 overflows to +inf
    (NMAX32, NMAX32, W(0xFF80_0000, 0xC7FF_FFFF_E000_0000)),
    (MAX32, F(2.0**103), W(0x7F80_0000, 0x47EF_FFFF_F000_0000)),  # half an ulp: tie -> inf
    (PINF, NINF, NAN),
    (PINF, F(1.0), PINF),
    (PNAN, F(1.0), NAN),
    (F(1.0), F(2.0**-24), W(0x3F80_0000, 0x3FF0_0000_1000_0000)),  # fp32 tie -> even (down)
    (W(0x3F80_0001, 0x3FF0_0000_2000_0000), F(2.0**-24),           # fp32 tie -> even (up)
     W(0x3F80_0002, 0x3FF0_0000_3000_0000)),
    (F(1.0), F(2.0**-53), W(0x3F80_0000, 0x3FF0_0000_0000_0000)),  # fp64 tie -> even (down)
    (W(None, 0x3FF0_0000_0000_0001), F(2.0**-53), W(None, 0x3FF0_0000_0000_0002)),  # (up)
    (TINY, TINY, W(0x0000_0002, 0x36B0_0000_0000_0000)),          # subnormals kept
)
VECTORS["fsub"] = rows(
    (F(5.0), F(7.5), F(-2.5)),
    (N0, P0, N0),
    (P0, P0, P0),
    (N0, N0, P0),
    (P0, N0, P0),
    (F(1.0), F(1.0), P0),
    (F(-2.0), F(-2.0), P0),
    (NMAX32, MAX32, W(0xFF80_0000, 0xC7FF_FFFF_E000_0000)),
    (PINF, PINF, NAN),
    (NINF, PINF, NINF),
    (F(1.0), F(2.0**-25), W(0x3F80_0000, 0x3FEF_FFFF_F000_0000)),  # fp32 tie -> even (up)
    (F(1.5 * 2.0**-126), F(2.0**-126), W(0x0040_0000, 0x3800_0000_0000_0000)),  # subnormal
)
VECTORS["fmul"] = rows(
    (F(3.0), F(-2.5), F(-7.5)),
    (F(-1.0), P0, N0),
    (N0, N0, P0),
    (F(-(2.0**-100)), F(2.0**-100), W(0x8000_0000, 0xB370_0000_0000_0000)),  # fp32 -> -0
    (F(2.0**100), F(2.0**100), W(0x7F80_0000, 0x4C70_0000_0000_0000)),       # fp32 -> inf
    (F(-(2.0**100)), F(2.0**100), W(0xFF80_0000, 0xCC70_0000_0000_0000)),
    (P0, PINF, NAN),
    (F(2.0**-126), F(0.5), W(0x0040_0000, 0x3800_0000_0000_0000)),  # subnormal, no FTZ
    (F(1 + 2.0**-23), F(1 + 2.0**-23), W(0x3F80_0002, 0x3FF0_0000_4000_0040)),
    (F(1 + 2.0**-12), F(1 + 2.0**-12), W(0x3F80_1000, 0x3FF0_0200_1000_0000)),  # fp32 tie
    (NNAN, F(1.0), NAN),
)
VECTORS["fdiv"] = rows(
    (F(7.0), F(2.0), F(3.5)),
    (F(1.0), F(3.0), W(0x3EAA_AAAB, 0x3FD5_5555_5555_5555)),
    (F(1.0), P0, PINF),
    (F(1.0), N0, NINF),                                # 1/-0 = -inf
    (F(-1.0), N0, PINF),
    (F(-1.0), P0, NINF),
    (PINF, N0, NINF),
    (P0, P0, NAN),
    (N0, P0, NAN),
    (PINF, PINF, NAN),
    (F(1.0), PINF, P0),
    (F(-1.0), PINF, N0),
    (P0, F(-1.0), N0),
    (MAX32, F(0.5), W(0x7F80_0000, 0x47FF_FFFF_E000_0000)),
    (F(2.0**-126), F(4.0), W(0x0020_0000, 0x37F0_0000_0000_0000)),   # subnormal
    (PNAN, F(1.0), NAN),
)
VECTORS["fsqrt"] = rows(
    (F(4.0), F(2.0)),
    (F(0.25), F(0.5)),
    (F(2.0), W(0x3FB5_04F3, 0x3FF6_A09E_667F_3BCD)),   # correctly rounded
    (F(-1.0), NAN),
    (NTINY, NAN),
    (N0, N0),                                          # sqrt(-0) = -0
    (P0, P0),
    (PINF, PINF),
    (NINF, NAN),
    (PNAN, NAN),
)
VECTORS["fpow"] = rows(                                # isa/libm.py (C99 Annex F cases)
    (P0, P0, F(1.0)),                                  # 0**0 = 1
    (QNAN, P0, F(1.0)),                                # x**0 = 1, even NaN
    (F(1.0), QNAN, F(1.0)),                            # 1**y = 1, even NaN
    (F(2.0), F(10.0), F(1024.0)),
    (F(2.0), F(-1.0), F(0.5)),
    (F(4.0), F(0.5), F(2.0)),
    (F(-2.0), F(3.0), F(-8.0)),                        # negative base, odd integer exponent
    (F(-2.0), F(2.0), F(4.0)),
    (F(-2.0), F(0.5), NAN),                            # negative base, non-integer exponent
    (F(-8.0), F(0.25), NAN),
    (P0, F(-1.0), PINF),
    (N0, F(-1.0), NINF),
    (N0, F(3.0), N0),
    (N0, F(2.0), P0),
    (F(-1.0), PINF, F(1.0)),
    (F(0.5), PINF, P0),
    (F(2.0), PINF, PINF),
    (NINF, F(3.0), NINF),
    (NINF, F(-3.0), N0),
    (F(2.0), F(128.0), W(0x7F80_0000, 0x47F0_0000_0000_0000)),      # fp32 overflows
    (F(2.0), F(-149.0), W(0x0000_0001, 0x36A0_0000_0000_0000)),     # fp32 subnormal
    (F(3.0), F(2.0), F(9.0)),                          # integer exponents are exact
    (F(10.0), F(-3.0), W(0x3A83_126F, 0x3F50_624D_D2F1_A9FC)),      # 0.001, rounded once
    (F(0.5), F(1e6), P0),                              # underflows to +0
    (F(-0.5), PINF, P0),
    (F(0.5), NINF, PINF),
)
# fmin/fmax: NaN if either operand is NaN — the table returns the canonical quiet NaN (its
# F(np.nan)), not a propagated payload, so those bits are pinned here.
VECTORS["fmin"] = rows(
    (F(1.0), F(2.0), F(1.0)),
    (F(2.0), F(1.0), F(1.0)),
    (F(-1.0), F(-2.0), F(-2.0)),
    (N0, P0, N0),
    (P0, N0, N0),
    (N0, N0, N0),
    (P0, P0, P0),
    (NINF, F(1.0), NINF),
    (PINF, MAX32, MAX32),
    (PNAN, F(1.0), QNAN),
    (F(1.0), PNAN, QNAN),
    (NNAN, PNAN, QNAN),
    (NINF, NNAN, QNAN),
)
VECTORS["fmax"] = rows(
    (F(1.0), F(2.0), F(2.0)),
    (F(2.0), F(1.0), F(2.0)),
    (F(-1.0), F(-2.0), F(-1.0)),
    (N0, P0, P0),
    (P0, N0, P0),
    (N0, N0, N0),
    (P0, P0, P0),
    (PINF, F(1.0), PINF),
    (NINF, NMAX32, NMAX32),
    (PNAN, F(1.0), QNAN),
    (F(1.0), PNAN, QNAN),
    (NNAN, PNAN, QNAN),
    (PINF, NNAN, QNAN),
)
VECTORS["fabs"] = rows(                                # clears the sign bit, nothing else
    (P0, P0),
    (N0, P0),
    (PNAN, PNAN),
    (NNAN, PNAN),
    (NINF, PINF),
    (F(-1.5), F(1.5)),
    (F(2.0), F(2.0)),
    (NTINY, TINY),
)
VECTORS["fneg"] = rows(                                # flips the sign bit, nothing else
    (P0, N0),
    (N0, P0),
    (PNAN, NNAN),
    (NNAN, PNAN),
    (PINF, NINF),
    (F(1.5), F(-1.5)),
    (TINY, NTINY),
)
VECTORS["fmov"] = rows(
    (SNAN, SNAN),
    (RAW, RAW),
    (NNAN, NNAN),
    (N0, N0),
    (I(-1), I(-1)),
)
VECTORS["lf"] = rows(                                  # rounded to the precision, to nearest even
    (Imm("2.5"), F(2.5)),
    (Imm("-0.0"), N0),
    (Imm("0.1"), W(0x3DCC_CCCD, 0x3FB9_9999_9999_999A)),
    (Imm("1.000000059604644775390625"), W(0x3F80_0000, 0x3FF0_0000_1000_0000)),  # 1+2**-24
    (Imm("1.000000178813934326171875"), W(0x3F80_0002, 0x3FF0_0000_3000_0000)),  # 1+3*2**-24
    (Imm("16777217.0"), W(0x4B80_0000, 0x4170_0000_1000_0000)),
    (Imm("3.4028235e38"), W(0x7F7F_FFFF, 0x47EF_FFFF_E54D_AFF8)),
    (Imm("1e39"), W(0x7F80_0000, 0x4807_8287_F49C_4A1D)),                       # fp32: inf
    (Imm("-1e39"), W(0xFF80_0000, 0xC807_8287_F49C_4A1D)),
    (Imm("1e-45"), W(0x0000_0001, 0x3696_D601_AD37_6AB9)),                      # fp32 subnormal
    (Imm("1e-46"), W(0x0000_0000, 0x3662_44CE_242C_5561)),                      # fp32: +0
)
VECTORS["fsel"] = rows(
    (I(1), SNAN, PNAN, SNAN),
    (I(0), SNAN, PNAN, PNAN),
    (I(-1), RAW, N0, RAW),
    (I(INT_MIN), N0, RAW, N0),
    (I(0), RAW, I(-1), I(-1)),
)

# Ordered comparisons: (a, b, a < b, a <= b, a == b); any NaN gives 0, -0 == +0.
_COMPARE = [
    (F(1.0), F(2.0), 1, 1, 0),
    (F(2.0), F(1.0), 0, 0, 0),
    (F(2.0), F(2.0), 0, 1, 1),
    (N0, P0, 0, 1, 1),
    (P0, N0, 0, 1, 1),
    (F(-1.0), N0, 1, 1, 0),
    (P0, TINY, 1, 1, 0),                                 # subnormals are not flushed
    (NINF, PINF, 1, 1, 0),
    (PINF, PINF, 0, 1, 1),
    (PNAN, F(1.0), 0, 0, 0),
    (F(1.0), PNAN, 0, 0, 0),
    (PNAN, PNAN, 0, 0, 0),
    (NINF, NNAN, 0, 0, 0),
]
VECTORS["flt"] = rows(*((a, b, I(lt)) for a, b, lt, le, eq in _COMPARE))
VECTORS["fle"] = rows(*((a, b, I(le)) for a, b, lt, le, eq in _COMPARE))
VECTORS["feq"] = rows(*((a, b, I(eq)) for a, b, lt, le, eq in _COMPARE))

VECTORS["itof"] = rows(                                # rounded to nearest even
    (I(0), P0),
    (I(1), F(1.0)),
    (I(-1), F(-1.0)),
    (I(INT_MIN), W(0xCF00_0000, 0xC1E0_0000_0000_0000)),
    (I(INT_MAX), W(0x4F00_0000, 0x41DF_FFFF_FFC0_0000)),      # fp32: 2**31
    (I(16777217), W(0x4B80_0000, 0x4170_0000_1000_0000)),     # fp32 tie -> 16777216
    (I(16777219), W(0x4B80_0002, 0x4170_0000_3000_0000)),     # fp32 tie -> 16777220
    (I(-16777217), W(0xCB80_0000, 0xC170_0000_1000_0000)),
)

# ftoi truncates, floor rounds toward -inf; both saturate to [INT_MIN, INT_MAX]; NaN gives 0.
_TO_INT = [  # (x, ftoi, floor)
    (F(2.5), 2, 2),
    (F(-2.5), -2, -3),
    (F(-0.5), 0, -1),
    (F(0.5), 0, 0),
    (F(-1.0), -1, -1),
    (N0, 0, 0),
    (NTINY, 0, -1),
    (TINY, 0, 0),
    (F(3e9), INT_MAX, INT_MAX),
    (F(-3e9), INT_MIN, INT_MIN),
    (F(2147483520.0), 2147483520, 2147483520),             # largest binary32 below 2**31
    (F(2.0**31), INT_MAX, INT_MAX),
    (F(-(2.0**31)), INT_MIN, INT_MIN),
    (PINF, INT_MAX, INT_MAX),
    (NINF, INT_MIN, INT_MIN),
    (QNAN, 0, 0),
    (NNAN, 0, 0),
    (W(None, 0x41DF_FFFF_FFE0_0000, "2147483647.5"), INT_MAX, INT_MAX),
    (W(None, 0xC1DF_FFFF_FFE0_0000, "-2147483647.5"), -INT_MAX, INT_MIN),
    (W(None, 0xC1E0_0000_0010_0000, "-2147483648.5"), INT_MIN, INT_MIN),  # floor saturates
]
VECTORS["ftoi"] = rows(*((x, I(t)) for x, t, f in _TO_INT))
VECTORS["floor"] = rows(*((x, I(f)) for x, t, f in _TO_INT))

# -- branches: which of two `li` instructions ran ---------------------------------------------

_BRANCH = [  # (a, b, beq, bne, blt, bge, bltu, bgeu)
    (I(5), I(5), 1, 0, 0, 1, 0, 1),
    (I(1), I(2), 0, 1, 1, 0, 1, 0),
    (I(-1), I(1), 0, 1, 1, 0, 0, 1),                    # unsigned: 0xFFFFFFFF > 1
    (I(1), I(-1), 0, 1, 0, 1, 1, 0),
    (I(INT_MIN), I(INT_MAX), 0, 1, 1, 0, 0, 1),
    (I(INT_MAX), I(INT_MIN), 0, 1, 0, 1, 1, 0),
    (I(0), I(-1), 0, 1, 0, 1, 1, 0),
    (I(-1), I(0xFFFF_FFFF), 1, 0, 0, 1, 0, 1),
    (I(0), I(INT_MIN), 0, 1, 0, 1, 1, 0),
]
for _k, _m in enumerate(("beq", "bne", "blt", "bge", "bltu", "bgeu"), start=2):
    VECTORS[_m] = rows(*((r[0], r[1], TAKEN if r[_k] else NOT_TAKEN) for r in _BRANCH))
VECTORS["beqz"] = rows((I(0), TAKEN), (I(INT_MIN), NOT_TAKEN), (I(-1), NOT_TAKEN),
                       (I(1), NOT_TAKEN))
VECTORS["bnez"] = rows((I(0), NOT_TAKEN), (I(INT_MIN), TAKEN), (I(-1), TAKEN), (I(1), TAKEN))


# ---------------------------------------------------------------------------------------------
# Running vectors on the machine


def run_sc(engine_name: str, p: str, source: str, image: dict):
    """Assemble `source` for SC, run it alone on one PE in precision p; the engine."""
    no_tandem(engine_name)
    program = assemble_text(source, proc="sc")
    engine = make_engine(engine_name, load_config(None, [f"precision={p}"]), {"sc": program},
                         image_from_json(image))
    result = engine.run(max_cycles=200_000)
    assert result.status == "halted", (result.status, result.error)
    return engine, program


def vector_program(m: str, vectors: list[V], p: str) -> tuple[str, list[int]]:
    """SC source that runs each vector once and stores its result word at OUT + i, and the
    input words it loads from local[0...]."""
    oc = OPCODES[m]
    lines: list[str] = []
    data: list[int] = []
    for i, v in enumerate(vectors):
        rd = f"r{8 + i % 50}"  # rotate destinations: a missing write cannot pass as the last one
        args = iter(v.args)
        text = []
        n_src = 0
        for operand in oc.operands:
            if operand.kind == "rd":
                text.append(rd)
            elif operand.kind == "rs":
                n_src += 1
                lines.append(f"ld r{n_src}, [r0 + {len(data)}]")
                data.append(next(args).word(p))
                text.append(f"r{n_src}")
            elif operand.kind in ("imm", "fimm"):
                text.append(next(args).text)
            elif operand.kind == "label":
                text.append(f"taken{i}")
            else:
                raise AssertionError(f"{m}: unexpected operand {operand}")
        assert next(args, None) is None, (m, v)
        lines.append(f"{m} {', '.join(text)}")
        if oc.kind == "branch":
            lines += [f"li {rd}, {NOT_TAKEN.v}", f"j done{i}",
                      f"taken{i}: li {rd}, {TAKEN.v}", f"done{i}:"]
        lines.append(f"st {rd}, [r0 + {OUT + i}]")
    lines.append("halt")
    return "\n".join(lines) + "\n", data


def describe(v: V, p: str) -> str:
    shown = []
    for a in v.args:
        shown.append(str(a) if isinstance(a, Imm) else f"{a} ({a.word(p):#x})")
    return ", ".join(shown)


def check_vectors(engine_name: str, p: str, m: str, vectors: list[V]) -> None:
    assert vectors
    source, data = vector_program(m, vectors, p)
    image = {"sc.local": [{"at": 0, "words": [hex(w) for w in data] or [0]},
                          {"at": OUT, "words": [hex(SENTINEL[p])] * len(vectors)}]}
    engine, _ = run_sc(engine_name, p, source, image)
    got = engine.memory("pe0.sc", "local")
    bad = []
    for i, v in enumerate(vectors):
        w = int(got[OUT + i])
        if isinstance(v.expect, AnyNaN):
            ok = is_nan(w, p)
            want = "any NaN"
        else:
            ok = w == v.expect.word(p)
            want = f"{v.expect.word(p):#x} ({v.expect})"
        if not ok:
            bad.append(f"  {m} {p} vector {i}: {describe(v, p)} -> expected {want}, got {w:#x}")
    assert not bad, f"{len(bad)} of {len(vectors)} {m} vectors differ ({engine_name}):\n" \
        + "\n".join(bad)


def vectors_for(p: str, m: str, xfail: int | None) -> list[V]:
    """The vectors of opcode m in precision p: the passing batch (xfail None), or the k-th
    vector marked xfail."""
    here = [v for v in VECTORS[m] if v.applies(p)]
    if xfail is None:
        return [v for v in here if not v.xfail]
    return [[v for v in here if v.xfail][xfail]]


def _cases():
    """(precision, opcode, xfail index): one batch of the passing vectors per opcode, and each
    vector marked xfail on its own (strict: it must keep failing until the semantics agree)."""
    for p in PRECISIONS:
        for m in VECTORS:
            if vectors_for(p, m, None):
                yield pytest.param(p, m, None, id=f"{p}-{m}")
            for k, v in enumerate(v for v in VECTORS[m] if v.applies(p) and v.xfail):
                yield pytest.param(p, m, k, id=f"{p}-{m}-xfail{k}",
                                   marks=pytest.mark.xfail(strict=True, reason=v.xfail))


@pytest.mark.parametrize("precision, mnemonic, xfail", list(_cases()))
def test_opcode_vectors(engine_name, precision, mnemonic, xfail):
    check_vectors(engine_name, precision, mnemonic, vectors_for(precision, mnemonic, xfail))


# ---------------------------------------------------------------------------------------------
# Seeded random vectors against an exact model of IEEE 754
#
# The hand vectors above pin the corner cases one by one; these add many ordinary and extreme
# operands (normal and subnormal, near overflow, cancelling sums, exact ties) whose expected
# words come from an exact model written here: operands decoded to `Fraction`s, the exact
# result rounded to nearest even by hand (`round_bits`: subnormals, overflow to inf, the sign
# of an exact zero), comparisons and conversions on the exact values. Nothing of the opcode
# table or of numpy's arithmetic is used.

FORMATS = {"fp32": (8, 23), "fp64": (11, 52)}  # exponent bits, fraction bits


def _exp2_floor(q: Fraction) -> int:
    """e with 2**e <= q < 2**(e + 1), for q > 0."""
    e = q.numerator.bit_length() - q.denominator.bit_length()
    if Fraction(2) ** e > q:
        e -= 1
    elif Fraction(2) ** (e + 1) <= q:
        e += 1
    return e


def _encode(p: str, negative: bool, e: int, m: int) -> int:
    """The word of (-1)**negative * m * 2**(e - fraction bits), m < 2**(fraction bits + 1),
    e >= emin (m below 2**fraction bits only at e == emin: a subnormal); inf if too large."""
    eb, fb = FORMATS[p]
    bias = 2 ** (eb - 1) - 1
    if m == 2 ** (fb + 1):  # rounding carried into the next binade
        m, e = m // 2, e + 1
    if e > bias:
        word = (2 ** eb - 1) << fb  # overflow: inf (round to nearest)
    elif m < 2 ** fb:
        word = m  # subnormal (or zero): exponent field 0
    else:
        word = ((e + bias) << fb) | (m - 2 ** fb)
    return word | (int(negative) << (eb + fb))


def round_bits(p: str, q: Fraction, zero_negative: bool = False) -> int:
    """The word of the exact value q rounded to nearest, ties to even, in precision p; an
    exact zero is -0 when `zero_negative`, a result that rounds to zero keeps q's sign."""
    eb, fb = FORMATS[p]
    if q == 0:
        return int(zero_negative) << (eb + fb)
    emin = 2 - 2 ** (eb - 1)
    e = max(_exp2_floor(abs(q)), emin)
    n = abs(q) / Fraction(2) ** (e - fb)  # q in units of the last place
    m = n.numerator // n.denominator
    r = n - m
    if r > Fraction(1, 2) or (r == Fraction(1, 2) and m % 2):
        m += 1
    return _encode(p, q < 0, e, m)


def sqrt_bits(p: str, q: Fraction) -> int:
    """The word of sqrt(q), q > 0, rounded to nearest even (exactly: integer square roots)."""
    eb, fb = FORMATS[p]
    emin = 2 - 2 ** (eb - 1)
    e = max(_exp2_floor(q) // 2, emin)  # floor(log2 sqrt(q))
    t = q / Fraction(4) ** (e - fb)     # sqrt(t) = sqrt(q) in units of the last place
    m = math.isqrt(t.numerator // t.denominator)  # floor(sqrt(t)) = isqrt(floor(t))
    half = Fraction(2 * m + 1, 2) ** 2
    if t > half or (t == half and m % 2):
        m += 1
    return _encode(p, False, e, m)


def value(p: str, w: int) -> Fraction:
    """The exact value of a finite word."""
    x = struct.unpack("<f", struct.pack("<I", w))[0] if p == "fp32" else \
        struct.unpack("<d", struct.pack("<Q", w))[0]
    assert math.isfinite(x), hex(w)
    return Fraction(x)


def negative(p: str, w: int) -> bool:
    eb, fb = FORMATS[p]
    return bool(w >> (eb + fb))


def random_word(rng: random.Random, p: str, spread: str) -> int:
    """A finite word: exponents across the whole range (subnormals to the largest binade) or
    near 1 ('mid'), random fraction bits (sometimes few, to make exact results and ties)."""
    eb, fb = FORMATS[p]
    top = 2 ** eb - 2  # largest finite exponent field
    field = rng.randint(0, top) if spread == "wide" else rng.randint(top // 2 - 30, top // 2 + 30)
    frac = rng.getrandbits(fb) if rng.random() < 0.7 else rng.getrandbits(4) << (fb - 4)
    return (rng.getrandbits(1) << (eb + fb)) | (field << fb) | frac


def _q(p, w):
    return value(p, w)


def _to_int(q: Fraction, down: bool) -> int:
    n = math.floor(q) if down else math.trunc(q)
    return max(INT_MIN, min(INT_MAX, n))


MODEL = {  # mnemonic -> (number of float operands, exact result word from the operand words)
    "fadd": (2, lambda p, a, b: round_bits(p, _q(p, a) + _q(p, b),
                                           negative(p, a) and negative(p, b))),
    "fsub": (2, lambda p, a, b: round_bits(p, _q(p, a) - _q(p, b),
                                           negative(p, a) and not negative(p, b))),
    "fmul": (2, lambda p, a, b: round_bits(p, _q(p, a) * _q(p, b),
                                           negative(p, a) != negative(p, b))),
    "fdiv": (2, lambda p, a, b: round_bits(p, _q(p, a) / _q(p, b),
                                           negative(p, a) != negative(p, b))),
    "fsqrt": (1, lambda p, a: sqrt_bits(p, _q(p, a)) if _q(p, a) > 0 else a),  # +-0: itself
    "flt": (2, lambda p, a, b: int(_q(p, a) < _q(p, b))),
    "fle": (2, lambda p, a, b: int(_q(p, a) <= _q(p, b))),
    "feq": (2, lambda p, a, b: int(_q(p, a) == _q(p, b))),
    "fmin": (2, lambda p, a, b: a if _q(p, a) < _q(p, b) or (_q(p, a) == _q(p, b)
                                                           and negative(p, a)) else b),
    "fmax": (2, lambda p, a, b: a if _q(p, a) > _q(p, b) or (_q(p, a) == _q(p, b)
                                                           and not negative(p, a)) else b),
    "ftoi": (1, lambda p, a: _to_int(_q(p, a), False)),
    "floor": (1, lambda p, a: _to_int(_q(p, a), True)),
    "itof": (0, lambda p, i: round_bits(p, Fraction(i))),
}
N_RANDOM = 96


def random_vectors(p: str, m: str) -> list[V]:
    """N_RANDOM vectors of opcode m in precision p, seeded by (p, m): the same every run."""
    rng = random.Random(f"{p}-{m}")
    n_float, model = MODEL[m]
    raw = (lambda w: W(w, None)) if p == "fp32" else (lambda w: W(None, w))
    out = []
    while len(out) < N_RANDOM:
        if n_float == 0:  # itof: integers, many of them wider than the fraction
            i = rng.randint(INT_MIN, INT_MAX) >> rng.randint(0, 31)
            out.append(V((I(i),), raw(model(p, i))))
            continue
        spread = "wide" if rng.random() < 0.5 else "mid"
        ws = [random_word(rng, p, spread) for _ in range(n_float)]
        if n_float == 2 and rng.random() < 0.2:  # the same magnitude: cancellation, equality
            ws[1] = ws[0] ^ (rng.getrandbits(1) << (sum(FORMATS[p])))
        if m == "fsqrt":
            ws[0] &= ~(1 << sum(FORMATS[p]))  # non-negative (negatives: the hand vectors)
        if m == "fdiv" and _q(p, ws[1]) == 0:
            continue  # x/0: the hand vectors
        got = model(p, *ws)
        expect = I(got) if m in ("flt", "fle", "feq", "ftoi", "floor") else raw(got)
        out.append(V(tuple(raw(w) for w in ws), expect))
    return out


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("mnemonic", list(MODEL))
def test_random_vectors_against_an_exact_model(engine_name, precision, mnemonic):
    check_vectors(engine_name, precision, mnemonic, random_vectors(precision, mnemonic))


@pytest.mark.parametrize("p, q, word", [
    # the model's rounding, checked against words worked out by hand
    ("fp32", Fraction(1) + Fraction(1, 2 ** 24), 0x3F80_0000),        # tie -> even (down)
    ("fp32", Fraction(1) + Fraction(3, 2 ** 24), 0x3F80_0002),        # tie -> even (up)
    ("fp32", Fraction(1, 3), 0x3EAA_AAAB),
    ("fp64", Fraction(1, 3), 0x3FD5_5555_5555_5555),
    ("fp32", Fraction(2) ** -149, 0x0000_0001),                         # smallest subnormal
    ("fp32", Fraction(2) ** -150, 0x0000_0000),                         # tie -> even: 0
    ("fp32", -Fraction(3, 2) * Fraction(2) ** -150, 0x8000_0001),   # rounds up to -2**-149
    ("fp32", Fraction(2) ** -126 - Fraction(2) ** -150, 0x0080_0000),  # carries to the normal
    ("fp32", Fraction(2) ** 128 - Fraction(2) ** 103, 0x7F80_0000),     # tie at the top: inf
    ("fp32", Fraction(2) ** 128 - Fraction(2) ** 103 - 1, 0x7F7F_FFFF),
    ("fp64", Fraction(2) ** -1074, 0x0000_0000_0000_0001),
    ("fp64", -Fraction(2) ** 1024, 0xFFF0_0000_0000_0000),
])
def test_the_exact_model_rounds_as_worked_out_by_hand(p, q, word):
    assert round_bits(p, q) == word


def test_the_exact_square_root_as_worked_out_by_hand():
    assert sqrt_bits("fp32", Fraction(2)) == 0x3FB5_04F3
    assert sqrt_bits("fp64", Fraction(2)) == 0x3FF6_A09E_667F_3BCD
    assert sqrt_bits("fp32", Fraction(2) ** -148) == 0x1A80_0000       # of a subnormal: 2**-74
    assert sqrt_bits("fp32", Fraction(1, 4)) == 0x3F00_0000
    assert sqrt_bits("fp64", Fraction(9, 4)) == 0x3FF8_0000_0000_0000


# ---------------------------------------------------------------------------------------------
# The other kinds: memory, FIFOs, control transfers, halt, nop — small programs

PROGRAM_CHECKS: dict[str, str] = {}


def _covers(*mnemonics: str):
    def mark(fn):
        for m in mnemonics:
            PROGRAM_CHECKS[m] = fn.__name__
        return fn
    return mark


def _words(engine, at: int, n: int) -> list[int]:
    return [int(w) for w in engine.memory("pe0.sc", "local")[at:at + n]]


@pytest.mark.parametrize("precision", PRECISIONS)
@_covers("ld", "st", "ldr", "ldg")
def test_loads_and_stores_keep_every_bit(engine_name, precision):
    p = precision
    local, resident, glob = (SNAN.word(p), RAW.word(p)), (NNAN.word(p), I(-1).word(p)), \
        (RAW.word(p), N0.word(p))
    engine, _ = run_sc(engine_name, p, f"""
        li r5, 3
        ld r1, [r5 - 3]                 # base register + negative offset: local[0]
        ld r2, [r0 + 1]
        ldr r3, [r0 + 4]
        ldr r4, [r5 + 2]                # resident[5]
        ldg r6, [r0 + 7]
        ldg r7, [r5 + 5]                # global[8]
        st r1, [r5 + {OUT - 3}]
        st r2, [r0 + {OUT + 1}]
        st r3, [r0 + {OUT + 2}]
        st r4, [r0 + {OUT + 3}]
        st r6, [r0 + {OUT + 4}]
        st r7, [r0 + {OUT + 5}]
        halt
    """, {"sc.local": [hex(w) for w in local],
          "sc.resident": {"at": 4, "words": [hex(w) for w in resident]},
          "scgm": {"at": 7, "words": [hex(w) for w in glob]}})
    want = [*local, *resident, *glob]
    assert _words(engine, OUT, 6) == want, [hex(w) for w in _words(engine, OUT, 6)]


@pytest.mark.parametrize("precision", PRECISIONS)
@_covers("j", "jr", "call", "ret", "halt", "nop")
def test_control_transfers(engine_name, precision):
    p = precision
    engine, program = run_sc(engine_name, p, f"""
            li r1, 1
            j over
            li r1, 2                    # skipped by j
    over:   st r1, [r0 + {OUT}]
            li r2, there
            li r3, 1
            jr r2
            li r3, 2                    # skipped by jr
    there:  st r3, [r0 + {OUT + 1}]
            li r4, 1
            call sub
    back:   st lr, [r0 + {OUT + 2}]     # lr = address of the bundle after the call
            st r4, [r0 + {OUT + 3}]
            li r5, 7
            nop
            nop
            st r5, [r0 + {OUT + 4}]
            halt
            li r6, 1                    # never: the processor stopped
            st r6, [r0 + {OUT + 5}]
    sub:    addi r4, r4, 2
            ret
    """, {"sc.local": {"at": OUT, "words": [hex(SENTINEL[p])] * 6}})
    back = program.labels["back"][1]
    there = program.labels["there"][1]
    assert back == 11 and there == 8  # counted by hand: SC bundles hold one instruction
    assert _words(engine, OUT, 6) == [1, 1, back, 3, 7, SENTINEL[p]]
    regs = engine.registers("pe0.sc")
    want = [0] * len(regs)
    want[1:7] = [1, there, 1, 3, 7, 0]
    want[63] = back
    assert regs == want  # nop wrote nothing; nothing after halt ran


@pytest.mark.parametrize("precision", PRECISIONS)
@_covers("send", "recv", "poll", "room", "wait")
def test_fifo_operations(engine_name, precision):
    p = precision
    config = load_config(None, [f"precision={p}"])
    engine, _ = run_sc(engine_name, p, f"""
            room r1, ring               # an empty send FIFO: all free
            poll r2, ring               # nothing has arrived: 0
            li r3, (DEST_SC << HDR_DEST_SHIFT) | 1     # a 1-word message to SC itself
            ld r4, [r0]                 # its payload: a raw word
            send ring, r3
            send ring, r4
            wait                        # sleeps until the header is back round the ring
            li r7, 2
    spin:   poll r6, ring
            bne r6, r7, spin
            recv r8, ring
            recv r9, ring
            poll r10, ring              # drained: 0
            st r1, [r0 + {OUT}]
            st r2, [r0 + {OUT + 1}]
            st r3, [r0 + {OUT + 2}]
            st r8, [r0 + {OUT + 3}]
            st r9, [r0 + {OUT + 4}]
            st r6, [r0 + {OUT + 5}]
            st r10, [r0 + {OUT + 6}]
            halt
    """, {"sc.local": [hex(SNAN.word(p))]})
    got = _words(engine, OUT, 7)
    header = got[2]
    assert got == [config.ring.fifo_depth, 0, header, header, SNAN.word(p), 2, 0], \
        [hex(w) for w in got]


# ---------------------------------------------------------------------------------------------
# Coverage


def test_every_opcode_is_covered():
    computed = {m for m, o in OPCODES.items() if o.kind in ("alu", "branch")}
    assert computed <= set(VECTORS), sorted(computed - set(VECTORS))
    assert not set(VECTORS) & set(PROGRAM_CHECKS)
    covered = set(VECTORS) | set(PROGRAM_CHECKS)
    assert covered == set(OPCODES), (sorted(set(OPCODES) - covered), sorted(covered - set(OPCODES)))


def test_every_vector_runs_in_some_precision():
    for m, vectors in VECTORS.items():
        for v in vectors:
            assert any(v.applies(p) for p in PRECISIONS), (m, v)
