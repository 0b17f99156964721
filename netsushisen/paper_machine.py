"""`paper --on-machine`: the machine behind the paper's findings.

`machine_check` renders a scene on the emulated machine in the serial ray-tree mode (one ray
tree in flight: IC visits the golden trace's rays in `tracesim.machine_order`) with IC's loads
recorded (`Engine.record_loads`), and compares with the trace-driven path for the same images:
IC's per-word counters (`compare_counters`: accesses by memory and by region, loads per
primitive) and the per-reference counts the findings use (`reference_check`: the paper's
references, each hit decided by the machine's own per-load hit flags, against `SweepStream`'s
for the same configuration — one rule, `tracesim.fetches` / `tracesim.reference_hits`).
With `lists_local` it does so in the reading the findings use (`--sizing records --lists
local`): the lists in IC's local memory (the kernels' LISTS_LOCAL build), the memories sized
against the shape records (`findings_config`), the trace side `SweepStream(lists_cached=False)`.

`ray_order_study` renders in the kernels' normal mode (several rays in flight, PAPER_ORDER), maps IC's
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
from netsushisen.emulator.loads import LOCAL, LoadStream
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import IC_LISTS_BASE
from netsushisen.host.records import record_sizes
from netsushisen.host.shapes import build_shape_data
from netsushisen.host.ic_access import (load_primitives, ordered_stream_chunks, pe_orders,
                                        to_reference)
from netsushisen.host.prepass import coarse_resolution
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.regions import GLOBAL
from netsushisen.paper_sweep import golden_chunks, replay_figures, sized_config
from netsushisen.reports.paper_data import (FINDINGS_LOCAL_WORDS, FINDINGS_POINT,  # noqa: F401
                                            PaperOptions)

SERIAL = {"SERIAL_TREES": 1}
"""The kernels' serial ray-tree mode (with one slot)."""

PAPER_ORDER = {"PRELOAD": 0, "LAZY_WORDS": 0}
"""The kernels' normal mode with the paper's load order, as the serial mode assembles it: every
test reads its record whole, in address order, and no list cell ahead (kernels/ic.s;
docs/kernels.md, "Reading ahead, reading less")."""

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


def findings_config(scene, config: MachineConfig) -> MachineConfig:
    """`config` as the findings read it (`--sizing records --lists local`): IC's cache and
    resident shares resolved against the shape records alone (`sized_config`; sizes given in
    bytes stay), IC's local memory at least FINDINGS_LOCAL_WORDS to hold the lists."""
    mc = config.ic_memory
    words = int(record_sizes(build_shape_data(scene, config.precision)).sum())
    c = sized_config(config, words, mc.resident_share, mc.cache_share)
    c.ic.local_words = max(c.ic.local_words, FINDINGS_LOCAL_WORDS)
    return c


def local_lists(s: LoadStream) -> LoadStream:
    """A stream recorded with the lists local, as the sweep sees it: IC's list-cell loads
    (local, from IC_LISTS_BASE) at their ICGM addresses, still in space LOCAL; its other local
    loads (slot table, fan buffers: no database) dropped."""
    keep = (s.space != LOCAL) | (s.address >= IC_LISTS_BASE)
    address = np.where(s.space == LOCAL, s.address - IC_LISTS_BASE, s.address)
    return LoadStream(s.space[keep], address[keep], s.hit[keep])


def machine_check(scene, res: int, config, engine: str, corners: bool = False, point: str = "",
                  prepass: bool = False, lists_local: bool = False) -> dict:
    """Render `scene` (a name, a file or a Scene) on the machine in the serial ray-tree mode
    (SLOTS=1, SERIAL_TREES=1: one ray tree in flight, so IC sees the golden trace's rays in
    `tracesim.machine_order`) with IC's loads recorded, and compare IC's per-word counters and
    per-reference counts with the trace-driven path's for the same images. `point`: the sweep
    point's label (`MACHINE_POINTS`; "" for the configuration as given). `prepass`: also run
    the pre-pass's coarse render on the machine (same mode) and report its cycles (§4.3: about
    1 % of the main pass). `lists_local`: in the findings' reading (`findings_config`; IC reads
    the lists from local memory, the trace side counts their loads as `local.primitive_list`)."""
    from netsushisen.pipeline import render  # noqa: PLC0415 (the machine side is heavy to import)

    t0 = time.perf_counter()
    if lists_local:
        scene = load_scene(scene) if isinstance(scene, str) else scene
        config = findings_config(scene, config)
    r = render(scene, config, res=res, corners=corners, slots=1, defines=SERIAL, engine=engine,
               record_loads=True, lists_local=lists_local)
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
    layout = setup.images.layout
    lists = 0
    for k, order in enumerate(pe_orders(golden, pes)):  # each PE's IC on its own pixels' rays
        model = TraceMemory.for_images(setup.images)
        local = 0
        for space, address in ordered_stream_chunks(layout, golden, order):
            if lists_local:  # list cells read from local memory: counted, never cached
                cell = (space == GLOBAL) & (address < layout.list_words)
                local += int(np.count_nonzero(cell))
                space, address = space[~cell], address[~cell]
            model.replay(space, address)
        want = model.stats()
        if local:
            want.setdefault("regions", {})["local.primitive_list"] = {"accesses": local}
        lists += local
        d = compare_counters(want, r.stats["memory"][f"pe{k}.ic"])
        if d and not diff:
            diff = d if pes == 1 else f"pe{k}: {d}"
    machines = [r.stats["memory"][f"pe{k}.ic"] for k in range(pes)]
    res_acc = sum(m["resident"]["accesses"] for m in machines) + lists  # local lists: at t_r
    cache = {key: sum(m["cache"][key] for m in machines) for key in ("accesses", "hits")}
    total = res_acc + cache["accesses"]
    streams = [r.engine.recorder.stream(f"pe{k}.ic") for k in range(pes)]
    if lists_local:
        streams = [local_lists(s) for s in streams]
    refs = reference_check(setup, golden, streams, lists_cached=not lists_local)
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


def trace_references(setup, golden, lists_cached: bool = True) -> dict[str, int]:
    """The trace-driven path's per-reference counts for the machine's configuration: the golden
    trace replayed by `SweepStream` (the reference layout, one point: the machine's layout and
    cache), as the paper's sweep counts them; `lists_cached=False`: the lists local (their loads
    `local.primitive_list`, outside the cache)."""
    layout = setup.images.layout
    reference = plan_layout(setup.scene, sized_config(setup.config, 1, 0.0, 0.0),
                            setup.prepass.priorities, layout.grid)
    cache = TraceMemory.for_images(setup.images).cache
    point = SweepPoint(layout, cache.geometry.capacity, cache.block_bytes, cache.ways)
    sweep = SweepStream(reference, [point], setup.config.word_bytes, lists_cached=lists_cached)
    for stream in golden_chunks(golden, pes=setup.config.pes)(reference)[1]:
        sweep.reset()
        for space, address in stream:
            sweep.replay(space, address)
    return {k: int(point.counts[k]) for k in (*REFERENCE_KEYS, LOCAL_LISTS)}


REFERENCE_KEYS = ("ref.resident", "ref.cache", "ref.hits")
LOCAL_LISTS = "local.primitive_list"


def reference_check(setup, golden, streams: list[LoadStream], lists_cached: bool = True) -> dict:
    """Per-reference counts on the machine (each PE's IC's recorded stream, summed) against the
    trace-driven path's: `ref_machine`, `ref_trace`, `ref_equal`, `ref_difference`, and the
    per-reference ρ and μ the machine's counts give. `lists_cached=False`: the findings'
    reading — the streams' list cells are local loads (`local_lists`), compared also with the
    sweep's `local.primitive_list`."""
    keys = REFERENCE_KEYS if lists_cached else (*REFERENCE_KEYS, LOCAL_LISTS)
    got = dict.fromkeys(keys, 0)
    for s in streams:
        local = s.space == LOCAL
        space = np.where(local, GLOBAL, s.space)
        for k, v in machine_references(setup.images.layout, space, s.address, s.hit).items():
            got[k] += v
        if not lists_cached:
            got[LOCAL_LISTS] += int(np.count_nonzero(local))
    want = trace_references(setup, golden, lists_cached)
    diff = "; ".join(f"{k}: trace-driven {want[k]}, machine {got[k]}" for k in keys
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
    rays in flight, PAPER_ORDER: so only the ray order differs; `serial`: the serial mode
    instead) with IC's loads recorded, and replay
    that stream through every memory configuration of Figures 4–5 under `options` (the same
    sweep as the trace-driven path's, in the machine's ray order): the figures' rows and the
    run."""
    from netsushisen.pipeline import DEFAULT_SLOTS, render  # noqa: PLC0415

    t0 = time.perf_counter()
    r = render(scene, config, res=res, corners=corners, engine=engine, record_loads=True,
               slots=1 if serial else DEFAULT_SLOTS, defines=SERIAL if serial else PAPER_ORDER)
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
