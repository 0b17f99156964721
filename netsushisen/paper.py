"""The paper pipeline: everything `netsushisen paper` computes, from scenes to report.md.

Per scene (`analyse_scene`): the golden model renders with its IC reference trace
(`host/golden.py`), the pre-pass (`host/prepass.py`) gives the priorities, and the trace — in the
machine's serial order (`tracesim.machine_order`) and as the IC access protocol's load stream
(`host/ic_access.py`) — is replayed once through every memory configuration of Figures 4 and 5
(`tracesim.SweepStream`): no cycle-accurate emulation. Each configuration is laid out by
`host.databases.plan_layout` with the pre-pass priorities, so resident vs cache and every ICGM
address are the ones the machine would get for that split. The records it fills
(`SceneData`, `PaperOptions`) and everything that reads them (tables, findings, figures,
report.md) are in `reports/paper*.py`.

The Figure 4–5 sweep itself is netsushisen/paper_sweep.py. `--on-machine` (netsushisen/
paper_machine.py) renders each scene on the emulated machine: `machine_check` (serial ray-tree
mode) compares IC's per-word counters and per-reference counts with the trace-driven path's;
`ray_order_study` replays IC's stream recorded in the normal mode through the same sweep (a
candidate reading, RAY_ORDER); with it the trace split among PE_CANDIDATE PEs is a candidate.

`sample_draw` replays Figures 4–5 under one draw of eye-ray jitter, pre-pass sampling and the
order of equal-count records (`paper --draws N`: each point's spread, reports/paper_spread.py).

`run_paper` runs a whole reproduction — every scene's analysis and machine check, each an
independent run on the cluster layer (netsushisen/cluster.py) — and writes the figures, the CSV
files and report.md; the command only parses, calls it and prints.
"""

from __future__ import annotations

import copy
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from netsushisen.cluster import (ResultCache, Task, content_key, kernel_digest,
                                 run_cached, scene_digest, unplain)
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import render as render_golden
from netsushisen.host.grid import build_grid
from netsushisen.host.prepass import run_prepass
from netsushisen.isa.config import MachineConfig, dump_toml
from netsushisen.isa.outputs import write_text
from netsushisen.reports.paper import RAY_ORDER, findings, machine_findings
from netsushisen.reports.paper_data import PaperOptions, Progress, SceneData
from netsushisen.reports.paper_plots import write_csvs, write_figures
from netsushisen.reports.paper_report import report_markdown
from netsushisen.reports.paper_spread import (draw_scenes, point_spread, spread_markdown,
                                              write_spread_csvs)
from netsushisen.paper_machine import (FINDINGS_POINT, MACHINE_POINTS, PE_CANDIDATE,  # noqa: F401
                                       compare_counters, machine_check, pes_config, point_config,
                                       ray_order_study)
from netsushisen.paper_sweep import golden_chunks, replay_figures, sweep_points  # noqa: F401


def scene_counts(scene) -> dict:
    from netsushisen.host.scenes import Kind
    return {"primitives": scene.n_primitives, "polygons": scene.count(Kind.POLYGON),
            "spheres": scene.count(Kind.SPHERE), "cones": scene.count(Kind.CONE),
            "cylinders": scene.count(Kind.CYLINDER), "lights": int(len(scene.light_position)),
            "reflective": scene.reflective, "transparent": scene.transparent}


def trace_experiments(golden) -> dict[str, np.ndarray]:
    """Tests per primitive under variants of the main pass that the reference trace alone can
    answer (no new render): the experiments report.md's explanations cite."""
    from netsushisen.host.golden import EYE, SHADOW

    n = len(golden.references)
    off = golden.trace_ray_offsets
    ray = np.repeat(np.arange(len(off) - 1), np.diff(off))
    prims = golden.trace_prims.astype(np.int64)
    kind = golden.trace_kind[ray]
    depth = golden.trace_depth[ray]
    pairs = np.sort(ray * n + prims)  # np.sort + neighbours: np.unique hashes, slower on 10⁸ keys
    pairs = pairs[np.concatenate([[True], pairs[1:] != pairs[:-1]])] if len(pairs) else pairs
    return {
        "as rendered": golden.references.astype(np.int64),
        "mailboxing (each primitive tested once per ray)": np.bincount(pairs % n, minlength=n),
        "eye rays only": np.bincount(prims[kind == EYE], minlength=n),
        "no shadow rays": np.bincount(prims[kind != SHADOW], minlength=n),
        "ray-tree depth 1 (eye rays and their shadow rays)": np.bincount(prims[depth <= 1], minlength=n),
    }


CANDIDATES = ("sizing records+lists", "lists in the cache", "32-byte blocks", "128-byte blocks",
              f"{PE_CANDIDATE} PEs")
"""The trace-driven readings every "partly" or "differs" of Figures 4–5 is rerun under
(`candidate_readings`; the last, the trace split among PE_CANDIDATE PEs, is checked on the
machine by `--on-machine`), which also adds the machine's normal ray order
(`paper_machine.ray_order_study`). The 32- and 128-byte blocks change the block the paper
states (64 B): the findings show them as sensitivities, never as explanations
(`reports.paper.stated_changes`)."""


def candidate_readings(config: MachineConfig, options: PaperOptions, pes: tuple[int, ...] = ()
                       ) -> dict[str, tuple[MachineConfig, PaperOptions]]:
    """Each candidate explanation as a (config, options) that differs from the run's in one
    choice; a candidate equal to the run's own reading is skipped. `pes`: also the trace split
    among that many PEs, each PE's rays on memories of its own (`golden_chunks`; `--on-machine`
    adds 4, which its machine check holds to the machine)."""
    out = {}
    other_sizing = "records+lists" if options.sizing == "records" else "records"
    other_lists = "cache" if options.lists == "local" else "local"
    out[f"sizing {other_sizing}"] = (config, PaperOptions(other_sizing, options.lists))
    out[f"lists in {'the cache' if other_lists == 'cache' else 'local memory'}"] = (
        config, PaperOptions(options.sizing, other_lists))
    for block in (32, 128):
        if block != config.ic_memory.block_bytes:
            c = copy.deepcopy(config)
            c.ic_memory.block_bytes = block
            out[f"{block}-byte blocks"] = (c, options)
    for n in pes:
        out[f"{n} PEs"] = (pes_config(config, n), options)
    return out


def analyse_scene(spec, res: int, config: MachineConfig, corners: bool = False,
                  progress: Progress | None = None, rays_per_chunk: int = 16384,
                  options: PaperOptions = PaperOptions(), candidates: bool = False,
                  pes: tuple[int, ...] = ()) -> SceneData:
    """Everything the paper's tables and figures need for one scene (`spec`: a name for
    `load_scene`, or a Scene). `candidates`: also replay under every `candidate_readings`
    (same golden trace and pre-pass; `SceneData.readings`; `pes` its PE counts), for the
    findings' experiments."""
    progress = progress or (lambda *a: None)
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    scene = load_scene(spec) if isinstance(spec, str) else spec
    spec = scene.name
    grid = build_grid(scene, config)
    progress(f"{spec}: golden render {res}x{res}", 0, 1)
    golden = render_golden(scene, config, res=res, corners=corners, keep_trace=True, grid=grid)
    seconds["golden"] = time.perf_counter() - t0
    progress(f"{spec}: pre-pass", 0, 1)
    t1 = time.perf_counter()
    pre = run_prepass(scene, config, res=res, corners=corners, grid=grid)
    seconds["prepass"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    sizes, fig4, fig5, loads = replay_figures(scene, golden_chunks(golden, rays_per_chunk), pre,
                                              grid, config, options, "", progress)
    seconds["replay"] = time.perf_counter() - t2
    mc = config.ic_memory
    data = SceneData(name=scene.name, res=res, corners=corners, precision=config.precision,
                     counts=scene_counts(scene), database_bytes=sizes["database"],
                     primitive_database_bytes=sizes["primitive_database_bytes"],
                     rays=dict(golden.rays), references=golden.references.copy(),
                     visible=np.unique(golden.hit_ids[golden.hit_ids >= 0]).astype(np.int64),
                     prepass=pre.summary(), fig4=fig4, fig5=fig5, loads=loads, t_r=mc.t_r,
                     t_g=mc.t_g,
                     block_bytes=mc.block_bytes, seconds=seconds, options=options,
                     experiments=trace_experiments(golden))
    if candidates:
        t3 = time.perf_counter()
        for label, (cfg, opts) in candidate_readings(config, options, pes).items():
            sizes, fig4, fig5, loads = replay_figures(
                scene, golden_chunks(golden, rays_per_chunk, cfg.pes), pre, grid, cfg, opts,
                f" ({label})", progress)
            v = copy.copy(data)
            v.database_bytes = sizes["database"]
            v.primitive_database_bytes = sizes["primitive_database_bytes"]
            v.fig4, v.fig5, v.loads, v.options = fig4, fig5, loads, opts
            v.block_bytes, v.readings, v.experiments = cfg.ic_memory.block_bytes, {}, {}
            data.readings[label] = v
        seconds["candidates"] = time.perf_counter() - t3
    seconds["total"] = time.perf_counter() - t0
    return data



def sample_draw(scene, res: int, config: MachineConfig, corners: bool, options: PaperOptions,
                draw: int, rays_per_chunk: int = 16384) -> dict:
    """Figures 4–5 under one draw of what the paper leaves to chance (`paper --draws`): the main
    pass's eye rays jittered within their pixels, the pre-pass's too, and the primitives with
    equal pre-pass counts in a random order (their records' order in ICGM), all seeded by
    `draw`. Same replay as `analyse_scene`, no candidates."""
    grid = build_grid(scene, config)
    golden = render_golden(scene, config, res=res, corners=corners, keep_trace=True, grid=grid,
                           jitter=draw)
    pre = run_prepass(scene, config, res=res, corners=corners, grid=grid, jitter=10 ** 6 + draw)
    _, fig4, fig5, _ = replay_figures(scene, golden_chunks(golden, rays_per_chunk), pre, grid,
                                      config, options, f" (draw {draw})", lambda *a: None)
    return {"scene": scene.name, "draw": draw, "fig4": fig4, "fig5": fig5}


# -- a whole reproduction -----------------------------------------------------------------------


@dataclass(frozen=True)
class PaperRequest:
    """What `netsushisen paper` was asked for (the command's options, checked)."""

    scenes: list[str]
    res: int
    config: MachineConfig
    out: Path
    options: PaperOptions = PaperOptions()
    corners: bool = False
    on_machine: bool = False
    engine: str = "compiled"
    command: str = "netsushisen paper"
    workers: int | None = None
    fresh: bool = False  # compute every run again (else a run cached in out/runs/ is reused)
    candidates: bool = True  # rerun Figures 4–5 under every `candidate_readings`
    draws: int = 0  # `sample_draw`s per scene: the spread of every Figure 4–5 point


@dataclass
class PaperRun:
    """What a reproduction made: the scenes evaluated (input order), the machine checks, the
    findings in both countings, the files written, and whether Ctrl-C cut it short."""

    scenes: list[SceneData]
    missing: list[str]
    checks: list[dict]
    items: list = field(default_factory=list)
    word_items: list = field(default_factory=list)
    report: Path | None = None
    files: list[Path] = field(default_factory=list)
    seconds: float = 0.0
    interrupted: bool = False
    cached: int = 0  # runs taken from out/runs/
    orders: list[dict] = field(default_factory=list)  # `ray_order_study` per scene (--on-machine)
    draws: list[dict] = field(default_factory=list)  # `sample_draw`s (--draws)

    @property
    def differing(self) -> list[dict]:
        """The machine checks whose per-word counters or per-reference counts differ from the
        trace-driven path's."""
        return [c for c in self.checks if not (c["equal"] and c.get("ref_equal", True))]


def output_folder(out: Path) -> Path:
    """The output folder, made; a file in its place is an error."""
    from netsushisen.options import check_output_dir

    check_output_dir(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def run_paper(request: PaperRequest, scheduler: str | None = None, show: bool = False) -> PaperRun:
    """Every scene's analysis (and with `on_machine` its machine check) as independent runs on
    the cluster (netsushisen/cluster.py: a LocalCluster, or the scheduler at `scheduler`), then
    the figures, the CSV files and report.md in `request.out`, scenes in the order given.
    `show`: progress on standard error (a bar on a terminal, else one line per finished run).
    Ctrl-C stops the work; what finished is written and the run says it was interrupted."""
    r = request
    scenes = [load_scene(s) for s in r.scenes]  # every bad name is reported before any work
    out = output_folder(r.out)
    start = time.perf_counter()
    results: dict[int, SceneData] = {}
    checks: dict[int, dict] = {}
    n = len(scenes)
    # the scenes as read here travel with the tasks: a worker on another machine has no .nff file
    pes = (PE_CANDIDATE,)  # the trace path models a PE split exactly (--on-machine checks it)
    tasks = [Task(analyse_scene,
                  (scene, r.res, r.config, r.corners, None, 16384, r.options, r.candidates, pes),
                  f"{scene.name}-trace") for scene in scenes]
    machine_runs = []  # (scene, label, config, with the pre-pass, lists local)
    if r.on_machine:
        machine_runs = [(scene, "", r.config, True, False) for scene in scenes]
        machine_runs += [(scene, label, point_config(r.config, cache, resident), False, False)
                         for scene in scenes for label, cache, resident in MACHINE_POINTS]
        machine_runs += [(scene, f"default, {PE_CANDIDATE} PEs", pes_config(r.config), False,
                          False) for scene in scenes]
        machine_runs += [(scene, FINDINGS_POINT, r.config, False, True) for scene in scenes]
        tasks += [Task(machine_check, (scene, r.res, cfg, r.engine, r.corners, label, pre, local),
                       f"{scene.name}-machine" + (f" ({label})" if label else ""))
                  for scene, label, cfg, pre, local in machine_runs]
        tasks += [Task(ray_order_study, (scene, r.res, r.config, r.engine, r.corners, r.options),
                       f"{scene.name}-machine (normal ray order)") for scene in scenes]
    n_checks = len(machine_runs)
    n_orders = n if r.on_machine else 0
    tasks += [Task(sample_draw, (scene, r.res, r.config, r.corners, r.options, k),
                   f"{scene.name}-draw {k}") for scene in scenes for k in range(1, r.draws + 1)]
    orders: dict[int, dict] = {}
    draws: dict[int, dict] = {}
    log = _log if show and not sys.stderr.isatty() else (lambda text: None)

    def done(i: int, result) -> None:
        if i < n:
            results[i] = result
            log(f"{result.name}: trace-driven path done in {result.seconds['total']:.0f} s")
        elif i >= n + n_checks + n_orders:
            draws[i] = result
            log(f"{result['scene']}: draw {result['draw']} done")
        elif i >= n + n_checks:
            orders[i - n - n_checks] = result
            log(f"{result['scene']}: machine, normal ray order, {result['cycles']:,} cycles, "
                f"{result['seconds']:.0f} s")
        else:
            checks[i - n] = result
            at = f" ({result['point']})" if result.get("point") else ""
            log(f"{result['scene']}{at}: machine {result['cycles']:,} cycles, counters "
                + ("equal" if result["equal"] else "differ") + f", {result['seconds']:.0f} s")

    config = dump_toml(r.config)
    digests = [(scene.name, scene_digest(scene)) for scene in scenes]
    keys = [content_key("paper scene", *d, r.res, r.corners, config, r.options.sizing,
                        r.options.lists,
                        "candidates" if r.candidates else "", *pes)
            for d in digests]
    if r.on_machine:
        kernels = kernel_digest()
        keys += [content_key("paper machine check", scene.name, scene_digest(scene),
                             r.res, r.corners, dump_toml(cfg), r.engine, kernels, label, pre,
                             *(("lists local",) if local else ()))
                 for scene, label, cfg, pre, local in machine_runs]
        keys += [content_key("paper ray order", scene.name, scene_digest(scene), r.res,
                             r.corners, config, r.engine, kernels, r.options.sizing,
                             r.options.lists) for scene in scenes]
    keys += [content_key("paper draw", scene.name, scene_digest(scene), r.res, r.corners, config,
                         r.options.sizing, r.options.lists, k)
             for scene in scenes for k in range(1, r.draws + 1)]

    def decode(i: int, data):
        return SceneData.from_plain(unplain(data)) if i < n else unplain(data)

    outcome, cached = run_cached(tasks, keys, ResultCache(out / "runs"), done,
                                 decode=decode, fresh=r.fresh,
                                 scheduler=scheduler, workers=r.workers, title="paper", show=show,
                                 status=lambda: f"{len(results)} of {n} scenes"
                                 + (f", {len(checks)} machine checks" if r.on_machine else ""))
    run = PaperRun([results[i] for i in sorted(results)],
                   [s.name for i, s in enumerate(scenes) if i not in results],
                   [checks[i] for i in sorted(checks)],
                   interrupted=outcome.interrupted, cached=cached,
                   orders=[orders[i] for i in sorted(orders)],
                   draws=[draws[i] for i in sorted(draws)])
    _attach_orders(run.scenes, run.orders)
    _write(r, run, out, start, r.workers or min(os.cpu_count() or 1, len(tasks)), scheduler)
    return run


def _attach_orders(scenes: list[SceneData], orders: list[dict]) -> None:
    """Each scene's sweep in the machine's normal ray order as one more candidate reading
    (RAY_ORDER), so the findings' experiments and the "Ray order" section see it."""
    by = {o["scene"]: o for o in orders if o.get("fig5")}
    for d in scenes:
        o = by.get(d.name)
        if o is not None:
            v = copy.copy(d)
            v.fig4, v.fig5, v.loads = o["fig4"], o["fig5"], o["loads"]
            v.readings, v.experiments = {}, {}
            d.readings = dict(d.readings) | {RAY_ORDER: v}


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _write(r: PaperRequest, run: PaperRun, out: Path, start: float, workers: int,
           scheduler: str | None = None) -> None:
    """Figures, CSV files and report.md of what finished."""
    spread = None
    if run.scenes and run.draws:
        per_draw = draw_scenes(run.scenes, run.draws)
        spread = point_spread(run.scenes, per_draw) if per_draw else None
    if run.scenes:
        run.files += write_figures(run.scenes, out, spread)
        run.files += write_csvs(run.scenes, out)
        run.files += write_spread_csvs(run.scenes, run.draws, out)
        run.items = findings(run.scenes, "ref") + machine_findings(run.checks)
        run.word_items = findings(run.scenes, "all")
    run.seconds = time.perf_counter() - start
    machine = None
    if r.on_machine and run.checks:
        mc = r.config.ic_memory
        where = (f"on the Dask cluster at {scheduler}" if scheduler
                 else f"{workers} runs at a time on a LocalCluster")
        machine = {"engine": r.engine, "res": r.res, "workers": where, "seconds": run.seconds,
                   "memory": f"IC cache {mc.cache_bytes} B, resident {mc.resident_bytes} B"
                   if mc.cache_share is None
                   else f"IC cache share {mc.cache_share}, resident share {mc.resident_share}",
                   "scenes": run.checks, "orders": run.orders}
    settings = {"res": r.res, "command": r.command, "max_depth": r.config.render.max_depth,
                "prepass_share": r.config.prepass.share,
                "engine": r.engine, "seconds": run.seconds}
    run.report = out / "report.md"
    names = [p.name for p in run.files]
    write_text(run.report,
               report_markdown(run.scenes, run.items, settings, [run.report.name] + names,
                                           run.missing if run.interrupted else None,
                                           run.word_items, machine,
                                           spread_markdown(run.scenes, run.draws)
                                           if run.scenes and run.draws else None))
