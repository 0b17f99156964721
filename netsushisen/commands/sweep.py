"""Design-space sweeps on Dask: every point of a spec rendered on the emulated machine.

    netsushisen sweep SPEC.toml [--scheduler ADDRESS] [--workers N] [--out DIR] [--engine NAME]
                                [--quiet]
    netsushisen sweep plot RESULTS [--x FIELD] [--y METRIC] [--hue FIELD] [--kind line|heat]
                                   [-o FILE]

The spec format is in netsushisen/sweep.py (and the README's "Sweeps"). Without --scheduler the
points run on a Dask LocalCluster with one worker process per core (or --workers N); with it,
on the cluster whose scheduler listens at ADDRESS (`dask scheduler`, then `dask worker ADDRESS`
on each machine). Each finished point is written at once to DIR/points/KEY.json (DIR default
`sweep/`); a rerun computes only the missing points. A failed point (fault, deadlock, cycle
limit, bad configuration, a worker lost too often) is recorded with its error and the sweep goes
on; the next run computes it again (`--no-retry` keeps it). Each point file carries a checksum of
its content and the hash of the spec that wrote it: a point file that is truncated, not JSON,
edited or written for another key is named in one line and computed again. At the end, and on
Ctrl-C (exit 130), DIR/results.csv and DIR/results.parquet hold one row per finished point; the
last line says `sweep: P points, C computed, K cached, F failed` (P distinct points: C + K = P
unless interrupted, when the rest are counted as not run).
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import sys
from pathlib import Path

from netsushisen.cluster import (ResultCache, Task, add_cluster_options, check_cluster_options,
                                 run_tasks)
from netsushisen.outputs import write_all
from netsushisen.errors import NetsushisenError
from netsushisen.options import add_output, add_quiet
from netsushisen.sweep import Point, Spec, load_spec, point_config, points, run_point, tidy_row, with_keys

FAILED = ("error", "fault", "deadlock", "max_cycles", "interrupted", "lost")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", metavar="SPEC.toml | plot",
                        help="the sweep spec; or `plot RESULTS` to draw a results table")
    parser.add_argument("results", nargs="?", metavar="RESULTS",
                        help="(plot) results.csv or results.parquet of a sweep")
    add_cluster_options(parser, "one point each at a time")
    add_output(parser, "output folder (default sweep/); with plot: the image file (default next "
                       "to RESULTS)", metavar="PATH", aliases=("--output",))
    parser.add_argument("--engine", help="engine of every point (default: the spec's, else compiled)")
    parser.add_argument("--no-retry", dest="retry", action="store_false",
                        help="keep failed points as they are (default: compute them again)")
    add_quiet(parser, "no progress bar")
    plot = parser.add_argument_group("plot")
    plot.add_argument("--x", help="(plot) field on the x axis (default: the first varied field)")
    plot.add_argument("--y", default="cycles", help="(plot) metric (default cycles)")
    plot.add_argument("--hue", help="(plot) field drawn as one line per value (or the heat map's y axis)")
    plot.add_argument("--kind", choices=("line", "heat"), default="line", help="(plot) line plot or heat map")


def run(args: argparse.Namespace) -> int:
    if args.spec == "plot":
        from netsushisen.reports.sweep_plot import plot_results
        if not args.results:
            raise NetsushisenError("sweep plot: give the results file (DIR/results.csv)")
        out = plot_results(args.results, x=args.x, y=args.y, hue=args.hue, kind=args.kind,
                           output=args.out)
        print(f"wrote {out}")
        return 0
    if args.results:
        raise NetsushisenError(f"sweep: unexpected argument {args.results!r} (only `sweep plot` takes RESULTS)")
    check_cluster_options(args)
    spec = load_spec(args.spec)
    engine = _engine(args.engine or spec.engine)
    _check_footprint(spec, engine, args.quiet)
    summary = run_sweep(spec, Path(args.out or "sweep"), engine, scheduler=args.scheduler,
                        workers=args.workers, show=not args.quiet and sys.stderr.isatty(),
                        retry=args.retry)
    print(summary.line())
    if summary.interrupted:
        return 130
    return 1 if summary.failed else 0


def _check_footprint(spec: Spec, engine: str, quiet: bool) -> None:
    """Before the cluster starts: the largest point must fit a worker's host (and the machine's
    frame); a large one is announced (netsushisen/limits.py)."""
    from netsushisen.limits import machine_bytes
    from netsushisen.options import check_footprint

    configs = [point_config(spec, p) for p in points(spec)]
    if configs:
        largest = max(configs, key=lambda c: machine_bytes(c, engine))
        check_footprint(f"sweep point of {spec.path.name}", largest, spec.res, engine, quiet=quiet)


def _engine(name: str | None) -> str:
    from netsushisen.emulator.engine import check_engine, default_engine
    return check_engine(name) if name else default_engine()


class Summary:
    def __init__(self, total: int, duplicates: int = 0) -> None:
        self.total, self.computed, self.cached, self.failed = total, 0, 0, 0
        self.duplicates = duplicates
        self.interrupted = False

    def line(self) -> str:
        dup = f" ({self.duplicates} more repeat one)" if self.duplicates else ""
        rest = self.total - self.computed - self.cached
        return (f"sweep: {self.total} points{dup}, {self.computed} computed, {self.cached} cached, "
                f"{self.failed} failed" + (f", {rest} not run" if rest else "")
                + (" (interrupted)" if self.interrupted else ""))


def _task(spec: Spec, p: Point, engine: str) -> dict:
    return {"key": p.key, "scene": p.scene, "values": list(p.values), "sets": list(p.sets),
            "config_file": spec.config_file, "res": spec.res, "engine": engine}


def _spec_hash(spec: Spec) -> str:
    try:
        return hashlib.sha256(spec.path.read_bytes()).hexdigest()[:16]
    except OSError:
        return ""


def _warm(spec: Spec, pts: list[Point], engine: str) -> None:
    """Compile (or load) the compiled engine once here, so workers load it from the disk cache
    instead of each compiling it."""
    if engine not in ("compiled", "tandem"):
        return
    from netsushisen.emulator.compiled.build import load
    for precision in sorted({point_config(spec, p).precision for p in pts}):
        load(precision)


def run_sweep(spec: Spec, out: Path, engine: str, scheduler: str | None = None,
              workers: int | None = None, show: bool = False, retry: bool = True) -> Summary:
    """Run every point not already in out/points (a corrupt point file again, and a failed
    point again unless `retry` is False) on the cluster (netsushisen/cluster.py); write the
    results tables (also on Ctrl-C)."""
    pts = with_keys(spec, points(spec), engine)
    cache = ResultCache(out / "points")
    distinct: dict[str, Point] = {}
    for p in pts:
        distinct.setdefault(p.key, p)  # the first point of each key
    summary = Summary(len(distinct), len(pts) - len(distinct))
    spec_hash = _spec_hash(spec)
    todo: list[Point] = []
    for key, p in distinct.items():
        found = cache.load(key)
        if isinstance(found, dict) and "status" not in found:
            found = "was written for another point"
        if isinstance(found, str):
            print(f"sweep: point {key} ({p.scene}, {_shown(p)}) {found}: computing it again",
                  file=sys.stderr)
        elif found is not None and (found["status"] not in FAILED or not retry):
            summary.cached += 1
            summary.failed += found["status"] in FAILED
            continue
        todo.append(p)

    def done(i: int, result: dict) -> None:
        cache.store(result, spec_hash)
        summary.computed += 1
        summary.failed += result["status"] in FAILED

    def lost(i: int, err: BaseException) -> None:  # a worker lost too often (KilledWorker) or the like
        p = todo[i]
        done(i, {"key": p.key, "scene": p.scene, "values": list(p.values), "status": "lost",
                 "error": f"{type(err).__name__}: {err}", "stats": None, "seconds": 0.0,
                 "engine": engine})

    try:
        if todo:
            _warm(spec, todo, engine)
            tasks = [Task(run_point, (_task(spec, p, engine),), f"point-{p.key}") for p in todo]
            outcome = run_tasks(tasks, done, scheduler=scheduler, workers=workers, title="sweep",
                                show=show, on_error=lost, done_before=summary.cached,
                                status=lambda: _status(summary))
            summary.interrupted = outcome.interrupted
    except KeyboardInterrupt:
        summary.interrupted = True
    finally:
        write_tables(spec, pts, cache, out)
    return summary


def _status(s: Summary) -> str:
    return f"{s.computed} computed, {s.cached} cached, {s.failed} failed"


def _shown(p: Point) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in p.values) or "base configuration"


def write_tables(spec: Spec, pts: list[Point], cache: ResultCache, out: Path) -> list[dict]:
    """results.csv and results.parquet: one row per finished point of this spec, in spec order."""
    rows, seen = [], set()
    for p in pts:
        if p.key in seen or not cache.has(p.key):
            continue
        seen.add(p.key)
        result = cache.load(p.key)
        if isinstance(result, dict) and "status" in result:
            rows.append(tidy_row(spec.fields, result))
    head = ["scene", *spec.fields, "status", "cycles"]
    tail = ["seconds", "error", "key"]
    middle = sorted({k for r in rows for k in r} - set(head) - set(tail))
    columns = head + middle + tail
    def write_csv(path: Path) -> None:
        with open(path, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(columns)
            for r in rows:
                w.writerow(["" if r.get(c) is None else r.get(c) for c in columns])
    # one set: a failure leaves the earlier results.csv and results.parquet as they were
    write_all([(out / "results.csv", write_csv),
               (out / "results.parquet", lambda p: _write_parquet(p, columns, rows))])
    return rows


def _write_parquet(path: Path, columns: list[str], rows: list[dict]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq
    arrays = {}
    for c in columns:
        vals = [r.get(c) for r in rows]
        kinds = {type(v) for v in vals if v is not None}
        if kinds <= {int} and kinds:
            arrays[c] = pa.array(vals, pa.int64())
        elif kinds <= {int, float} and kinds:
            arrays[c] = pa.array([None if v is None else float(v) for v in vals], pa.float64())
        else:
            arrays[c] = pa.array([None if v is None else str(v) for v in vals], pa.string())
    pq.write_table(pa.table(arrays), path)
