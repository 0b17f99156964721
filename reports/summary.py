"""The short report `render` prints, read from the run's statistics dict alone: what was
rendered and how the run ended, the rays by kind, where the cycles went per processor, and how
IC's memory did.

Dynamic ILP is operations per cycle (stalls included); static ILP is operations per bundle of the
kernel as scheduled: the same names and meanings as in `report ilp`, `report annotate` and
`report diff`. The memory line gives the paper's quantities for IC's shape-data loads
(its two-level memory of resident memory and cache; docs/databases.md): ρ = the share served by
resident memory, μ = the cache hit rate, and the mean access time measured next to the paper's
model t = t_r·{ρ + (1 − ρ)(8 − 6μ)} (which assumes t_c = 2·t_r and t_g = 8·t_r).
"""

from __future__ import annotations

from netsushisen.reports.tables import Section, render_table


def memory_figures(stats: dict, proc: str = "pe0.ic", region: str | None = "shape_data") -> dict | None:
    """ρ, μ and access times for one processor's loads (4-byte words, the machine's own counting;
    `netsushisen paper` also counts per primitive reference) from one database region (None: every
    region of its resident and global memory together)."""
    mem = stats["memory"].get(proc, {})
    regions = mem.get("regions", {})

    def counts(space: str) -> tuple[int, int]:
        keys = [k for k in regions if k.startswith(f"{space}.")] if region is None else [f"{space}.{region}"]
        return (sum(regions.get(k, {}).get("accesses", 0) for k in keys),
                sum(regions.get(k, {}).get("hits", 0) for k in keys))

    res = counts("resident")[0]
    acc, hits = counts("global")
    total = res + acc
    if not total:
        return None
    cfg = stats["config"]["ic_memory" if proc.endswith("ic") else "sc_memory"]
    rho = res / total
    mu = hits / acc if acc else 1.0
    measured = (res * cfg["t_r"] + hits * cfg["t_c"] + (acc - hits) * cfg["t_g"]) / total
    model = cfg["t_r"] * (rho + (1 - rho) * (8 - 6 * mu))
    return {"loads": total, "resident": res, "cache": acc, "hits": hits, "rho": rho, "mu": mu,
            "measured": measured, "model": model}


SHOWN_STALL_SHARE = 0.005
"""A cause below this share of the processor's cycles (0.5 %: it would print as 0%) is not a
top stall."""


def _top_stalls(p: dict, n: int = 3) -> str:
    """The `n` largest stall causes of at least 0.5 % of the cycles: `cache_miss 12%, ...`."""
    cycles = max(p["cycles"], 1)
    items = sorted(((cause, c) for cause, c in p["stalls"].items()
                    if c / cycles >= SHOWN_STALL_SHARE), key=lambda kv: (-kv[1], kv[0]))[:n]
    return ", ".join(f"{cause} {100 * c / cycles:.0f}%" for cause, c in items) or "-"


def processor_table(stats: dict) -> Section:
    rows = []
    for name, p in stats["processors"].items():
        if not p.get("present", True):
            continue
        stage = name.rsplit(".", 1)[-1]
        cycles = max(p["cycles"], 1)
        program = (stats.get("programs") or {}).get(stage) or {}
        static = (program.get("static_ilp") or {}).get("ops_per_bundle")
        rows.append([name, p["cycles"], p["ops"], p["ops"] / cycles, static,
                     p["stall_cycles"] / cycles, _top_stalls(p)])
    return Section("processors", "ILP and stalls",
                   ["processor", "cycles", "ops", "dynamic ILP", "static ILP", "stalled",
                    "top stalls"], rows,
                   {"cycles": "int", "ops": "int", "dynamic ILP": "f2", "static ILP": "f2",
                    "stalled": "pct"}, whole=("top stalls",))


def memory_table(stats: dict) -> Section | None:
    rows = []
    for name in stats["memory"]:
        if not name.endswith(".ic"):
            continue
        for region in ("shape_data", "primitive_list"):
            f = memory_figures(stats, name, region)
            if f:
                rows.append([name, region, f["loads"], f["rho"], f["mu"], f["measured"],
                             f["model"]])
    if not rows:
        return None
    return Section("memory", "IC memory (paper §5: resident ρ, cache hit rate μ, access time in t_r)",
                   ["processor", "region", "loads", "ρ", "μ", "t measured", "t model"], rows,
                   {"loads": "int", "ρ": "f3", "μ": "f3", "t measured": "f2", "t model": "f2"})


def summary_tables(stats: dict, width: int | None = None) -> str:
    """The ILP / stall and memory tables, as `report` draws its tables: at most the terminal's
    width (80 columns when the output is not a terminal; reports/tables.py)."""
    sections = [processor_table(stats)]
    mt = memory_table(stats)
    if mt is not None:
        sections.append(mt)
    return render_table(sections, width)


def render_headline(stats: dict, seconds: float, output: str) -> list[str]:
    """What was rendered, how the run ended, and the rays by kind (statistics of `render`:
    the `render`, `rays` and `visible_primitives` sections beside the run's own)."""
    r, rays, cfg, run = stats["render"], stats["rays"], stats["config"], stats["run"]
    res, pes = r["resolution"], cfg["pes"]
    return [
        f"{r['scene']}: {res}x{res}{' corners' if r['corners'] else ''} on {pes} "
        f"PE{'s' if pes > 1 else ''}, {cfg['precision']}, "
        f"{'generic' if r['generic'] else 'specialised'} kernels, {run.get('engine', '?')} engine: "
        f"{run['status'] or 'interrupted'} after {run['cycles']:,} cycles ({seconds:.1f} s) "
        f"-> {output}",
        f"rays: eye {rays['eye']:,} (hits {rays['eye_hits']:,}), reflection {rays['reflection']:,}, "
        f"refraction {rays['refraction']:,}, shadow {rays['shadow']:,}; "
        f"visible primitives {stats['visible_primitives']:,}"]


def print_render_summary(stats: dict, seconds: float, output: str,
                         width: int | None = None) -> None:
    """The whole summary `render` prints: the headline (wrapped between words at the width),
    then the ILP / stall and memory tables."""
    import textwrap

    from netsushisen.reports.tables import report_width

    for line in render_headline(stats, seconds, output):
        print(textwrap.fill(line, width or report_width(), subsequent_indent="  ",
                            break_long_words=False, break_on_hyphens=False))
    print(summary_tables(stats, width), end="")
