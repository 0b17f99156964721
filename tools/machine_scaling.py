"""The machine run's cost against size, fitted and checked at a larger size (issue 43 item 3).

    python tools/machine_scaling.py [--scene tetra] [--sizes 16,32,64,128] [--repeats 2]
                                    [--measure 512] [--out FILE.json]

Times one machine configuration (the compiled engine, the default configuration in fp32) at each
size, round-robin, split as `netsushisen accuracy` splits a row (netsushisen/accuracy_runs.py:
host, load, machine, read-out, and the machine stage's CPU seconds), fits seconds = a + b·rays
(eye rays, res²) by least squares to the machine stage's wall and CPU seconds, predicts the
`--measure` size and then runs it once to check the prediction (it takes minutes at 512). The
README's "How the costs scale" quotes its output. `netsushisen accuracy --sizes` fits every row
of a study the same way; this tool is the machine run alone, which a study at 512² repeats.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from netsushisen.accuracy import warm_up, with_sets
    from netsushisen.accuracy_runs import machine_job, round_robin
    from netsushisen.host.catalog import load_scene
    from netsushisen.isa.config import load_config
    from netsushisen.reports.accuracy import Timing
    from netsushisen.reports.accuracy_scaling import fit_line

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="tetra")
    p.add_argument("--sizes", default="16,32,64,128")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--measure", type=int, default=512, help="the size predicted and run (0: none)")
    p.add_argument("--out", help="write the points, fits and check as JSON")
    args = p.parse_args(argv)
    sizes = sorted({int(x) for x in args.sizes.split(",")})
    scene = load_scene(args.scene)
    config = with_sets(load_config(None, []), precision="fp32")
    warm_up(scene, config, "compiled", ("fp32",))
    measured = round_robin({n: machine_job(scene, config, n, "compiled") for n in sizes},
                           args.repeats)
    points = {}
    for n in sizes:
        (_, r), parts = measured[n]
        t = Timing.of_parts(parts, ["machine"])
        points[n] = {"cycles": r.run.cycles, "rays": n * n} | {
            stage: t.spread([stage]) for stage in ("host", "load", "machine", "machine_cpu")}
        print(f"{n}²: {r.run.cycles:,} cycles; " + "; ".join(
            f"{k} {v[0]:.3f} ({v[1]:.3f}–{v[2]:.3f}) s" for k, v in points[n].items()
            if isinstance(v, tuple)))
    out = {"scene": args.scene, "sizes": sizes, "points": points, "fits": {}, "check": {}}
    rays = [n * n for n in sizes]
    for stage in ("machine", "machine_cpu"):
        f = fit_line(rays, [points[n][stage][0] for n in sizes])
        out["fits"][stage] = {"a": f.a, "b": f.b, "r2": f.r2,
                              "predicted": f.predict(args.measure ** 2) if args.measure else None}
        r2 = "–" if f.r2 is None else f"{f.r2:.4f}"
        print(f"{stage}: {f.a:.3f} s + {f.b * 1e6:.2f} µs·rays (R² {r2})"
              + (f"; predicts {f.predict(args.measure ** 2):.1f} s at {args.measure}²"
                 if args.measure else ""))
    if args.measure:
        (_, r), parts = machine_job(scene, config, args.measure, "compiled")()
        for stage in ("machine", "machine_cpu"):
            pred = out["fits"][stage]["predicted"]
            err = pred / parts[stage] - 1
            out["check"][stage] = {"measured": parts[stage], "predicted": pred, "error": err}
            print(f"{args.measure}² {stage}: measured {parts[stage]:.1f} s, predicted {pred:.1f} s "
                  f"({err:+.1%}: {'within' if abs(err) <= 0.2 else 'NOT within'} 20 %)")
        out["check"] |= {"cycles": r.run.cycles, "parts": parts,
                         "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    if args.out:
        Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
