"""The resident pre-pass (the paper's; docs/databases.md): which shape records IC keeps in
resident memory.

The host renders the scene once at a coarse resolution with the golden model (same grid, same
rules as the main pass), counts intersection tests per primitive over every ray kind, sorts the
primitives by count (descending; ties by ascending id, so unreferenced primitives follow in id
order), gives them priorities 1, 2, 3, ... (1 = most referenced) and copies shape records into
resident memory in priority order until the next one does not fit: M records. The priorities go
into the primitive-list cells; IC compares a cell's priority with M to choose `ldr` or `ldg`.

The coarse render shoots `config.prepass.share` of the main pass's eye rays: with the paper's
1 % a 512 x 512 main pass gets a 51 x 51 pre-pass (res x sqrt(share) per axis, rounded, at
least 1), the same sample convention (pixel centres or SPD corners) as the main pass.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from netsushisen.host.databases import plan_layout
from netsushisen.host.golden import render
from netsushisen.host.grid import Grid, build_grid
from netsushisen.host.scenes import Scene
from netsushisen.isa.config import MachineConfig


@dataclass
class PrepassResult:
    priorities: np.ndarray  # (N,) int64 permutation of 1..N, 1 = most referenced
    resident_count: int  # M
    resident_bytes: int  # bytes the M resident records use
    capacity_bytes: int  # resident memory size (shares resolved against the primitive database)
    references: np.ndarray  # (N,) int64 tests per primitive in the coarse render, all ray kinds
    resolution: int  # coarse image side
    eye_rays: int
    seconds: float

    def summary(self) -> dict[str, float | int]:
        refs = self.references
        n = len(refs)
        resident = self.priorities <= self.resident_count
        total = int(refs.sum())
        return {"resolution": self.resolution, "eye_rays": self.eye_rays, "primitives": n,
                "referenced": int(np.count_nonzero(refs)), "resident_count": self.resident_count,
                "resident_bytes": self.resident_bytes, "capacity_bytes": self.capacity_bytes,
                "resident_reference_share": float(refs[resident].sum() / total) if total else 0.0,
                "seconds": self.seconds}


def coarse_resolution(res: int, share: float) -> int:
    """Side of the pre-pass image: `share` of the eye rays means sqrt(share) per axis."""
    return max(1, int(round(res * math.sqrt(share))))


def priorities_from_counts(counts: np.ndarray, ties: int | None = None) -> np.ndarray:
    """Priority per primitive: rank by descending count, ties by ascending id (or, with a seed
    `ties`, in a random order: a permutation of the records' layout the paper leaves open),
    starting at 1."""
    counts = np.asarray(counts, dtype=np.int64)
    key = (np.arange(len(counts)) if ties is None
           else np.random.default_rng(ties).permutation(len(counts)))
    order = np.lexsort((key, -counts))
    priorities = np.empty(len(counts), np.int64)
    priorities[order] = np.arange(1, len(counts) + 1)
    return priorities


def run_prepass(scene: Scene, config: MachineConfig | None = None, res: int = 512, corners: bool = False,
                grid: Grid | None = None, jitter: int | None = None) -> PrepassResult:
    """Pre-pass for a main pass of res x res: coarse golden render, priorities, resident fill.
    `jitter`: a seed for the coarse render's sampling and for the order of primitives with equal
    counts (their records' order in ICGM): one draw of `paper --draws`."""
    start = time.perf_counter()
    config = config or MachineConfig()
    grid = grid if grid is not None else build_grid(scene, config)
    coarse = coarse_resolution(res, config.prepass.share)
    golden = render(scene, config, res=coarse, corners=corners, grid=grid, jitter=jitter)
    priorities = priorities_from_counts(golden.references, jitter)
    layout = plan_layout(scene, config, priorities, grid)
    wb = config.word_bytes
    return PrepassResult(priorities=priorities, resident_count=layout.resident_count,
                         resident_bytes=layout.resident_words * wb,
                         capacity_bytes=layout.resident_capacity * wb, references=golden.references,
                         resolution=coarse, eye_rays=golden.rays["eye"],
                         seconds=time.perf_counter() - start)
