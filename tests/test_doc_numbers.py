"""tools/doc_numbers.py (issue 29): the cheap quoted cycle counts match a fresh run, and an edited
one is caught with its file and line."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _tool():
    spec = importlib.util.spec_from_file_location("doc_numbers", ROOT / "tools" / "doc_numbers.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["doc_numbers"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_cheap_quoted_cycles_match_and_an_edit_is_caught(tmp_path):
    tool = _tool()
    cheap = [c for c in tool.CLAIMS if c.cheap]
    assert cheap and tool.check(ROOT, cheap) == []
    (tmp_path / "docs").mkdir()
    shutil.copy(ROOT / "README.md", tmp_path / "README.md")
    shutil.copy(ROOT / "docs" / "timeline.md", tmp_path / "docs" / "timeline.md")
    doc = tmp_path / "docs" / "timeline.md"
    measured = tool.cycles("tetra", 4, False)
    doc.write_text(doc.read_text().replace(f"its {measured:,} cycles", f"its {measured + 1:,} cycles"))
    problems = tool.check(tmp_path, cheap)
    assert len(problems) == 1 and problems[0].startswith("docs/timeline.md:") and f"{measured:,}" in problems[0]
    tool.check(tmp_path, cheap, write=True)  # --write puts the measured number back
    assert tool.check(tmp_path, cheap) == []
