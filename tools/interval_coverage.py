"""Coverage of the sampled-simulation 95 % intervals over many redraws, from measured tile cycles.

    python tools/interval_coverage.py [--data tests/data/tile_cycles.json] [--redraws 1000] [--seed 0]

Per scene, resolution and sampling share (10 / 25 / 50 % of 64 tiles): the share of redraws of
the stratified sample whose interval (`reports.accuracy.regression_estimate`) covers the full
run's cycles. Arithmetic only: the tiles were measured once by tools/tile_cycles.py.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def table(data: dict, redraws: int, seed: int = 0) -> list[tuple[str, int, float, float]]:
    from netsushisen.accuracy import SAMPLE_SHARES
    from netsushisen.reports.accuracy import coverage

    rows = []
    for case in data["cases"]:
        n_tiles = len(case["cycles"])
        for share in SAMPLE_SHARES:
            n = min(n_tiles, max(2, int(round(share * n_tiles))))
            rows.append((case["scene"], case["res"], share,
                         coverage(case["cycles"], case["aux"]["tests"], case["full"], n, redraws, seed)))
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=str(ROOT / "tests" / "data" / "tile_cycles.json"))
    p.add_argument("--redraws", type=int, default=1000)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    data = json.loads(Path(args.data).read_text())
    print("| scene | res | 10 % | 25 % | 50 % |\n| --- | --- | --- | --- | --- |")
    rows = table(data, args.redraws, args.seed)
    for i in range(0, len(rows), 3):
        s, r = rows[i][0], rows[i][1]
        print(f"| {s} | {r}² | " + " | ".join(f"{100 * c:.1f} %" for *_, c in rows[i:i + 3]) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
