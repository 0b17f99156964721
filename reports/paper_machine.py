"""`netsushisen paper --on-machine`'s comparison and the scenes-in-parallel runner.

The on-machine check (`commands/paper.py: machine_check`, which renders on an engine: reports
never import engine objects) compares IC's counters from the machine with the trace-driven
path's: accesses by memory and by region, loads per primitive, hence ρ and μ; they must be
equal, and `compare_counters` says where they are not.

`run_parallel` runs such tasks (and `analyse_scene`) in worker processes, one scene per worker:
scenes are independent, and a 512×512 scene takes minutes. Workers ignore Ctrl-C; the parent
stops them and keeps every result already returned.
"""

from __future__ import annotations

import multiprocessing
import signal
import time
from typing import Callable

COMPARED = ("resident", "cache", "global", "regions", "primitives")
"""IC's counters the two paths must agree on (`MemorySystem.stats()` keys)."""


def _first_difference(got: dict, want: dict, path: str = "") -> str:
    """Where two counter dictionaries first differ, as `key.key: trace X, machine Y`."""
    for k in sorted(set(got) | set(want), key=str):
        a, b = got.get(k), want.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            d = _first_difference(a, b, f"{path}{k}.")
            if d:
                return d
        elif a != b:
            return f"{path}{k}: trace-driven {a}, machine {b}"
    return ""


def compare_counters(trace: dict, machine: dict) -> str:
    """'' when IC's counters agree on every COMPARED key, else the first difference."""
    return _first_difference({k: trace[k] for k in COMPARED if k in trace},
                             {k: machine[k] for k in COMPARED if k in machine})


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_parallel(tasks: list[tuple[Callable, tuple]], jobs: int,
                 on_done: Callable[[int, object], None]) -> bool:
    """Run `fn(*args)` for every task in `jobs` worker processes (spawned: no engine state is
    inherited); `on_done(index, result)` in the parent as each finishes. A worker's exception is
    raised here. Returns False when interrupted (Ctrl-C): workers are stopped, results already
    delivered are kept."""
    ctx = multiprocessing.get_context("spawn")
    pool = ctx.Pool(max(1, jobs), initializer=_ignore_sigint)
    try:
        pending = {i: pool.apply_async(fn, args) for i, (fn, args) in enumerate(tasks)}
        while pending:
            for i in [i for i, a in pending.items() if a.ready()]:
                on_done(i, pending.pop(i).get())
            time.sleep(0.2)
        pool.close()
        return True
    except KeyboardInterrupt:
        return False
    finally:
        pool.terminate()
        pool.join()
