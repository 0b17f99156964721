"""Imports point down (issue 31, item 3): read from each module's syntax tree, every import
statement included (those inside functions and `if TYPE_CHECKING:` too: a late import is still a
dependency).

- `isa/` (the machine as data) imports nothing above it: only `isa/` and the base;
- `emulator/` (the machine) imports nothing from the top package `netsushisen/` but the base,
  and nothing from `reports/`;
- `reports/` reads statistics and records: it imports neither `host/` nor `emulator/` nor
  numba;
- numba is imported at module level only by the compiled engine (emulator/compiled/), so a
  command that runs no machine never pays for it (tests/test_engine_choice.py runs them with
  numba missing).

The base is the top package's leaf modules every layer reports and writes through —
`errors.py` (diagnostics) and `outputs.py` (atomic writes) — which themselves import nothing of
the project but each other.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"isa": "netsushisen.isa", "asm": "netsushisen.asm", "emulator": "netsushisen.emulator",
            "host": "netsushisen.host", "reports": "netsushisen.reports",
            "debugger": "netsushisen.debugger"}
TOP = "netsushisen"


def _imports(path: Path, source: str | None = None) -> list[tuple[str, int, bool]]:
    """(module imported, line, at module level) of every import statement in `path` (or in
    `source`, read as if it were that file)."""
    tree = ast.parse(path.read_text() if source is None else source, str(path))
    package = _module_name(path).rsplit(".", 1)[0]
    found: list[tuple[str, int, bool]] = []

    def visit(node: ast.AST, top: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = top and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                   ast.Lambda))
            if isinstance(child, ast.Import):
                found.extend((a.name, child.lineno, top) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:  # relative: resolve against the module's package
                    parts = package.split(".")
                    base = ".".join(parts[:len(parts) - child.level + 1] + ([base] if base else []))
                found.append((base, child.lineno, top))
                found.extend((f"{base}.{a.name}", child.lineno, top) for a in child.names)
            visit(child, inner)

    visit(tree, True)
    return found


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT)
    folder = rel.parts[0]
    dotted = ".".join(rel.with_suffix("").parts[1:])
    return f"{PACKAGES.get(folder, TOP)}.{dotted}".removesuffix(".__init__")


def _modules(folder: str) -> list[Path]:
    return sorted((ROOT / folder).rglob("*.py"))


def _project(name: str) -> str | None:
    """The project module an import names, by the layer it belongs to: `netsushisen.isa`,
    `netsushisen.options` (a module of the top package), ...; None outside the project."""
    parts = name.split(".")
    if parts[0] != TOP or len(parts) < 2:
        return None
    return ".".join(parts[:2])


def _offences(folder: str, allowed) -> list[str]:
    out = []
    for path in _modules(folder):
        for name, line, _ in _imports(path):
            layer = _project(name)
            if layer is not None and not allowed(layer):
                out.append(f"{path.relative_to(ROOT)}:{line}: imports {name}")
    return sorted(set(out))


def test_isa_imports_nothing_above_it():
    assert _offences("isa", lambda m: m == PACKAGES["isa"]) == []


def test_emulator_imports_nothing_from_the_top_package_or_reports():
    allowed = {PACKAGES[p] for p in ("isa", "asm", "emulator")}
    assert _offences("emulator", lambda m: m in allowed) == []


def test_the_diagnostics_and_file_writers_import_nothing_of_the_project():
    """isa/errors.py and isa/outputs.py sit under every layer: they import only each other."""
    for name in ("errors", "outputs"):
        imported = {n for n, _, _ in _imports(ROOT / "isa" / f"{name}.py") if n.startswith(TOP)}
        assert {n.rsplit(".", 1)[0] if n.count(".") > 2 else n for n in imported} <= {
            "netsushisen.isa.errors"}, (name, imported)


def _reports_offences() -> list[str]:
    bad = {PACKAGES["host"], PACKAGES["emulator"]}
    out = _offences("reports", lambda m: m not in bad)
    out += [f"{p.relative_to(ROOT)}:{line}: imports {name}" for p in _modules("reports")
            for name, line, _ in _imports(p) if name.split(".")[0] == "numba"]
    return sorted(set(out))


def test_reports_import_no_host_emulator_or_numba():
    """reports/ only reads statistics and result records (issue 31 item 1)."""
    assert _reports_offences() == []


def test_numba_is_imported_at_module_level_only_by_the_compiled_engine():
    offences = []
    for folder in ("isa", "asm", "emulator", "host", "reports", "debugger", "netsushisen"):
        for path in _modules(folder):
            rel = path.relative_to(ROOT)
            if rel.parts[:2] == ("emulator", "compiled"):
                continue
            offences += [f"{rel}:{line}" for name, line, top in _imports(path)
                         if top and name.split(".")[0] == "numba"]
    assert offences == []


def test_the_check_sees_late_relative_and_type_checking_imports():
    """The walker is not blind: a late import, a TYPE_CHECKING one and a relative one in a
    module of emulator/ all count (a source read as if it were a module of the tree)."""
    source = ("from typing import TYPE_CHECKING\n"
              "if TYPE_CHECKING:\n    from netsushisen.options import RunOptions\n"
              "def f():\n    from netsushisen.reports import glossary\n    import numba\n"
              "from ..reports import tables\n")
    found = {(n, top) for n, _, top in _imports(ROOT / "emulator" / "probe.py", source)}
    assert ("netsushisen.options", True) in found
    assert ("netsushisen.reports.glossary", False) in found and ("numba", False) in found
    assert ("netsushisen.reports", True) in found  # `..reports` from netsushisen.emulator
    assert _project("netsushisen.options.RunOptions") == "netsushisen.options"
    assert _project("numpy") is None
