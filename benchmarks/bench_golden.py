"""Golden-model speed: rays per second for a scene at a resolution (prints, never asserts).

    python benchmarks/bench_golden.py [SCENE ...] [--res N] [--precision fp32|fp64] [--corners]

Grid build and render are timed separately; rays = eye + reflection + refraction + shadow.
"""

from __future__ import annotations

import argparse
import time

from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import render
from netsushisen.host.grid import build_grid
from netsushisen.isa.config import load_config


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=["tetra", "balls", "mount", "rings"])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--precision", default="fp32", choices=("fp32", "fp64"))
    ap.add_argument("--corners", action="store_true")
    args = ap.parse_args()
    config = load_config(None, [f"precision={args.precision}"])
    print(f"{'scene':<8} {'prims':>6} {'grid s':>7} {'render s':>9} {'rays':>9} {'rays/s':>10} {'refs/ray':>9}")
    for spec in args.scenes:
        scene = load_scene(spec)
        t0 = time.perf_counter()
        grid = build_grid(scene, config)
        t1 = time.perf_counter()
        r = render(scene, config, res=args.res, corners=args.corners, grid=grid)
        t2 = time.perf_counter()
        rays = r.rays["eye"] + r.rays["reflection"] + r.rays["refraction"] + r.rays["shadow"]
        print(f"{scene.name:<8} {scene.n_primitives:>6} {t1 - t0:>7.2f} {t2 - t1:>9.2f} {rays:>9} "
              f"{rays / (t2 - t1):>10,.0f} {r.total_references / rays:>9.1f}")


if __name__ == "__main__":
    main()
