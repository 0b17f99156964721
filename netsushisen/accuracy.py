"""Measure what accuracy costs: per knob, each setting's error against truth and its cost.

It sits above the host and the machine (as `render.py` does) because the axes need both: golden
renders (host/golden.py) and machine runs through the engine interface (via `render.prepare` /
`render.finish`). The rows and their arithmetic are `reports/accuracy.py`; the command is
`netsushisen/commands/accuracy.py`. Four axes:

  precision  truth golden fp64; golden fp32, golden fp16 (numpy float16 throughout), golden fp32
             on bf16-rounded scene values, the machine in fp32 and in fp64
  depth      truth depth 10; depth 1 … 8, golden image and rays, machine cycles
  prepass    truth the full-resolution ranking; pre-pass at the config's share and 8², 16², … sides
  fidelity   truth the full cycle-accurate run; analytic, trace-driven, sampled (SMARTS), the
             reference engine

Times: before any timed row, `warm_up` compiles and runs every engine path once per precision (a
tiny render on the machine), so the one-time numba compile is reported once (`warm_up`'s seconds)
and charged to no row. Each row is then timed over `REPEATS` runs (the CLI's --repeats), the
settings of an axis round-robin (netsushisen/accuracy_runs.py), split into stages — host
preparation, engine load, machine run, read-out, and a sampled row's auxiliary golden render —
each with its median and min–max spread (`reports.accuracy.Timing`). An axis compares the stage
that is the setting's cost (`Timing.basis`: a machine row's machine stage). Identical machine
configurations on different axes are measured once per worker and carry one run key, which the
report checks (`reports.accuracy.identical_runs`).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import sys
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from netsushisen.cluster import ResultCache, Task, content_key, kernel_digest, run_cached, scene_digest
from netsushisen.emulator import stats as run_stats
from netsushisen.host import golden
from netsushisen.host.prepass import coarse_resolution
from netsushisen.host.scenes import Scene
from netsushisen.isa.config import MachineConfig, apply_override, dump_toml
from netsushisen.pipeline import RenderResult, RenderSetup, finish, prepare
from netsushisen.accuracy_runs import (MachineStopped, machine_job, round_robin, run_key, run_parts,
                                       timed_job)
from netsushisen.reports.accuracy import (PER_STRATUM, Row, Timing, fidelity_errors,  # noqa: F401
                                          hit_id_share, ic_regions, image_errors,
                                          strata_bounds, stratified_tiles,
                                          memory_point, ray_errors, regression_estimate, relative,
                                          traced_rays)
from netsushisen.emulator.tracesim import TraceMemory
from netsushisen.host.ic_access import machine_order, ordered_stream_chunks

DEPTHS = tuple(range(1, 9))
TRUTH_DEPTH = 10
TRUTH_CAP = 40
"""The depth axis's truth starts at TRUTH_DEPTH and doubles (10, 20, 40) until two consecutive
truths give the same 8-bit golden image; TRUTH_CAP is the last tried (the row then says the truth
did not converge)."""
TILES = 64
"""Sampling units of the sampled cycle-accurate rows: the eye samples cut into this many runs of
consecutive samples in the order DIS hands them out (so a tile's predecessor is what the full run
did just before it: its warm-up)."""
SAMPLE_SHARES = (0.10, 0.25, 0.50)
"""Shares of the tiles the sampled rows simulate. Each share's n tiles are a stratified random
sample (`stratified_tiles`): the tiles cut into n // 4 strata of consecutive tiles, 4 drawn in each."""
REFERENCE_BUDGET = 2_000_000
"""Cycles the reference engine (≈60 k cycles/s) is given; a longer run is compared over this
prefix with the compiled engine's, and its full time extrapolated (0: no reference row)."""
CALIBRATION_RES = 8
"""The analytic and trace-driven rows' cycles come from one machine run this small."""

REPEATS = 3
"""Runs each timed row is measured over (the median is its seconds, min–max its spread)."""
WARM_RES = 2
"""Side of the tiny renders `warm_up` compiles and warms every path with."""
EMULATED = ("golden fp16", "golden bf16 scene")
"""Settings computed in software (numpy float16; bf16-rounded values): their wall time is the
emulation's, not the precision's cost (their cost is rays traced), so they are timed once."""

Progress = Callable[[str], None]
Emit = Callable[[Row], None]
"""emit(row): a row is final (the cluster layer sends it to the command at once, so Ctrl-C
keeps every finished row, not only whole scene × axis units)."""


def _quiet(_: str) -> None:
    pass


class _Rows(list):
    """The rows of an axis: each appended one is emitted."""

    def __init__(self, emit: Emit | None) -> None:
        super().__init__()
        self.emit = emit or (lambda row: None)

    def append(self, row: Row) -> None:
        super().append(row)
        self.emit(row)


def with_sets(config: MachineConfig, **fields) -> MachineConfig:
    """A copy of `config` with dotted fields set, through `--set`'s own rule (converted to the
    field's type, then validated): with_sets(c, **{"render.max_depth": 3})."""
    c = copy.deepcopy(config)
    for path, value in fields.items():
        apply_override(c, f"{path}={json.dumps(value)}")
    c.validate("accuracy")
    return c


def run_machine(setup: RenderSetup, engine: str, max_cycles: int | None = None
                ) -> tuple[RenderResult, float]:
    """Run a prepared setup; (result, wall seconds of load, run and read-out). A run that does
    not end cleanly raises MachineStopped (a cycle limit within `max_cycles` is expected)."""
    result, parts = run_parts(setup, engine, max_cycles)
    return result, sum(parts.values())


def timed(fn: Callable[[], object], repeats: int = REPEATS) -> tuple[object, Timing]:
    """fn() run `repeats` times: (the last result, the runs' timing)."""
    runs, result = [], None
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        result = fn()
        runs.append(time.perf_counter() - start)
    return result, Timing.of(runs)


ENGINE_STAGES = ("load", "machine", "readout")
"""A simulation's own stages (after host preparation): what the fidelity axis compares, since a
sampled row's many short runs each pay the engine's load and read-out."""
MACHINE_BASIS = ("machine",)
"""What a machine row's axis compares: the cycle loop alone (host preparation, the engine's load
and read-out are the same work at every setting and are shown beside it)."""


def machine_timing(parts: dict[str, list[float]]) -> Timing:
    """A machine row's timing: its stages, the machine stage compared."""
    return Timing.of_parts(parts, MACHINE_BASIS)


def machine_timed(scene: Scene, config: MachineConfig, res: int, engine: str,
                  repeats: int = REPEATS,
                  max_cycles: int | None = None) -> tuple[RenderSetup, RenderResult, Timing]:
    """(setup, result, timing) of one machine setting alone (`repeats` runs, each host
    preparation then the engine: stages host, load, machine, readout); reused when this
    configuration was measured before in this process."""
    key = run_key(scene, config, res, engine)
    (outcome, parts), = round_robin({key: machine_job(scene, config, res, engine, max_cycles)},
                                    repeats, {key: key}).values()
    if isinstance(outcome, BaseException):
        raise outcome
    setup, result = outcome
    return setup, result, machine_timing(parts)


def warm_up(scene: Scene, config: MachineConfig, engine: str,
            precisions: tuple[str, ...] = ("fp32", "fp64"),
            progress: Progress = _quiet) -> dict[str, float]:
    """Compile and warm the engine once per precision before any timed row: a WARM_RES render
    (the compiled engine's numba compile, ~45 s per precision on a cold cache, or its cache
    load). Seconds per precision, reported once and charged to no row. The golden model is numpy
    (nothing to compile), so it needs no warm-up."""
    out = {}
    for precision in dict.fromkeys((*precisions, config.precision)):
        progress(f"warm-up: {engine} engine {precision}")
        start = time.perf_counter()
        run_machine(prepare(scene, with_sets(config, precision=precision), WARM_RES), engine)
        out[f"machine {precision}"] = time.perf_counter() - start
    return out


def machine_point(stats: dict) -> dict[str, float]:
    """Cycles, ρ, μ, t of a machine run's statistics (IC shape data, every PE)."""
    m = stats["config"]["ic_memory"]
    return {"cycles": stats["run"]["cycles"]} | memory_point(ic_regions(stats), m["t_r"],
                                                             m["t_c"], m["t_g"])


# ------------------------------------------------------------------------------------------------
# Precision


def round_bf16(a: np.ndarray) -> np.ndarray:
    """float64 values rounded to bfloat16 (8 significant bits, round to nearest even, via
    float32), returned as float64."""
    f = np.asarray(a, np.float64).astype(np.float32)
    u = f.view(np.uint32).astype(np.uint64)
    u = (u + 0x7FFF + ((u >> 16) & 1)) & 0xFFFF0000
    out = u.astype(np.uint32).view(np.float32).astype(np.float64)
    return np.where(np.isfinite(f), out, f)


def round_scene(scene: Scene, rounder: Callable[[np.ndarray], np.ndarray]) -> Scene:
    """A copy of `scene` with every stored number (vertices, normals, centres, radii, cone ends,
    materials, lights, background, camera) passed through `rounder`."""
    r = lambda a: rounder(np.asarray(a, np.float64))  # noqa: E731
    pg, sp, cn, m, cam = scene.polygons, scene.spheres, scene.cones, scene.materials, scene.camera
    return dataclasses.replace(
        scene, background=r(scene.background), light_position=r(scene.light_position),
        light_color=r(scene.light_color),
        camera=dataclasses.replace(cam, eye=r(cam.eye), at=r(cam.at), up=r(cam.up),
                                   angle=float(r(cam.angle)), hither=float(r(cam.hither))),
        materials=dataclasses.replace(m, color=r(m.color), kd=r(m.kd), ks=r(m.ks), shine=r(m.shine),
                                      t=r(m.t), ior=r(m.ior)),
        polygons=dataclasses.replace(pg, vertices=r(pg.vertices), normals=r(pg.normals)),
        spheres=dataclasses.replace(sp, center=r(sp.center), radius=r(sp.radius)),
        cones=dataclasses.replace(cn, base=r(cn.base), base_radius=r(cn.base_radius),
                                  apex=r(cn.apex), apex_radius=r(cn.apex_radius)))


def _image_row(axis, scene, setting, truth_img, u8, ids, rays, timing: Timing, cost, how,
               values=None) -> Row:
    errors, psnr = image_errors(u8, truth_img.image_u8)
    errors = {"hit_ids": hit_id_share(ids,
                                      truth_img.hit_ids)} | errors | ray_errors(rays, truth_img.rays)
    return Row(axis, scene, setting, False, errors, timing.median, cost, how,
               {"psnr_db": psnr} | (values or {}), timing=timing, emulated=setting in EMULATED)


def _golden_job(scene: Scene, config: MachineConfig, res: int, precision: str | None):
    """A golden render (grid built inside: host preparation) as one job of stage "golden"."""
    def once():
        with np.errstate(all="ignore"):
            return golden.render(scene, config, res=res, precision=precision)
    return timed_job(once, "golden")


def _golden(scene: Scene, config: MachineConfig, res: int, precision: str | None, repeats: int):
    """A golden render timed over `repeats` runs."""
    (g, parts), = round_robin({0: _golden_job(scene, config, res, precision)}, repeats).values()
    return g, Timing.of_parts(parts)


def precision_rows(scene: Scene, res: int, config: MachineConfig, engine: str,
                   progress: Progress = _quiet, repeats: int = REPEATS,
                   emit: Emit | None = None) -> list[Row]:
    """The golden model's precisions and the machine's, their repeats round-robin (the emulated
    ones, whose time is not their cost, once); a golden row's seconds are its render, a machine
    row compares its machine stage (host, load and read-out beside it)."""
    name = scene.name
    variants = {
        "golden fp32": (scene, "fp32",
                        "the golden numpy model in float32 (the machine's precision)"),
        "golden fp16": (scene, "fp16",
         "the golden model run with numpy float16 as its precision: every stored value and every "
         "operation rounded to float16 (shine 100000 overflows to inf; Phong's pow goes through "
         "isa/libm.py in float64 and is rounded into the float16 pixel sums); its seconds are numpy's "
         "software emulation of float16, not what fp16 hardware would take: its cost is the rays "
         "traced"),
        "golden bf16 scene": (round_scene(scene, round_bf16), "fp32",
                              "every number of the scene (vertices, normals, centres, radii, cone "
                              "ends, materials, lights, camera) rounded to bfloat16 (8 significant "
                              "bits, nearest even); the golden model then computes in float32 (an "
                              "emulation of bf16 storage: its seconds are not bf16's cost; its "
                              "cost is the rays traced)"),
    }
    configs = {p: with_sets(config, precision=p) for p in ("fp32", "fp64")}
    jobs = {"golden fp64": _golden_job(scene, config, res, "fp64"),
            "golden fp32": _golden_job(scene, config, res, "fp32")}
    jobs |= {f"machine {p}": machine_job(scene, c, res, engine) for p, c in configs.items()}
    keys = {f"machine {p}": run_key(scene, c, res, engine) for p, c in configs.items()}
    progress(f"{name} precision: {', '.join(jobs)} ({repeats} rounds)")
    measured = round_robin(jobs, repeats, keys)
    for setting in EMULATED:
        progress(f"{name} precision: {setting}")
        sc, precision, _ = variants[setting]
        measured |= round_robin({setting: _golden_job(sc, config, res, precision)}, 1)
    truth, tparts = measured["golden fp64"]
    first = _image_row("precision", name, "golden fp64", truth, truth.image_u8,
                       truth.hit_ids, truth.rays, Timing.of_parts(tparts),
                       {"rays": traced_rays(truth.rays)},
                       "the golden numpy model in float64: the truth")
    first.truth = True
    rows = _Rows(emit)
    rows.append(first)
    for setting, (sc, precision, how) in variants.items():
        g, parts = measured[setting]
        rows.append(_image_row("precision", name, setting, truth, g.image_u8, g.hit_ids, g.rays,
                               Timing.of_parts(parts), {"rays": traced_rays(g.rays)}, how))
    for p in configs:
        (_, r), parts = measured[f"machine {p}"]
        row = _image_row("precision", name, f"machine {p}", truth, r.image_u8, r.hit_ids, r.rays,
                         machine_timing(parts), {"rays": traced_rays(r.rays), "cycles": r.run.cycles},
                         f"the kernels on the {engine} engine in {p}; cost in machine cycles; "
                         "seconds: host preparation + engine load + machine run + read-out, the "
                         "machine run compared")
        row.run = keys[f"machine {p}"]
        rows.append(row)
    return list(rows)


# ------------------------------------------------------------------------------------------------
# Depth


def converged_truth(scene: Scene, config: MachineConfig, res: int, start: int = TRUTH_DEPTH,
                    cap: int = TRUTH_CAP,
                    progress: Progress = _quiet) -> tuple[int, bool, list[int]]:
    """(truth depth, whether it converged, depths tried): golden renders at start, 2·start, …
    (the last at most `cap`) until two consecutive ones give the same 8-bit image; the deeper of
    the equal pair is the truth (depth `cap` and False when none did)."""
    tried, previous, d = [], None, start
    while True:
        progress(f"{scene.name} depth truth: {d}")
        u8 = golden.render(scene, with_sets(config, **{"render.max_depth": d}), res=res).image_u8
        tried.append(d)
        if previous is not None and np.array_equal(u8, previous):
            return d, True, tried
        if d >= cap:
            return d, False, tried
        previous, d = u8, min(2 * d, cap)


def depth_rows(scene: Scene, res: int, config: MachineConfig, engine: str,
               progress: Progress = _quiet, depths=DEPTHS, truth_depth: int = TRUTH_DEPTH,
               repeats: int = REPEATS, cap: int = TRUTH_CAP, emit: Emit | None = None) -> list[Row]:
    """Each depth's golden image against the truth's, and the machine's cycles and time at that
    depth. A row's seconds are the machine's alone (host preparation + run, the cost of running
    at that depth); the golden render's time, which only serves the comparison, is not added."""
    name = scene.name
    truth_depth, converged, tried = converged_truth(scene, config, res, truth_depth, cap, progress)
    order = list(dict.fromkeys((truth_depth, *depths)))
    configs = {d: with_sets(config, **{"render.max_depth": d}) for d in order}
    goldens = {}
    for d in order:
        progress(f"{name} depth {d}: golden")
        start = time.perf_counter()
        goldens[d] = (golden.render(scene, configs[d], res=res), time.perf_counter() - start)
    progress(f"{name} depth: machine at {', '.join(map(str, order))} ({repeats} rounds)")
    keys = {d: run_key(scene, c, res, engine) for d, c in configs.items()}
    rows = _Rows(emit)
    tg = goldens[truth_depth][0]

    def row(d: int, measured) -> None:  # each depth's row sent on the moment it is final
        g, g_seconds = goldens[d]
        outcome, parts = measured
        if isinstance(outcome, MachineStopped):  # the machine cannot hold it: the golden row alone
            r, mt, stopped = None, Timing.of([g_seconds], {"golden": [g_seconds]}), str(outcome)
        else:
            (_, r), mt = outcome, machine_timing(parts)
        errors, psnr = image_errors(g.image_u8, tg.image_u8)
        t = d == truth_depth
        machine = (f"machine cycles and seconds (host preparation, engine load, machine run, "
                   f"read-out; the machine run compared) on the {engine} engine (its rays "
                   + ("equal" if r.rays == g.rays else "DIFFER from")
                   + " the golden model's)" if r is not None else
                   f"no machine cycles: {stopped}; seconds: the golden model's")
        rows.append(Row("depth", name, f"depth {d}", t, {k: 0.0 for k in errors} if t else errors,
                        mt.median, {"rays": traced_rays(g.rays), "cycles": r.run.cycles if r else None},
                        f"golden {g.precision} image and rays at max_depth {d} against depth "
                        f"{truth_depth}; {machine}",
                        {"depth": d, "psnr_db": psnr,
                         "machine_rays": traced_rays(r.rays) if r else None,
                         "golden_seconds": g.seconds, "truth_depth": truth_depth,
                         "truth_converged": converged,
                         "truth_depths_tried": len(tried)}, timing=mt,
                        run=keys[d] if r is not None else ""))

    round_robin({d: machine_job(scene, c, res, engine) for d, c in configs.items()}, repeats, keys,
                done=row)
    return sorted(rows, key=lambda r: r.values["depth"])


# ------------------------------------------------------------------------------------------------
# Pre-pass resolution


def prepass_sides(res: int, share: float) -> list[int]:
    """The config's pre-pass side, then 8, 16, 32, … below res, then res (the truth)."""
    sides = [coarse_resolution(res, share)]
    k = 8
    while k < res:
        sides.append(k)
        k *= 2
    sides.append(res)
    return list(dict.fromkeys(sides))


def prepass_rows(scene: Scene, res: int, config: MachineConfig, engine: str,
                 progress: Progress = _quiet, repeats: int = REPEATS,
                 emit: Emit | None = None) -> list[Row]:
    """A row's seconds are its pre-pass's (the golden coarse render, over `repeats` preparations);
    its time share is that against the main run's engine time. The truth (side = res) is
    measured first, so each row is final when made; they are returned in `prepass_sides` order."""
    name = scene.name
    sides = prepass_sides(res, config.prepass.share)
    rows = _Rows(emit)
    truth = None
    measure_order = [res] + [s for s in sides if s != res]
    configs = {side: with_sets(config, **{"prepass.share": (side / res) ** 2})
               for side in measure_order}

    def job(cfg):
        inner = machine_job(scene, cfg, res, engine)

        def run():
            (setup, r), parts = inner()
            return (setup, r), {"prepass": setup.prepass.seconds} | parts
        return run

    progress(f"{name} pre-pass: {', '.join(f'{s}x{s}' for s in measure_order)} ({repeats} rounds)")
    measured = round_robin({side: job(c) for side, c in configs.items()}, repeats)
    for side in measure_order:
        (setup, r), parts = measured[side]
        if setup.prepass.resolution != side:
            raise AssertionError(f"pre-pass side {setup.prepass.resolution}, wanted {side}")
        # the pre-pass is part of the host stage: its own stage is what this axis compares
        parts = {"prepass": parts["prepass"],
                 "host": [h - p for h, p in zip(parts["host"], parts["prepass"])]} | {
            k: v for k, v in parts.items() if k not in ("prepass", "host")}
        timing = Timing.of_parts(parts, ["prepass"])
        pre, point = setup.prepass, machine_point(r.stats)
        truth = point if truth is None else truth
        t = side == res
        default = side == coarse_resolution(res, config.prepass.share)
        errors = {"rho": abs(point["rho"] - truth["rho"]), "t": relative(point["t"], truth["t"]),
                  "cycles": relative(point["cycles"], truth["cycles"])}
        rows.append(Row("prepass", name,
                        f"pre-pass {side}x{side}" + (" (config share)" if default else ""),
                        t, errors, timing.compared,
                        {"rays": pre.eye_rays, "ray_share": pre.eye_rays / (res * res),
                         "time_share": timing.compared / timing.components["machine"],
                         "cycles": point["cycles"]},
                        f"golden pre-pass at {side}x{side} ranks primitives, the top "
                        f"{pre.resident_count} of {len(pre.priorities)} resident; the main "
                        f"{res}x{res} run on the {engine} engine gives ρ, t (IC shape data) and "
                        f"cycles; error against the {res}x{res} ranking (ρ: absolute); seconds: "
                        "the pre-pass (its share: against the main run's machine stage)",
                        {"rho": point["rho"], "mu": point["mu"], "t": point["t"],
                         "resident_count": pre.resident_count,
                         "main_seconds": timing.components["machine"]}, timing=timing,
                        run=run_key(scene, configs[side], res, engine)))
    return [rows[measure_order.index(side)] for side in sides]


# ------------------------------------------------------------------------------------------------
# Simulation fidelity


def trace_point(setup: RenderSetup, res: int) -> tuple[dict, int, float]:
    """(ρ/μ/t of the golden trace at res x res through the setup's resident + cache model,
    intersection tests, seconds): the trace-driven path of `netsushisen paper`."""
    start = time.perf_counter()
    g = golden.render(setup.scene, setup.config, res=res, corners=setup.corners, keep_trace=True,
                      grid=setup.images.layout.grid)
    model = TraceMemory.for_images(setup.images)
    for space, address in ordered_stream_chunks(setup.images.layout, g, machine_order(g)):
        model.replay(space, address)
    m = setup.config.ic_memory
    point = memory_point(model.stats().get("regions", {}), m.t_r, m.t_c, m.t_g)
    return point, g.total_references, time.perf_counter() - start


def sample_tiles(setup: RenderSetup, engine: str, tiles: list[int], n_tiles: int = TILES,
                 progress: Progress = _quiet, repeats: int = 1, warm_tiles: int | None = None
                 ) -> dict[int, dict]:
    """Per sampled tile: its marginal cycles and IC counters, and the seconds spent (`runs`: each
    of `repeats` repetitions of its two runs, the tiles round-robin; `parts`: their load,
    machine and read-out stages; `seconds`: the runs' median).

    A tile is a run of consecutive eye samples in DIS order. Each is simulated after a warm-up —
    the tile before it — as one run (warm-up + tile) minus a run of the warm-up alone, so the
    cache state, the pipeline's fill and its drain are the warm-up's, not the tile's.

    This marginal is unbiased up to a small residue: over all 64 tiles at 32x32 the marginals sum
    to 1,031,329 cycles on tetra against the full run's 1,030,002 (+0.13 %) and to 5,033,465 on
    balls against 5,019,913 (+0.27 %) (tests/data/tile_cycles.json, tools/tile_cycles.py). Against the exact marginal T(tiles 0..t) − T(tiles 0..t−1)
    (whose sum is the full run) each tile is off by a few hundred cycles of either sign (tetra:
    at most 2,354 on a 15 k-cycle tile; zero on the background tiles): the one-tile warm-up
    leaves a different cache content and round-robin phase than the whole history does. A
    two-tile warm-up does not shrink it (tetra −0.23 %), so one tile is kept. The fill of the
    OS → IC → SC → COL pipeline and the drain of the last ray trees are in both runs and cancel;
    tile 0, which has no warm-up, carries the one fill the full run has."""
    words = setup.host_words.reshape(setup.side * setup.side, -1)
    bounds = np.linspace(0, len(words), n_tiles + 1).round().astype(int)
    if warm_tiles is None:
        warm_tiles = warm_up_tiles(len(words), n_tiles)

    def run(first: int, last: int) -> tuple[dict, dict[str, float]]:
        first = max(first, 0)  # tile 0 has no warm-up
        if first > last:
            return {"cycles": 0, "res": 0, "acc": 0, "hits": 0}, {}
        sub = dataclasses.replace(setup, host_words=words[bounds[first]:bounds[last + 1]].ravel())
        r, parts = run_parts(sub, engine)
        reg = ic_regions(r.stats)
        return {"cycles": r.run.cycles,
                "res": reg.get("resident.shape_data", {}).get("accesses", 0),
                "acc": reg.get("global.shape_data", {}).get("accesses", 0),
                "hits": reg.get("global.shape_data", {}).get("hits", 0)}, parts

    def tile_job(tile: int):
        def job():
            both, p1 = run(tile - warm_tiles, tile)
            warm, p2 = run(tile - warm_tiles, tile - 1)
            stages = {k: p1.get(k, 0.0) + p2.get(k, 0.0) for k in ("load", "machine", "readout")}
            return (both, warm), stages
        return job

    progress(f"{setup.scene.name} fidelity: {len(tiles)} sampled tiles ({repeats} rounds)")
    measured = round_robin({t: tile_job(t) for t in tiles}, repeats)
    out = {}
    for tile in tiles:
        (both, warm), parts = measured[tile]
        runs = [sum(v) for v in zip(*parts.values())]
        out[tile] = {k: both[k] - warm[k]
                     for k in both} | {"seconds": float(np.median(runs)), "runs": runs,
                                       "parts": parts,
                                       "simulated": both["cycles"] + warm["cycles"]}
    return out


WARM_SAMPLES = 16
"""Eye samples a sampled tile's warm-up covers at least (`warm_up_tiles`). A warm-up too short
leaves the caches colder and the pipeline emptier than the full run has them, and every tile's
marginal comes out high: tetra at 16x16 (4 samples a tile), all 64 tiles sum to +5.5 % of the
full run with a 1-tile (4-sample) warm-up, +2.9 % with 8 samples, +0.31 % with 16, −0.18 % with
32 (the classic kernels); with today's kernels and 16 samples: tetra 16² +0.00 %, 32² +0.13 %,
balls 16² +0.43 %, 32² +0.27 % (tools/tile_cycles.py prints these)."""


def warm_up_tiles(samples: int, n_tiles: int = TILES) -> int:
    """Tiles of warm-up before a sampled tile: at least WARM_SAMPLES eye samples, at least one."""
    per_tile = samples / n_tiles
    return max(1, int(np.ceil(WARM_SAMPLES / per_tile))) if per_tile > 0 else 1


def tile_auxiliary(setup: RenderSetup, n_tiles: int = TILES) -> dict[str, list[int]]:
    """Per tile (as `sample_tiles` cuts them): the golden model's rays and intersection tests,
    known for every tile from one golden render, no machine run."""
    g = golden.render(setup.scene, setup.config, res=setup.res, corners=setup.corners,
                      keep_trace=True, grid=setup.images.layout.grid)
    n = setup.side * setup.side
    bounds = np.linspace(0, n, n_tiles + 1).round().astype(int)
    tests = np.bincount(g.trace_pixel, weights=np.diff(g.trace_ray_offsets), minlength=n)
    rays = np.bincount(g.trace_pixel, minlength=n)
    cut = lambda a: [int(a[lo:hi].sum()) for lo, hi in zip(bounds, bounds[1:])]  # noqa: E731
    return {"tests": cut(tests), "rays": cut(rays)}


def sampled_row(scene: str, share: float, tiles: dict[int, dict], chosen: list[int], truth: dict,
                mem: dict, n_tiles: int = TILES, engine: str = "compiled",
                strata: list[int] | None = None, host: list[float] | None = None,
                aux: list[float] | None = None, aux_seconds: list[float] | None = None) -> Row:
    """The SMARTS row of `chosen` tiles (their samples in `tiles`), drawn in the strata whose
    bounds are `strata` (None: one stratum, a simple random sample). Its time per repetition is
    the host preparation (`host`, one per repetition), every chosen tile's two runs (load,
    machine, read-out) and the auxiliary golden render the estimator needs (`aux_seconds`, per
    repetition); it compares all but the host preparation, which the full run shares."""
    bounds = strata or [0, n_tiles]
    samples = [tiles[t] for t in chosen]
    x = np.ones(n_tiles) if aux is None else np.asarray(aux, np.float64)
    groups = [([tiles[t]["cycles"] for t in chosen if lo <= t < hi],
               [x[t] for t in chosen if lo <= t < hi],
               x[lo:hi]) for lo, hi in zip(bounds, bounds[1:])]
    est, low, high = regression_estimate([g for g in groups if g[0]])
    res = sum(s["res"] for s in samples)
    acc = sum(s["acc"] for s in samples)
    hits = sum(s["hits"] for s in samples)
    point = memory_point({"resident.shape_data": {"accesses": res},
                          "global.shape_data": {"accesses": acc, "hits": hits}},
                         mem["t_r"], mem["t_c"], mem["t_g"])
    values = {"cycles": est, "rho": point["rho"], "mu": point["mu"], "t": point["t"],
              "tiles": len(chosen), "strata": len(groups),
              "covers": bool(low <= truth["cycles"] <= high)}
    reps = min([len(s.get("runs", [s["seconds"]])) for s in samples] + [len(host or [0.0]) or 1])

    def stage(s: dict, k: str, i: int) -> float:
        if "parts" in s:
            return s["parts"][k][i]
        return s.get("runs", [s["seconds"]])[i] if k == "machine" else 0.0

    parts = {"host": (host or [0.0] * reps)[:reps]} | {
        k: [sum(stage(s, k, i) for s in samples) for i in range(reps)] for k in ENGINE_STAGES}
    if aux_seconds:
        parts["auxiliary"] = [aux_seconds[i % len(aux_seconds)] for i in range(reps)]
    timing = Timing.of_parts(parts, [k for k in (*ENGINE_STAGES, "auxiliary") if k in parts])
    return Row("fidelity", scene, f"(c) sampled {100 * share:g} %", False,
               fidelity_errors(values, truth),
               timing.median, {"cycles": sum(s["simulated"] for s in samples)},
               f"{len(chosen)} of {n_tiles} tiles (runs of consecutive eye samples in DIS order, "
               f"chosen at random, stratified: {len(groups)} strata of consecutive tiles) each "
               f"simulated on the {engine} engine after a warm-up of at least {WARM_SAMPLES} eye "
               "samples (warm-up + tile minus warm-up alone); total cycles by the stratified "
               "regression estimator on the golden model's intersection tests per tile, a 95 % "
               "interval from the stratified jackknife with Satterthwaite's degrees of freedom and "
               "the warm-up allowance in quadrature; ρ, μ, t from the tiles' IC counters; cost: "
               "cycles simulated, warm-ups included; seconds: host preparation + the tiles' runs (load, "
               "machine, read-out) + the auxiliary golden render, all but the host compared",
               values, low, high, timing=timing)


def fidelity_rows(scene: Scene, res: int, config: MachineConfig, engine: str,
                  progress: Progress = _quiet, shares=SAMPLE_SHARES, n_tiles: int = TILES,
                  seed: int = 1992, reference_budget: int = REFERENCE_BUDGET,
                  repeats: int = REPEATS, emit: Emit | None = None) -> list[Row]:
    """Every row's seconds include host preparation (`prepare`, or the golden renders the model
    rows need) and are the median of `repeats` runs; the reference engine's row is one run."""
    name = scene.name
    progress(f"{name} fidelity: full cycle-accurate and its {CALIBRATION_RES}x{CALIBRATION_RES} "
             f"calibration ({repeats} rounds)")
    cal_res = min(CALIBRATION_RES, res)
    key = run_key(scene, config, res, engine)
    measured = round_robin({"full": machine_job(scene, config, res, engine),
                            "calibration": machine_job(scene, config, cal_res, engine)},
                           repeats, {"full": key})
    (setup, full), fparts = measured["full"]
    ft = Timing.of_parts(fparts, ENGINE_STAGES)
    (cal_setup, cal), cparts = measured["calibration"]
    ct = Timing.of_parts(cparts)
    full_seconds = ft.compared
    truth = machine_point(full.stats)
    mem = dataclasses.asdict(config.ic_memory)
    rows = _Rows(emit)
    rows.append(Row("fidelity", name, f"(d) full ({engine})", True,
                    {k: 0.0 for k in ("cycles", "rho", "mu", "t")}, ft.median,
                    {"cycles": truth["cycles"]},
                    f"the whole render on the {engine} engine: the truth (seconds: host "
                    "preparation + engine load + machine run + read-out; all but the host "
                    "compared)",
                    dict(truth), timing=ft, run=key))
    # the analytic and trace-driven rows take their cycles from one small machine run
    progress(f"{name} fidelity: analytic and trace-driven")
    cal_refs = golden.render(scene, config, res=cal_res,
                             grid=cal_setup.images.layout.grid).total_references
    coarse = setup.prepass.resolution
    models = round_robin({"a": timed_job(lambda: trace_point(setup, coarse), "model"),
                          "b": timed_job(lambda: trace_point(setup, res), "model")}, repeats)
    pre = fparts["host"]  # the pre-pass and grid the models need: the full run's preparation

    def model_timing(parts):
        n = min(len(parts["model"]), len(ct.runs), len(pre))
        return Timing.of_parts({"host": pre[:n], "model": parts["model"][:n],
                                "calibration": ct.runs[:n]}, ["model", "calibration"])
    (a_point, _, _), a_parts = models["a"]
    a_timing = model_timing(a_parts)
    a = {"cycles": cal.run.cycles * (res / cal_res) ** 2, "rho": a_point["rho"],
         "mu": a_point["mu"], "t": a_point["t_model"]}
    rows.append(Row("fidelity", name, "(a) analytic", False, fidelity_errors(a, truth),
                    a_timing.median, {"cycles": cal.run.cycles},
                    f"ρ and μ from the {coarse}x{coarse} pre-pass render's trace through the "
                    "resident + cache model, t from the paper's t_r·{ρ + (1 − ρ)(8 − 6μ)}; cycles "
                    f"= a {cal_res}x{cal_res} machine run × (pixels ratio)", a, timing=a_timing))
    (b_point, refs, _), b_parts = models["b"]
    b_timing = model_timing(b_parts)
    b = {"cycles": cal.run.cycles * refs / max(cal_refs, 1), "rho": b_point["rho"],
         "mu": b_point["mu"], "t": b_point["t"]}
    rows.append(Row("fidelity", name, "(b) trace-driven", False, fidelity_errors(b, truth),
                    b_timing.median, {"cycles": cal.run.cycles, "references": refs},
                    f"the golden {res}x{res} IC reference trace, in the machine's serial ray order, "
                    "through the resident + cache model (emulator/tracesim.py); cycles = "
                    f"a {cal_res}x{cal_res} machine run × (intersection tests ratio)", b, timing=b_timing))
    # sampled: a stratified random sample of tiles per share (`stratified_tiles`), each scene
    # its own draw (the seed and the scene's name), the tiles shared by shares simulated once
    n_tiles = min(n_tiles, setup.side * setup.side)
    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    counts = [min(n_tiles, max(2, int(round(s * n_tiles)))) for s in shares]
    chosen = [stratified_tiles(rng, n_tiles, n) for n in counts]
    samples = sample_tiles(setup, engine, sorted(set().union(*chosen)), n_tiles, progress, repeats)
    # the estimator's auxiliary (every tile's golden intersection tests): one golden render,
    # which each sampled row needs and is charged in full
    progress(f"{name} fidelity: the sampled rows' auxiliary golden render ({repeats} runs)")
    (aux, aux_parts), = round_robin({0: timed_job(lambda: tile_auxiliary(setup, n_tiles),
                                                  "auxiliary")}, repeats).values()
    for share, n, tiles in zip(shares, counts, chosen):
        rows.append(sampled_row(name, share, samples, tiles, truth, mem, n_tiles, engine,
                                strata_bounds(n_tiles, n), pre, aux["tests"],
                                aux_parts["auxiliary"]))
    if engine != "reference" and reference_budget > 0:
        rows.append(reference_row(setup, full, full_seconds, truth, engine,
                                  reference_budget, progress, ft.components["host"]))
    return list(rows)


def reference_row(setup: RenderSetup, full: RenderResult, full_seconds: float,
                  truth: dict, engine: str,
                  budget: int, progress: Progress = _quiet, host_seconds: float = 0.0) -> Row:
    """(e): the reference engine, whole when the run fits `budget` cycles, else over the first
    `budget` cycles against the compiled engine stopped at the same cycle (its time extrapolated)."""
    name = setup.scene.name
    whole = truth["cycles"] <= budget
    progress(f"{name} fidelity: reference engine"
             + ("" if whole else f" (first {budget:,} cycles)"))
    ref, parts = run_parts(setup, "reference", None if whole else budget)
    seconds = sum(parts.values())
    if whole:
        other = full
    else:
        other, _ = run_machine(setup, engine, budget)
    same = (run_stats.dumps(run_stats.without_engine(ref.stats))
            == run_stats.dumps(run_stats.without_engine(other.stats)))
    point = machine_point(ref.stats)
    errors = fidelity_errors(point, machine_point(other.stats)) | {"differs": 0.0 if same else 1.0}
    estimate = host_seconds + (seconds if whole else seconds * truth["cycles"] / budget)
    return Row("fidelity", name, "(e) reference engine", False, errors, host_seconds + seconds,
               {"cycles": ref.run.cycles},
               ("the whole render" if whole else f"the first {budget:,} cycles (its full time "
                "extrapolated)") + " on the reference engine (plain Python), its statistics "
                                   f"compared byte for byte with the {engine} "
                                   "engine's" + ("" if whole else " over the same cycles")
               + (": identical" if same else ": THEY DIFFER") + "; seconds: host preparation (the "
               "full row's median) + one run of the engine (not repeated: it is ~100× slower)",
               point | {"identical": same, "seconds_full": estimate,
                        "speedup": (estimate - host_seconds) / full_seconds
                        if full_seconds else None},
               timing=Timing.of_parts({"host": [host_seconds]} | {k: [v] for k, v in parts.items()},
                                      ENGINE_STAGES))


AXIS_RUNNERS = {"precision": precision_rows, "depth": depth_rows, "prepass": prepass_rows,
                "fidelity": fidelity_rows}


# ------------------------------------------------------------------------------------------------
# The study: every scene × axis as one run on the cluster layer


_WARM: set[tuple[str, str]] = set()
"""(engine, precision) pairs this worker process has warmed (`axis_unit`)."""


def precisions_of(axes: list[str], config: MachineConfig) -> tuple[str, ...]:
    """The precisions the machine runs in on these axes: both on the precision axis, else the
    configuration's."""
    return ("fp32", "fp64") if "precision" in axes else (config.precision,)


def axis_unit(scene: Scene, axis: str, res: int, config: MachineConfig, engine: str, seed: int,
              repeats: int, emit: Emit | None = None) -> list[Row]:
    """One scene × axis, in a worker: the engine is warmed once per process first (its numba
    cache load and first run are charged to no row), then each row is emitted as it is final."""
    for precision in precisions_of([axis], config):
        if (engine, precision) not in _WARM:
            warm_up(scene, config, engine, (precision,))
            _WARM.add((engine, precision))
    extra = {"seed": seed} if axis == "fidelity" else {}
    return AXIS_RUNNERS[axis](scene, res, config, engine, repeats=repeats, emit=emit, **extra)


@dataclass
class Study:
    """The rows per axis (scenes in the order given, each unit's rows in its runner's order;
    an interrupted unit keeps the rows it had finished), the warm-up seconds, whether Ctrl-C
    stopped it."""

    rows: dict[str, list[Row]]
    warm: dict[str, float]
    interrupted: bool
    where: str = ""
    cached: int = 0  # scene × axis units taken from the cache


def _rows(i: int, data: list[dict]) -> list[Row]:
    """A cached unit's rows back from their plain form (`cluster.plain`)."""
    return [Row(**(d | {"timing": Timing(**d["timing"]) if d["timing"] else None})) for d in data]


def run_study(scenes: list[Scene], axes: list[str], res: int, config: MachineConfig, engine: str,
              seed: int = 1992, repeats: int = REPEATS, scheduler: str | None = None,
              workers: int | None = None, show: bool = False, cache_dir=None,
              fresh: bool = False) -> Study:
    """Warm up here (the compile lands in the disk cache the workers load), then every scene ×
    axis as one task on the cluster layer (netsushisen/cluster.py); rows arrive as they finish.
    A unit whose rows are in `cache_dir` (a finished unit of an earlier run with the same
    inputs, `repeats` and `seed` included) is not run again unless `fresh`.
    `show`: a progress bar on a terminal, else one line per finished row on standard error."""
    start = time.perf_counter()
    log = (lambda text: print(text, file=sys.stderr,
                              flush=True)) if show and not sys.stderr.isatty() \
        else (lambda text: None)
    try:
        warm = warm_up(scenes[0], config, engine, precisions_of(axes, config), progress=log)
    except KeyboardInterrupt:
        return Study({}, {}, True)
    units = [(si, axis) for si in range(len(scenes)) for axis in axes]
    finished: dict[int, list[Row]] = {}
    partial: dict[int, list[Row]] = {}

    def item(i: int, row: Row) -> None:
        partial.setdefault(i, []).append(row)
        log(f"{row.scene} {row.axis}: {row.setting} done at {time.perf_counter() - start:.0f} s")

    def done(i: int, rows: list[Row]) -> None:
        finished[i] = rows
        si, axis = units[i]
        log(f"{scenes[si].name} {axis}: done at {time.perf_counter() - start:.0f} s")

    tasks = [Task(axis_unit, (scenes[si], axis, res, config, engine, seed, repeats),
                  f"{scenes[si].name}-{axis}", emits=True) for si, axis in units]
    inputs = (res, dump_toml(config), engine, seed, repeats, kernel_digest())
    digests = [scene_digest(scene) for scene in scenes]
    keys = [content_key("accuracy unit", scenes[si].name, digests[si], axis, *inputs)
            for si, axis in units]
    cache = ResultCache(Path(cache_dir)) if cache_dir is not None else None
    outcome, cached = run_cached(tasks, keys, cache, done, decode=_rows, fresh=fresh,
                                 scheduler=scheduler,
                                 workers=workers, title="accuracy", show=show, on_item=item,
                                 status=lambda: f"{sum(map(len, partial.values()))} rows")
    rows: dict[str, list[Row]] = {a: [] for a in axes}
    for i, (si, axis) in enumerate(units):
        rows[axis] += finished.get(i, partial.get(i, []))
    n = workers or min(os.cpu_count() or 1, len(tasks))
    where = f"the Dask cluster at {scheduler}" if scheduler else f"a LocalCluster of {n} worker{'s' * (n != 1)}"
    return Study({a: r for a, r in rows.items() if r}, warm, outcome.interrupted, where, cached)
