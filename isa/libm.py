"""pow as the C library computes it, for every engine and the golden model.

`fpow` is defined as C's `powf` (fp32) or `pow` (fp64). numpy's own power loops are not the C
library's (they differ in the last bit for about one argument pair in five), so the Python side
calls the C library through ctypes, and numba-compiled code calls the same functions (numba's
`np.power` on float32 / float64 scalars lowers to `powf` / `pow`). The reference engine, the
compiled engine and the golden model therefore agree bit for bit on one machine; a different C
library may round some results differently, which is why no test pins pow's last bit against a
literal.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np

from netsushisen.isa.jit import overload

_LIBM = ctypes.CDLL(ctypes.util.find_library("m") or "libm.so.6")
_powf = _LIBM.powf
_powf.restype, _powf.argtypes = ctypes.c_float, [ctypes.c_float, ctypes.c_float]
_pow = _LIBM.pow
_pow.restype, _pow.argtypes = ctypes.c_double, [ctypes.c_double, ctypes.c_double]


def c_pow(a, b):
    """C `powf(a, b)` for float32 scalars, `pow(a, b)` otherwise; the result has a's type."""
    if isinstance(a, np.float32):
        return np.float32(_powf(a, b))
    return np.float64(_pow(a, b))


@overload(c_pow)
def _c_pow_numba(a, b):
    from numba.core import types

    if a == types.float32:
        return lambda a, b: np.power(a, np.float32(b))
    return lambda a, b: np.power(np.float64(a), np.float64(b))


_powf_array = np.frompyfunc(lambda a, b: _powf(a, b), 2, 1)
_pow_array = np.frompyfunc(lambda a, b: _pow(a, b), 2, 1)


def c_pow_array(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Elementwise `c_pow` over arrays (the golden model's Phong highlights)."""
    a = np.asarray(a)
    if a.dtype == np.float32:
        return _powf_array(a, np.asarray(b, np.float32)).astype(np.float32)
    return _pow_array(a, np.asarray(b, np.float64)).astype(np.float64)
