"""Design-space sweeps: a spec file names scenes and the configuration fields to vary; every point
is one render on the emulated machine, stored under a content key as soon as it finishes.

A spec (TOML; `examples/sweeps/` has the paper's Fig 5 grid and a PE-count × DIS-mode study):

    scenes = ["tetra", "balls"]        # built-in names or .nff files (relative to the spec)
    res = 32                           # N×N image per point
    config = "base.toml"               # optional base configuration (relative to the spec)
    set = ["ring.fifo_depth=32"]       # optional fixed `--set` overrides
    engine = "compiled"                # optional (default: the engine interface's default)

    [vary]                             # the axes; points = scenes × the product of the axes
    "ic_memory.cache_bytes" = [2048, 4096, 8192]           # a list
    "ic_memory.t_g" = {start = 4, stop = 16, step = 4}     # a range, stop included
    local = [0.1, 0.3, 0.5]            # a name that is no configuration field is a parameter

    [zip]                              # optional: lists of equal length varied together (one axis)
    "ring.fifo_depth" = [16, 32]
    "ring.link_buffer_words" = [2, 4]

    [derive]                           # optional: fields computed from the parameters
    "ic_memory.cache_share" = "local * (1 - split)"

Every field is a `--set` path (`netsushisen config` lists them) and is checked, with every
value, before anything runs: a bad one is an error located in the spec.

A point's key is a hash of everything its result is a function of: the scene's NFF text, the
kernel sources, the resolution, the full resolved configuration, the engine and the project's
version (the kernels' defines are a function of these). `points/KEY.json` holds its result; a
rerun computes only the points whose file is missing.

`run_sweep` runs the points not cached on the cluster layer (netsushisen/cluster.py) and writes
the results tables (reports/sweep_table.py); the command only parses, calls it and prints.
"""

from __future__ import annotations

import ast
import hashlib
import itertools
import json
import math
import operator
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from netsushisen import __version__
from netsushisen.cluster import ResultCache, Task, kernel_digest, run_tasks, scene_digest
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.limits import MAX_CONSTANT_BITS, MAX_SWEEP_POINTS, read_input
from netsushisen.isa.config import MachineConfig, apply_override, dump_toml, load_config
from netsushisen.options import MAX_RES
from netsushisen.reports.sweep_table import write_results

SPEC_KEYS = ("scenes", "res", "config", "set", "engine", "vary", "zip", "derive")


class SpecError(NetsushisenError):
    """A sweep spec that cannot run: located in the spec file."""


@dataclass(frozen=True)
class Point:
    """One run of a sweep: a scene and the value of every varied field (parameters included)."""

    scene: str
    values: tuple[tuple[str, Any], ...]
    sets: tuple[str, ...]  # the `--set` overrides of the point (fixed ones first)
    key: str = ""

    def row(self) -> dict[str, Any]:
        return {"scene": self.scene, **dict(self.values)}


@dataclass
class Spec:
    path: Path
    scenes: list[str]
    res: int
    config_file: str | None
    sets: list[str]
    engine: str | None
    axes: list[list[dict[str, Any]]] = field(default_factory=list)  # each: assignments in order
    derive: dict[str, str] = field(default_factory=dict)

    @property
    def fields(self) -> list[str]:
        """Every varied name (axis fields and parameters, then derived fields), in spec order."""
        names = [k for axis in self.axes for k in axis[0]] if self.axes else []
        return names + list(self.derive)


def is_field(name: str) -> bool:
    """A configuration field (`ring.fifo_depth`, `pes`), else a parameter of the spec."""
    import dataclasses
    return "." in name or name in {f.name for f in dataclasses.fields(MachineConfig)}


def _line_of(text: str, key: str) -> int | None:
    """The 1-based line where `key` is assigned in the spec (tomllib gives no positions)."""
    for i, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        for k in (key, f'"{key}"', f"'{key}'"):
            if s.startswith(k) and s[len(k):].lstrip().startswith("="):
                return i
    return None


def _values(name: str, raw: Any, where) -> list[Any]:
    if isinstance(raw, list):
        if not raw:
            raise SpecError(where(f"'{name}' has no values"))
        return raw
    if isinstance(raw, dict) and set(raw) == {"start", "stop", "step"}:
        start, stop, step = raw["start"], raw["stop"], raw["step"]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (start, stop, step)) \
                or step <= 0 or stop < start:
            raise SpecError(where(f"'{name}': a range needs numbers with step > 0 and stop ≥ start"))
        if not all(math.isfinite(v) for v in (start, stop, step)):
            raise SpecError(where(f"'{name}': a range needs finite numbers"))
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        if n > MAX_SWEEP_POINTS:
            raise SpecError(where(f"'{name}': a range of {n:,} values, more than "
                                  f"{MAX_SWEEP_POINTS:,} (limits.MAX_SWEEP_POINTS)"))
        if all(isinstance(v, int) for v in (start, stop, step)):
            return [start + i * step for i in range(n)]
        return [round(start + i * step, 12) for i in range(n)]
    raise SpecError(where(f"'{name}': give a list of values or {{start, stop, step}}"))


_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
        ast.Div: operator.truediv, ast.FloorDiv: operator.floordiv, ast.Pow: operator.pow}


def evaluate(expr: str, names: dict[str, Any]) -> Any:
    """An arithmetic expression over numbers and the point's parameters (+ − × / // ** and
    parentheses; nothing else is allowed)."""
    def ev(node: ast.AST) -> Any:
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return node.value
        if isinstance(node, ast.Name):
            if node.id not in names:
                raise ValueError(f"unknown name {node.id!r} (parameters: {', '.join(names) or 'none'})")
            value = names[node.id]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{node.id!r} is {value!r}, not a number")
            return value
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            a, b = ev(node.left), ev(node.right)
            if isinstance(node.op, ast.Pow) and isinstance(a, int) and isinstance(b, int) \
                    and abs(a) > 1 and b * math.log2(abs(a)) > MAX_CONSTANT_BITS:
                raise ValueError(f"a power of more than {MAX_CONSTANT_BITS} bits "
                                 "(limits.MAX_CONSTANT_BITS)")
            v = _OPS[type(node.op)](a, b)
            if isinstance(v, int) and v.bit_length() > MAX_CONSTANT_BITS:
                raise ValueError(f"a result of more than {MAX_CONSTANT_BITS} bits "
                                 "(limits.MAX_CONSTANT_BITS)")
            if not isinstance(v, (int, float)):  # e.g. a complex power of a negative number
                raise ValueError(f"{v!r} is not a real number")
            return v
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            v = ev(node.operand)
            return -v if isinstance(node.op, ast.USub) else v
        raise ValueError(f"only numbers, parameters and + - * / // ** are allowed, not {ast.dump(node)[:40]}")
    try:
        return ev(ast.parse(expr, mode="eval"))
    except SyntaxError as err:
        raise ValueError(f"not an expression: {err.msg}") from None
    except ZeroDivisionError:
        raise ValueError("division by zero") from None
    except (OverflowError, RecursionError, MemoryError):
        raise ValueError("the number or the expression is too large") from None


def load_spec(path: str | Path) -> Spec:
    """Read and check a spec: every field, every value and every derived expression is tried on
    the base configuration, so a mistake is reported, located, before any point runs."""
    path = Path(path)
    try:
        text = read_input(path, "sweep spec").decode("utf-8")
        data = tomllib.loads(text)
    except (FileNotFoundError, IsADirectoryError):
        raise SpecError(Diagnostic("no such sweep spec", file=str(path))) from None
    except RecursionError:
        raise SpecError(Diagnostic("not valid TOML: nested too deeply", file=str(path))) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise SpecError(Diagnostic(f"not valid TOML: {err}", file=str(path))) from None

    def where(message: str, key: str | None = None) -> Diagnostic:
        return Diagnostic(message, file=str(path), line=_line_of(text, key) if key else None)

    errors: list[Diagnostic] = []
    for k in data:
        if k not in SPEC_KEYS:
            errors.append(where(f"unknown key '{k}' (a spec has: {', '.join(SPEC_KEYS)})", k))
    scenes = data.get("scenes")
    if not isinstance(scenes, list) or not scenes or not all(isinstance(s, str) for s in scenes):
        errors.append(where("'scenes' must be a non-empty list of scene names or .nff files", "scenes"))
        scenes = []
    res = data.get("res", 32)
    if not isinstance(res, int) or isinstance(res, bool) or not 1 <= res <= MAX_RES:
        errors.append(where(f"'res' must be an integer 1..{MAX_RES}, not {res!r}", "res"))
    sets = data.get("set", [])
    if not isinstance(sets, list) or not all(isinstance(s, str) for s in sets):
        errors.append(where("'set' must be a list of 'path.to.field=value' strings", "set"))
        sets = []
    base = data.get("config")
    if base is not None and not isinstance(base, str):
        errors.append(where("'config' must be the path of a configuration file", "config"))
        base = None
    engine = data.get("engine")
    if engine is not None:
        from netsushisen.emulator.engine import check_engine
        try:
            check_engine(engine)
        except NetsushisenError as err:
            errors.append(where(f"'engine': {err.diagnostics[0].message}", "engine"))
    scenes = [_scene_path(s, path) for s in scenes]
    base_file = str((path.parent / base).resolve()) if base else None
    spec = Spec(path, scenes, res if isinstance(res, int) else 32, base_file, sets, engine)
    for section in ("vary", "zip", "derive"):
        if section in data and not isinstance(data[section], dict):
            errors.append(where(f"[{section}] must be a table", section))
            data[section] = {}
    for name, raw in data.get("vary", {}).items():
        try:
            spec.axes.append([{name: v} for v in _values(name, raw, lambda m: where(m, name))])
        except SpecError as err:
            errors.extend(err.diagnostics)
    zipped = data.get("zip", {})
    if zipped:
        try:
            cols = {n: _values(n, raw, lambda m, n=n: where(m, n)) for n, raw in zipped.items()}
            lengths = {len(v) for v in cols.values()}
            if len(lengths) > 1:
                raise SpecError(where("[zip] lists must have equal lengths "
                                      f"({', '.join(f'{n}: {len(v)}' for n, v in cols.items())})", "zip"))
            spec.axes.append([{n: cols[n][i] for n in cols} for i in range(lengths.pop())])
        except SpecError as err:
            errors.extend(err.diagnostics)
    for name, expr in data.get("derive", {}).items():
        if not isinstance(expr, str) or not is_field(name):
            errors.append(where(f"[derive] '{name}': a configuration field = \"expression\"", name))
        else:
            spec.derive[name] = expr
    if not spec.axes and not errors:
        errors.append(where("nothing to vary: add a [vary] (or [zip]) table"))
    total = len(spec.scenes) * math.prod(len(axis) for axis in spec.axes)
    if total > MAX_SWEEP_POINTS:
        errors.append(where(f"{total:,} points ({len(spec.scenes)} scenes × "
                            f"{' × '.join(str(len(a)) for a in spec.axes)} values), more than "
                            f"{MAX_SWEEP_POINTS:,} (limits.MAX_SWEEP_POINTS)"))
    if errors:
        raise SpecError(errors)
    _check_points(spec, text, where)
    return spec


def _scene_path(scene: str, spec_path: Path) -> str:
    from netsushisen.host.catalog import parse_spec
    if parse_spec(scene) is not None:
        return scene
    p = Path(scene)
    return str(p if p.is_absolute() else (spec_path.parent / p).resolve())


def _check_points(spec: Spec, text: str, where) -> None:
    """Build and validate every point's configuration (each field, each value, each derived
    value): every distinct problem is reported, located at the field it names."""
    try:
        base = load_config(spec.config_file, spec.sets)
    except NetsushisenError as err:
        raise SpecError([where(f"base configuration: {d.message}", "config") for d in err.diagnostics]) from None
    from netsushisen.pipeline import check_fifo_depth
    errors: dict[str, Diagnostic] = {}

    def problem(name: str | None, message: str, at: str = "") -> None:
        if message not in errors:  # each problem once, at the first point that has it
            errors[message] = where(message + at, name)

    for assignment in _assignments(spec):
        config = _copy(base)
        ok = True
        for name, value in list(assignment.items()) + [(n, None) for n in spec.derive]:
            if not is_field(name):
                continue
            try:
                if name in spec.derive:
                    value = evaluate(spec.derive[name], assignment)
                apply_override(config, f"{name}={_toml(value)}")
            except (ValueError, TypeError, NetsushisenError) as err:
                msg = err.diagnostics[0].message if isinstance(err, NetsushisenError) else str(err)
                label = f"[derive] '{name}' = {spec.derive[name]!r}" if name in spec.derive \
                    else f"'{name}' = {value!r}"
                problem(name, f"{label}: {msg}")
                ok = False
        if ok:
            try:
                config.validate("sweep point")
                check_fifo_depth(config)
            except NetsushisenError as err:
                for d in err.diagnostics:
                    named = [n for n in assignment if n in d.message] + \
                            [n for n in spec.derive if n in d.message]
                    shown = ", ".join(f"{n} = {assignment[n]!r}" for n in assignment if is_field(n))
                    problem(named[0] if named else None, d.message, f" (at {shown})")
        if len(errors) >= 20:
            break
    if errors:
        raise SpecError(list(errors.values()))


def _copy(config: MachineConfig) -> MachineConfig:
    import copy
    return copy.deepcopy(config)


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    return repr(value)


def _assignments(spec: Spec):
    """Every combination of the axes, as one dict of names to values (derived fields excluded)."""
    for combo in itertools.product(*spec.axes):
        merged: dict[str, Any] = {}
        for part in combo:
            merged.update(part)
        yield merged


def points(spec: Spec) -> list[Point]:
    """Scenes × the product of the axes, each with its content key."""
    out = []
    for scene in spec.scenes:
        for assignment in _assignments(spec):
            values = dict(assignment)
            for name, expr in spec.derive.items():
                values[name] = evaluate(expr, assignment)
            sets = tuple(spec.sets) + tuple(f"{k}={_toml(v)}" for k, v in values.items() if is_field(k))
            out.append(Point(scene, tuple(values.items()), sets))
    return out


def point_config(spec: Spec, point: Point) -> MachineConfig:
    return load_config(spec.config_file, list(point.sets))


def with_keys(spec: Spec, pts: list[Point], engine: str) -> list[Point]:
    kernels = kernel_digest()
    scenes = {s: scene_digest(s) for s in spec.scenes}
    out = []
    for p in pts:
        h = hashlib.sha256()
        for part in (scenes[p.scene], kernels, str(spec.res), dump_toml(point_config(spec, p)),
                     engine, __version__):
            h.update(part.encode() + b"\0")
        out.append(Point(p.scene, p.values, p.sets, h.hexdigest()[:20]))
    return out


# -- one point, in a worker ---------------------------------------------------------------------

_MEMO = None


def run_point(task: dict) -> dict:
    """Render one point (runs in a Dask worker; the host work of its scene is kept between
    points: render.HostMemo). Never raises for bad input or a failed run: the result says."""
    global _MEMO
    from netsushisen.pipeline import HostMemo, finish, prepare
    if _MEMO is None:
        _MEMO = HostMemo()
    t0 = time.perf_counter()
    out = {"key": task["key"], "scene": task["scene"], "values": task["values"],
           "version": __version__, "engine": task["engine"]}
    try:
        config = load_config(task["config_file"], list(task["sets"]))
        setup = prepare(task["scene"], config, task["res"], memo=_MEMO)
        eng = setup.engine(task["engine"])
        run = eng.run()
        result = finish(setup, eng, run)
        out["status"] = run.status
        out["error"] = run.error.format() if run.error is not None else ""
        out["stats"] = result.stats
    except NetsushisenError as err:
        out["status"] = "error"
        out["error"] = err.format()
        out["stats"] = None
    out["seconds"] = time.perf_counter() - t0
    return out


# -- running a sweep: every point not cached, on the cluster layer -----------------------------

FAILED = ("error", "fault", "deadlock", "max_cycles", "interrupted", "lost")


def check_sweep_footprint(spec: Spec, engine: str, quiet: bool) -> None:
    """Before the cluster starts: the largest point must fit a worker's host (and the machine's
    frame); a large one is announced (isa/limits.py)."""
    from netsushisen.isa.limits import machine_bytes
    from netsushisen.options import check_footprint

    configs = [point_config(spec, p) for p in points(spec)]
    if configs:
        largest = max(configs, key=lambda c: machine_bytes(c, engine))
        check_footprint(f"sweep point of {spec.path.name}", largest, spec.res, engine, quiet=quiet)


def engine_of(name: str | None) -> str:
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
    results, seen = [], set()
    for p in pts:
        if p.key in seen or not cache.has(p.key):
            continue
        seen.add(p.key)
        result = cache.load(p.key)
        if isinstance(result, dict) and "status" in result:
            results.append(result)
    return write_results(out, spec.fields, results)
