"""Figures 3–5 as PNG plots (matplotlib, Agg backend) and every table and figure as CSV.

    table1.csv        scene, column, paper, ours
    table2.csv        scene, primitives, visible (paper, ours), shares (paper, ours)
    fig3_locality.csv scene, f, C (f = k/N at every 1 %; the plot uses every k)
    fig4_miss_rate.csv   scene, cache share, cache bytes, references through the cache, their hits,
                      miss rate (per primitive reference), then the same per word (all IC
                      loads, and shape data alone)
    fig5_access_time.csv scene, local share, resident split, resident / cache bytes, M, ρ, μ, t
                      per primitive reference, then per word (all IC loads, shape data alone)

The figures draw the paper's stated claims over our curves (Figure 3: the 70–80 % band at
f = 20 % and where C reaches 1; Figure 4: a line at 30 %; Figure 5: a line at 70 % resident),
and Figure 5 is drawn per reference (fig5_access_time.png) and per word (…_per_word.png);
fig5_rho_miss_rate.png draws ρ and the miss rate against the split. Legends sit outside the
data, the panels of one figure share their y-scale, no point is clipped, and the colours come
from reports/palette.py (a scene or a local-memory size has one colour in every plot).
"""

from __future__ import annotations

import csv
from pathlib import Path

from netsushisen.isa.outputs import replacing, write_file
from netsushisen.reports.paper import table1, table2
from netsushisen.reports.paper_data import COUNTINGS, LOCAL_SHARES, SceneData
from netsushisen.reports.palette import PAPER, local_colour, scene_colour, style

FIGURES = ("fig3_locality.png", "fig4_miss_rate.png", "fig5_access_time.png",
           "fig5_access_time_per_word.png", "fig5_rho_miss_rate.png")


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _suffix(scenes: list[SceneData]) -> str:
    d = scenes[0]
    return f"{d.res}×{d.res}{' corners' if d.corners else ''}, {d.precision}"


def write_csvs(scenes: list[SceneData], out: Path) -> list[Path]:
    paths = []

    def write(name: str, header: list[str], rows: list[list]) -> None:
        p = out / name
        with replacing(p, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(header)
            w.writerows(rows)
        paths.append(p)

    write("table1.csv", ["scene", "column", "paper", "ours"],
          [[r["scene"], r["column"], r["paper"], r["ours"]] for r in table1(scenes)])
    t2 = table2(scenes)
    keys = list(t2[0]) if t2 else []
    write("table2.csv", keys, [[r[k] for k in keys] for r in t2])
    rows = []
    for d in scenes:
        f, c = d.locality()
        for pct in range(101):
            k = int(round(pct / 100 * d.n))
            rows.append([d.name, f"{f[k]:.6f}", f"{c[k]:.6f}"])
    write("fig3_locality.csv", ["scene", "f", "C"], rows)
    rows = []
    for d in scenes:
        for r in d.fig4:
            a, s = r["all"], r["shape"]
            f = r["ref"]
            rows.append([d.name, r["cache_share"], r["cache_bytes"], f["cache_accesses"],
                         f["cache_hits"],
                         f"{f['miss_rate']:.6f}", a["cache_accesses"], a["cache_hits"],
                         f"{a['miss_rate']:.6f}",
                         s["cache_accesses"], s["cache_hits"], f"{s['miss_rate']:.6f}"])
    write("fig4_miss_rate.csv",
          ["scene", "cache_share", "cache_bytes", "references", "reference_hits",
                                 "miss_rate", "word_accesses", "word_hits", "word_miss_rate",
                                 "shape_accesses", "shape_hits", "shape_miss_rate"], rows)
    rows = []
    for d in scenes:
        for r in d.fig5:
            a, s = r["all"], r["shape"]
            f = r["ref"]
            rows.append([d.name, r["local_share"], r["resident_split"], r["resident_bytes"],
                         r["cache_bytes"],
                         r["resident_count"], f["loads"], f"{f['rho']:.6f}", f"{f['mu']:.6f}",
                         f"{f['t_measured']:.6f}", a["loads"], f"{a['rho']:.6f}", f"{a['mu']:.6f}",
                         f"{a['t_measured']:.6f}", f"{s['rho']:.6f}", f"{s['mu']:.6f}",
                         f"{s['t_measured']:.6f}"])
    write("fig5_access_time.csv",
          ["scene", "local_share", "resident_split", "resident_bytes", "cache_bytes",
                                   "resident_count", "references", "rho", "mu", "t",
                                   "word_loads", "word_rho",
                                   "word_mu", "word_t", "shape_rho", "shape_mu", "shape_t"], rows)
    return paths


FIGURE_DPI = 110


def _save(fig, path: Path) -> None:
    write_file(path, lambda p: fig.savefig(p, format=Path(path).suffix[1:] or None,
                                           bbox_inches="tight"))
    _plt().close(fig)


def _legend_outside(fig, ax, **kw) -> None:
    """The legend right of the axes, never over the data (Figure 5's used to cover points)."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=7,
              title_fontsize=7, **kw)


def figure3(scenes: list[SceneData], path: Path) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8.4, 4.8), dpi=FIGURE_DPI)
    for i, d in enumerate(scenes):
        f, c = d.locality()
        ax.plot(100 * f, 100 * c, linestyle=style(i)["linestyle"], color=scene_colour(i),
                label=f"{d.name} (N = {d.n})")
    ax.plot([0, 100], [0, 100], color="0.6", linestyle=":", linewidth=1, label="uniform")
    # the paper: in mount and rings 20 % of the primitives take 70–80 % of the references
    ax.fill_between([18.5, 21.5], 70, 80, facecolor="none", edgecolor="black", hatch="////",
                    linewidth=0.8, label="paper: 70–80 % at f = 20 % (mount, rings)")
    names = {d.name for d in scenes}
    for name, f1, m in (("mount", 80, "X"), ("rings", 33, "P")):
        if name in names:
            ax.plot([f1], [100], marker=m, markersize=10, color="black", linestyle="none",
                    markerfacecolor="white", label=f"paper: {name} reaches C = 1 at f = {f1} %")
    ax.set_xlabel("f(k) = k/N: share of primitives, most referenced first (%)")
    ax.set_ylabel("C(k): cumulative share of references (%)")
    ax.set_title("Figure 3: locality of primitive references (tests per "
                 f"primitive)\n({_suffix(scenes)})")
    ax.set_xlim(0, 100)
    ax.set_ylim(0, 103)
    ax.grid(alpha=0.3)
    _legend_outside(fig, ax)
    fig.tight_layout()
    _save(fig, path)


def figure4(scenes: list[SceneData], path: Path, spread: dict | None = None) -> None:
    """Both countings on one y-scale (sharey), so the per-word curve's lower miss rates show
    as lower, not as the same height on another axis."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6), dpi=FIGURE_DPI, sharey=True)
    for ax, what in zip(axes, ("ref", "all")):
        for i, d in enumerate(scenes):
            x = [100 * r["cache_share"] for r in d.fig4]
            y = [100 * r[what]["miss_rate"] for r in d.fig4]
            ax.plot(x, y, **style(i), color=scene_colour(i), markersize=4,
                    label=f"{d.name} ({d.primitive_database_bytes / 1024:.0f} KiB)")
            if spread and what == "ref":  # min–max over the draws (`--draws`)
                band = [spread[(d.name, "fig4", 0.0, r["cache_share"])] for r in d.fig4]
                ax.fill_between(x, [100 * b[1] for b in band], [100 * b[2] for b in band],
                                color=scene_colour(i), alpha=0.2, linewidth=0)
        ax.axvline(30, **PAPER, label="paper: saturates above 30 %")
        ax.set_xlabel(f"cache size (% of the database: {_sizing(scenes)})")
        ax.set_title(COUNTINGS[what]
                     + (" (the paper's counting)" if what == "ref" else ""), fontsize=10)
        ax.set_xlim(0, 105)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("cache miss rate (%)")
    _legend_outside(fig, axes[-1], title="scene (database)")
    fig.suptitle(f"Figure 4: cache miss rate, cache-only local memory ({_suffix(scenes)}, "
                 f"direct-mapped, {scenes[0].block_bytes}-byte "
                 f"blocks)\n{scenes[0].options.describe()}", fontsize=10)
    fig.tight_layout()
    _save(fig, path)


def figure5(scenes: list[SceneData], path: Path, what: str = "ref",
            spread: dict | None = None) -> None:
    _save(figure5_drawn(scenes, what, spread), path)


def _panels(n: int) -> tuple[int, int]:
    """(columns, rows) of a figure with one panel per scene."""
    cols = 2 if n > 1 else 1
    rows = (n + cols - 1) // cols
    return cols, rows


def figure5_drawn(scenes: list[SceneData], what: str = "ref", spread: dict | None = None):
    """Figure 5 as a matplotlib figure (tests measure it): every point drawn, none clipped, one
    y-scale for all panels so the scenes compare at a glance."""
    plt = _plt()
    cols, rows = _panels(len(scenes))
    fig, axes = plt.subplots(rows, cols, figsize=(6.0 * cols + 1.6, 3.9 * rows + 0.8),
                             dpi=FIGURE_DPI, squeeze=False, sharey=True)
    top = 0.0
    for ax, d in zip(axes.ravel(), scenes):
        for i, local in enumerate(LOCAL_SHARES):
            sel = [r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9]
            x = [100 * r["resident_split"] for r in sel]
            t = [r[what]["t_measured"] / d.t_r for r in sel]
            top = max([top, *t])
            ax.plot(x, t, **style(i), color=local_colour(i), markersize=4,
                    label=f"local {100 * local:.0f} %")
            if spread and what == "ref":  # min–max over the draws (`--draws`)
                band = [spread[(d.name, "fig5", local, r["resident_split"])] for r in sel]
                top = max([top, *(b[2] for b in band)])
                ax.fill_between(x, [b[1] for b in band], [b[2] for b in band],
                                color=local_colour(i), alpha=0.25, linewidth=0)
        ax.axvline(70, **PAPER, label="paper: best near 70 % (3 : 1)")
        ax.set_title(d.name)
        ax.set_xlabel("resident share of local memory (%)")
        ax.set_xlim(-3, 103)
        ax.set_xticks(range(0, 101, 20))
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("t (units of t_r)")
    axes[0, 0].set_ylim(0.9, top * 1.04 + 0.05)  # every point, the highest included
    _legend_outside(fig, axes[0, -1], title="local memory (% of database)")
    for ax in axes.ravel()[len(scenes):]:
        ax.set_visible(False)
    fig.suptitle("Figure 5: effective access time t = t_r·{ρ + (1 − ρ)(8 − 6μ)}, "
                 f"{COUNTINGS[what]} ({_suffix(scenes)})\n{scenes[0].options.describe()}\n"
                 "one y-scale for every panel; the 100 %-resident points (no cache) drawn, "
                 "not clipped" + ("; bands: min–max over the run and its draws (--draws)"
                                  if spread and what == "ref" else ""), fontsize=9)
    fig.tight_layout()
    return fig


def figure_rho_miss_drawn(scenes: list[SceneData], what: str = "ref"):
    """ρ and the cache's miss rate against the resident split (§5.1: the paper measured both),
    one column per scene, ρ above and the miss rate below, each row on one y-scale."""
    plt = _plt()
    n = len(scenes)
    fig, axes = plt.subplots(2, n, figsize=(3.6 * n + 1.8, 6.4), dpi=FIGURE_DPI, squeeze=False,
                             sharey="row")
    for j, d in enumerate(scenes):
        for i, local in enumerate(LOCAL_SHARES):
            sel = [r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9]
            x = [100 * r["resident_split"] for r in sel]
            rho = [100 * r[what]["rho"] for r in sel]
            cached = [(xx, 100 * r[what]["miss_rate"]) for xx, r in zip(x, sel)
                      if r["cache_bytes"] > 0 and r[what]["cache_accesses"] > 0]  # no cache
            kw = dict(style(i), color=local_colour(i), markersize=4,
                      label=f"local {100 * local:.0f} %")
            axes[0, j].plot(x, rho, **kw)
            if cached:
                axes[1, j].plot(*zip(*cached), **kw)
        axes[0, j].set_title(d.name)
        axes[1, j].set_xlabel("resident share of local memory (%)")
        for ax in axes[:, j]:
            ax.set_xlim(-3, 103)
            ax.set_xticks(range(0, 101, 20))
            ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("ρ: references served resident (%)")
    axes[1, 0].set_ylabel("cache miss rate 1 − μ (%)\n(100 % resident: no cache, no point)")
    axes[0, 0].set_ylim(bottom=0)
    axes[1, 0].set_ylim(bottom=0)
    _legend_outside(fig, axes[0, -1], title="local memory (% of database)")
    fig.suptitle(f"ρ and the cache miss rate against the resident split, {COUNTINGS[what]} "
                 f"({_suffix(scenes)})\n{scenes[0].options.describe()}", fontsize=9)
    fig.tight_layout()
    return fig


def _sizing(scenes: list[SceneData]) -> str:
    return "shape records" if scenes[0].options.sizing == "records" else "lists + records"


def write_figures(scenes: list[SceneData], out: Path, spread: dict | None = None) -> list[Path]:
    """Every figure; `spread` (reports/paper_spread.py: point_spread) draws each Figure 4–5
    point's min–max over the draws as a band."""
    paths = [out / name for name in FIGURES]
    figure3(scenes, paths[0])
    figure4(scenes, paths[1], spread)
    figure5(scenes, paths[2], "ref", spread)
    figure5(scenes, paths[3], "all")
    _save(figure_rho_miss_drawn(scenes, "ref"), paths[4])
    return paths
