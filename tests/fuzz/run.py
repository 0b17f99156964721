"""Run the hostile-input corpus (tests/fuzz/corpus.py) and check the rule for every input: exit 0,
or exit 1 with an `error:` line — never exit 70 (an internal error), never a traceback, never
more than TIME_LIMIT seconds or MEMORY_CEILING of memory.

    python tests/fuzz/run.py [--per-category N] [--only CATEGORY] [--show-failures]

Each case runs as its own process (`python -m netsushisen.cli ARGV`) in a fresh folder; its
peak memory is the child's maximum resident set (os.wait4). The closing note gives the corpus
size by category, the exit codes, the slowest case and the largest peak.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fuzz.corpus import API_HARNESS, CATEGORIES, Case, base_stats, cases  # noqa: E402

TIME_LIMIT = 60.0
"""Seconds one input may take (issue 30's acceptance)."""

MEMORY_CEILING = 2 << 30
"""Peak resident memory one input may take (2 GiB): the tools refuse what would need more
(isa/limits.py) before allocating it."""


@dataclass
class Outcome:
    case: Case
    code: int | None  # None: killed at TIME_LIMIT
    seconds: float
    peak_bytes: int
    stderr: str

    def problem(self) -> str | None:
        """Why this run breaks the rule, or None."""
        if self.code is None:
            return f"took more than {TIME_LIMIT:.0f} s"
        if self.code == 70 or "internal error" in self.stderr:
            return "internal error (exit 70)"
        if "Traceback" in self.stderr:
            return "a traceback"
        if self.code not in (0, 1):
            return f"exit {self.code}"
        if self.code == 1 and "error:" not in self.stderr:
            return "exit 1 without an error line"
        if self.peak_bytes > MEMORY_CEILING:
            return f"peak memory {self.peak_bytes / 2**20:,.0f} MiB"
        return None


def run_case(case: Case, python: str = sys.executable) -> Outcome:
    with tempfile.TemporaryDirectory(prefix="nss-fuzz-") as tmp:
        for name, data in case.files.items():
            (Path(tmp) / name).write_bytes(data)
        env = dict(os.environ, NETSUSHISEN_DEBUG="", PYTHONWARNINGS="ignore")
        env.pop("NETSUSHISEN_DEBUG")
        start = time.perf_counter()
        with open(Path(tmp) / ".stderr", "w+b") as err:
            argv = ([python, "-c", API_HARNESS, case.python] if case.python
                    else [python, "-m", "netsushisen.cli", *case.argv])
            proc = subprocess.Popen(argv, cwd=tmp,
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=err, env=env)
            code: int | None = None
            peak = 0
            while True:
                pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    code = os.waitstatus_to_exitcode(status)
                    peak = usage.ru_maxrss * 1024
                    proc.returncode = code
                    break
                if time.perf_counter() - start > TIME_LIMIT:
                    proc.kill()
                    _, status, usage = os.wait4(proc.pid, 0)
                    proc.returncode = -9
                    peak = usage.ru_maxrss * 1024
                    break
                time.sleep(0.02)
            seconds = time.perf_counter() - start
            err.seek(0)
            stderr = err.read().decode("utf-8", "replace")
    return Outcome(case, code, seconds, peak, stderr)


def corpus(per_category: int) -> list[Case]:
    with tempfile.TemporaryDirectory() as tmp:
        return cases(per_category, base_stats(tmp))


def summary(outcomes: list[Outcome]) -> list[str]:
    by_cat = Counter(o.case.category for o in outcomes)
    codes = Counter(o.code for o in outcomes)
    bad = [o for o in outcomes if o.problem()]
    slowest = max(outcomes, key=lambda o: o.seconds)
    largest = max(outcomes, key=lambda o: o.peak_bytes)
    return [
        f"fuzz: {len(outcomes)} inputs: " + ", ".join(f"{c} {by_cat[c]}" for c in CATEGORIES if by_cat[c]),
        "exits: " + ", ".join(f"{k if k is not None else 'killed'}: {v}" for k, v in sorted(
            codes.items(), key=lambda kv: (kv[0] is None, kv[0] or 0))),
        f"slowest {slowest.case.name} {slowest.seconds:.1f} s (limit {TIME_LIMIT:.0f} s); "
        f"largest peak {largest.case.name} {largest.peak_bytes / 2**20:,.0f} MiB "
        f"(ceiling {MEMORY_CEILING / 2**20:,.0f} MiB)",
        f"{len(bad)} broke the rule" + (": " + ", ".join(f"{o.case.name} ({o.problem()})"
                                                         for o in bad) if bad else ""),
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--per-category", type=int, default=40)
    parser.add_argument("--only", choices=CATEGORIES)
    parser.add_argument("--show-failures", action="store_true")
    args = parser.parse_args(argv)
    todo = [c for c in corpus(args.per_category) if args.only in (None, c.category)]
    outcomes = []
    for i, case in enumerate(todo, 1):
        outcome = run_case(case)
        outcomes.append(outcome)
        if outcome.problem():
            print(f"[{i}/{len(todo)}] {case.name}: {outcome.problem()}: netsushisen "
                  f"{' '.join(a[:60] for a in case.argv)}", file=sys.stderr)
            if args.show_failures:
                print("    " + "\n    ".join(outcome.stderr.strip().splitlines()[-5:]), file=sys.stderr)
    print("\n".join(summary(outcomes)))
    return 1 if any(o.problem() for o in outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
