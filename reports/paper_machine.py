"""`netsushisen paper --on-machine` and the scenes-in-parallel runner.

`machine_check` renders one scene on the emulated machine in the serial ray-tree mode
(SLOTS=1, SERIAL_TREES=1: one ray tree in flight, so IC sees the golden trace's rays in
`tracesim.machine_order`) and replays the golden trace through the trace-driven memory for the
same images; the two sets of IC counters — accesses by memory and by region, loads per
primitive, hence ρ and μ — must be equal, and the result says where they are not.

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


def machine_check(scene: str, res: int, config, engine: str, corners: bool = False) -> dict:
    """Render `scene` on the machine (serial mode) and compare IC's counters with the
    trace-driven path's for the same images."""
    from netsushisen.host.golden import render as golden_render
    from netsushisen.render import render
    from netsushisen.reports.tracesim import TraceMemory, machine_order, ordered_stream_chunks

    t0 = time.perf_counter()
    r = render(scene, config, res=res, corners=corners, slots=1, defines={"SERIAL_TREES": 1}, engine=engine)
    t_machine = time.perf_counter() - t0
    setup = r.setup
    machine = r.stats["memory"]["pe0.ic"]
    out = {"scene": setup.scene.name, "cycles": int(r.run.cycles), "status": r.run.status,
           "machine_seconds": t_machine}
    if r.run.status not in ("halted", "finished"):
        out.update(equal=False, difference=f"the machine stopped: {r.run.status}"
                   + (f" ({r.run.error})" if r.run.error else ""), rho="–", mu="–",
                   seconds=time.perf_counter() - t0)
        return out
    golden = golden_render(setup.scene, setup.config, res=res, corners=corners, keep_trace=True,
                           grid=setup.images.layout.grid)
    model = TraceMemory.for_images(setup.images)
    for space, address in ordered_stream_chunks(setup.images.layout, golden, machine_order(golden)):
        model.replay(space, address)
    trace = model.stats()
    diff = compare_counters(trace, machine)
    res_acc, cache = machine["resident"]["accesses"], machine["cache"]
    total = res_acc + cache["accesses"]
    out.update(equal=not diff, difference=diff,
               rho=f"{res_acc / total:.4f}" if total else "–",
               mu=f"{cache['hits'] / cache['accesses']:.4f}" if cache["accesses"] else "–",
               loads=total, seconds=time.perf_counter() - t0)
    return out


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
