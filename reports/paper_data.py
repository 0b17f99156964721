"""The records of `netsushisen paper`: what one scene's evaluation holds (`SceneData`), how it
counts and sizes (`PaperOptions`), and the memory configurations Figures 4 and 5 sweep.

They are made by `netsushisen/paper.py` (the golden trace replayed through the trace-driven
memory model for every configuration: no cycle-accurate emulation); the tables, findings,
figures and report.md here only read them.

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
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

FINDINGS_POINT = "findings' reading: records, lists local"
"""The label of `--on-machine`'s row in the reading the findings use (`machine_check(lists_local=True)`)."""

FINDINGS_LOCAL_WORDS = 1 << 18
"""IC's local words in the findings' reading: room for IC's data and the lists (tetra's ~99 K
words, rings' ~106 K; the default 65536 holds neither)."""


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
        where = ("list cells in local memory, outside the cache and the shares"
                 if self.lists == "local"
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
    t_g: int = 8  # the global memory's access time (t_g = 8·t_r, §5.2), for the ρ* of finding 14
    block_bytes: int = 64
    seconds: dict[str, float] = field(default_factory=dict)
    options: PaperOptions = field(default_factory=PaperOptions)
    # variant -> tests per primitive
    experiments: dict[str, np.ndarray] = field(default_factory=dict)
    readings: dict[str, "SceneData"] = field(default_factory=dict)  # candidate reading -> its sweep

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

    @classmethod
    def from_plain(cls, d: dict) -> "SceneData":
        """A SceneData from its plain form (`cluster.plain`, arrays already back: a cached run)."""
        return cls(**(d | {"options": PaperOptions(**d["options"]),
                           "readings": {k: cls.from_plain(v)
                                        for k, v in d.get("readings", {}).items()}}))

    def with_references(self, refs: np.ndarray) -> "SceneData":
        """A copy counting `refs` as the tests per primitive (an experiment's variant)."""
        d = copy.copy(self)
        d.references = np.asarray(refs, np.int64)
        return d
