"""The results tables of a sweep: one tidy row per point (results.csv, results.parquet).

`tidy_row` reads a point's result record (its statistics, status, values); `write_results`
writes the rows of a sweep's finished points, in spec order, as one set of files.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

from netsushisen.isa.outputs import write_all


def tidy_row(spec_fields: list[str], result: dict) -> dict[str, Any]:
    """scene, every varied field, status, cycles, stalls by cause per processor, ρ / μ / t per
    region of IC's memory (all PEs together), rays, seconds, key."""
    from netsushisen.reports.summary import memory_figures
    values = dict(result["values"])
    row: dict[str, Any] = {"scene": result["scene"]}
    row.update({f: values.get(f) for f in spec_fields})
    row["status"] = result["status"]
    s = result.get("stats")
    row["cycles"] = s["run"]["cycles"] if s else None
    if s:
        for proc, p in sorted(s["processors"].items()):
            for cause, n in sorted(p.get("stalls", {}).items()):
                row[f"stall.{proc}.{cause}"] = n
        merged = _merge_ic(s)
        regions = sorted({k.split(".", 1)[1] for k in merged["memory"]["ic"]["regions"]
                          if not k.startswith("local.")})
        for region in regions + ["all"]:
            f = memory_figures(merged, "ic", None if region == "all" else region)
            if f:
                row[f"rho.{region}"] = f["rho"]
                row[f"mu.{region}"] = f["mu"]
                row[f"t.{region}"] = f["measured"]
        for kind, n in s.get("rays", {}).items():
            row[f"rays.{kind}"] = n
    row["seconds"] = round(result["seconds"], 3)
    row["error"] = result.get("error") or ""
    row["key"] = result["key"]
    return row


def _merge_ic(stats: dict) -> dict:
    """Statistics with every PE's IC region counters summed under one processor `ic`."""
    regions: dict[str, dict[str, int]] = {}
    for name, mem in stats["memory"].items():
        if name.endswith(".ic"):
            for k, c in (mem.get("regions") or {}).items():
                acc = regions.setdefault(k, {})
                for field_, n in c.items():
                    if isinstance(n, (int, float)):
                        acc[field_] = acc.get(field_, 0) + n
    return {"memory": {"ic": {"regions": regions}}, "config": stats["config"]}


def write_results(out: Path, fields: list[str], results: list[dict]) -> list[dict]:
    """results.csv and results.parquet in `out`: one row per result (the spec's order), the
    spec's varied `fields` after the scene; written as one set (a failure leaves the earlier
    pair as it was)."""
    rows = [tidy_row(fields, r) for r in results]
    head = ["scene", *fields, "status", "cycles"]
    tail = ["seconds", "error", "key"]
    middle = sorted({k for r in rows for k in r} - set(head) - set(tail))
    columns = head + middle + tail
    def write_csv(path: Path) -> None:
        with open(path, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(columns)
            for r in rows:
                w.writerow(["" if r.get(c) is None else r.get(c) for c in columns])
    write_all([(out / "results.csv", write_csv),
               (out / "results.parquet", lambda p: _write_parquet(p, columns, rows))])
    return rows


def _write_parquet(path: Path, columns: list[str], rows: list[dict]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq
    arrays = {}
    for c in columns:
        vals = [r.get(c) for r in rows]
        kinds = {type(v) for v in vals if v is not None}
        if kinds <= {int} and kinds:
            arrays[c] = pa.array(vals, pa.int64())
        elif kinds <= {int, float} and kinds:
            arrays[c] = pa.array([None if v is None else float(v) for v in vals], pa.float64())
        else:
            arrays[c] = pa.array([None if v is None else str(v) for v in vals], pa.string())
    pq.write_table(pa.table(arrays), path)
