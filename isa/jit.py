"""numba's markers for the ISA's semantics, without importing numba until a machine is compiled.

The opcode semantics (opcodes.py) and their helpers (words.py, libm.py) are plain Python that the
reference engine and the golden model call and that the compiled engine compiles unchanged. numba
needs them registered (`register_jitable`, `overload`) before it compiles a caller; registering
them at import would make every command pay numba's import (about 0.2-0.4 s), even `asm` and
`report`, which run no machine, and would make the package unusable where numba does not import.
So the ISA only marks them here, and the compiled engine calls `register_with_numba()` when it is
imported (emulator/compiled/__init__.py), before it compiles anything.
"""

from __future__ import annotations

from typing import Callable

_JITABLE: list[Callable] = []
_OVERLOADS: list[tuple[Callable, Callable]] = []
_registered = False


def jitable(fn: Callable) -> Callable:
    """Mark `fn` (a plain function numba can compile) as callable from compiled code; `fn` is
    returned unchanged (as numba's `register_jitable` does)."""
    _JITABLE.append(fn)
    if _registered:  # marked after the compiled engine was imported: register it at once
        _register_jitable(fn)
    return fn


def overload(fn: Callable) -> Callable[[Callable], Callable]:
    """Mark `impl` as `fn`'s implementation in compiled code (numba's `@overload(fn)`)."""
    def mark(impl: Callable) -> Callable:
        _OVERLOADS.append((fn, impl))
        if _registered:
            _register_overload(fn, impl)
        return impl
    return mark


def _register_jitable(fn: Callable) -> None:
    from numba.extending import register_jitable
    register_jitable(fn)


def _register_overload(fn: Callable, impl: Callable) -> None:
    from numba.extending import overload as numba_overload
    numba_overload(fn)(impl)


def register_with_numba() -> None:
    """Register every marked function with numba (imports numba); once per process."""
    global _registered
    if _registered:
        return
    for fn in _JITABLE:
        _register_jitable(fn)
    for fn, impl in _OVERLOADS:
        _register_overload(fn, impl)
    _registered = True
