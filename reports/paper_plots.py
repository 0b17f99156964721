"""Figures 3–5 as PNG plots (matplotlib, Agg backend) and every table and figure as CSV.

    table1.csv        scene, column, paper, ours
    table2.csv        scene, primitives, visible (paper, ours), shares (paper, ours)
    fig3_locality.csv scene, f, C (f = k/N at every 1 %; the plot uses every k)
    fig4_miss_rate.csv   scene, cache share, cache bytes, accesses, hits, miss rate (all IC loads
                      and shape data alone)
    fig5_access_time.csv scene, local share, resident split, resident / cache bytes, M, ρ, μ,
                      t measured, t model (all IC loads and shape data alone)
"""

from __future__ import annotations

import csv
from pathlib import Path

from netsushisen.reports.paper import table1, table2
from netsushisen.reports.paper_data import LOCAL_SHARES, SceneData

FIGURES = ("fig3_locality.png", "fig4_miss_rate.png", "fig5_access_time.png")


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
        with p.open("w", newline="", encoding="utf-8") as f:
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
            rows.append([d.name, r["cache_share"], r["cache_bytes"], a["cache_accesses"], a["cache_hits"],
                         f"{a['miss_rate']:.6f}", s["cache_accesses"], s["cache_hits"], f"{s['miss_rate']:.6f}"])
    write("fig4_miss_rate.csv", ["scene", "cache_share", "cache_bytes", "accesses", "hits", "miss_rate",
                                 "shape_accesses", "shape_hits", "shape_miss_rate"], rows)
    rows = []
    for d in scenes:
        for r in d.fig5:
            a, s = r["all"], r["shape"]
            rows.append([d.name, r["local_share"], r["resident_split"], r["resident_bytes"], r["cache_bytes"],
                         r["resident_count"], a["loads"], f"{a['rho']:.6f}", f"{a['mu']:.6f}",
                         f"{a['t_measured']:.6f}", f"{a['t_model']:.6f}", f"{s['rho']:.6f}", f"{s['mu']:.6f}",
                         f"{s['t_measured']:.6f}", f"{s['t_model']:.6f}"])
    write("fig5_access_time.csv", ["scene", "local_share", "resident_split", "resident_bytes", "cache_bytes",
                                   "resident_count", "loads", "rho", "mu", "t", "t_model", "shape_rho",
                                   "shape_mu", "shape_t", "shape_t_model"], rows)
    return paths


def figure3(scenes: list[SceneData], path: Path) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=110)
    for d in scenes:
        f, c = d.locality()
        ax.plot(100 * f, 100 * c, label=f"{d.name} (N = {d.n})")
    ax.plot([0, 100], [0, 100], color="0.6", linestyle=":", linewidth=1, label="uniform")
    ax.axvline(20, color="0.8", linewidth=0.8)
    ax.set_xlabel("f(k) = k/N: share of primitives, most referenced first (%)")
    ax.set_ylabel("C(k): cumulative share of references (%)")
    ax.set_title(f"Figure 3: locality of primitive references\n({_suffix(scenes)})")
    ax.set_xlim(0, 100)
    ax.set_ylim(0, 101)
    ax.grid(alpha=0.3)
    ax.legend(title="scene", loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure4(scenes: list[SceneData], path: Path) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=110)
    for d in scenes:
        x = [100 * r["cache_share"] for r in d.fig4]
        y = [100 * r["all"]["miss_rate"] for r in d.fig4]
        ax.plot(x, y, marker="o", label=f"{d.name} ({d.primitive_database_bytes / 1024:.0f} KiB)")
    ax.set_xlabel("cache size (% of the primitive database: lists + shape data)")
    ax.set_ylabel("cache miss rate (% of cache accesses)")
    ax.set_title(f"Figure 4: cache miss rate, cache-only local memory\n({_suffix(scenes)}, "
                 f"direct-mapped, {scenes[0].block_bytes}-byte blocks)")
    ax.set_xlim(0, 105)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(title="scene (database)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure5(scenes: list[SceneData], path: Path) -> None:
    plt = _plt()
    n = len(scenes)
    cols = 2 if n > 1 else 1
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.9 * rows), dpi=110, squeeze=False)
    for ax, d in zip(axes.ravel(), scenes):
        for local in LOCAL_SHARES:
            sel = [r for r in d.fig5 if abs(r["local_share"] - local) < 1e-9]
            x = [100 * r["resident_split"] for r in sel]
            ax.plot(x, [r["all"]["t_measured"] / d.t_r for r in sel], marker="o", markersize=3,
                    label=f"local {100 * local:.0f} %")
        ax.set_title(f"{d.name}")
        ax.set_xlabel("resident share of local memory (%)")
        ax.set_ylabel("t, effective access time (units of t_r)")
        ax.set_xlim(-3, 103)
        ax.set_ylim(bottom=0.9)
        ax.grid(alpha=0.3)
        ax.legend(title=f"{d.name}: local memory\n(% of database)", fontsize=8, title_fontsize=8,
                  loc="upper center")
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.suptitle("Figure 5: effective memory access time t = t_r·{ρ + (1 − ρ)(8 − 6μ)} "
                 f"(t_c = 2·t_r, t_g = 8·t_r)\nall IC database loads ({_suffix(scenes)})")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_figures(scenes: list[SceneData], out: Path) -> list[Path]:
    paths = [out / name for name in FIGURES]
    figure3(scenes, paths[0])
    figure4(scenes, paths[1])
    figure5(scenes, paths[2])
    return paths
