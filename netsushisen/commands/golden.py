"""Render a scene with the golden numpy model (the oracle the emulated machine must match).

Prints a short summary (and the scene's located warnings, host/nff_geometry.py); writes the
image (PNG) only where -o says, and optionally the eye rays' hit-primitive ids (.npy, int32,
-1 = background) and the statistics (JSON: primitives, visible_primitives, rays by kind, total
references, seconds).
"""

from __future__ import annotations

import argparse
import json
import sys


from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import render
from netsushisen.host.images import encode_png
from netsushisen.host.nff import scene_warnings
from netsushisen.options import (add_config_options, add_json, add_output, add_resolution,
                                 check_footprint, check_output_folders, check_resolution,
                                 config_from_args, npy_writer, write_outputs)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="built-in SPD name (tetra, balls, mount, rings[:SIZE]) or an .nff file")
    add_resolution(parser, 64)
    parser.add_argument("--corners", action="store_true",
                        help="SPD eye rays through the pixel corners ((N+1)^2 rays, pixel = mean of 4)")
    add_config_options(parser, precision=True, depth=True)
    add_output(parser, "write the image as PNG (only here: without -o no image is written)",
               metavar="PNG", aliases=("--output",))
    parser.add_argument("--ids", metavar="NPY", help="write the eye rays' hit-primitive ids (.npy)")
    add_json(parser, "write the statistics as JSON to FILE (- : standard output)")


def run(args: argparse.Namespace) -> int:
    check_resolution(args.res)
    check_output_folders(args.out, args.ids, args.json)
    config = config_from_args(args)
    check_footprint(f"golden {args.scene}", None, args.res + 1 if args.corners else args.res,
                    None, golden=True)
    scene = load_scene(args.scene)
    for line in scene_warnings(scene):
        print(line, file=sys.stderr)
    result = render(scene, config, res=args.res, corners=args.corners)
    stats = {"scene": scene.name, "source": scene.source, "res": args.res, "corners": args.corners,
             "precision": result.precision, "primitives": scene.n_primitives,
             "visible_primitives": result.visible_primitives, "rays": result.rays,
             "references": result.total_references, "seconds": round(result.seconds, 3),
             "grid": result.grid.stats()}
    write_outputs([(args.out, lambda p: p.write_bytes(encode_png(result.image_u8))),
                   (args.ids, npy_writer(result.hit_ids)),
                   (args.json, json.dumps(stats, indent=2) + "\n")])
    if args.json == "-":
        return 0
    r = result.rays
    total = r["eye"] + r["reflection"] + r["refraction"] + r["shadow"]
    print(f"{scene.name}: {scene.n_primitives} primitives, {result.visible_primitives} visible; "
          f"{args.res}x{args.res} {'corners' if args.corners else 'centres'} {result.precision}")
    print(f"rays: eye {r['eye']} (hits {r['eye_hits']}), reflection {r['reflection']}, "
          f"refraction {r['refraction']}, shadow {r['shadow']}; references {result.total_references}")
    print(f"{result.seconds:.2f} s, {total / max(result.seconds, 1e-9):,.0f} rays/s")
    return 0
