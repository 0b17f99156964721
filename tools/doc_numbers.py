"""The measured numbers the README and docs quote, regenerated from commands and checked.

    python tools/doc_numbers.py [--check | --write] [--cheap] [--root DIR]

Each claim is a number in a document, found by a pattern around it, and the measurement that
produces it (machine cycles of a render on the compiled engine: deterministic). `--check`
(default) measures each and exits 1 listing every quoted number that differs; `--write` puts the
measured numbers into the documents. `--cheap` keeps the claims that take a second or two
(tests/test_doc_numbers.py runs those, so a kernel change that moves one fails until the document
is regenerated with `--write`). The sampled-interval coverage table has its own tool
(tools/interval_coverage.py); the accuracy tables come from `netsushisen accuracy --res 32`.
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Claim:
    file: str  # relative to the root
    pattern: str  # regex; group 1 is the number (digits with thousands commas)
    scene: str
    res: int
    generic: bool = False
    cheap: bool = False

    def describe(self) -> str:
        return f"{self.scene} {self.res}x{self.res}" + (" generic" if self.generic else "") + " cycles"


CLAIMS = (
    Claim("docs/timeline.md", r"MB for its ([\d,]+) cycles", "tetra", 4, cheap=True),
    Claim("README.md", r"do less work: tetra ([\d,]+) vs", "tetra", 16, cheap=True),
    Claim("README.md", r"do less work: tetra [\d,]+ vs ([\d,]+) cycles", "tetra", 16, generic=True),
    Claim("README.md", r"balls ([\d,]+) vs [\d,]+ \(", "balls", 16),
    Claim("README.md", r"balls [\d,]+ vs ([\d,]+) \(", "balls", 16, generic=True),
)


@lru_cache(maxsize=None)
def cycles(scene: str, res: int, generic: bool) -> int:
    from netsushisen.isa.config import MachineConfig
    from netsushisen.pipeline import render

    return int(render(scene, MachineConfig(), res=res, engine="compiled", generic=generic).run.cycles)


def check(root: Path, claims, write: bool = False) -> list[str]:
    """Every claim whose quoted number differs from the measured one (written in with `write`)."""
    problems = []
    for c in claims:
        path = root / c.file
        text = path.read_text(encoding="utf-8")
        m = re.search(c.pattern, text)
        if m is None:
            problems.append(f"{c.file}: the claim /{c.pattern}/ is not in the document")
            continue
        quoted, measured = int(m.group(1).replace(",", "")), cycles(c.scene, c.res, c.generic)
        if quoted != measured:
            line = text.count("\n", 0, m.start(1)) + 1
            problems.append(f"{c.file}:{line}: quotes {quoted:,} for {c.describe()}, measured {measured:,}")
            if write:
                text = text[:m.start(1)] + f"{measured:,}" + text[m.end(1):]
                path.write_text(text, encoding="utf-8")
    return problems


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group()
    g.add_argument("--check", action="store_true", help="measure and compare (default)")
    g.add_argument("--write", action="store_true", help="write the measured numbers into the documents")
    p.add_argument("--cheap", action="store_true", help="only the claims that take a second or two")
    p.add_argument("--root", default=str(ROOT), help="the project root holding the documents")
    args = p.parse_args(argv)
    claims = [c for c in CLAIMS if c.cheap or not args.cheap]
    problems = check(Path(args.root), claims, write=args.write)
    for line in problems:
        print(line, file=sys.stderr)
    if args.write:
        print(f"{len(problems)} of {len(claims)} quoted numbers rewritten")
        return 0
    print(f"{len(claims) - len(problems)} of {len(claims)} quoted numbers match")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
