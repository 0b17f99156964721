"""Is a scene numerically stable? fp32 against fp64, shadow acne, and how far it can be moved.

    netsushisen numerics [SCENE] [--res N] [--out DIR] [--engine NAME] [--config FILE] [--set k=v]...
                         [--scheduler ADDRESS] [--workers N]

With a SCENE (built-in SPD name or .nff file): renders it with the golden model in fp32 and in
fp64 and judges their differences as the catalog does (the float64 oracle, on the differing rays
only): pixels whose hit primitive differs beyond rounding of an edge, vertex or tie, shadow rays
of eye hits blocked in one precision only beyond rounding, and pixels whose 8-bit colour differs
by more than one level with the same hit (a map in DIR/numerics_map.png: white / grey = another
primitive beyond / within rounding, red = another colour); then moves the scene by 1, 10, 100,
... until fp32 stops agreeing with fp64 there: the largest translation it survives. Writes
DIR/numerics.json. Memory: the golden model's per eye ray, twice the pixels' worth at most
(limits.numerics_footprint, checked before any work).

Without a SCENE: the built-in catalog of hard cases (docs/golden.md, "The numerical catalog"),
one row per case and path (golden fp32, golden fp64, the machine on --engine), each judged
against the brute-force float64 oracle. Writes DIR/catalog.json and DIR/catalog.md.

Exit 0 when everything is stable; 1 with the reasons on standard error when something is not.
--res defaults to 32 with a SCENE (the catalog uses each case's own size, capped by --res).

Each catalog case, and each translation of a SCENE (all tried at once; the report keeps those up
to the first that breaks), is one run on the Dask layer (netsushisen/cluster.py): a LocalCluster
of --workers processes or the cluster at --scheduler ADDRESS. Rows come in catalog order. Ctrl-C
writes what was judged and exits 130.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from netsushisen.isa.outputs import write_file
from netsushisen.cluster import add_cluster_options, check_cluster_options
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.host.catalog import load_scene
from netsushisen.host.images import encode_png
from netsushisen.isa.limits import check_host, numerics_footprint
from netsushisen.options import (add_config_options, add_engine, add_output, add_quiet,
                                 add_resolution, check_resolution, config_overrides,
                                 engine_from_args)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", nargs="?", metavar="SCENE",
                        help="built-in SPD name or .nff file (default: the built-in catalog of hard cases)")
    add_resolution(parser, None, "N×N eye rays (default 32 with a SCENE; the catalog: each case's own)")
    add_output(parser, "output folder (default numerics/)", metavar="DIR", default="numerics")
    add_engine(parser)
    add_config_options(parser)
    add_cluster_options(parser, "one catalog case or one translation each at a time")
    add_quiet(parser, "no progress lines, no table (the verdict and the files still)")


def _write(path: Path, write) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise NetsushisenError(Diagnostic(f"cannot write: {err.strerror}", file=str(path))) from None
    write_file(path, write)


def catalog_table(verdicts) -> list[str]:
    """The catalog as Markdown rows (the README quotes this table)."""
    rows = ["| case | path | eye rays | wrong hits | shadow rays judged | wrongly blocked | verdict |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    for v in verdicts:
        rows.append(f"| {v.case} | {v.path} | {v.rays} | {v.wrong_hits} | {v.shadow_rays} | "
                    f"{v.wrongly_blocked} | {'stable' if v.stable else 'UNSTABLE: ' + v.reason()} |")
    return rows


def _catalog(args, out: Path, engine: str) -> int:
    from netsushisen import numerics  # noqa: PLC0415 (heavy: the oracle and the machine)
    paths = [numerics.GOLDEN32, numerics.GOLDEN64, f"emulator-{engine}"]
    # one row a verdict as it comes, 80 columns at most (the longest case and path names fit)
    row = "{:<25} {:<18} {:>5} {:>5} {:>6} {:>7} {}"
    if not args.quiet:
        print(row.format("case", "path", "rays", "wrong", "shadow", "blocked", "verdict"))
    verdicts = []

    def show(v):
        verdicts.append(v)
        if not args.quiet:
            print(row.format(v.case, v.path, v.rays, v.wrong_hits, v.shadow_rays, v.wrongly_blocked,
                             "stable" if v.stable else "UNSTABLE"), flush=True)

    _, interrupted = numerics.catalog_on_cluster(paths, args.res, args.scheduler, args.workers, progress=show)
    if interrupted:
        print("interrupted: the rows above are what was judged", file=sys.stderr)
        _save_catalog(out, verdicts)
        return 130
    _save_catalog(out, verdicts)
    bad = [v for v in verdicts if not v.stable]
    for v in bad:
        print(f"unstable: {v.case} on {v.path}: {v.reason()}", file=sys.stderr)
    print(f"{len(verdicts) - len(bad)} of {len(verdicts)} case×path rows stable; written to {out}/")
    return 1 if bad else 0


def _save_catalog(out: Path, verdicts) -> None:
    rows = [{**asdict(v), "stable": v.stable, "reason": v.reason()} for v in verdicts]
    _write(out / "catalog.json", lambda p: p.write_text(json.dumps(rows, indent=2) + "\n"))
    _write(out / "catalog.md", lambda p: p.write_text("\n".join(catalog_table(verdicts)) + "\n"))


def _scene(args, out: Path) -> int:
    from netsushisen import numerics  # noqa: PLC0415
    res = args.res or 32
    check_host(numerics_footprint(f"numerics {args.scene} {res}×{res}", res), quiet=args.quiet)
    scene = load_scene(args.scene)
    sets = tuple(config_overrides(args))
    rep, interrupted = numerics.scene_report_on_cluster(scene, res, sets, args.scheduler, args.workers)
    if rep.pair is None:
        print("interrupted before fp32 and fp64 were compared: nothing written", file=sys.stderr)
        return 130
    pair = rep.pair
    _write(out / "numerics_map.png", lambda p: p.write_bytes(encode_png(numerics.difference_map(pair))))
    largest = rep.largest_stable_translation
    data = {"scene": scene.name, "res": res, "pixels": pair.pixels,
            "hit_differs": int(pair.hit_differs.sum()), "hit_beyond_rounding": int(pair.hit_beyond.sum()),
            "colour_tolerance": numerics.COLOUR_TOLERANCE, "colour_differs": int(pair.colour_differs.sum()),
            "colour_beyond_rounding": int(pair.colour_beyond.sum()), "max_colour_levels": pair.max_levels,
            "shadow_rays": pair.shadow_rays, "blocked_only_fp32": pair.blocked_only_fp32,
            "shadow_differs": pair.shadow_differs, "shadow_beyond_rounding": pair.shadow_beyond,
            "stable": rep.stable(), "reasons": rep.reasons(), "largest_stable_translation": largest,
            "complete": not interrupted,
            "translations": [{"by": by, "stable": ok, "reasons": why} for by, ok, why in rep.translations]}
    _write(out / "numerics.json", lambda p: p.write_text(json.dumps(data, indent=2) + "\n"))
    print(f"{scene.name}: {res}x{res}, fp32 against fp64")
    print(f"  pixels: {int(pair.hit_differs.sum())} hit another primitive ({int(pair.hit_beyond.sum())} "
          f"beyond rounding), {int(pair.colour_differs.sum())} another colour by more than "
          f"{numerics.COLOUR_TOLERANCE} level ({int(pair.colour_beyond.sum())} unexplained), of {pair.pixels} "
          f"(map: {out}/numerics_map.png)")
    print(f"  shadow rays of eye hits: {pair.shadow_rays}, blocked in one precision only: "
          f"{pair.shadow_differs} ({pair.shadow_beyond} beyond rounding; fp32 only: {pair.blocked_only_fp32})")
    for by, ok, why in rep.translations:
        print(f"  translated by {by:g}: {'stable' if ok else 'breaks: ' + '; '.join(why)}")
    print(f"  largest stable translation: {'none' if largest is None else f'{largest:g}'}")
    if interrupted:
        print(f"interrupted: the translations above are what was measured; written to {out}/", file=sys.stderr)
        return 130
    for reason in rep.reasons():
        print(f"unstable: {scene.name}: {reason}", file=sys.stderr)
    return 0 if rep.stable() else 1


def run(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    check_cluster_options(args)
    engine = engine_from_args(args)
    out = Path(args.out)
    if not args.scene and (args.config or config_overrides(args)):
        raise NetsushisenError("--config / --set apply to a SCENE; the catalog's cases carry their own settings")
    return _scene(args, out) if args.scene else _catalog(args, out, engine)
