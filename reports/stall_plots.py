"""Pictures of where the cycles went: `report stalls --plot` and `report annotate --plot`.

Stalls: one horizontal bar per processor, as long as its cycles, cut into the cycles that issued
a bundle and the stall cycles by cause (the causes above 1 % of some processor's cycles each
have a colour, the rest are `other`), with percentages on the wide pieces. Annotate: per
processor, the cycles charged to each bundle address along the listing, stacked by cause over
the issued cycles, loops shaded and labels marked on the axis. matplotlib's Agg backend (no
display needed); the same statistics give the same picture.
"""

from __future__ import annotations

from pathlib import Path

from netsushisen.reports.annotate import bundle_counts, choose_processors, find_loops
from netsushisen.reports.tables import present_processors

ISSUED_COLOUR = "#b0b0b0"
OTHER = "other"


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _palette(causes: list[str]) -> dict[str, object]:
    plt = _pyplot()
    cmap = plt.get_cmap("tab20")
    colours = {c: cmap(i % 20) for i, c in enumerate(causes)}
    colours[OTHER] = "#404040"
    return colours


def _main_causes(per_proc: list[dict[str, int]], cycles: list[int], floor: float = 0.01) -> list[str]:
    """Causes that reach `floor` of some processor's cycles, by total cycles."""
    total: dict[str, int] = {}
    keep = set()
    for stalls, c in zip(per_proc, cycles):
        for cause, n in stalls.items():
            total[cause] = total.get(cause, 0) + n
            if n >= floor * max(c, 1):
                keep.add(cause)
    return sorted(keep, key=lambda k: (-total[k], k))


def plot_stalls(stats: dict, path: str | Path, title: str = "") -> Path:
    """Stacked bars of cycles by cause per processor."""
    plt = _pyplot()
    procs = present_processors(stats)
    names = [n for n, _ in procs]
    cycles = [int(p["cycles"]) for _, p in procs]
    stalls = [dict(p.get("stalls", {})) for _, p in procs]
    causes = _main_causes(stalls, cycles)
    colours = _palette(causes)
    fig, ax = plt.subplots(figsize=(10, 1.2 + 0.6 * len(names)), layout="constrained")
    y = list(range(len(names)))[::-1]
    left = [0.0] * len(names)

    def piece(label: str, values: list[int], colour) -> None:
        ax.barh(y, values, left=left, color=colour, label=label, edgecolor="white", linewidth=0.5)
        for i, v in enumerate(values):
            if cycles[i] and v / cycles[i] >= 0.06:
                ax.text(left[i] + v / 2, y[i], f"{100 * v / cycles[i]:.0f}%", ha="center",
                        va="center", fontsize=8)
            left[i] += v

    piece("issued", [int(p["bundles"]) for _, p in procs], ISSUED_COLOUR)
    for cause in causes:
        piece(cause, [s.get(cause, 0) for s in stalls], colours[cause])
    rest = [sum(n for c, n in s.items() if c not in causes) for s in stalls]
    if any(rest):
        piece(OTHER, rest, colours[OTHER])
    ax.set_yticks(y, names)
    ax.set_xlabel("machine cycles")
    ax.xaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: f"{v:,.0f}"))
    ax.set_title(title or "Cycles by cause per processor (issued + stall causes; docs/stalls.md)",
                 loc="left", fontsize=10)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8, frameon=False)
    ax.spines[["top", "right"]].set_visible(False)
    out = Path(path)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_annotate(stats: dict, path: str | Path, proc: str | None = None) -> Path:
    """Cycles charged to each bundle address along the listing, stacked by cause, per processor."""
    plt = _pyplot()
    chosen = choose_processors(stats, proc)
    counts = [bundle_counts(stats, n, p) for n, p in chosen]
    all_stalls = [{c: n for b in cs for c, n in b.stalls.items()} for cs in counts]
    totals = [{c: sum(b.stalls.get(c, 0) for b in cs) for c in s} for cs, s in zip(counts, all_stalls)]
    causes = _main_causes(totals, [int(p["cycles"]) for _, p in chosen])
    colours = _palette(causes)
    fig, axes = plt.subplots(len(chosen), 1, figsize=(12, 0.6 + 2.6 * len(chosen)),
                             layout="constrained", squeeze=False)
    seen: set[str] = set()
    for ax, (name, p), cs in zip(axes[:, 0], chosen, counts):
        pcs = [b.pc for b in cs]
        bottom = [0] * len(cs)

        def layer(label: str, values: list[int], colour) -> None:
            if not any(values):
                return
            ax.bar(pcs, values, bottom=bottom, width=1.0, color=colour,
                   label=None if label in seen else label, linewidth=0)
            seen.add(label)
            for i, v in enumerate(values):
                bottom[i] += v

        layer("issued", [b.issued for b in cs], ISSUED_COLOUR)
        for cause in causes:
            layer(cause, [b.stalls.get(cause, 0) for b in cs], colours[cause])
        layer(OTHER, [sum(n for c, n in b.stalls.items() if c not in causes) for b in cs], colours[OTHER])
        for lp in find_loops(cs):
            ax.axvspan(lp.start - 0.5, lp.end + 0.5, color="#1f77b4", alpha=0.06, linewidth=0)
        starts = [(b.pc, b.label) for b in cs if "+" not in b.label and not b.label.isdigit()]
        if len(starts) > 40:  # too many to read: the hottest labels only
            heat = {b.pc: b.cycles for b in cs}
            keep = {pc for pc, _ in sorted(starts, key=lambda s: -heat.get(s[0], 0))[:40]}
            starts = [s for s in starts if s[0] in keep]
        if starts:
            ax.set_xticks([pc for pc, _ in starts], [lb for _, lb in starts], rotation=90, fontsize=7)
        ax.set_xlim(min(pcs, default=0) - 0.5, max(pcs, default=0) + 0.5)
        ax.set_ylabel("cycles")
        ax.yaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: f"{v:,.0f}"))
        ax.set_title(f"{name}: {int(p['cycles']):,} cycles, charged per bundle address "
                     "(shaded: loops)", loc="left", fontsize=10)
        ax.spines[["top", "right"]].set_visible(False)
    fig.legend(loc="outside right upper", fontsize=8, frameon=False)
    out = Path(path)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
