"""Machine state for the debugger: checkpoints (for reverse execution) and a canonical dump.

Checkpoints. `freeze` pickles the machine's mutable state — the same parts `Machine.snapshot`
copies (PEs with their cores, memories, caches and ring; DIS; COL; cycle; status; error; the
deadlock counters) — and compresses it with zlib (local memories are mostly zeros: a PE
freezes to a few KB). What `Machine.snapshot` shares instead of copying (programs, config,
global and resident memories, decoded bundles) is kept by reference, as are immutable objects
the pickler cannot copy (bound methods, the run's error). `thaw` installs such a state back.
Going back to cycle T = thawing the last checkpoint at or before T and replaying the cycles
after it: the engine is deterministic, so the result is exactly the state the machine had.

Canonical dump. `state_dump` walks the same state into plain, comparable data — every
register, scoreboard entry, memory word, cache tag, FIFO word, counter, and the aliasing
between objects — so two dumps are equal iff the machine states are; tests compare them, and
`info state` prints its digest. Dicts are dumped as mappings, sorted by key: their insertion
order is not machine state (the engine never depends on it; statistics sort), and the compiled
engine's write-back (`--fast-forward`) builds its counter dicts in another order than the
reference engine's first-use order.
"""

from __future__ import annotations

import hashlib
import io
import pickle
import types
import zlib
from collections import deque
from dataclasses import dataclass

import numpy as np

from netsushisen.isa.processors import Processor

STATE_KEYS = ("pes", "dis", "col", "cycle", "status", "error", "no_progress")
"""The parts of a Machine that change during a run (the keys of `Machine.snapshot()`)."""

_ATOMIC = (types.BuiltinMethodType, types.BuiltinFunctionType, types.FunctionType,
           types.MethodType, type, BaseException, Processor)


def live_state(machine) -> dict:
    return {k: getattr(machine, k) for k in STATE_KEYS}


def install(machine, state: dict) -> None:
    """Make `state` (fresh objects, e.g. from `thaw`) the machine's state; the same as
    `Machine.restore` without its deep copy (which cannot copy a run's fault)."""
    for k in STATE_KEYS:
        setattr(machine, k, state[k])
    machine._active = [core for pe in machine.pes for core in pe.active]


@dataclass
class Frozen:
    cycle: int
    blob: bytes
    refs: list  # objects kept by reference (shared or immutable)

    @property
    def size(self) -> int:
        return len(self.blob)


def freeze(machine) -> Frozen:
    shared = machine._shared_memo()
    refs: list = []
    index: dict[int, int] = {}

    class _Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            if id(obj) in shared or isinstance(obj, _ATOMIC):
                k = index.get(id(obj))
                if k is None:
                    k = index[id(obj)] = len(refs)
                    refs.append(obj)
                return k
            return None

    buf = io.BytesIO()
    _Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(live_state(machine))
    return Frozen(machine.cycle, zlib.compress(buf.getvalue(), 1), refs)


def thaw(machine, frozen: Frozen) -> None:
    refs = frozen.refs

    class _Unpickler(pickle.Unpickler):
        def persistent_load(self, pid):
            return refs[pid]

    install(machine, _Unpickler(io.BytesIO(zlib.decompress(frozen.blob))).load())


# ---------------------------------------------------------------------------------------------
# Canonical dump


def state_dump(machine) -> dict:
    """The machine's whole mutable state as plain data (see the module docstring)."""
    shared = machine._shared_memo()
    memo: dict[int, int] = {}
    keep: list = []  # keep visited objects alive so ids stay unique during the walk
    return {k: _canon(v, shared, memo, keep) for k, v in live_state(machine).items()}


def state_digest(machine) -> str:
    h = hashlib.sha256()
    h.update(repr(state_dump(machine)).encode())
    return h.hexdigest()[:16]


def _slots(cls) -> list[str]:
    out = []
    for c in cls.__mro__:
        for s in getattr(c, "__slots__", ()):
            if s not in ("__dict__", "__weakref__") and s not in out:
                out.append(s)
    return out


def _canon(obj, shared, memo, keep):
    if obj is None or isinstance(obj, (bool, int, str, bytes)):
        return obj
    if isinstance(obj, float):
        return ("float", obj.hex())
    if isinstance(obj, np.generic):
        return ("scalar", obj.dtype.str, obj.tobytes())
    if isinstance(obj, np.ndarray):
        return ("ndarray", obj.dtype.str, obj.shape, obj.tobytes())
    if id(obj) in shared:
        return ("shared", type(obj).__name__)
    if isinstance(obj, BaseException):
        return ("error", type(obj).__name__, str(obj))
    if isinstance(obj, _ATOMIC):
        return ("callable", getattr(obj, "__qualname__", type(obj).__name__))
    if id(obj) in memo:
        return ("ref", memo[id(obj)])
    memo[id(obj)] = len(memo)
    keep.append(obj)
    if isinstance(obj, tuple):
        return ("tuple", [_canon(v, shared, memo, keep) for v in obj])
    if isinstance(obj, list):
        return ("list", [_canon(v, shared, memo, keep) for v in obj])
    if isinstance(obj, deque):
        return ("deque", [_canon(v, shared, memo, keep) for v in obj])
    if isinstance(obj, (set, frozenset)):
        return ("set", sorted(repr(_canon(v, shared, memo, keep)) for v in obj))
    if isinstance(obj, dict):  # a mapping: insertion order is not state (see the docstring)
        keys = [(repr(ck), ck, k) for k in obj for ck in (_canon(k, shared, memo, keep),)]
        keys.sort(key=lambda t: t[0])
        return ("dict", [(ck, _canon(obj[k], shared, memo, keep)) for _, ck, k in keys])
    fields = dict(getattr(obj, "__dict__", {}))
    for s in _slots(type(obj)):
        if hasattr(obj, s):
            fields[s] = getattr(obj, s)
    return ("object", type(obj).__qualname__,
            [(k, _canon(v, shared, memo, keep)) for k, v in fields.items()])


def dump_differences(a: dict, b: dict, limit: int = 10) -> list[str]:
    """Where two dumps differ (paths), for test failure messages."""
    out: list[str] = []

    def walk(x, y, path):
        if len(out) >= limit or x == y:
            return
        if type(x) is not type(y) or not isinstance(x, (tuple, list, dict)):
            out.append(f"{path}: {str(x)[:80]} != {str(y)[:80]}")
            return
        if isinstance(x, dict):
            for k in sorted(set(x) | set(y), key=str):
                walk(x.get(k), y.get(k), f"{path}.{k}")
            return
        if len(x) != len(y):
            out.append(f"{path}: length {len(x)} != {len(y)}")
        for i, (p, q) in enumerate(zip(x, y)):
            label = p[0] if isinstance(p, tuple) and len(p) == 2 and isinstance(p[0], str) else i
            walk(p, q, f"{path}/{label}")

    walk(a, b, "state")
    return out
