"""Machine words: how a register or memory word holds an integer or a float.

Registers and memory hold raw words; an operation decides how to read them. Integer operations
see 32-bit two's-complement values (wrap-around). FP operations see IEEE 754 values of the
machine's precision: binary32 (the machine's format) or binary64 (a knob for accuracy studies).
The word is as wide as the FP format (4 or 8 bytes); addresses count words, so programs and
memory images do not change with precision — only byte sizes (and so cache behaviour) do.
In fp64 mode an integer is kept sign-extended in the 64-bit word.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from netsushisen.isa.jit import jitable

INT_MIN = -(1 << 31)
INT_MAX = (1 << 31) - 1


@jitable
def wrap32(v: int) -> int:
    """Reduce any Python int to the signed 32-bit value with the same low 32 bits."""
    v &= 0xFFFFFFFF
    return v - 0x100000000 if v & 0x80000000 else v


@dataclass(frozen=True)
class WordFormat:
    precision: str  # "fp32" | "fp64"

    @property
    def bytes(self) -> int:
        return 4 if self.precision == "fp32" else 8

    @property
    def word_dtype(self) -> type:
        return np.uint32 if self.precision == "fp32" else np.uint64

    @property
    def float_type(self) -> type:
        return np.float32 if self.precision == "fp32" else np.float64

    @property
    def mask(self) -> int:
        return (1 << (8 * self.bytes)) - 1

    def from_int(self, v: int) -> int:
        """The word holding integer v (wrapped to 32 bits, sign-extended to the word)."""
        return wrap32(int(v)) & self.mask

    def to_int(self, w: int) -> int:
        return wrap32(int(w))

    def from_float(self, x: float) -> int:
        """The word holding x rounded (to nearest even) to the machine's precision."""
        if self.precision == "fp32":
            return struct.unpack("<I", struct.pack("<f", np.float32(x)))[0]
        return struct.unpack("<Q", struct.pack("<d", float(x)))[0]

    def to_float(self, w: int):
        """The FP value (a numpy scalar of the precision) held by word w."""
        if self.precision == "fp32":
            return np.float32(struct.unpack("<f", struct.pack("<I", int(w) & 0xFFFFFFFF))[0])
        return np.float64(struct.unpack("<d", struct.pack("<Q", int(w) & self.mask))[0])


FP32 = WordFormat("fp32")
FP64 = WordFormat("fp64")


def word_format(precision: str) -> WordFormat:
    return FP32 if precision == "fp32" else FP64
