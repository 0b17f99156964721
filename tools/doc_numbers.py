"""The measured numbers the README and docs quote, regenerated from commands and checked.

    python tools/doc_numbers.py [--check | --write | --list] [--cheap] [--file DOC]... [--root DIR]

Each claim is a place in a document — a pattern whose groups are the quoted values, a table row
or a sentence — and the measurement that produces those values: machine cycles, bundles,
operations per cycle, stall shares of renders on the compiled engine (deterministic), before and
after a kernel change (`--kernels classic`), with configuration overrides, specialised and
generic. `--check` (default) measures each and exits 1 listing every quoted value that differs,
with its file and line; `--write` puts the measured values into the documents (rerun it after a
kernel change, then review the diff: the prose around a number may need a word changed).
`--cheap` keeps the claims that take a few seconds (tests/test_doc_numbers.py runs those, so a
kernel change that moves one fails until the documents are regenerated with `--write`); `--file`
keeps one document's claims (repeatable); `--list` prints every claim and whether it is cheap.
All of them take about 2 minutes on an idle core (the 32×32 kernel table is most of it).

Not here, with their own commands: the sampled-interval coverage table (tools/interval_coverage.py,
from tools/tile_cycles.py's data; docs/accuracy.md), the accuracy study's tables (`netsushisen
accuracy --res 32`; README says when they are stale) and the mutation scores (tools/mutate.py).
Wall-clock times are claims of their own kind (`Claim.about`): the Quickstart's seconds, quoted
as "about N s" on the machine named (MACHINE), match when a fresh measurement is within a
factor of 2; cycles match exactly. Numbers the documents give as history ("before", "with the kernels of that
time") are not claims.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


# ------------------------------------------------------------------------------------------------
# Measurements (each render once per process)


@dataclass(frozen=True)
class Measured:
    """What the claims read from one render's statistics."""

    cycles: int
    per_stage: dict  # stage -> {"cycles", "ops", "issued", "stall_cycles", "stalls", "bundles", "static_ilp"}
    parts: dict  # IC's list walk: part of a reference -> (cycles, references) (`reference_parts`)

    def ilp(self, stage: str) -> float:
        """Dynamic ILP: operations per cycle, stalls included."""
        s = self.per_stage[stage]
        return s["ops"] / s["cycles"]

    def stalled(self, stage: str) -> float:
        s = self.per_stage[stage]
        return s["stall_cycles"] / s["cycles"]


@lru_cache(maxsize=None)
def measure(scene: str, res: int, generic: bool = False, kernels: str | None = None,
            sets: tuple[str, ...] = ()) -> Measured:
    from netsushisen.isa.config import load_config
    from netsushisen.pipeline import render

    m = render(scene, load_config(None, list(sets)), res=res, engine="compiled", generic=generic,
               kernel_dir=kernels)
    stats = m.stats
    per = {}
    for stage in ("os", "ic", "sc"):
        p = stats["processors"][f"pe0.{stage}"]
        prog = stats["programs"][stage]
        per[stage] = {"cycles": p["cycles"], "ops": p["ops"], "issued": p["bundles"], "stall_cycles": p.get("stall_cycles", 0),
                      "stalls": dict(p.get("stalls", {})), "bundles": prog["bundles"],
                      "static_ilp": (prog.get("static_ilp") or {}).get("ops_per_bundle")}
    return Measured(int(stats["run"]["cycles"]), per, reference_parts(stats))


# IC's list walk by part of a reference, as the kernels label their code (today's and the
# classic ones): a label's cycles (issued + stalled) go to the first part whose rule it meets,
# and a part's references are the entries to its first labels (offset 0). The hit's code
# (`*_hit*`, the patch's fan search) is no part of a reference.
REFERENCE_PARTS = {
    "cell": (lambda b: b in ("cell_loop", "visit", "next_cell", "cell_read", "next_read")
             or b.startswith("rec_"),
             ("cell_loop", "visit", "cell_read")),  # (cell_read alone where there is one)
    "sphere": (lambda b: b.startswith("sph_") and "hit" not in b, ("sph_g", "sph_r")),
    "cylinder": (lambda b: b.startswith("cyl_") and "hit" not in b, ("cyl_g", "cyl_r")),
    "polygon": (lambda b: b.startswith(("poly", "tri_", "quad_")) and "hit" not in b,
                ("poly_g", "poly_r")),
}


def reference_parts(stats: dict) -> dict[str, tuple[int, int]]:
    """IC's cycles and references per part of a reference (`REFERENCE_PARTS`) in a render's
    statistics (pe0.ic; `report annotate`'s per-bundle counts)."""
    from netsushisen.reports.annotate import bundle_counts

    out = {part: [0, 0] for part in REFERENCE_PARTS}
    counts = bundle_counts(stats, "pe0.ic", stats["processors"]["pe0.ic"])
    # today's cell_loop falls into cell_read, where every reference passes
    ahead = any(b.label == "cell_read" for b in counts)
    for b in counts:
        base, _, offset = b.label.partition("+")
        for part, (rule, entries) in REFERENCE_PARTS.items():
            if rule(base):
                out[part][0] += b.cycles
                if not offset and base in entries and (not ahead or base != "cell_loop"):
                    out[part][1] += b.issued
                break
    return {part: (c, n) for part, (c, n) in out.items()}


def cycles(scene: str, res: int, generic: bool = False) -> int:
    """Machine cycles of `render SCENE --res RES` (bundled kernels, compiled engine)."""
    return measure(scene, res, generic).cycles


# ------------------------------------------------------------------------------------------------
# How the documents write numbers


def count(n: int) -> str:
    return f"{n:,}"


def change(before: float, after: float) -> str:
    """A relative change as the documents write it: +10.5, −13.5 (a real minus sign)."""
    return f"{100 * (after / before - 1):+.1f}".replace("-", "−")


def fixed(x: float, digits: int) -> str:
    return f"{x:.{digits}f}"


def share(x: float) -> str:
    """A share in whole percent (36 for 0.357)."""
    return f"{100 * x:.0f}"


NUM = r"(\d{1,3}(?:,\d{3})*)"
DEC = r"([\d.]+)"
PCT = r"([−+-][\d.]+)"


# ------------------------------------------------------------------------------------------------
# Claims


@dataclass(frozen=True)
class Claim:
    file: str  # relative to the root
    pattern: str  # regex; its groups are the quoted values, in the order `values` returns them
    values: Callable[[], tuple[str | None, ...]]  # None: an optional group the row leaves out
    what: str
    cheap: bool = False
    about: float = 0.0
    """A time the document gives as "about N s" on a machine it names: it matches when the
    measured value is within this factor of the quoted one either way (wall-clock times are not
    deterministic; cycles are, and match exactly)."""

    def matches(self, quoted: str | None, measured: str | None) -> bool:
        if self.about and quoted is not None and measured is not None:
            q, m = float(quoted), float(measured)
            return q > 0 and 1 / self.about <= m / q <= self.about
        return (quoted.replace("-", "−") if quoted else quoted) == measured


MACHINE = "a 2-core x86-64 machine"
"""The machine the README's times were measured on, named beside them."""


@lru_cache(maxsize=None)
def render_seconds() -> tuple[str, str]:
    """Wall-clock seconds of the Quickstart's `netsushisen render tetra --res 64`, as a user
    runs it (a new process): from an empty compiled-engine cache (a fresh folder), then again
    with the engine cached — rounded as the README writes them."""
    import os
    import subprocess
    import tempfile
    import time

    out = []
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NETSUSHISEN_CACHE=tmp)
        for _ in range(2):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "netsushisen.cli", "render", "tetra", "--res",
                            "64", "-q", "-o", os.path.join(tmp, "tetra.png")], env=env,
                           check=True, capture_output=True)
            out.append(time.perf_counter() - start)
    return f"{out[0]:.0f}", f"{out[1]:.0f}"


def _ilp_row(scene: str) -> tuple[str, ...]:
    m = measure(scene, 16)
    s = m.per_stage
    return (count(m.cycles), fixed(s["os"]["static_ilp"], 2), fixed(m.ilp("os"), 2),
            fixed(s["ic"]["static_ilp"], 2), fixed(m.ilp("ic"), 2), fixed(m.ilp("sc"), 2))


def _specialised(scene: str) -> tuple[str, ...]:
    a, b = measure(scene, 16).cycles, measure(scene, 16, generic=True).cycles
    return count(a), count(b), change(b, a)


def _kernels_row(scene: str) -> tuple[str, ...]:
    old, new = measure(scene, 32, kernels="classic"), measure(scene, 32)
    return (count(old.cycles), count(new.cycles), change(old.cycles, new.cycles),
            fixed(old.ilp("ic"), 2), fixed(new.ilp("ic"), 2), share(old.stalled("ic")), share(new.stalled("ic")),
            share(old.stalled("os")), share(new.stalled("os")))


def _kernels_total() -> tuple[str, ...]:
    scenes = ("tetra", "balls", "mount", "rings")
    old = sum(measure(s, 32, kernels="classic").cycles for s in scenes)
    new = sum(measure(s, 32).cycles for s in scenes)
    return count(old), count(new), change(old, new)


def _per_reference(part: str) -> tuple[str, ...]:
    """IC cycles per reference of one part, classic kernels → today's, per scene ("—" where the
    scene has no such reference)."""
    out = []
    for scene in ("tetra", "balls", "mount", "rings"):
        old, new = measure(scene, 32, kernels="classic").parts[part], measure(scene, 32).parts[part]
        out.append(f"{old[0] / old[1]:.1f} → {new[0] / new[1]:.1f}" if new[1] else "—")
    return tuple(out)


def _fmul_diff() -> tuple[str, ...]:
    a, b = measure("tetra", 4), measure("tetra", 4, sets=("ic.latency.fmul=6",))
    fmul = lambda m: m.per_stage["ic"]["stalls"].get("operand:fmul", 0)  # noqa: E731
    return (count(a.cycles), count(b.cycles), change(a.cycles, b.cycles), count(fmul(a)), count(fmul(b)),
            fixed(a.ilp("ic"), 3), fixed(b.ilp("ic"), 3))


def _fmul_row(latency: int) -> tuple[str, ...]:
    m = measure("tetra", 8, sets=(f"ic.latency.fmul={latency}",))
    return count(m.cycles), fixed(m.ilp("ic"), 3)


def _bundles() -> tuple[str, ...]:
    a, b = measure("tetra", 16).per_stage, measure("tetra", 16, generic=True).per_stage
    return str(a["ic"]["bundles"]), str(b["ic"]["bundles"]), str(a["sc"]["bundles"]), str(b["sc"]["bundles"])


@lru_cache(maxsize=None)
def database_bytes(scene: str) -> dict[str, int]:
    """fp32 bytes of each database of `scene` with the default configuration (`scene info`)."""
    from netsushisen.host.catalog import load_scene
    from netsushisen.host.databases import database_bytes as sizes
    from netsushisen.isa.config import MachineConfig

    return sizes(load_scene(scene), MachineConfig())


def _database_row(scene: str) -> tuple[str, ...]:
    b = database_bytes(scene)
    return (*(count(b[k]) for k in ("voxel_data", "primitive_list", "shape_data", "luminance_data")),
            count(b["primitive_list"] + b["shape_data"]))


def _list_shares() -> tuple[str, ...]:
    shares = [b["primitive_list"] / (b["primitive_list"] + b["shape_data"])
              for b in map(database_bytes, ("tetra", "balls", "mount", "rings"))]
    from netsushisen.host.catalog import load_scene

    per_prim = database_bytes("tetra")["primitive_list"] / 8 / load_scene("tetra").n_primitives  # 2 words of 4 bytes
    return share(min(shares)), share(max(shares)), fixed(per_prim, 1)


@lru_cache(maxsize=None)
def catalog() -> dict:
    """`netsushisen numerics` (the catalog on golden fp32, golden fp64 and the compiled engine):
    {(case, path): Verdict}."""
    from netsushisen import numerics

    paths = [numerics.GOLDEN32, numerics.GOLDEN64, "emulator-compiled"]
    return {(v.case, v.path): v for v in numerics.run_catalog(paths)}


def _catalog_row(case: str) -> tuple[str | None, ...]:
    """A row of the README's shortened catalog table: per golden path wrong/eye rays and (when
    the case judges shadows and has some to judge) wrong shadow rays/shadow rays judged; the machine's wrong/eye rays and
    whether it equals golden fp32."""
    from netsushisen import numerics

    c = catalog()
    judged = next(k for k in numerics.CATALOG if k.name == case).shadows
    out: list[str | None] = []
    for path in (numerics.GOLDEN32, numerics.GOLDEN64):
        v = c[case, path]
        out += [str(v.wrong_hits), str(v.rays)]
        wrong = v.wrongly_blocked + v.wrongly_lit  # either way (oracle.contact_truth)
        out += [str(wrong), str(v.shadow_rays)] if judged and v.shadow_rays else [None, None]
    m = c[case, "emulator-compiled"]
    return (*out, str(m.wrong_hits), str(m.rays), "= golden fp32" if not m.notes else "; ".join(m.notes))


def _catalog_total() -> tuple[str, ...]:
    c = catalog()
    return str(sum(v.stable for v in c.values())), str(len(c))


def _numerics_tetra() -> tuple[str, ...]:
    from netsushisen import numerics
    from netsushisen.host.catalog import load_scene

    rep = numerics.scene_report(load_scene("tetra"), 16)
    agree = "all pixels" if not rep.pair.hit_differs.any() and not rep.pair.colour_differs.any() else "not all pixels"
    return agree, f"{rep.largest_stable_translation:g}"


def _numerics_balls() -> tuple[str, ...]:
    from netsushisen import numerics
    from netsushisen.host.catalog import load_scene

    pair = numerics.compare_precisions(load_scene("balls"), 16)
    return str(int(pair.colour_beyond.sum())), str(pair.max_levels)


S = r"\s+"  # a space or a line break in the document's prose
CATALOG_CASES = ("far_tiny_sphere", "grazing_sphere", "grazing_cylinder", "grazing_cone", "shared_edge_fan",
                 "closed_mesh", "tiny_triangle_far", "ray_in_polygon_plane", "degenerate_polygons", "axis_parallel",
                 "origin_on_grid_face", "spanning_object", "self_intersection", "total_internal_reflection",
                 "translated_1e3", "translated_1e4", "translated_1e5", "translated_1e6", "contact_shadow_1e4",
                 "contact_shadow_1e5", "contact_shadow_1e6", "fp32_vs_fp64_balls", "fp32_vs_fp64_tetra")

CLAIMS: tuple[Claim, ...] = (
    # README: ILP at 16×16
    *(Claim("README.md", rf"\| {s} \| {NUM} \| {DEC} / {DEC} \| {DEC} / {DEC} \| {DEC} \|",
            (lambda s=s: _ilp_row(s)), f"ILP table row {s} 16x16", cheap=s == "tetra")
      for s in ("tetra", "balls")),
    # README: the Quickstart's render, its cycles (exactly) and times (about, on MACHINE)
    Claim("README.md", rf"emulator,{S}{NUM}{S}machine{S}cycles", lambda: (count(cycles("tetra", 64)),),
          "Quickstart: tetra 64x64 cycles", cheap=True),
    Claim("README.md", rf"about{S}(\d+){S}s{S}from{S}an{S}empty{S}cache{S}on{S}"
          + S.join(MACHINE.split()),
          lambda: render_seconds()[:1], "Quickstart: tetra 64x64 seconds from an empty cache",
          about=2.0),
    Claim("README.md", rf"same{S}render{S}takes{S}about{S}(\d+){S}s", lambda: render_seconds()[1:],
          "Quickstart: tetra 64x64 seconds, the engine cached", about=2.0),
    # README: specialised against generic kernels at 16×16
    Claim("README.md", rf"IC (\d+) vs (\d+) bundles for tetra, SC (\d+) vs (\d+)\)", _bundles,
          "IC and SC bundles of tetra's specialised and generic kernels", cheap=True),
    Claim("README.md", rf"do less work: tetra {NUM} vs {NUM} cycles \({PCT} %\)", lambda: _specialised("tetra"),
          "tetra 16x16 cycles, specialised vs generic", cheap=True),
    *(Claim("README.md", rf"{s} {NUM} vs {NUM} \({PCT} %\)", (lambda s=s: _specialised(s)),
            f"{s} 16x16 cycles, specialised vs generic") for s in ("balls", "mount", "rings")),
    # README: the IC rescheduling, classic kernels against today's at 32×32
    *(Claim("README.md", rf"\| {s} \| {NUM} \| {NUM} \| {PCT} % \| {DEC} → {DEC} \| (\d+) % → (\d+) % \| "
            rf"(\d+) % → (\d+) % \|", (lambda s=s: _kernels_row(s)), f"kernel table row {s} 32x32")
      for s in ("tetra", "balls", "mount", "rings")),
    Claim("README.md", rf"\| total \| {NUM} \| {NUM} \| {PCT} % \|", _kernels_total, "kernel table total 32x32"),
    *(Claim("README.md", rf"\| {label} " + 4 * r"\| (—|[\d.]+ → [\d.]+) " + r"\|",
            (lambda part=part: _per_reference(part)),
            f"IC cycles per reference, {part}")
      for part, label in (("cell", "the cell: P, S, memory, kind word, dispatch"), ("sphere", "sphere test"),
                          ("cylinder", "cylinder test"), ("polygon", "polygon test"))),
    # README: the `diff` example
    Claim("README.md", rf"cycles{S}{NUM}{S}→{S}{NUM}{S}\({PCT}{S}%\),{S}IC's{S}`operand:fmul`{S}stalls{S}{NUM}{S}→"
          rf"{S}{NUM},{S}its{S}dynamic{S}ILP{S}{DEC}{S}→{S}{DEC}", _fmul_diff,
          "diff example: tetra 4x4 against ic.latency.fmul=6", cheap=True),
    # docs/timeline.md
    Claim("docs/timeline.md", rf"MB for its {NUM} cycles", lambda: (count(cycles("tetra", 4)),),
          "tetra 4x4 cycles", cheap=True),
    Claim("docs/timeline.md", rf"`render tetra --res 4` is {NUM} cycles, `--res 8` {NUM}",
          lambda: (count(cycles("tetra", 4)), count(cycles("tetra", 8))), "tetra 4x4 and 8x8 cycles", cheap=True),
    Claim("docs/timeline.md", rf"cycles 0 to {NUM}, bundles issued: pe0.os {NUM}",
          lambda: (count(cycles("tetra", 4)), count(measure("tetra", 4).per_stage["os"]["issued"])), "tetra 4x4 cycles and OS bundles",
          cheap=True),
    # docs/api.md: the fmul latency study at 8×8
    *(Claim("docs/api.md", rf"\| {lat} \| {NUM} \| {DEC} \|", (lambda lat=lat: _fmul_row(lat)),
            f"tetra 8x8 with ic.latency.fmul={lat}", cheap=lat == 3) for lat in (3, 6, 12)),
    Claim("docs/api.md", rf"with `fmul = 2` this render takes {NUM} cycles",
          lambda: (count(measure("tetra", 8, sets=("ic.latency.fmul=2",)).cycles),),
          "tetra 8x8 with ic.latency.fmul=2"),
    # README: `numerics` on a scene, and the catalog's table (rays judged, per case and path)
    Claim("README.md", rf"`netsushisen{S}numerics{S}tetra{S}--res{S}16`:{S}(all{S}pixels|not{S}all{S}pixels){S}agree,"
          rf"{S}largest{S}stable{S}translation{S}(\d+)", _numerics_tetra, "numerics tetra --res 16"),
    Claim("README.md", rf"`netsushisen{S}numerics{S}balls{S}--res{S}16`:{S}(\d+){S}pixels{S}differ{S}in{S}colour{S}by"
          rf"{S}up{S}to{S}(\d+){S}levels", _numerics_balls, "numerics balls --res 16"),
    Claim("README.md", rf"`netsushisen{S}numerics`,{S}(\d+){S}of{S}(\d+){S}rows{S}stable", _catalog_total,
          "catalog rows stable"),
    *(Claim("README.md", rf"\| `{case}` \| [^|]+ \| " + 2 * r"(\d+)/(\d+) wrong hits(?:, (\d+)/(\d+) shadow rays wrong)? \| "
            + r"(\d+)/(\d+) wrong hits, ([^|]+?) \|", (lambda case=case: _catalog_row(case)), f"catalog row {case}")
      for case in CATALOG_CASES),
    # docs/databases.md: the databases' sizes
    *(Claim("docs/databases.md", rf"\| {s} \| {NUM} \| {NUM} \| {NUM} \| {NUM} \| {NUM} \|",
            (lambda s=s: _database_row(s)), f"database sizes of {s}") for s in ("tetra", "balls", "mount", "rings")),
    Claim("docs/databases.md", rf"The lists are (\d+)–(\d+) %{S}of{S}the{S}primitive{S}database{S}\(tetra:{S}([\d.]+)"
          rf"{S}list{S}entries{S}per{S}primitive", _list_shares, "the lists' share of the primitive database"),
)


# ------------------------------------------------------------------------------------------------
# Check and write


def check(root: Path, claims, write: bool = False) -> list[str]:
    """Every claim whose quoted values differ from the measured ones (written in with `write`),
    one line each with the file and line."""
    problems = []
    texts: dict[str, str] = {}
    for c in claims:
        text = texts.setdefault(c.file, (root / c.file).read_text(encoding="utf-8"))
        m = re.search(c.pattern, text)
        if m is None:
            problems.append(f"{c.file}: the claim '{c.what}' (/{c.pattern}/) is not in the document")
            continue
        measured = c.values()
        quoted = m.groups()
        if len(measured) != len(quoted):
            raise ValueError(f"claim '{c.what}': {len(quoted)} groups, {len(measured)} values")
        differ = [(q, v) for q, v in zip(quoted, measured) if not c.matches(q, v)]
        if not differ:
            continue
        line = text.count("\n", 0, m.start()) + 1
        problems.append(f"{c.file}:{line}: {c.what}: quotes " + ", ".join(map(str, quoted)) +
                        "; measured " + ", ".join(map(str, measured)))
        if write:
            if any((q is None) != (v is None) for q, v in zip(quoted, measured)):
                problems[-1] += " (a value is there on one side only: rewrite it by hand)"
                continue
            for i in range(len(quoted), 0, -1):  # from the last group, so offsets hold
                if measured[i - 1] is not None:
                    text = text[:m.start(i)] + measured[i - 1] + text[m.end(i):]
            texts[c.file] = text
    if write:
        for file, text in texts.items():
            path = root / file
            if path.read_text(encoding="utf-8") != text:
                path.write_text(text, encoding="utf-8")
    return problems


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group()
    g.add_argument("--check", action="store_true", help="measure and compare (default)")
    g.add_argument("--write", action="store_true", help="write the measured values into the documents")
    g.add_argument("--list", action="store_true", help="list the claims")
    p.add_argument("--cheap", action="store_true", help="only the claims that take a few seconds")
    p.add_argument("--file", action="append", metavar="DOC", help="only this document's claims (e.g. README.md)")
    p.add_argument("--root", default=str(ROOT), help="the project root holding the documents")
    args = p.parse_args(argv)
    claims = [c for c in CLAIMS if (c.cheap or not args.cheap) and (not args.file or c.file in args.file)]
    if not claims:
        print(f"doc_numbers: no claims in {', '.join(args.file or [])}", file=sys.stderr)
        return 1
    if args.list:
        for c in claims:
            print(f"{c.file}: {c.what}{' (cheap)' if c.cheap else ''}")
        return 0
    problems = check(Path(args.root), claims, write=args.write)
    for line in problems:
        print(line, file=sys.stderr)
    if args.write:
        print(f"{len(problems)} of {len(claims)} claims rewritten")
        return 0
    print(f"{len(claims) - len(problems)} of {len(claims)} claims match")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
