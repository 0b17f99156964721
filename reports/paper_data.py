"""The numbers behind the paper's Table 1, Table 2 and Figures 3–5, from the fastest exact path.

Per scene: the golden model renders with its IC reference trace (`host/golden.py`), the
pre-pass (`host/prepass.py`) gives the priorities, and the trace — in the machine's serial
order (`tracesim.machine_order`) and as the IC access protocol's load stream
(`host/ic_access.py`) — is replayed once through every memory configuration of the sweeps
(`tracesim.SweepStream`): no cycle-accurate emulation. Each configuration is laid out by
`host.databases.plan_layout` with the pre-pass priorities, so resident vs cache and every ICGM
address are the ones the machine would get for that split.

Figure 4: cache-only local memory (resident 0) of 10 %, 20 %, ..., 100 % of the primitive
database (primitive_list + shape_data). Figure 5: local memory of 10 %, 30 %, 50 % of it, split
resident : cache from 0 : 100 to 100 : 0 in steps of 10 %.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import plan_layout
from netsushisen.host.golden import render
from netsushisen.host.grid import build_grid
from netsushisen.host.prepass import run_prepass
from netsushisen.isa.config import MachineConfig
from netsushisen.reports.tracesim import SweepPoint, SweepStream, machine_order, ordered_stream_chunks

PAPER_SCENES = ("tetra", "balls", "mount", "rings")
CACHE_SHARES = tuple(round(0.1 * i, 2) for i in range(1, 11))  # Figure 4
LOCAL_SHARES = (0.1, 0.3, 0.5)  # Figure 5
RESIDENT_SPLITS = tuple(round(0.1 * i, 2) for i in range(0, 11))  # resident share of local memory

Progress = Callable[[str, float, float], None]
"""progress(description, done, total)"""


@dataclass
class SceneData:
    name: str
    res: int
    corners: bool
    precision: str
    counts: dict  # Table 1 columns
    database_bytes: dict[str, int]
    primitive_database_bytes: int
    rays: dict[str, int]
    references: np.ndarray  # (N,) tests per primitive, every ray kind (main pass)
    visible: np.ndarray  # ids of the primitives some eye ray hits
    prepass: dict
    fig4: list[dict] = field(default_factory=list)  # per cache share
    fig5: list[dict] = field(default_factory=list)  # per (local share, resident split)
    loads: int = 0
    t_r: int = 1
    block_bytes: int = 64
    seconds: dict[str, float] = field(default_factory=dict)

    # Table 2 ------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.references)

    @property
    def visible_share(self) -> float:
        return len(self.visible) / self.n if self.n else 0.0

    @property
    def visible_reference_share(self) -> float:
        total = int(self.references.sum())
        return float(self.references[self.visible].sum()) / total if total else 0.0

    # Figure 3 -----------------------------------------------------------------------------
    def locality(self) -> tuple[np.ndarray, np.ndarray]:
        """(f(k), C(k)) for k = 0..N: primitives sorted by descending reference count."""
        refs = np.sort(self.references)[::-1].astype(np.float64)
        total = refs.sum()
        c = np.concatenate([[0.0], np.cumsum(refs) / total]) if total else np.zeros(self.n + 1)
        return np.arange(self.n + 1) / max(self.n, 1), c

    def c_at(self, f: float) -> float:
        """C at f(k) = f (k = round(f·N))."""
        fk, c = self.locality()
        return float(c[int(round(f * self.n))])

    @property
    def unreferenced_share(self) -> float:
        return float(np.count_nonzero(self.references == 0)) / self.n if self.n else 0.0


def scene_counts(scene) -> dict:
    from netsushisen.host.scenes import Kind
    return {"primitives": scene.n_primitives, "polygons": scene.count(Kind.POLYGON),
            "spheres": scene.count(Kind.SPHERE), "cones": scene.count(Kind.CONE),
            "cylinders": scene.count(Kind.CYLINDER), "lights": int(len(scene.light_position)),
            "reflective": scene.reflective, "transparent": scene.transparent}


def _shares(config: MachineConfig, resident: float, cache: float) -> MachineConfig:
    c = copy.deepcopy(config)
    c.ic_memory.resident_share = resident
    c.ic_memory.cache_share = cache
    return c


def sweep_points(config: MachineConfig) -> list[tuple[str, float, float]]:
    """(figure, local or cache share, resident split) of every configuration swept."""
    out = [("fig4", c, 0.0) for c in CACHE_SHARES]
    out += [("fig5", local, r) for local in LOCAL_SHARES for r in RESIDENT_SPLITS]
    return out


def analyse_scene(spec, res: int, config: MachineConfig, corners: bool = False,
                  progress: Progress | None = None, rays_per_chunk: int = 16384) -> SceneData:
    """Everything the paper's tables and figures need for one scene (`spec`: a name for
    `load_scene`, or a Scene)."""
    progress = progress or (lambda *a: None)
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    scene = load_scene(spec) if isinstance(spec, str) else spec
    spec = scene.name
    grid = build_grid(scene, config)
    progress(f"{spec}: golden render {res}x{res}", 0, 1)
    golden = render(scene, config, res=res, corners=corners, keep_trace=True, grid=grid)
    seconds["golden"] = time.perf_counter() - t0
    progress(f"{spec}: pre-pass", 0, 1)
    t1 = time.perf_counter()
    pre = run_prepass(scene, config, res=res, corners=corners, grid=grid)
    seconds["prepass"] = time.perf_counter() - t1
    reference = plan_layout(scene, _shares(config, 0.0, 0.0), pre.priorities, grid)
    wb = config.word_bytes
    points: dict[tuple[int, int], SweepPoint] = {}
    chosen = []
    for fig, share, split in sweep_points(config):
        if fig == "fig4":
            cfg = _shares(config, 0.0, share)
        else:
            cfg = _shares(config, share * split, share * (1 - split))
        lay = plan_layout(scene, cfg, pre.priorities, grid)
        key = (lay.resident_count, lay.cache_bytes)
        if key not in points:
            points[key] = SweepPoint(lay, lay.cache_bytes, config.ic_memory.block_bytes)
        chosen.append((fig, share, split, lay.resident_capacity * wb, key))
    sweep = SweepStream(reference, list(points.values()), wb)
    order = machine_order(golden)
    n_chunks = max(1, -(-len(order) // rays_per_chunk))
    t2 = time.perf_counter()
    loads = 0
    for i, (space, address) in enumerate(ordered_stream_chunks(reference, golden, order, rays_per_chunk)):
        progress(f"{spec}: replay {len(points)} memory configurations", i, n_chunks)
        loads += len(address)
        sweep.replay(space, address)
    progress(f"{spec}: replay {len(points)} memory configurations", n_chunks, n_chunks)
    seconds["replay"] = time.perf_counter() - t2
    mc = config.ic_memory
    db_bytes = reference.primitive_database_words * wb
    data = SceneData(name=scene.name, res=res, corners=corners, precision=config.precision,
                     counts=scene_counts(scene), database_bytes=reference.sizes(),
                     primitive_database_bytes=db_bytes, rays=dict(golden.rays),
                     references=golden.references.copy(),
                     visible=np.unique(golden.hit_ids[golden.hit_ids >= 0]).astype(np.int64),
                     prepass=pre.summary(), loads=loads, t_r=mc.t_r,
                     block_bytes=mc.block_bytes, seconds=seconds)
    for fig, share, split, resident_bytes, key in chosen:
        pt = points[key]
        f = SweepStream.figures(pt, mc.t_r, mc.t_c, mc.t_g)
        row = {"resident_bytes": resident_bytes, "resident_count": key[0], "cache_bytes": key[1],
               "all": f["all"], "shape": f["shape"]}
        if fig == "fig4":
            data.fig4.append({"cache_share": share} | row)
        else:
            data.fig5.append({"local_share": share, "resident_split": split} | row)
    seconds["total"] = time.perf_counter() - t0
    return data
