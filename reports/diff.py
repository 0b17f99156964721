"""Diff of two statistics files: what changed between two runs, and by how much.

As gem5 users diff `stats.txt`: first the inputs that differ (configuration fields, the render's
settings, the programs' sizes and defines, the image), so the reader knows what was changed;
then per processor the cycles, bundles, operations, dynamic and static ILP, stall cycles and
each stall cause; then per processor and database region the loads, ρ, μ and access time t
(measured and the paper's model). Each row has A, B, the change B − A and the relative change
(B − A) / A (none when A is 0 or missing). Rows are long-form (one metric per row) so that every
format, CSV included, is one table a spreadsheet or pandas can pivot.
"""

from __future__ import annotations

from netsushisen.isa.opcodes import OPCODES
from netsushisen.reports.ilp import static_ilp_of
from netsushisen.reports.summary import memory_figures
from netsushisen.reports.tables import Section

CHANGE_COLUMNS = ["A", "B", "change", "relative"]
CHANGE_FORMATS = {"A": "num", "B": "num", "change": "+num", "relative": "+pct"}


def flatten(d, prefix: str = "") -> dict[str, object]:
    """Nested dicts as `a.b.c` -> leaf value."""
    out: dict[str, object] = {}
    if isinstance(d, dict):
        for k, v in d.items():
            out.update(flatten(v, f"{prefix}{k}."))
    elif prefix:
        out[prefix[:-1]] = d
    return out


def inputs(stats: dict) -> dict[str, object]:
    """What a run was made from: configuration, render settings (wall times aside), programs'
    bundles, defines and source file, the image's hash."""
    out = {f"config.{k}": v for k, v in flatten(stats.get("config", {})).items()}
    out.update({f"render.{k}": v for k, v in flatten(stats.get("render") or {}).items()
                if "seconds" not in k})
    for stage, p in (stats.get("programs") or {}).items():
        if p:
            out[f"programs.{stage}.bundles"] = p.get("bundles")
            out[f"programs.{stage}.source"] = p.get("source")
            out.update({f"programs.{stage}.defines.{k}": v for k, v in (p.get("defines") or {}).items()})
        else:
            out[f"programs.{stage}"] = None
    if "image_sha256" in stats:
        out["image_sha256"] = stats["image_sha256"]
    return out


def _default(key: str) -> str | None:
    """What a configuration field left unset means, where the statistics can say: a latency
    override absent is the opcode table's latency."""
    parts = key.split(".")
    if len(parts) == 4 and parts[0] == "config" and parts[2] == "latency" and parts[3] in OPCODES:
        return f"{OPCODES[parts[3]].latency} (default)"
    return None


def change(a, b) -> list:
    """[A, B, B − A, (B − A) / A] for numbers; the change is None where either is missing."""
    if a is None or b is None:
        return [a, b, None, None]
    return [a, b, b - a, (b - a) / a if a else None]


def processor_metrics(stats: dict, name: str) -> dict[str, float | int]:
    p = stats["processors"].get(name)
    if not p or not p.get("present", True):
        return {}
    cycles = int(p["cycles"])
    st = static_ilp_of(stats, name.rsplit(".", 1)[-1])
    out = {"cycles": cycles, "bundles": int(p["bundles"]), "ops": int(p["ops"]),
           "dynamic ILP": p["ops"] / cycles if cycles else None,
           "static ILP": st["ops_per_bundle"] if st else None,
           "stall cycles": int(p["stall_cycles"])}
    out.update({f"stall {c}": int(n) for c, n in p.get("stalls", {}).items()})
    return out


def region_metrics(stats: dict, name: str, region: str | None) -> dict[str, float | int]:
    f = memory_figures(stats, name, region)
    if not f:
        return {}
    return {"loads": f["loads"], "ρ": f["rho"], "μ": f["mu"] if f["cache"] else None,
            "t": f["measured"], "t model": f["model"]}


def _regions(stats: dict, name: str) -> list[str]:
    regions = (stats["memory"].get(name) or {}).get("regions") or {}
    return sorted({k.split(".", 1)[1] for k in regions if not k.startswith("local.")})


def _ordered(a: dict, b: dict) -> list[str]:
    """A's keys in order, then B's new ones; stall causes after the fixed metrics, by name."""
    keys = list(a) + [k for k in b if k not in a]
    fixed = [k for k in keys if not k.startswith("stall ") or k == "stall cycles"]
    return fixed + sorted(k for k in keys if k.startswith("stall ") and k != "stall cycles")


def diff_sections(a: dict, b: dict, changed_only: bool = False) -> list[Section]:
    """The inputs that differ, then every figure of A and B with its change (`changed_only`:
    the figures that changed)."""
    ia, ib = inputs(a), inputs(b)
    cfg = Section("inputs", "Inputs that differ", ["field", "A", "B"],
                  caption="configuration, render settings, programs, memory image")
    for k in sorted(set(ia) | set(ib)):
        if ia.get(k) != ib.get(k):
            cfg.rows.append([k, ia[k] if k in ia else _default(k), ib[k] if k in ib else _default(k)])
    if not cfg.rows:
        cfg.caption = "the two runs had the same inputs"

    procs = Section("processors", "Per processor (change = B − A, relative = change / A)",
                    ["processor", "metric"] + CHANGE_COLUMNS, formats=dict(CHANGE_FORMATS),
                    caption="dynamic ILP = ops per cycle; static ILP = ops per bundle as scheduled")
    ra, rb = a.get("run") or {}, b.get("run") or {}
    procs.rows.append(["(run)", "cycles"] + change(ra.get("cycles"), rb.get("cycles")))
    names = list(a["processors"]) + [n for n in b["processors"] if n not in a["processors"]]
    for name in names:
        ma, mb = processor_metrics(a, name), processor_metrics(b, name)
        for k in _ordered(ma, mb):
            procs.rows.append([name, k] + change(ma.get(k, 0 if k.startswith("stall ") and ma else None),
                                                 mb.get(k, 0 if k.startswith("stall ") and mb else None)))

    mem = Section("memory", "Per processor and region: loads, ρ, μ, t (in cycles)",
                  ["processor", "region", "metric"] + CHANGE_COLUMNS, formats=dict(CHANGE_FORMATS))
    mnames = list(a["memory"]) + [n for n in b["memory"] if n not in a["memory"]]
    for name in mnames:
        regions = _regions(a, name) + [r for r in _regions(b, name) if r not in _regions(a, name)]
        for region in regions + (["all"] if regions else []):
            r = None if region == "all" else region
            ma, mb = region_metrics(a, name, r), region_metrics(b, name, r)
            for k in list(ma) + [k for k in mb if k not in ma]:
                mem.rows.append([name, region, k] + change(ma.get(k), mb.get(k)))
    if changed_only:
        for sec in (procs, mem):
            at = sec.columns.index("A")
            sec.rows = [r for r in sec.rows if r[at] != r[at + 1]]
            sec.caption = (sec.caption + "; " if sec.caption else "") + "changed figures only"
    return [cfg, procs, mem]
