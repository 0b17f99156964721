"""`paper --on-machine`: the machine behind the paper's findings.

`machine_check` renders a scene on the emulated machine in the serial ray-tree mode (one ray
tree in flight: IC visits the golden trace's rays in `tracesim.machine_order`) with IC's loads
recorded (`Engine.record_loads`), and compares with the trace-driven path for the same images:
IC's per-word counters (`compare_counters`: accesses by memory and by region, loads per
primitive) and the per-reference counts the findings use (`reference_check`: the paper's
references, each hit decided by the machine's own per-load hit flags, against `SweepStream`'s
for the same configuration — one rule, `tracesim.fetches` / `tracesim.reference_hits`).

`ray_order_study` renders in the kernels' normal mode (several rays in flight), maps IC's
recorded stream back to the sweep's reference layout (`host.ic_access.to_reference`) and
replays it through every configuration of Figures 4–5 (`paper_sweep.replay_figures`), so the
findings can be recomputed in the machine's own ray order (report.md's "Ray order" section).
Every function here runs in a worker process: module-level, picklable arguments.
"""

from __future__ import annotations

import copy
import time

import numpy as np

from netsushisen.emulator.tracesim import (SweepPoint, SweepStream, TraceMemory,
                                           stream_references)
from netsushisen.host.databases import RESIDENT, plan_layout
from netsushisen.host.golden import render as render_golden
from netsushisen.emulator.loads import LoadStream
from netsushisen.host.ic_access import (load_primitives, ordered_stream_chunks, pe_orders,
                                        to_reference)
from netsushisen.host.prepass import coarse_resolution
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.regions import GLOBAL
from netsushisen.paper_sweep import golden_chunks, replay_figures, sized_config
from netsushisen.reports.paper_data import PaperOptions

SERIAL = {"SERIAL_TREES": 1}
"""The kernels' serial ray-tree mode (with one slot)."""

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


MACHINE_POINTS = (
    ("cache-only 10 %", 0.1, 0.0),
    ("cache-only 100 %", 1.0, 0.0),
    ("30 % local, 70 % resident", 0.09, 0.21),
    ("50 % local, all resident", 0.0, 0.5),
)
"""Sweep points `--on-machine` also renders (label, cache share, resident share of the machine's
primitive database — lists + records, `--sizing records+lists --lists cache`, the machine's own
reading): Figure 4's extremes, the paper's 70 % split at 30 % local, and a resident-only one."""


def point_config(config: MachineConfig, cache: float, resident: float) -> MachineConfig:
    """`config` with IC's cache and resident memory as shares of the scene's database."""
    c = copy.deepcopy(config)
    c.ic_memory.cache_share, c.ic_memory.resident_share = cache, resident
    return c


PE_CANDIDATE = 4
"""The PE count of the candidate reading every `paper` run replays (the trace split among PEs
as the machine's static distribution splits the pixels), which `--on-machine` checks on the
machine."""


def pes_config(config: MachineConfig, pes: int = PE_CANDIDATE) -> MachineConfig:
    """`config` with `pes` PEs (each with its own IC memories; ICGM shared), the pixels
    divided statically (the division the trace-driven path models: `pe_orders`)."""
    c = copy.deepcopy(config)
    c.pes, c.distribution = pes, "static"
    return c


def machine_check(scene, res: int, config, engine: str, corners: bool = False, point: str = "",
                  prepass: bool = False) -> dict:
    """Render `scene` (a name, a file or a Scene) on the machine in the serial ray-tree mode
    (SLOTS=1, SERIAL_TREES=1: one ray tree in flight, so IC sees the golden trace's rays in
    `tracesim.machine_order`) with IC's loads recorded, and compare IC's per-word counters and
    per-reference counts with the trace-driven path's for the same images. `point`: the sweep
    point's label (`MACHINE_POINTS`; "" for the configuration as given). `prepass`: also run
    the pre-pass's coarse render on the machine (same mode) and report its cycles (§4.3: about
    1 % of the main pass)."""
    from netsushisen.pipeline import render  # noqa: PLC0415 (the machine side is heavy to import)

    t0 = time.perf_counter()
    r = render(scene, config, res=res, corners=corners, slots=1, defines=SERIAL, engine=engine,
               record_loads=True)
    t_machine = time.perf_counter() - t0
    setup = r.setup
    out = {"scene": setup.scene.name, "point": point, "cycles": int(r.run.cycles),
           "status": r.run.status, "machine_seconds": t_machine}
    if prepass:
        side = coarse_resolution(res, config.prepass.share)
        coarse = render(setup.scene, config, res=side, corners=corners, slots=1,
                        defines=SERIAL, engine=engine)
        out["prepass"] = {"resolution": side, "cycles": int(coarse.run.cycles),
                          "status": coarse.run.status}
    if r.run.status not in ("halted", "finished"):
        out.update(equal=False, difference=f"the machine stopped: {r.run.status}"
                   + (f" ({r.run.error})" if r.run.error else ""), rho="–", mu="–",
                   ref_equal=False, ref_difference="", seconds=time.perf_counter() - t0)
        return out
    golden = render_golden(setup.scene, setup.config, res=res, corners=corners, keep_trace=True,
                           grid=setup.images.layout.grid)
    pes = setup.config.pes
    diff = ""
    for k, order in enumerate(pe_orders(golden, pes)):  # each PE's IC on its own pixels' rays
        model = TraceMemory.for_images(setup.images)
        for space, address in ordered_stream_chunks(setup.images.layout, golden, order):
            model.replay(space, address)
        d = compare_counters(model.stats(), r.stats["memory"][f"pe{k}.ic"])
        if d and not diff:
            diff = d if pes == 1 else f"pe{k}: {d}"
    machines = [r.stats["memory"][f"pe{k}.ic"] for k in range(pes)]
    res_acc = sum(m["resident"]["accesses"] for m in machines)
    cache = {key: sum(m["cache"][key] for m in machines) for key in ("accesses", "hits")}
    total = res_acc + cache["accesses"]
    streams = [r.engine.recorder.stream(f"pe{k}.ic") for k in range(pes)]
    refs = reference_check(setup, golden, streams)
    out.update(equal=not diff, difference=diff,
               rho=f"{res_acc / total:.4f}" if total else "–",
               mu=f"{cache['hits'] / cache['accesses']:.4f}" if cache["accesses"] else "–",
               loads=total, seconds=time.perf_counter() - t0, **refs)
    return out


def machine_references(layout, space: np.ndarray, address: np.ndarray,
                       hit: np.ndarray) -> dict[str, int]:
    """The paper's per-reference counts of a recorded IC stream in `layout` (the machine's own
    hit flags decide each reference's hit)."""
    prim, _ = load_primitives(layout, space, address)
    return stream_references(prim, hit, layout.record_space == RESIDENT)


def trace_references(setup, golden) -> dict[str, int]:
    """The trace-driven path's per-reference counts for the machine's configuration: the golden
    trace replayed by `SweepStream` (the reference layout, one point: the machine's layout and
    cache), as the paper's sweep counts them."""
    layout = setup.images.layout
    reference = plan_layout(setup.scene, sized_config(setup.config, 1, 0.0, 0.0),
                            setup.prepass.priorities, layout.grid)
    cache = TraceMemory.for_images(setup.images).cache
    point = SweepPoint(layout, cache.geometry.capacity, cache.block_bytes, cache.ways)
    sweep = SweepStream(reference, [point], setup.config.word_bytes, lists_cached=True)
    for stream in golden_chunks(golden, pes=setup.config.pes)(reference)[1]:
        sweep.reset()
        for space, address in stream:
            sweep.replay(space, address)
    return {k: int(point.counts[k]) for k in REFERENCE_KEYS}


REFERENCE_KEYS = ("ref.resident", "ref.cache", "ref.hits")


def reference_check(setup, golden, streams: list[LoadStream]) -> dict:
    """Per-reference counts on the machine (each PE's IC's recorded stream, summed) against the
    trace-driven path's: `ref_machine`, `ref_trace`, `ref_equal`, `ref_difference`, and the
    per-reference ρ and μ the machine's counts give."""
    got = dict.fromkeys(REFERENCE_KEYS, 0)
    for s in streams:
        for k, v in machine_references(setup.images.layout, s.space, s.address, s.hit).items():
            got[k] += v
    want = trace_references(setup, golden)
    diff = "; ".join(f"{k}: trace-driven {want[k]}, machine {got[k]}" for k in REFERENCE_KEYS
                     if got[k] != want[k])
    total = got["ref.resident"] + got["ref.cache"]
    return {"ref_machine": got, "ref_trace": want, "ref_equal": not diff, "ref_difference": diff,
            "ref_rho": f"{got['ref.resident'] / total:.4f}" if total else "–",
            "ref_mu": f"{got['ref.hits'] / got['ref.cache']:.4f}" if got["ref.cache"] else "–"}


# -- the ray-order study ------------------------------------------------------------------------


def machine_chunks(layout, space: np.ndarray, address: np.ndarray, loads_per_chunk: int = 1 << 22):
    """A stream recorded on the machine in `layout`, for `replay_figures`: a function of the
    reference layout giving (number of chunks, the stream there in chunks that end between
    tests — before a list cell that follows a record — so no reference is cut)."""
    prim, _ = load_primitives(layout, space, address)
    starts = np.flatnonzero((prim[1:] < 0) & (prim[:-1] >= 0)) + 1
    want = np.arange(loads_per_chunk, len(prim), loads_per_chunk)
    cuts = np.unique(starts[np.minimum(np.searchsorted(starts, want), len(starts) - 1)]) \
        if len(starts) else np.zeros(0, np.int64)
    bounds = np.concatenate([[0], cuts, [len(prim)]])

    def chunks(reference):
        ref_address = to_reference(layout, reference, space, address)
        return len(bounds) - 1, [((np.full(b - a, GLOBAL, np.int8), ref_address[a:b])
                                  for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist()))]
    return chunks


def ray_order_study(scene, res: int, config: MachineConfig, engine: str, corners: bool = False,
                    options: PaperOptions = PaperOptions(), serial: bool = False) -> dict:
    """Render `scene` on the machine in the kernels' normal mode (the default slots, several
    rays in flight; `serial`: the serial mode instead) with IC's loads recorded, and replay
    that stream through every memory configuration of Figures 4–5 under `options` (the same
    sweep as the trace-driven path's, in the machine's ray order): the figures' rows and the
    run."""
    from netsushisen.pipeline import DEFAULT_SLOTS, render  # noqa: PLC0415

    t0 = time.perf_counter()
    r = render(scene, config, res=res, corners=corners, engine=engine, record_loads=True,
               slots=1 if serial else DEFAULT_SLOTS, defines=SERIAL if serial else None)
    setup = r.setup
    out = {"scene": setup.scene.name, "cycles": int(r.run.cycles), "status": r.run.status,
           "slots": setup.defines.get("SLOTS"), "machine_seconds": time.perf_counter() - t0}
    if r.run.status not in ("halted", "finished"):
        out.update(fig4=[], fig5=[], loads=0, seconds=time.perf_counter() - t0)
        return out
    layout = setup.images.layout
    s = r.engine.recorder.stream("pe0.ic")
    _, fig4, fig5, loads = replay_figures(setup.scene, machine_chunks(layout, s.space, s.address),
                                          setup.prepass, layout.grid, config, options, "",
                                          lambda *a: None)
    out.update(fig4=fig4, fig5=fig5, loads=loads, seconds=time.perf_counter() - t0)
    return out
