"""Pictures of where the cycles went: `report stalls --plot` and `report annotate --plot`.

Stalls: one horizontal bar per processor, as long as its cycles, cut into the cycles that issued
a bundle and the stall cycles by cause (the nine causes with the largest share of some
processor's stall cycles are drawn one by one, the rest as `other`), with percentages on the
wide pieces. Annotate: per processor, the cycles charged to each bundle address along the
listing, stacked by cause over the issued cycles, loops shaded and labels marked on the axis.
A cause's colour is the stall table's (isa/stalls.py `colour`), so it is the same in both plots
and in every run. matplotlib's Agg backend (no display needed); the same statistics give the
same picture.
"""

from __future__ import annotations

from pathlib import Path

from netsushisen.isa.stalls import ISSUED_COLOUR, OTHER_COLOUR, colour
from netsushisen.isa.outputs import write_file
from netsushisen.reports.annotate import bundle_counts, choose_processors, find_loops
from netsushisen.reports.tables import present_processors

OTHER = "other"


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _palette(causes: list[str]) -> dict[str, str]:
    """The colours of the causes drawn one by one and of `other` (isa/stalls.py)."""
    colours = {c: colour(c) for c in causes}
    colours[OTHER] = OTHER_COLOUR
    return colours


def _main_causes(per_proc: list[dict[str, int]], cycles: list[int], most: int = 9) -> list[str]:
    """The `most` causes with the largest share of some processor's stall cycles (so that a
    processor idle most of the time still shows what stalls it when it works); the rest are
    drawn as `other`."""
    share: dict[str, float] = {}
    for stalls in per_proc:
        total = max(sum(stalls.values()), 1)
        for cause, n in stalls.items():
            if n:
                share[cause] = max(share.get(cause, 0.0), n / total)
    return sorted(share, key=lambda k: (-share[k], k))[:most]


def plot_stalls(stats: dict, path: str | Path, title: str = "") -> Path:
    """Stacked bars of cycles by cause per processor, written to `path`."""
    return _save(stalls_figure(stats, title), path)


def stalls_figure(stats: dict, title: str = ""):
    """The figure of `plot_stalls` (a matplotlib Figure; the caller closes it)."""
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
    return fig


def _save(fig, path: str | Path) -> Path:
    """Write `fig` to `path` (the format from its suffix) atomically, and close it."""
    out = Path(path)
    try:
        write_file(out, lambda p: fig.savefig(p, dpi=120, format=out.suffix[1:] or None))
    finally:
        _pyplot().close(fig)
    return out


def legend_colours(fig) -> dict[str, str]:
    """What a figure's legends say: label -> colour as hex RGB (how the tests compare plots)."""
    from matplotlib.colors import to_hex

    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    return {text.get_text(): to_hex(handle.get_facecolor())
            for legend in legends
            for text, handle in zip(legend.get_texts(), legend.legend_handles)}


def _tick_labels(cs, spacing: float) -> list[tuple[int, str]]:
    """Label starts to mark on the axis: the hottest first, each at least `spacing` bundle
    addresses from those kept, so that none overlap."""
    heat: dict[int, int] = {}
    start = None
    for b in cs:
        if "+" not in b.label and not b.label.isdigit():
            start = b.pc
        if start is not None:
            heat[start] = heat.get(start, 0) + b.cycles
    label = {b.pc: b.label for b in cs}
    kept: list[int] = []
    for pc in sorted(heat, key=lambda pc: (-heat[pc], pc)):
        if all(abs(pc - k) >= spacing for k in kept):
            kept.append(pc)
    return [(pc, label[pc]) for pc in sorted(kept)]


def _innermost(loops):
    """Loops that hold no other loop: the ones worth shading."""
    parents = {lp.parent for lp in loops}
    return [lp for i, lp in enumerate(loops) if i not in parents]


def plot_annotate(stats: dict, path: str | Path, proc: str | None = None) -> Path:
    """Cycles charged to each bundle address along the listing, stacked by cause, per processor,
    written to `path`. A bar far above the rest (an idle `wait` or `recv`) is cut at 1.5× the
    next highest and labelled with its cycles, so the others stay readable."""
    return _save(annotate_figure(stats, proc), path)


def annotate_figure(stats: dict, proc: str | None = None):
    """The figure of `plot_annotate` (a matplotlib Figure; the caller closes it)."""
    from matplotlib.patches import Patch

    plt = _pyplot()
    chosen = choose_processors(stats, proc)
    counts = [bundle_counts(stats, n, p) for n, p in chosen]
    totals = [{c: sum(b.stalls.get(c, 0) for b in cs) for c in {c for b in cs for c in b.stalls}}
              for cs in counts]
    causes = _main_causes(totals, [int(p["cycles"]) for _, p in chosen])
    colours = _palette(causes)
    fig, axes = plt.subplots(len(chosen), 1, figsize=(12, 0.8 + 2.8 * len(chosen)),
                             layout="constrained", squeeze=False)
    used: set[str] = set()
    for ax, (name, p), cs in zip(axes[:, 0], chosen, counts):
        import numpy as np

        lo, hi = min((b.pc for b in cs), default=0), max((b.pc for b in cs), default=0)
        pcs = list(range(lo, hi + 1))
        at = {b.pc: b for b in cs}
        edges = np.arange(lo, hi + 2) - 0.5
        bottom = np.zeros(len(pcs), np.int64)

        def layer(label: str, values: list[int], colour) -> None:
            v = np.asarray(values, np.int64)
            if not v.any():
                return
            ax.stairs(bottom + v, edges, baseline=bottom.copy(), fill=True, color=colour, linewidth=0)
            used.add(label)
            bottom[:] += v

        def per_pc(f) -> list[int]:
            return [f(at[pc]) if pc in at else 0 for pc in pcs]

        layer("issued", per_pc(lambda b: b.issued), ISSUED_COLOUR)
        for cause in causes:
            layer(cause, per_pc(lambda b, c=cause: b.stalls.get(c, 0)), colours[cause])
        layer(OTHER, per_pc(lambda b: sum(n for c, n in b.stalls.items() if c not in causes)),
              colours[OTHER])
        for lp in _innermost(find_loops(cs)):
            ax.axvspan(lp.start - 0.5, lp.end + 0.5, color="#1f77b4", alpha=0.08, linewidth=0)
        heights = sorted(bottom.tolist(), reverse=True)
        if len(heights) > 1 and heights[1] > 0 and heights[0] > 3 * heights[1]:
            top = 1.5 * heights[1]
            ax.set_ylim(0, top)
            for pc, h in zip(pcs, bottom.tolist()):
                if h > top:
                    ax.annotate(f"{h:,} ↑", (pc, top), xytext=(3, -10), textcoords="offset points",
                                fontsize=8, ha="left")
        span = hi - lo + 1
        ticks = _tick_labels(cs, span / 70)
        if ticks:
            ax.set_xticks([pc for pc, _ in ticks], [lb for _, lb in ticks], rotation=90, fontsize=7)
        ax.set_xlim(lo - 0.5, hi + 0.5)
        ax.set_ylabel("cycles")
        ax.yaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: f"{v:,.0f}"))
        ax.set_title(f"{name}: {int(p['cycles']):,} cycles charged per bundle address "
                     "(shaded: innermost loops)", loc="left", fontsize=10)
        ax.spines[["top", "right"]].set_visible(False)
    order = [lb for lb in ["issued"] + causes + [OTHER] if lb in used]
    fig.legend([Patch(color=ISSUED_COLOUR if lb == "issued" else colours[lb]) for lb in order], order,
               loc="outside right upper", fontsize=8, frameon=False)
    return fig
