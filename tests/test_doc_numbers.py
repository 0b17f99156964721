"""tools/doc_numbers.py (issue 29): the cheap quoted numbers (cycles, bundles, ILP, stalls at
small sizes) match a fresh run, and an edited one is caught with its file and line and put back
by --write."""

from __future__ import annotations

import importlib.util
import re
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _tool():
    spec = importlib.util.spec_from_file_location("doc_numbers", ROOT / "tools" / "doc_numbers.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["doc_numbers"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def _copy_documents(tool, cheap, to: Path) -> None:
    for file in {c.file for c in cheap}:
        (to / file).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / file, to / file)


def test_cheap_quoted_numbers_match_and_an_edit_is_caught(tmp_path):
    tool = _tool()
    cheap = [c for c in tool.CLAIMS if c.cheap]
    assert {c.file for c in cheap} >= {"README.md", "docs/timeline.md", "docs/api.md"}
    assert tool.check(ROOT, cheap) == []
    _copy_documents(tool, cheap, tmp_path)
    doc = tmp_path / "docs" / "timeline.md"
    measured = tool.cycles("tetra", 4)
    doc.write_text(doc.read_text().replace(f"its {measured:,} cycles", f"its {measured + 1:,} cycles"))
    # a cycle count in a README table row (tetra's ILP row at 16×16), one off
    readme = tmp_path / "README.md"
    row = tool.cycles("tetra", 16)
    text = readme.read_text()
    assert re.search(rf"\| tetra \| {row:,} \| [\d.]+ / ", text)
    readme.write_text(text.replace(f"| tetra | {row:,} |", f"| tetra | {row - 1:,} |", 1))
    problems = tool.check(tmp_path, cheap)
    assert len(problems) == 2, problems
    assert any(p.startswith("docs/timeline.md:22:") and f"{measured + 1:,}" in p for p in problems)
    assert any(p.startswith("README.md:") and "ILP table row tetra" in p and f"{row:,}" in p for p in problems)
    tool.check(tmp_path, cheap, write=True)  # --write puts the measured numbers back
    assert tool.check(tmp_path, cheap) == []
    assert readme.read_text() == (ROOT / "README.md").read_text()


def test_a_claim_that_left_its_document_is_reported(tmp_path):
    tool = _tool()
    claim = next(c for c in tool.CLAIMS if c.file == "docs/timeline.md")
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "timeline.md").write_text("the sentence was rewritten\n")
    problems = tool.check(tmp_path, [claim])
    assert problems == [f"docs/timeline.md: the claim '{claim.what}' (/{claim.pattern}/) is not in the document"]


def test_formats_are_the_documents():
    tool = _tool()
    assert tool.change(309_434, 267_640) == "−13.5" and tool.change(20_589, 22_744) == "+10.5"
    assert tool.count(1_193_425) == "1,193,425" and tool.share(0.357) == "36" and tool.fixed(1.2799, 3) == "1.280"


def test_times_match_within_their_factor_and_cycles_exactly(tmp_path):
    """A time the README gives as "about N s" on the machine it names matches a measurement
    within a factor of 2; a cycle count only exactly; the Quickstart's numbers are claims."""
    tool = _tool()
    whats = {c.what: c for c in tool.CLAIMS}
    assert whats["Quickstart: tetra 64x64 seconds from an empty cache"].about == 2.0
    assert whats["Quickstart: tetra 64x64 cycles"].about == 0.0
    assert whats["Quickstart: tetra 64x64 cycles"].cheap  # checked by the default suite
    (tmp_path / "README.md").write_text("takes about 46 s from an empty cache on "
                                        f"{tool.MACHINE}, emulator, 3,910,103 machine cycles\n")
    for measured, problems in (("60", 0), ("30", 0), ("95", 1), ("20", 1)):
        claim = tool.Claim("README.md", whats["Quickstart: tetra 64x64 seconds from an empty "
                                             "cache"].pattern, lambda m=measured: (m,), "time",
                           about=2.0)
        assert len(tool.check(tmp_path, [claim])) == problems, measured
    exact = tool.Claim("README.md", whats["Quickstart: tetra 64x64 cycles"].pattern,
                       lambda: ("3,910,104",), "cycles")
    assert len(tool.check(tmp_path, [exact])) == 1
    assert tool.check(tmp_path, [tool.Claim("README.md", exact.pattern, lambda: ("3,910,103",),
                                            "cycles")]) == []


@pytest.mark.slow
def test_the_quickstart_times_match_about():
    """The Quickstart's seconds (an empty compiled-engine cache, then a cached one), measured
    again as a user runs the command: within the claims' factor (`-m slow`: a minute or two)."""
    tool = _tool()
    timed = [c for c in tool.CLAIMS if c.about]
    assert len(timed) == 2
    assert tool.check(ROOT, timed) == []
