"""Plots of a sweep's results table (`netsushisen sweep plot`): one panel per scene, a line per
value of --hue, or a heat map of the metric over two fields."""

from __future__ import annotations

import csv
from pathlib import Path

from netsushisen.isa.outputs import write_file
from netsushisen.isa.errors import Diagnostic, NetsushisenError


def read_results(path: str | Path) -> list[dict]:
    """Rows of results.csv (numbers parsed) or results.parquet."""
    path = Path(path)
    if not path.exists():
        raise NetsushisenError(Diagnostic("no such results file", file=str(path)))
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq
        return pq.read_table(path).to_pylist()
    with open(path, newline="", encoding="utf-8") as f:
        return [{k: _number(v) for k, v in r.items()} for r in csv.DictReader(f)]


def _number(text: str):
    if text == "":
        return None
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text


def _fields(rows: list[dict]) -> list[str]:
    """The varied fields: the columns between `scene` and `status`."""
    cols = list(rows[0])
    return cols[cols.index("scene") + 1:cols.index("status")] if "status" in cols else []


def plot_results(path: str | Path, x: str | None = None, y: str = "cycles", hue: str | None = None,
                 kind: str = "line", output: str | Path | None = None) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    rows = [r for r in read_results(path) if r.get(y) is not None]
    if not rows:
        raise NetsushisenError(Diagnostic(f"no finished point has a value of {y!r}", file=str(path)))
    fields = _fields(rows)
    x = x or (fields[0] if fields else None)
    for name, what in ((x, "--x"), (y, "--y"), (hue, "--hue")):
        if name is not None and name not in rows[0]:
            raise NetsushisenError(f"{what} {name!r}: no such column (varied fields: "
                                   f"{', '.join(fields)}; metrics include cycles, rho.all, mu.all, t.all)")
    if x is None:
        raise NetsushisenError("give --x FIELD")
    if kind == "heat" and hue is None:
        raise NetsushisenError("a heat map needs --hue FIELD for its second axis")
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(1, len(scenes), figsize=(4.2 * len(scenes), 3.6), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        mine = [r for r in rows if r["scene"] == scene]
        if kind == "line":
            groups = list(dict.fromkeys(r[hue] for r in mine)) if hue else [None]
            for g in groups:
                pts = sorted((r[x], r[y]) for r in mine if hue is None or r[hue] == g)
                ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o",
                        label=f"{hue} = {g}" if hue else None)
            if hue:
                ax.legend(fontsize=7)
            ax.set_ylabel(y)
        else:
            xs = sorted({r[x] for r in mine})
            hs = sorted({r[hue] for r in mine})
            grid = np.full((len(hs), len(xs)), np.nan)
            for r in mine:
                grid[hs.index(r[hue]), xs.index(r[x])] = r[y]
            im = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
            ax.set_xticks(range(len(xs)), [f"{v:g}" if isinstance(v, float) else str(v) for v in xs],
                          fontsize=7, rotation=45)
            ax.set_yticks(range(len(hs)), [f"{v:g}" if isinstance(v, float) else str(v) for v in hs],
                          fontsize=7)
            ax.set_ylabel(hue)
            fig.colorbar(im, ax=ax, label=y)
        ax.set_title(scene)
        ax.set_xlabel(x)
    fig.tight_layout()
    out = Path(output) if output else Path(path).with_name(f"plot_{y}_vs_{x}{'_' + kind if kind != 'line' else ''}.png")
    write_file(out, lambda p: fig.savefig(p, dpi=110, format=Path(out).suffix[1:] or None))
    plt.close(fig)
    return out
