"""Per-tile machine cycles of the sampled-simulation rows, measured once and kept as small data.

    python tools/tile_cycles.py [--out tests/data/tile_cycles.json] [--scenes tetra balls]
                                [--res 16 32] [--engine compiled]

For each scene and resolution: the full run's cycles, and for every one of the 64 tiles (runs of
consecutive eye samples in DIS order, `netsushisen.accuracy.TILES`) its marginal cycles after the
warm-up `sample_tiles` uses, plus the tile's golden intersection tests and rays (the auxiliary
the estimator uses). The coverage of the sampled intervals over many redraws is then arithmetic
on these numbers (`netsushisen.accuracy.coverage`), with no rerun: `tests/test_accuracy.py`
measures it from this file, and docs/accuracy.md quotes the table it prints.
Rerun it after a kernel change (the cycles move).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    from netsushisen.accuracy import TILES, run_machine, sample_tiles, tile_auxiliary
    from netsushisen.host.catalog import load_scene
    from netsushisen.isa.config import MachineConfig
    from netsushisen.pipeline import prepare

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(ROOT / "tests" / "data" / "tile_cycles.json"))
    p.add_argument("--scenes", nargs="+", default=["tetra", "balls"])
    p.add_argument("--res", nargs="+", type=int, default=[16, 32])
    p.add_argument("--engine", default="compiled")
    args = p.parse_args(argv)
    config = MachineConfig()
    out = {"tiles": TILES, "cases": []}
    for name in args.scenes:
        scene = load_scene(name)
        for res in args.res:
            setup = prepare(scene, config, res)
            full, _ = run_machine(setup, args.engine)
            tiles = sample_tiles(setup, args.engine, list(range(TILES)), TILES)
            aux = tile_auxiliary(setup, TILES)
            case = {"scene": name, "res": res, "full": full.run.cycles,
                    "cycles": [tiles[t]["cycles"] for t in range(TILES)], "aux": aux}
            out["cases"].append(case)
            print(f"{name} {res}x{res}: full {case['full']:,}, tiles sum {sum(case['cycles']):,} "
                  f"({sum(case['cycles']) / case['full'] - 1:+.2%})", file=sys.stderr)
    Path(args.out).write_text(json.dumps(out, separators=(",", ":")) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
