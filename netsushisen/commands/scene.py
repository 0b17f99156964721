"""Inspect scenes: `netsushisen scene info SCENE [--json]`, `netsushisen scene nff SCENE [-o FILE]`,
`netsushisen scene list`.

SCENE is a built-in SPD generator (`tetra`, `balls`, `mount`, `rings`, optionally `NAME:SIZE` for
a size factor) or the path of an `.nff` file. `info` prints the paper's Table 1 columns for the
scene; `nff` writes the scene as NFF text (the way to get a built-in scene into a file).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from rich.console import Console
from rich.table import Table

from netsushisen.host.catalog import BUILTIN_SCENES, builtin_help, load_scene
from netsushisen.host.nff import format_nff, write_nff
from netsushisen.host.scenes import Kind, Scene
from netsushisen.options import add_json, add_output, write_text

_SCENE_HELP = (f"built-in scene ({', '.join(BUILTIN_SCENES)}; NAME:SIZE picks the SPD size "
               "factor, e.g. balls:2) or path of an .nff file")


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="scene_action", metavar="ACTION", required=True)
    info = sub.add_parser("info", help="Table-1 counts of a scene (primitives by kind, lights, "
                                       "reflective/transparent, database sizes)")
    info.add_argument("scene", metavar="SCENE", help=_SCENE_HELP)
    add_json(info, "print the counts as JSON (to FILE if given)")
    nff = sub.add_parser("nff", help="write a scene as NFF text")
    nff.add_argument("scene", metavar="SCENE", help=_SCENE_HELP)
    add_output(nff, "write to FILE instead of standard output", aliases=("--output",))
    sub.add_parser("list", help="list the built-in scenes")


def run(args: argparse.Namespace) -> int:
    if args.scene_action == "list":
        print(builtin_help())
        return 0
    scene = load_scene(args.scene)
    if args.scene_action == "nff":
        if args.out:
            write_nff(scene, args.out)
        else:
            sys.stdout.write(format_nff(scene))
        return 0
    counts = scene_counts(scene)
    if args.json:
        write_text(args.json, json.dumps(counts, indent=2) + "\n")
    else:
        _print_table(scene, counts)
    return 0


def scene_counts(scene: Scene) -> dict[str, Any]:
    """The paper's Table 1 columns for `scene`. `polygons` counts `p` and `pp` records alike.

    `database_bytes`: bytes of voxel_data, primitive_list, shape_data and luminance_data laid out
    for the default configuration (fp32 words).
    """
    counts: dict[str, Any] = {
        "primitives": scene.n_primitives,
        "polygons": scene.count(Kind.POLYGON),
        "spheres": scene.count(Kind.SPHERE),
        "cones": scene.count(Kind.CONE),
        "cylinders": scene.count(Kind.CYLINDER),
        "lights": int(len(scene.light_position)),
        "reflective": scene.reflective,
        "transparent": scene.transparent,
    }
    counts["database_bytes"] = database_bytes(scene)
    return counts


def database_bytes(scene: Scene) -> dict[str, int]:
    """Byte sizes of the four databases for the default machine configuration
    (`netsushisen.host.databases`; docs/databases.md)."""
    from netsushisen.host.databases import database_bytes as sizes

    return {str(k): int(v) for k, v in sizes(scene).items()}


def _yes_no(flag: bool) -> str:
    return "yes" if flag else "no"


def _print_table(scene: Scene, counts: dict[str, Any]) -> None:
    patches = int(scene.polygons.is_patch.sum())
    table = Table(title=f"scene {scene.name}", caption=scene.source or None,
                  show_header=True, header_style="bold")
    table.add_column("Table 1 column")
    table.add_column("count", justify="right")
    table.add_column("notes")
    table.add_row("primitives", str(counts["primitives"]), "")
    table.add_row("polygons", str(counts["polygons"]),
                  f"p {counts['polygons'] - patches}, pp {patches}")
    table.add_row("spheres", str(counts["spheres"]), "")
    table.add_row("cones", str(counts["cones"]), "")
    table.add_row("cylinders", str(counts["cylinders"]), "")
    table.add_row("lights", str(counts["lights"]), "")
    table.add_row("reflective", _yes_no(counts["reflective"]), "some material has Ks > 0")
    table.add_row("transparent", _yes_no(counts["transparent"]), "some material has T > 0")
    table.add_row("materials", str(len(scene.materials)), "distinct f records")
    for key, value in counts["database_bytes"].items():
        table.add_row(key, f"{value:,}", "bytes (fp32 words)")
    console = Console(file=sys.stdout, width=min(Console(file=sys.stdout).width, 100))
    console.print(table)
    for note in scene.notes:
        console.print(f"note: {note}")
