"""Engine speed: machine cycles per CPU-second of the reference and the compiled engine, measured
in the same run on the four paper scenes, and their ratio (prints; never asserts).

The reference engine renders each scene at a small size (default 16×16), the compiled engine at
a larger one (default 128×128): cycles per CPU-second are steady across sizes, and the larger run
amortises the compiled engine's start (flattening the state, writing it back). Each engine runs
each scene `--repeat` times, alternating, and the best rate counts (as timeit does): on a shared
machine the slower runs measure the neighbours, not the engine. The compiled
loop is loaded (and, the first time on a machine, compiled and cached) before timing starts;
that first-compile time is printed separately. Both runs are checked to end alike.

Usage: python benchmarks/bench_engines.py [--ref-res 16] [--res 128] [--repeat 3]
                                         [--scenes tetra balls ...]
"""

from __future__ import annotations

import argparse
import time

from netsushisen.emulator.compiled.build import load
from netsushisen.isa.config import MachineConfig
from netsushisen.pipeline import prepare


def measure(scene: str, res: int, engine: str) -> tuple[int, float]:
    setup = prepare(scene, MachineConfig(), res=res)
    e = setup.engine(engine)
    t = time.process_time()
    run = e.run()
    cpu = time.process_time() - t
    assert run.status in ("halted", "finished"), run
    return run.cycles, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref-res", type=int, default=16)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=["tetra", "balls", "mount", "rings"])
    args = ap.parse_args()
    t = time.perf_counter()
    load("fp32")
    measure(args.scenes[0], 2, "compiled")  # compile (first time on a machine) or load the cache
    print(f"compiled loop ready in {time.perf_counter() - t:.1f} s (the first run on a machine "
          "compiles and caches it)")
    print(f"{'scene':8} {'reference':>22} {'compiled':>24} {'ratio':>7}")
    for scene in args.scenes:
        r_rate = c_rate = 0.0
        for _ in range(max(args.repeat, 1)):
            rc, rt = measure(scene, args.ref_res, "reference")
            cc, ct = measure(scene, args.res, "compiled")
            r_rate, c_rate = max(r_rate, rc / rt), max(c_rate, cc / ct)
        print(f"{scene:8} {r_rate / 1e3:8.1f} k cyc/s ({args.ref_res}²) "
              f"{c_rate / 1e6:8.2f} M cyc/s ({args.res}²) {c_rate / r_rate:6.0f}×", flush=True)


if __name__ == "__main__":
    main()
