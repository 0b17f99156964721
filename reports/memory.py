"""Memory report: per processor and database region, the paper's ρ, μ and access time t.

ρ = share of the region's loads served by resident memory, μ = cache hit rate of its global
loads, t measured = mean cycles per load with the run's t_r / t_c / t_g, t model = the paper's
t_r·{ρ + (1 − ρ)(8 − 6μ)} (equal to the measured one when t_c = 2·t_r and t_g = 8·t_r). The
`all` row sums every region of the processor's resident and global memory. Local memory
reads (OS's voxel data, SC's scene block, kernel data) are listed apart.
"""

from __future__ import annotations

from netsushisen.reports.summary import memory_figures
from netsushisen.reports.tables import Section


def memory_sections(stats: dict) -> list[Section]:
    main = Section("regions", "Resident memory and cache per database region (t in cycles)",
                   ["processor", "region", "loads", "resident", "cache", "ρ", "μ", "t", "t model"],
                   formats={"loads": "int", "resident": "int", "cache": "int", "ρ": "f3", "μ": "f3",
                            "t": "f2", "t model": "f2"})
    local = Section("local", "Local memory", ["processor", "region", "reads", "writes"],
                    formats={"reads": "int", "writes": "int"})
    caches = Section("caches", "Caches", ["processor", "sets", "ways", "block bytes", "accesses",
                                          "hits", "misses", "hit rate"],
                     formats={"sets": "int", "ways": "int", "block bytes": "int", "accesses": "int",
                              "hits": "int", "misses": "int", "hit rate": "pct"})
    for name, mem in stats["memory"].items():
        regions = mem.get("regions") or {}
        names = sorted({k.split(".", 1)[1] for k in regions if not k.startswith("local.")})
        for region in names + (["all"] if names else []):
            f = memory_figures(stats, name, None if region == "all" else region)
            if f:
                main.rows.append([name, region, f["loads"], f["resident"], f["cache"], f["rho"],
                                  f["mu"] if f["cache"] else None, f["measured"], f["model"]])
        loc = mem.get("local") or {}
        if loc.get("reads") or loc.get("writes"):
            local.rows.append([name, "(all)", loc.get("reads", 0), loc.get("writes", 0)])
            for k, v in sorted(regions.items()):
                if k.startswith("local."):
                    local.rows.append([name, k.split(".", 1)[1], v.get("accesses", 0), None])
        c = mem.get("cache")
        if c and c.get("accesses"):
            caches.rows.append([name, c["sets"], c.get("ways", 1), c["block_bytes"], c["accesses"],
                                c["hits"], c["misses"], c["hits"] / c["accesses"]])
    main.caption = ("no loads fell in a named region (the run's memory image had no region maps)"
                    if not main.rows else "")
    return [main, caches, local]
