"""The numbers behind the paper's Table 1, Table 2 and Figures 3–5, from the fastest exact path.

Per scene: the golden model renders with its IC reference trace (`host/golden.py`), the
pre-pass (`host/prepass.py`) gives the priorities, and the trace — in the machine's serial
order (`host.ic_access.machine_order`) and as the IC access protocol's load stream
(`host/ic_access.py`) — is replayed once through every memory configuration of the sweeps
(`emulator.tracesim.SweepStream`): no cycle-accurate emulation. Each configuration is laid out by
`host.databases.plan_layout` with the pre-pass priorities, so resident vs cache and every ICGM
address are the ones the machine would get for that split.

Figure 4: cache-only local memory (resident 0) of 10 %, 20 %, ..., 100 % of the primitive
database. Figure 5: local memory of 10 %, 30 %, 50 % of it, split resident : cache from
0 : 100 to 100 : 0 in steps of 10 %.

`PaperOptions` says what "the primitive database" is and where the list cells live
(docs/databases.md, "The paper's evaluation"): `sizing="records"` (default) sizes local memory
against the shape records alone, `"records+lists"` against lists + records (the machine's
`cache_share` rule); `lists="local"` (default) keeps list cells in local memory beside the
resident data (t_r, never cached, not charged to the shares), `lists="cache"` reads them from
ICGM through the cache, as the machine's IC kernel does. Every configuration is counted both
per primitive reference (`row["ref"]`, the paper's counting) and per word (`row["all"]`,
`row["shape"]`).
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
from netsushisen.emulator.tracesim import SweepPoint, SweepStream
from netsushisen.host.ic_access import machine_order, ordered_stream_chunks

PAPER_SCENES = ("tetra", "balls", "mount", "rings")
CACHE_SHARES = tuple(round(0.1 * i, 2) for i in range(1, 11))  # Figure 4
LOCAL_SHARES = (0.1, 0.3, 0.5)  # Figure 5
RESIDENT_SPLITS = tuple(round(0.1 * i, 2) for i in range(0, 11))  # resident share of local memory

SIZINGS = ("records", "records+lists")
LIST_PLACEMENTS = ("local", "cache")
COUNTINGS = {"ref": "per primitive reference", "all": "per word"}


@dataclass(frozen=True)
class PaperOptions:
    """How the evaluation counts and sizes (the defaults are the paper's reading; report.md
    argues them)."""

    sizing: str = "records"
    lists: str = "local"

    def __post_init__(self) -> None:
        if self.sizing not in SIZINGS:
            raise ValueError(f"sizing {self.sizing!r}: choose one of {', '.join(SIZINGS)}")
        if self.lists not in LIST_PLACEMENTS:
            raise ValueError(f"lists {self.lists!r}: choose one of {', '.join(LIST_PLACEMENTS)}")

    def describe(self) -> str:
        size = ("shape records only" if self.sizing == "records" else "list cells + shape records")
        where = ("list cells in local memory, outside the cache and the shares" if self.lists == "local"
                 else "list cells in ICGM, read through the cache")
        return f"database = {size}; {where}"


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
    options: PaperOptions = field(default_factory=PaperOptions)
    experiments: dict[str, np.ndarray] = field(default_factory=dict)  # variant -> tests per primitive

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

    def f_reaching(self, c: float) -> float:
        """Smallest f(k) with C(k) ≥ c (the paper reads "C = 1" off its plot; 0.99 and 0.999
        say how close to 1 "reaches" is)."""
        fk, ck = self.locality()
        i = int(np.searchsorted(ck, c - 1e-12))
        return float(fk[min(i, self.n)])

    def with_references(self, refs: np.ndarray) -> "SceneData":
        """A copy counting `refs` as the tests per primitive (an experiment's variant)."""
        d = copy.copy(self)
        d.references = np.asarray(refs, np.int64)
        return d


def scene_counts(scene) -> dict:
    from netsushisen.host.scenes import Kind
    return {"primitives": scene.n_primitives, "polygons": scene.count(Kind.POLYGON),
            "spheres": scene.count(Kind.SPHERE), "cones": scene.count(Kind.CONE),
            "cylinders": scene.count(Kind.CYLINDER), "lights": int(len(scene.light_position)),
            "reflective": scene.reflective, "transparent": scene.transparent}


def _sized(config: MachineConfig, base_words: int, resident: float, cache: float) -> MachineConfig:
    """`config` with IC's resident and cache sizes set to shares of `base_words` (the sized
    database), rounded as the machine rounds shares (resident: whole words, cache: whole blocks)."""
    c = copy.deepcopy(config)
    mc = c.ic_memory
    wb = config.word_bytes
    mc.resident_share = mc.cache_share = None
    mc.resident_bytes = int(resident * base_words) * wb
    size = int(cache * base_words * wb)
    mc.cache_bytes = size - size % mc.block_bytes
    return c


def sweep_points(config: MachineConfig) -> list[tuple[str, float, float]]:
    """(figure, local or cache share, resident split) of every configuration swept."""
    out = [("fig4", c, 0.0) for c in CACHE_SHARES]
    out += [("fig5", local, r) for local in LOCAL_SHARES for r in RESIDENT_SPLITS]
    return out


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


def analyse_scene(spec, res: int, config: MachineConfig, corners: bool = False,
                  progress: Progress | None = None, rays_per_chunk: int = 16384,
                  options: PaperOptions = PaperOptions()) -> SceneData:
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
    reference = plan_layout(scene, _sized(config, 1, 0.0, 0.0), pre.priorities, grid)
    base = reference.shape_words if options.sizing == "records" else reference.primitive_database_words
    wb = config.word_bytes
    points: dict[tuple[int, int], SweepPoint] = {}
    chosen = []
    for fig, share, split in sweep_points(config):
        if fig == "fig4":
            cfg = _sized(config, base, 0.0, share)
        else:
            cfg = _sized(config, base, share * split, share * (1 - split))
        lay = plan_layout(scene, cfg, pre.priorities, grid)
        key = (lay.resident_count, lay.cache_bytes)
        if key not in points:
            points[key] = SweepPoint(lay, lay.cache_bytes, config.ic_memory.block_bytes)
        chosen.append((fig, share, split, lay.resident_capacity * wb, key))
    sweep = SweepStream(reference, list(points.values()), wb, lists_cached=options.lists == "cache")
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
    data = SceneData(name=scene.name, res=res, corners=corners, precision=config.precision,
                     counts=scene_counts(scene), database_bytes=reference.sizes(),
                     primitive_database_bytes=base * wb, rays=dict(golden.rays),
                     references=golden.references.copy(),
                     visible=np.unique(golden.hit_ids[golden.hit_ids >= 0]).astype(np.int64),
                     prepass=pre.summary(), loads=loads, t_r=mc.t_r,
                     block_bytes=mc.block_bytes, seconds=seconds, options=options,
                     experiments=trace_experiments(golden))
    for fig, share, split, resident_bytes, key in chosen:
        pt = points[key]
        f = SweepStream.figures(pt, mc.t_r, mc.t_c, mc.t_g)
        row = {"resident_bytes": resident_bytes, "resident_count": key[0], "cache_bytes": key[1],
               "all": f["all"], "shape": f["shape"], "ref": f["ref"]}
        if fig == "fig4":
            data.fig4.append({"cache_share": share} | row)
        else:
            data.fig5.append({"local_share": share, "resident_split": split} | row)
    seconds["total"] = time.perf_counter() - t0
    return data
