"""What every named quantity means, and in what unit: one table for statistics and configuration.

`report flat` prints each statistic as `name value # description (unit)`, `config --dump` puts
`# description (unit; default ...)` above each configuration field, and both read it here:

- the statistics' rows are `STATISTICS` below (a name pattern, a description, a unit), and the
  stall causes' rows come from the one stall-cause table (isa/stalls.py `CAUSES`, the home of
  what each cause means: the engines, `report stalls --explain` and docs/stalls.md read it too);
- the configuration's rows come from the configuration itself: each field's description is its
  docstring in isa/config.py (read from the source, so it has one home) and its unit is
  `CONFIG_UNITS` below; an opcode's latency comes from the opcode table (isa/opcodes.py).

A name is dotted and stable (`pe0.ic.stalls.cache_hit`, `run.cycles`, `config.ic_memory.t_g`):
the statistics file's keys, with the `processors` and `memory` sections keyed by the processor
(`pe0.ic.cycles`, `pe0.ic.cache.hits`). In a pattern, `*` is one dotted part and `**` one or more.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import re
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Quantity:
    pattern: str
    description: str
    unit: str = ""

    def comment(self) -> str:
        """`description (unit)`, as a flat dump's `#` comment says it."""
        return f"{self.description} ({self.unit})" if self.unit else self.description


_P = "pe*.*"  # a processor: pe0.os, pe3.ic

STATISTICS: tuple[Quantity, ...] = (
    Quantity("run.status", "how the run ended: halted, finished, fault, deadlock, max_cycles or "
             "interrupted"),
    Quantity("run.cycles", "machine cycles the run took", "cycles"),
    Quantity("run.engine", "the engine that ran the machine: reference, compiled or tandem"),
    Quantity("run.message", "the fault or deadlock report (none: the run ended without one)"),
    Quantity("run.left_in_flight", "words still in FIFOs when the run ended", "words"),
    Quantity(f"{_P}.present", "whether the processor ran a program (1) or was absent (0)"),
    Quantity(f"{_P}.halted", "whether the processor executed `halt` (1) or not (0)"),
    Quantity(f"{_P}.pc", "the program counter at the end of the run", "address"),
    Quantity(f"{_P}.cycles", "cycles simulated on the processor: bundles + stall cycles", "cycles"),
    Quantity(f"{_P}.bundles", "bundles issued", "bundles"),
    Quantity(f"{_P}.ops", "operations executed", "operations"),
    Quantity(f"{_P}.stall_cycles", "cycles in which the processor issued no bundle", "cycles"),
    Quantity(f"{_P}.ops_by_unit.*", "operations executed on this unit class", "operations"),
    Quantity(f"{_P}.ops_by_mnemonic.*", "operations of this mnemonic executed", "operations"),
    Quantity(f"{_P}.bundles_by_pc.*", "bundles issued at this code address", "bundles"),
    Quantity(f"{_P}.stalls_by_pc.*.label", "the code address as label+offset"),
    Quantity(f"{_P}.local.reads", "local memory reads", "accesses"),
    Quantity(f"{_P}.local.writes", "local memory writes", "accesses"),
    Quantity(f"{_P}.local.words", "local memory size", "words"),
    Quantity(f"{_P}.resident.accesses", "resident memory loads (ldr, and ldg served resident)",
             "accesses"),
    Quantity(f"{_P}.resident.words", "resident memory size", "words"),
    Quantity(f"{_P}.cache.accesses", "loads through the cache (ldg)", "accesses"),
    Quantity(f"{_P}.cache.hits", "cache hits", "accesses"),
    Quantity(f"{_P}.cache.misses", "cache misses (each fills one block from global memory)",
             "accesses"),
    Quantity(f"{_P}.cache.sets", "sets of the cache (cache bytes / (block bytes × ways))",
             "sets"),
    Quantity(f"{_P}.cache.ways", "blocks per cache set (1: direct-mapped; LRU replacement)",
             "blocks"),
    Quantity(f"{_P}.cache.block_bytes", "cache block size", "bytes"),
    Quantity(f"{_P}.global.accesses", "global memory (ICGM / SCGM) accesses: cache misses",
             "accesses"),
    Quantity(f"{_P}.regions.*.*.accesses", "loads from this memory space and database region",
             "accesses"),
    Quantity(f"{_P}.regions.*.*.hits", "of those, cache hits", "accesses"),
    Quantity(f"{_P}.regions.*.*.misses", "of those, cache misses", "accesses"),
    Quantity(f"{_P}.primitives.*", "loads of this primitive's shape record (references)",
             "accesses"),
    Quantity("global_memory.*.words", "global memory size", "words"),
    Quantity("fifos.**.capacity", "FIFO capacity", "words"),
    Quantity("fifos.**.peak", "most words the FIFO held at once", "words"),
    Quantity("fifos.**.words", "words ever pushed into the FIFO", "words"),
    Quantity("fifos.**.left", "words left in the FIFO at the end", "words"),
    Quantity("dis.messages", "host messages DIS handed out", "messages"),
    Quantity("dis.words", "host words DIS handed out", "words"),
    Quantity("dis.messages_per_pe.*", "host messages DIS handed to this PE", "messages"),
    Quantity("col.pixel_messages", "pixel messages COL took", "messages"),
    Quantity("col.words", "words COL took", "words"),
    Quantity("programs.*.bundles", "bundles of the program", "bundles"),
    Quantity("programs.*.data_words", "data words of the program", "words"),
    Quantity("programs.*.source", "the program's source file"),
    Quantity("programs.*.defines.*", "an assembler symbol the program was assembled with (-D)"),
    Quantity("programs.*.static_ilp.proc", "the processor the program is for"),
    Quantity("programs.*.static_ilp.bundles", "bundles of the program", "bundles"),
    Quantity("programs.*.static_ilp.ops", "operations of the program", "operations"),
    Quantity("programs.*.static_ilp.ops_per_bundle", "static ILP: operations per bundle as "
             "scheduled", "operations/bundle"),
    Quantity("programs.*.static_ilp.max_reads", "register reads a bundle may make (read ports)",
             "reads"),
    Quantity("programs.*.static_ilp.max_writes", "register writes a bundle may make (write "
             "ports)", "writes"),
    Quantity("programs.*.static_ilp.reads_per_bundle", "register reads per bundle", "reads/bundle"),
    Quantity("programs.*.static_ilp.writes_per_bundle", "register writes per bundle",
             "writes/bundle"),
    Quantity("programs.*.static_ilp.read_port_use", "share of the read ports used", "share"),
    Quantity("programs.*.static_ilp.write_port_use", "share of the write ports used", "share"),
    Quantity("programs.*.static_ilp.slot_fill.*", "share of this unit class's slots filled",
             "share"),
    Quantity("render.scene", "the scene rendered"),
    Quantity("render.resolution", "image side", "pixels"),
    Quantity("render.corners", "SPD corner rays (1) or pixel centres (0)"),
    Quantity("render.generic", "every kernel feature assembled (1) or only the scene's (0)"),
    Quantity("render.slots", "rays OS keeps in flight", "rays"),
    Quantity("render.prepass.resolution", "pre-pass image side", "pixels"),
    Quantity("render.prepass.eye_rays", "pre-pass eye rays", "rays"),
    Quantity("render.prepass.primitives", "primitives of the scene", "primitives"),
    Quantity("render.prepass.referenced", "primitives the pre-pass referenced", "primitives"),
    Quantity("render.prepass.capacity_bytes", "resident memory the pre-pass filled", "bytes"),
    Quantity("render.prepass.resident_bytes", "bytes of the records made resident", "bytes"),
    Quantity("render.prepass.resident_count", "records made resident", "primitives"),
    Quantity("render.prepass.resident_reference_share", "share of the pre-pass's references to "
             "resident records", "share"),
    Quantity("render.prepass.seconds", "pre-pass wall time (none: not recorded)", "s"),
    Quantity("rays.eye", "eye rays (samples)", "rays"),
    Quantity("rays.eye_hits", "eye rays that hit a primitive", "rays"),
    Quantity("rays.reflection", "reflection rays spawned", "rays"),
    Quantity("rays.refraction", "refraction rays spawned", "rays"),
    Quantity("rays.shadow", "shadow rays spawned", "rays"),
    Quantity("visible_primitives", "primitives hit by an eye ray", "primitives"),
    Quantity("image_sha256", "SHA-256 of the 8-bit image"),
    Quantity("schema.name", "the statistics file's schema"),
    Quantity("schema.version", "the schema's version"),
)
"""Every statistic but the stall causes (`stalls.<cause>`, `stalls_by_pc.<pc>.stalls.<cause>`:
the glossary's) and the configuration (`config.<field>`: isa/config.py)."""

CONFIG_UNITS: dict[str, str] = {
    "pes": "PEs", "max_cycles": "cycles", "taken_branch_penalty": "cycles",
    "local_words": "words", "latency": "cycles", "t_r": "cycles", "t_c": "cycles",
    "t_g": "cycles", "block_bytes": "bytes", "cache_bytes": "bytes", "cache_ways": "blocks per set",
    "resident_bytes": "bytes",
    "cache_share": "share of the primitive database", "resident_share": "share of the "
    "primitive database", "fifo_depth": "words", "link_latency": "cycles",
    "link_buffer_words": "words", "deadlock_cycles": "cycles", "top_resolution": "voxels per axis",
    "sub_resolution": "voxels per axis", "subdivide_threshold": "primitives",
    "share": "share of the eye rays", "max_depth": "rays", "min_weight": "weight",
    "epsilon": "scene units",
}
"""The unit of each configuration field, by field name (fields without a unit are absent)."""


# ---------------------------------------------------------------------------------------------
# The configuration's rows


@functools.lru_cache(maxsize=None)
def _field_docs() -> dict[tuple[str, str], str]:
    """(class name, field name) -> the first sentence of the field's docstring in
    isa/config.py."""
    from netsushisen.isa import config

    tree = ast.parse(Path(config.__file__).read_text(encoding="utf-8"))
    docs = {}
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
        body = cls.body
        for a, b in zip(body, body[1:]):
            if (isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name)
                    and isinstance(b, ast.Expr) and isinstance(b.value, ast.Constant)
                    and isinstance(b.value.value, str)):
                text = " ".join(b.value.value.split())
                docs[(cls.name, a.target.id)] = text.split(". ")[0].rstrip(".")
    return docs


@functools.lru_cache(maxsize=None)
def config_fields() -> dict[str, tuple[object, str, str]]:
    """Every configuration field by its dotted path (`ic_memory.t_g`): (default, description,
    unit); a processor's latency table as `ic.latency` and, from the opcode table, each
    overridable mnemonic's default as `ic.latency.fmul`."""
    from netsushisen.isa.config import MachineConfig, _latency_override_problem
    from netsushisen.isa.opcodes import OPCODES

    docs = _field_docs()
    out: dict[str, tuple[object, str, str]] = {}

    def walk(obj, prefix: str) -> None:
        for f in dataclasses.fields(obj):
            path = f"{prefix}{f.name}"
            value = getattr(obj, f.name)
            doc = docs.get((type(obj).__name__, f.name), "")
            if dataclasses.is_dataclass(value):
                cls_doc = " ".join((type(value).__doc__ or "").split()).split(". ")[0].rstrip(".")
                out[path] = (None, cls_doc, "")
                walk(value, path + ".")
                continue
            out[path] = (value, doc, CONFIG_UNITS.get(f.name, ""))
            if f.name == "latency":
                proc = prefix.rstrip(".")
                for m, op in OPCODES.items():
                    if proc in op.procs and _latency_override_problem(proc, m) is None:
                        out[f"{path}.{m}"] = (op.latency, f"latency of {m} on {proc.upper()}",
                                              "cycles")

    walk(MachineConfig(), "")
    return out


def config_comment(path: str, value: object = dataclasses.MISSING) -> str | None:
    """`description (unit; default D)` of a configuration field (None: not a field); the
    default is said only where `value` differs from it or is not given."""
    entry = config_fields().get(path)
    if entry is None:
        return None
    default, doc, unit = entry
    parts = [unit] if unit else []
    if default is not None and not isinstance(default, dict) and (
            value is dataclasses.MISSING or value != default):
        shown = str(default).lower() if isinstance(default, bool) else default
        parts.append(f"default {shown}")
    return f"{doc} ({'; '.join(parts)})" if parts else doc


# ---------------------------------------------------------------------------------------------
# Looking a name up


def _regex(pattern: str) -> re.Pattern:
    parts = []
    for part in pattern.split("."):
        parts.append(".+" if part == "**" else re.escape(part).replace(r"\*", "[^.]+"))
    return re.compile(r"\.".join(parts) + r"\Z")


@functools.lru_cache(maxsize=None)
def _compiled() -> list[tuple[re.Pattern, Quantity]]:
    return [(_regex(q.pattern), q) for q in STATISTICS]


_STALL = re.compile(r"(pe[^.]+\.[^.]+)\.(?:stalls|stalls_by_pc\.[^.]+\.stalls)\.(.+)\Z")


def describe(name: str) -> Quantity | None:
    """The row of a flat statistic's name (None: the table does not know it)."""
    from netsushisen.reports.glossary import explain, lookup

    if name.startswith("config."):
        path = name[len("config."):]
        comment = config_comment(path)
        if comment is None:
            return None
        return Quantity(name, comment)
    m = _STALL.match(name)
    if m:
        if lookup(m.group(2)) is None:
            return None
        where = " at this code address" if ".stalls_by_pc." in name else ""
        return Quantity(name, f"stall cycles{where}: {explain(m.group(2))}", "cycles")
    for rx, q in _compiled():
        if rx.match(name):
            return q
    return None
