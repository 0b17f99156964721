"""NFF parse speed: megabytes and primitives per second (prints, never asserts).

    python benchmarks/bench_nff.py [FILE.nff | SCENE ...]

Without arguments it parses the shared SPD files when ../shared/spd is present, else the
built-in scenes written out as NFF text (so it runs in a bare clone too).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from netsushisen.host.catalog import load_scene
from netsushisen.host.nff import format_nff, parse_nff

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "spd"


def _texts(args: list[str]) -> list[tuple[str, str]]:
    if args:
        out = []
        for a in args:
            p = Path(a)
            out.append((p.name, p.read_text()) if p.is_file() else (a, format_nff(load_scene(a))))
        return out
    if SHARED.is_dir():
        return [(p.name, p.read_text()) for p in sorted(SHARED.glob("*.nff"))]
    return [(name, format_nff(load_scene(name))) for name in ("tetra", "balls", "mount", "rings")]


def main() -> None:
    print(f"{'file':<14} {'MB':>6} {'prims':>7} {'seconds':>8} {'MB/s':>7} {'prims/s':>10}")
    total_mb = total_s = 0.0
    for name, text in _texts(sys.argv[1:]):
        best = float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            scene = parse_nff(text, name)
            best = min(best, time.perf_counter() - t0)
        mb = len(text) / 1e6
        total_mb, total_s = total_mb + mb, total_s + best
        print(f"{name:<14} {mb:>6.2f} {scene.n_primitives:>7} {best:>8.3f} {mb / best:>7.1f} "
              f"{scene.n_primitives / best:>10,.0f}")
    print(f"{'all':<14} {total_mb:>6.2f} {'':>7} {total_s:>8.3f} {total_mb / total_s:>7.1f}")


if __name__ == "__main__":
    main()
