"""Mutation testing for netsushisen (issue 18): do the fast tests catch a planted bug?

cosmic-ray supplies the mutation operators (one AST change at a time), the enumeration of every
mutant and the session database; this driver supplies what the project's layout needs and
cosmic-ray's own `exec` does not:

- the worktree is never touched: each worker mutates its own copy of the tree, made importable
  as `netsushisen` by links that mirror pyproject's package-dir (isa/ -> netsushisen/isa, ...)
  and put first on PYTHONPATH, ahead of the editable install's finder;
- each module is judged by the fast test files it maps to (tools/mutation.toml), on the
  reference engine only, stopping at the first failure;
- a seeded random sample when the whole set does not fit in an hour (`--all` runs every mutant);
- a timeout per group taken from its baseline run (a mutant that hangs counts as killed);
- equivalent mutants listed with reasons in tools/mutation.toml and set aside in the score.

Usage: python tools/mutate.py [--all | --sample N] [--seed S] [--jobs J] [--group NAME]
       [--mutant MODULE:OPERATOR:OCCURRENCE ...] [--workdir DIR] [--fail-under PCT]
Writes DIR/results.json and DIR/report.md (every survivor with its diff); exits 1 when the score
is under --fail-under, 2 on bad input, 130 on Ctrl-C (the mutants already run are reported).
"""

from __future__ import annotations

import argparse
import ast
import functools
import json
import os
import queue
import random
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

PROJECT = Path(__file__).resolve().parents[1]
CONFIG = PROJECT / "tools" / "mutation.toml"


class MutateError(Exception):
    """Bad input (config, option, missing tool): reported as one located line, exit 2."""


@dataclass(frozen=True)
class Group:
    """Modules mutated together and the fast test files that judge them."""
    name: str
    modules: tuple[str, ...]
    tests: tuple[str, ...]
    engine: str = "reference"
    """The engine the tests run on: `compiled` for the compiled engine's own code (each mutant
    then compiles its loop, about a minute, in a numba cache of its tree's own)."""
    functions: tuple[str, ...] = ()
    """Only mutants inside these top-level functions (all of the modules' when empty)."""
    opt_in: bool = False
    """Left out of the default sample; run with `--group NAME` (so adding such a group does
    not change the seeded sample of the others)."""


@dataclass(frozen=True)
class Equivalent:
    """A mutant no test can tell from the original, with the reason why."""
    module: str
    operator: str
    occurrence: int
    line: int
    reason: str


@dataclass(frozen=True)
class Settings:
    seed: int
    sample: int
    jobs: int
    timeout_factor: float
    timeout_min: float
    groups: tuple[Group, ...]
    equivalents: tuple[Equivalent, ...]


@dataclass
class Outcome:
    """One mutant's result as the report shows it."""
    group: str
    module: str
    operator: str
    occurrence: int
    line: int
    status: str              # killed | survived | equivalent | incompetent | no-mutation
    seconds: float
    diff: str = ""
    note: str = ""
    fields: dict = field(default_factory=dict)


def load_settings(path: Path = CONFIG) -> Settings:
    """Read and check tools/mutation.toml; every error names the file and the entry."""
    where = path.relative_to(PROJECT) if path.is_relative_to(PROJECT) else path
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise MutateError(f"{where}: {err}") from None
    run = data.get("run", {})
    groups = []
    for i, g in enumerate(data.get("group", [])):
        name = g.get("name", f"#{i}")
        for key in ("modules", "tests"):
            if not g.get(key):
                raise MutateError(f"{where}: group {name!r}: '{key}' is empty or missing")
            for rel in g[key]:
                if not (PROJECT / rel).is_file():
                    raise MutateError(f"{where}: group {name!r}: {key[:-1]} {rel!r} does not exist")
        engine = g.get("engine", "reference")
        if engine not in ("reference", "compiled"):
            raise MutateError(f"{where}: group {name!r}: engine {engine!r} is not reference or compiled")
        functions = tuple(g.get("functions", ()))
        missing = set(functions) - {f for rel in g["modules"] for f in function_spans(PROJECT / rel)}
        if missing:
            raise MutateError(f"{where}: group {name!r}: no function {', '.join(sorted(missing))} "
                              f"in {', '.join(g['modules'])}")
        groups.append(Group(name, tuple(g["modules"]), tuple(g["tests"]), engine, functions,
                            bool(g.get("opt-in", False))))
    if not groups:
        raise MutateError(f"{where}: no [[group]]")
    equivalents = []
    for i, e in enumerate(data.get("equivalent", [])):
        missing = [k for k in ("module", "operator", "occurrence", "line", "reason") if k not in e]
        if missing:
            raise MutateError(f"{where}: equivalent #{i + 1}: missing {', '.join(missing)}")
        equivalents.append(Equivalent(e["module"], e["operator"], int(e["occurrence"]),
                                      int(e["line"]), e["reason"]))
    return Settings(int(run.get("seed", 0)), int(run.get("sample", 0)), int(run.get("jobs", 1)),
                    float(run.get("timeout-factor", 4)), float(run.get("timeout-min", 30)),
                    tuple(groups), tuple(equivalents))


def make_tree(workdir: Path, index: int) -> Path:
    """A fresh copy of the worktree (tracked and untracked-but-not-ignored files), importable as
    `netsushisen` from its root, with ../shared beside it as the tests expect."""
    listing = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=PROJECT,
                             capture_output=True, check=True).stdout.decode().split("\0")
    root = workdir / f"tree{index}"
    if root.exists():
        shutil.rmtree(root)
    tree = root / "project"
    for rel in filter(None, listing):
        src = PROJECT / rel
        if src.is_file():
            (tree / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, tree / rel)
    shared = PROJECT.parent / "shared"
    if shared.exists():
        (root / "shared").symlink_to(shared.resolve())
    package_dir = tomllib.loads((PROJECT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    for package, folder in package_dir.items():
        link = tree / package.replace(".", "/")
        if package.count(".") == 1 and not link.exists():
            link.symlink_to(Path("..") / folder)
    return tree


def test_command(tree: Path, group: Group) -> str:
    """The group's tests on the copy: its engine, one process, stop at the first failure. The
    compiled engine caches its code under the tree (a mutant's loop is a new cache entry, never
    one the user's runs load)."""
    cache = [f"NETSUSHISEN_CACHE={tree.parent / 'numba-cache'}"] if group.engine == "compiled" else []
    return shlex.join(["env", "-C", str(tree), f"PYTHONPATH={tree}", *cache, sys.executable, "-m",
                       "pytest", "-p", "no:xdist", "-x", "-q", "--engine", group.engine, *group.tests])


def enumerate_mutants(groups: tuple[Group, ...], session: Path) -> list[tuple[Group, object]]:
    """Every mutant of every group's modules (cosmic-ray's operators), in a stable order."""
    import cosmic_ray.commands
    from cosmic_ray.work_db import WorkDB, use_db

    if session.exists():
        session.unlink()
    by_module = {m: g for g in groups for m in g.modules}
    cwd = os.getcwd()
    os.chdir(PROJECT)            # work items keep project-relative module paths
    try:
        with use_db(str(session), WorkDB.Mode.create) as db:
            cosmic_ray.commands.init([Path(m) for m in by_module], db, {})
            items = list(db.work_items)
    finally:
        os.chdir(cwd)
    items.sort(key=lambda w: (str(w.mutations[0].module_path), w.mutations[0].operator_name,
                              w.mutations[0].occurrence))
    return [(by_module[str(w.mutations[0].module_path)], w) for w in items]


def annotation_spans(module: Path) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Where a module's annotations are: every module here has `from __future__ import
    annotations`, so an annotation is a string never evaluated (dataclasses read only the
    ClassVar/InitVar names), and a mutant inside one (`int | None` -> `int ^ None`) is
    equivalent by construction. Such mutants are set aside before sampling."""
    tree = ast.parse(module.read_text())
    if not any(isinstance(n, ast.ImportFrom) and n.module == "__future__"
               and any(a.name == "annotations" for a in n.names) for n in tree.body):
        return []
    notes = []
    for node in ast.walk(tree):
        if isinstance(node, ast.arg) and node.annotation is not None:
            notes.append(node.annotation)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.returns is not None:
            notes.append(node.returns)
        elif isinstance(node, ast.AnnAssign):
            notes.append(node.annotation)
    return [((n.lineno, n.col_offset), (n.end_lineno, n.end_col_offset)) for n in notes]


@functools.lru_cache(maxsize=None)
def function_spans(module: Path) -> dict[str, tuple[int, int]]:
    """Top-level functions of a module: name -> (first line, last line), decorators included."""
    tree = ast.parse(module.read_text())
    return {n.name: (min([n.lineno, *(d.lineno for d in n.decorator_list)]), n.end_lineno)
            for n in tree.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}


def in_functions(mutant, group: Group) -> bool:
    """Whether a mutant lies in one of its group's functions (every mutant when none named)."""
    if not group.functions:
        return True
    spec = mutant.mutations[0]
    spans = function_spans(PROJECT / spec.module_path)
    return any(spans[f][0] <= spec.start_pos[0] <= spans[f][1] for f in group.functions if f in spans)


def in_annotation(mutant, spans: dict) -> bool:
    spec = mutant.mutations[0]
    where = (spec.start_pos[0], spec.start_pos[1])
    return any(a <= where < b for a, b in spans[str(spec.module_path)])


def choose(mutants: list, sample: int, seed: int, groups: set[str], wanted: list[str]) -> list:
    """The mutants to run: the named ones, else a seeded sample (0 = all) of the chosen groups."""
    if wanted:
        def name(w) -> str:
            spec = w.mutations[0]
            return f"{spec.module_path}:{spec.operator_name}:{spec.occurrence}"
        chosen = [(g, w) for g, w in mutants if name(w) in set(wanted)]
        missing = sorted(set(wanted) - {name(w) for _, w in chosen})
        if missing:
            raise MutateError(f"--mutant: no mutant {', '.join(missing)} (MODULE:OPERATOR:OCCURRENCE, "
                              "as results.json names them)")
        return chosen
    pool = [(g, w) for g, w in mutants if g.name in groups or (not groups and not g.opt_in)]
    if sample and sample < len(pool):
        picked = sorted(random.Random(seed).sample(range(len(pool)), sample))
        pool = [pool[i] for i in picked]
    return pool


def baseline(tree: Path, group: Group) -> float:
    """The group's tests on the unmutated copy must pass; returns their wall seconds."""
    start = time.monotonic()
    proc = subprocess.run(shlex.split(test_command(tree, group)), capture_output=True, text=True)
    if proc.returncode != 0:
        tail = (proc.stdout + proc.stderr).strip().splitlines()[-1:] or ["(no output)"]
        raise MutateError(f"group {group.name!r}: the tests fail before any mutation: {tail[0]}")
    return time.monotonic() - start


def classify(group: Group, item, result, seconds: float, equivalents: dict) -> Outcome:
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome

    spec = item.mutations[0]
    module, line = str(spec.module_path), spec.start_pos[0]
    outcome = Outcome(group.name, module, spec.operator_name, spec.occurrence, line, "", seconds,
                      result.diff or "")
    if result.worker_outcome == WorkerOutcome.NO_TEST:
        outcome.status = "no-mutation"
    elif result.test_outcome == TestOutcome.KILLED:
        outcome.status = "killed"
        outcome.note = "timeout" if result.output == "timeout" else ""
    elif result.test_outcome == TestOutcome.SURVIVED:
        outcome.status = "survived"
    else:
        outcome.status = "incompetent"
        outcome.note = (result.output or "").strip().splitlines()[-1:][0] if result.output else ""
    eq = equivalents.get((module, spec.operator_name, spec.occurrence))
    if eq is not None:
        if eq.line != line:
            outcome.note = f"equivalent entry is stale: it names line {eq.line}, the mutant is on {line}"
        elif outcome.status == "survived":
            outcome.status, outcome.note = "equivalent", eq.reason
        elif outcome.status == "killed":
            outcome.note = "listed as equivalent but a test kills it: drop the entry"
    return outcome


def earlier(path: Path) -> tuple[list[Outcome], list[str]]:
    """An earlier run's killed mutants (kept) and the names of the rest (to run again)."""
    try:
        rows = json.loads(path.read_text())["mutants"]
    except (OSError, ValueError, KeyError) as err:
        raise MutateError(f"--retest {path}: not a results.json of tools/mutate.py ({err})") from None
    kept = [Outcome(**r) for r in rows if r["status"] == "killed"]
    again = [f"{r['module']}:{r['operator']}:{r['occurrence']}" for r in rows if r["status"] != "killed"]
    return kept, again


def summary(outcomes: list[Outcome]) -> dict:
    counts = {s: sum(o.status == s for o in outcomes)
              for s in ("killed", "survived", "equivalent", "incompetent", "no-mutation")}
    judged = counts["killed"] + counts["survived"]
    counts["run"] = len(outcomes)
    counts["score"] = round(100.0 * counts["killed"] / judged, 2) if judged else 100.0
    return counts


def write_report(workdir: Path, outcomes: list[Outcome], info: dict) -> None:
    """results.json (every mutant) and report.md (counts, then every survivor with its diff)."""
    counts = summary(outcomes)
    (workdir / "results.json").write_text(json.dumps(
        {"info": info, "counts": counts,
         "mutants": [{k: v for k, v in o.__dict__.items() if k != "fields"} for o in outcomes]},
        indent=1, sort_keys=True))
    lines = [f"# Mutation run {info['date']}", "", f"- {info['what']}",
             f"- wall time {info['wall_seconds']:.0f} s, {info['jobs']} workers", "",
             "| run | killed | survived | equivalent | incompetent | score |", "|---|---|---|---|---|---|",
             f"| {counts['run']} | {counts['killed']} | {counts['survived']} | {counts['equivalent']} "
             f"| {counts['incompetent']} | {counts['score']} % |", ""]
    for o in sorted(outcomes, key=lambda o: (o.module, o.line)):
        if o.status in ("survived", "incompetent") or o.note.startswith(("equivalent entry", "listed")):
            lines += [f"## {o.status}: {o.module}:{o.line} {o.operator}#{o.occurrence}",
                      *([o.note, ""] if o.note else []), "```diff", o.diff.strip(), "```", ""]
    (workdir / "report.md").write_text("\n".join(lines))


def parse_args(argv: list[str] | None, settings: Settings) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="tools/mutate.py", description=__doc__.splitlines()[0])
    parser.add_argument("--all", action="store_true", help="every mutant, not a sample")
    parser.add_argument("--sample", type=int, default=settings.sample, help="mutants drawn (default %(default)s)")
    parser.add_argument("--seed", type=int, default=settings.seed, help="sample seed (default %(default)s)")
    parser.add_argument("--jobs", type=int, default=settings.jobs, help="parallel workers (default %(default)s)")
    parser.add_argument("--group", action="append", default=[], help="only this group (repeatable)")
    parser.add_argument("--mutant", action="append", default=[], metavar="MODULE:OPERATOR:OCCURRENCE",
                        help="run just this mutant (repeatable; ignores the sample)")
    parser.add_argument("--retest", type=Path, metavar="RESULTS_JSON",
                        help="the mutants of an earlier run: rerun its survivors (and equivalents), "
                             "keep its killed ones (tests only get added, so a kill stands)")
    parser.add_argument("--workdir", type=Path,
                        default=Path(tempfile.gettempdir()) / f"netsushisen-mutation-{os.getuid()}",
                        help="copies, session and report (default %(default)s)")
    parser.add_argument("--fail-under", type=float, default=95.0, help="exit 1 under this score (default %(default)s)")
    args = parser.parse_args(argv)
    if args.jobs < 1 or args.sample < 0:
        parser.error("--jobs must be >= 1 and --sample >= 0")
    unknown = set(args.group) - {g.name for g in settings.groups}
    if unknown:
        parser.error(f"--group: no group {', '.join(sorted(unknown))} in tools/mutation.toml")
    return args


def main(argv: list[str] | None = None) -> int:
    try:
        settings = load_settings()
        args = parse_args(argv, settings)
        try:
            from cosmic_ray.mutating import mutate_and_test
            from cosmic_ray.work_item import MutationSpec
        except ImportError:
            raise MutateError("cosmic-ray is not installed: pip install -e '.[test,mutation]'") from None
        args.workdir.mkdir(parents=True, exist_ok=True)
        mutants = enumerate_mutants(settings.groups, args.workdir / "session.sqlite")
        spans = {m: annotation_spans(PROJECT / m) for g in settings.groups for m in g.modules}
        typed = [(g, w) for g, w in mutants if in_annotation(w, spans)]
        mutants = [(g, w) for g, w in mutants if not in_annotation(w, spans) and in_functions(w, g)]
        kept: list[Outcome] = []
        if args.retest:
            kept, wanted = earlier(args.retest)
            args.mutant = wanted
        chosen = ([] if args.retest and not args.mutant else
                  choose(mutants, 0 if args.all else args.sample, args.seed, set(args.group), args.mutant))
        groups = sorted({g for g, _ in chosen}, key=lambda g: g.name)
        print(f"{len(mutants)} mutants in {sum(len(g.modules) for g in settings.groups)} modules "
              f"({len(typed)} more inside annotations set aside as equivalent); "
              f"running {len(chosen)} ({'named' if args.mutant else 'all' if len(chosen) == len(mutants) else f'seeded sample, seed {args.seed}'}) "
              f"on {args.jobs} workers", flush=True)
        trees = [make_tree(args.workdir, j) for j in range(args.jobs)]
        with ThreadPoolExecutor(args.jobs) as pool:
            base = dict(zip(groups, pool.map(lambda g: baseline(trees[0], g), groups)))
    except MutateError as err:
        print(f"mutate: {err}", file=sys.stderr)
        return 2
    for g, secs in base.items():
        print(f"  baseline {g.name}: {secs:.1f} s", flush=True)
    timeouts = {g: max(settings.timeout_min, settings.timeout_factor * s) for g, s in base.items()}
    equivalents = {(e.module, e.operator, e.occurrence): e for e in settings.equivalents}
    free: queue.Queue[Path] = queue.Queue()
    for t in trees:
        free.put(t)

    def run(group: Group, item):
        tree = free.get()
        try:
            spec = item.mutations[0]
            start = time.monotonic()
            result = mutate_and_test([MutationSpec(tree / spec.module_path, spec.operator_name,
                                                   spec.occurrence, spec.start_pos, spec.end_pos,
                                                   spec.operator_args)],
                                     test_command(tree, group), timeouts[group])
            outcome = classify(group, item, result, time.monotonic() - start, equivalents)
            outcome.diff = outcome.diff.replace(f"{tree}/", "")
            return outcome
        finally:
            free.put(tree)

    outcomes: list[Outcome] = list(kept)
    start = time.monotonic()
    info = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "seed": args.seed,
            "jobs": args.jobs, "total_mutants": len(mutants), "in_annotations": len(typed),
            "what": f"{len(chosen)} of {len(mutants)} mutants"
                    + ("" if args.mutant or len(chosen) == len(mutants) else f" (seeded sample, seed {args.seed})")}
    if args.retest:
        before = json.loads(args.retest.read_text())["info"]
        info["what"] = (f"{before['what']}: {len(kept)} killed kept from the run of {before['date']}, "
                        f"{len(chosen)} survivors and equivalents run again")
        info["earlier_wall_seconds"] = before["wall_seconds"] + before.get("earlier_wall_seconds", 0)
    pool = ThreadPoolExecutor(args.jobs)
    futures = [pool.submit(run, g, w) for g, w in chosen]
    interrupted = False
    try:
        for n, fut in enumerate(as_completed(futures), 1):
            o = fut.result()
            outcomes.append(o)
            print(f"[{n:4}/{len(chosen)}] {o.status:11} {o.seconds:5.1f}s {o.module}:{o.line} "
                  f"{o.operator}#{o.occurrence} {o.note}", flush=True)
    except KeyboardInterrupt:
        interrupted = True
        pool.shutdown(wait=False, cancel_futures=True)
    else:
        pool.shutdown()
    info["wall_seconds"] = time.monotonic() - start
    per = info["wall_seconds"] / max(len(outcomes) - len(kept), 1)  # mutants run in this call
    info["full_run_estimate_seconds"] = round(per * len(mutants))
    write_report(args.workdir, outcomes, info)
    counts = summary(outcomes)
    print(f"{'interrupted: ' if interrupted else ''}{counts['run']} run: {counts['killed']} killed, "
          f"{counts['survived']} survived, {counts['equivalent']} equivalent, "
          f"{counts['incompetent']} incompetent; score {counts['score']} % after equivalents; "
          f"{info['wall_seconds']:.0f} s ({per:.1f} s a mutant, all {len(mutants)} would take "
          f"~{info['full_run_estimate_seconds'] / 60:.0f} min); report {args.workdir / 'report.md'}")
    if interrupted:
        return 130
    return 1 if counts["score"] < args.fail_under else 0


if __name__ == "__main__":
    sys.exit(main())
