"""Timed runs of the accuracy study: each run split into its stages, the repeats of an axis's
settings interleaved, and identical machine configurations measured once.

Why the split: at small sizes a machine row is mostly host work (grid, pre-pass, memory images,
kernels) and the engine's fixed load (the compiled engine flattens the reference machine's state
into arrays, ~0.2 s at 16x16 whatever the cycles), so a total hides what a setting costs — fp64
read +79 % in time while its cycles rose 14 %. A machine run is timed as four stages:

  host     `prepare`: grid, pre-pass, memory images, kernels, eye rays
  load     the engine built and loaded (`setup.engine`, and the compiled engine's `flatten`)
  machine  the cycle loop alone: the figure the precision and depth axes compare
  readout  the compiled engine's write-back and `finish` (frame, ids, ray counts, statistics)

The machine stage is also kept as this process's CPU seconds (`machine_cpu`, not part of a run's
total): on a shared machine wall time grows with everyone else's load (a 512x512 tetra run took
196 s of wall time at one load and 455 s at another), CPU time does not.

Why interleaved: one setting's repeats in a row share whatever else the machine was doing then;
round-robin (every setting once, then again) spreads that over all settings alike.

Why measured once: "machine fp32" on the precision axis, "depth 5" on the depth axis and the
fidelity axis's full run are the same configuration (same scene, config, size and engine: the
same `run_key`); the first axis to need it measures it and the others in the same worker reuse
its runs. Rows carry the key, and `reports.accuracy.identical_runs` checks that rows with one key
agree within their spread (they need not come from one worker: `--workers N`, a cluster).
"""

from __future__ import annotations

import time
from collections import OrderedDict
from typing import Callable, Hashable, TypeVar

from netsushisen.cluster import content_key, scene_digest
from netsushisen.host.scenes import Scene
from netsushisen.isa.config import MachineConfig, dump_toml
from netsushisen.isa.errors import NetsushisenError
from netsushisen.pipeline import RenderResult, RenderSetup, finish, prepare

STAGES = ("host", "load", "machine", "readout")
"""A machine run's stages, in the order they happen (the module docstring says what each is)."""

K = TypeVar("K", bound=Hashable)
Job = Callable[[], tuple[object, dict[str, float]]]
"""One repetition of a setting: (its result, seconds per stage)."""


class MachineStopped(NetsushisenError):
    """A study's machine run that did not end cleanly (e.g. at a deep ray depth more rays wait
    than OS's memory holds: `queue_overflow`)."""


def run_parts(setup: RenderSetup, engine: str, max_cycles: int | None = None
              ) -> tuple[RenderResult, dict[str, float]]:
    """Run a prepared setup: (result, seconds of load, machine and readout). A run that does not
    end cleanly is bad input for a study (a cycle limit within `max_cycles` is expected)."""
    t0 = time.perf_counter()
    eng = setup.engine(engine)
    t1, c1 = time.perf_counter(), time.process_time()
    run = eng.run(max_cycles)
    t2, c2 = time.perf_counter(), time.process_time()
    result = finish(setup, eng, run)
    t3 = time.perf_counter()
    phases = getattr(eng, "phases", None) or {}
    flatten, back = phases.get("flatten", 0.0), phases.get("write_back", 0.0)
    fixed_cpu = phases.get("flatten_cpu", 0.0) + phases.get("write_back_cpu", 0.0)
    if run.status not in ("halted", "finished") and not (max_cycles and run.status == "max_cycles"):
        raise MachineStopped(f"{setup.scene.name} {setup.res}x{setup.res}: the machine run ended "
                             f"{run.status} at cycle {run.cycles:,}"
                             + (f": {run.error.format()}" if run.error else ""))
    return result, {"load": t1 - t0 + flatten, "machine": max(0.0, t2 - t1 - flatten - back),
                    "readout": back + t3 - t2, "machine_cpu": max(0.0, c2 - c1 - fixed_cpu)}


def machine_job(scene: Scene, config: MachineConfig, res: int, engine: str,
                max_cycles: int | None = None) -> Job:
    """A repetition of a machine row: `prepare` (host), then the engine (load, machine,
    readout); its result is (setup, RenderResult)."""
    def job():
        start = time.perf_counter()
        setup = prepare(scene, config, res)
        host = time.perf_counter() - start
        result, parts = run_parts(setup, engine, max_cycles)
        return (setup, result), {"host": host} | parts
    return job


def run_key(scene: Scene, config: MachineConfig, res: int, engine: str) -> str:
    """What makes two machine rows the same run: scene, configuration, size, engine."""
    return content_key("accuracy machine run", scene_digest(scene), dump_toml(config), res,
                       engine)[:16]


Outcome = tuple[object, dict[str, list[float]]]
"""A setting's last result (or the MachineStopped that ended it) and each stage's per-run seconds."""

_MEASURED: "OrderedDict[tuple[str, int], Outcome]" = OrderedDict()
"""Machine runs this worker process has measured, by (run_key, repeats): reused by the next
axis that needs the same configuration. The last few only (each keeps its engine's state)."""
KEEP = 4


def round_robin(jobs: dict[K, Job], repeats: int, keys: dict[K, str] | None = None,
                stops: tuple[type[BaseException], ...] = (MachineStopped,),
                done: Callable[[K, Outcome], None] | None = None) -> dict[K, Outcome]:
    """Each job `repeats` times, round by round (every job once, then again), so no setting's
    repeats run in a row. A job whose `keys` entry was measured before in this process (same
    run_key, same repeats) is not run again: its runs are reused. A job raising one of `stops`
    is dropped from later rounds; its outcome is the exception and the stages it had.
    `done(k, outcome)` is called as each setting becomes final (a reused one at once, the others
    in the last round), so its row can be sent on before the round ends (Ctrl-C keeps it)."""
    keys = keys or {}
    out: dict[K, Outcome] = {}
    todo = []
    for k in jobs:
        memo = (keys.get(k), repeats)
        if memo[0] is not None and memo in _MEASURED:
            out[k] = _MEASURED[memo]
            _MEASURED.move_to_end(memo)
            if done:
                done(k, out[k])
        else:
            todo.append(k)
    parts: dict[K, dict[str, list[float]]] = {k: {} for k in todo}
    last: dict[K, object] = {}
    rounds = max(1, repeats)
    for i in range(rounds):
        for k in todo:
            if isinstance(last.get(k), BaseException):
                continue
            try:
                last[k], stage = jobs[k]()
            except stops as err:
                last[k] = err
            else:
                for name, seconds in stage.items():
                    parts[k].setdefault(name, []).append(seconds)
            if i == rounds - 1 or isinstance(last[k], BaseException):
                out[k] = (last[k], parts[k])
                if done:
                    done(k, out[k])
    for k in todo:
        if keys.get(k) is not None and not isinstance(last[k], BaseException):
            _MEASURED[(keys[k], repeats)] = out[k]
            while len(_MEASURED) > KEEP:
                _MEASURED.popitem(last=False)
    return out


def timed_job(fn: Callable[[], object], stage: str) -> Job:
    """A job of one stage: fn() timed whole."""
    def job():
        start = time.perf_counter()
        result = fn()
        return result, {stage: time.perf_counter() - start}
    return job
