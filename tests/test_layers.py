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

Issue 45 (item 1) makes the layers hold transitively: one rank table (`RANKS`: isa < asm <
emulator, host, kernels < reports < debugger < commands and the top package), checked on every
import statement (function-level ones included: a module imports only its own layer and lower
ranks, never a peer of its rank) and on the transitive module-level closure of every module —
what importing it loads — computed from the syntax trees' import graph (each imported module's
parent packages included, `if TYPE_CHECKING:` blocks excluded, since they do not run) and
confirmed by importing every layer's modules in a fresh interpreter.

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
    `source`, read as if it were that file). Each file is parsed once per session."""
    key = (path, source)
    if key not in _FOUND:
        _FOUND[key] = _parse_imports(path, source)
    return _FOUND[key]


_FOUND: dict = {}


def _parse_imports(path: Path, source: str | None) -> list[tuple[str, int, bool]]:
    tree = ast.parse(path.read_text() if source is None else source, str(path))
    package = _module_name(path).rsplit(".", 1)[0]
    if path.name == "__init__.py":
        package = _module_name(path)
    found: list[tuple[str, int, bool]] = []
    typing_only: set[int] = set()

    def visit(node: ast.AST, top: bool, typing: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = top and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                   ast.Lambda))
            guarded = typing or (isinstance(child, ast.If) and "TYPE_CHECKING" in
                                 ast.unparse(child.test))
            if isinstance(child, ast.Import):
                found.extend((a.name, child.lineno, top) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:  # relative: resolve against the module's package
                    parts = package.split(".")
                    base = ".".join(parts[:len(parts) - child.level + 1] + ([base] if base else []))
                found.append((base, child.lineno, top))
                found.extend((f"{base}.{a.name}", child.lineno, top) for a in child.names)
            if typing and isinstance(child, (ast.Import, ast.ImportFrom)):
                typing_only.add(child.lineno)
            visit(child, inner, guarded)

    visit(tree, True, False)
    _TYPING_ONLY[(path, source)] = typing_only
    return found


_TYPING_ONLY: dict = {}
"""(path, source) -> lines of the imports `_imports` found under `if TYPE_CHECKING:`."""


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



# -- Issue 45: one rank table, checked statement by statement and transitively ----------------

RANKS: dict[str, int] = {
    "netsushisen.isa": 0, "netsushisen.asm": 1,
    "netsushisen.emulator": 2, "netsushisen.host": 2, "netsushisen.kernels": 2,
    "netsushisen.reports": 3, "netsushisen.debugger": 4, TOP: 5,
}
"""The layers, lowest first. A module imports its own layer and layers of a lower rank only: a
peer of the same rank is no dependency either (the emulator runs kernels, the host builds
scenes; neither imports the other). The commands (`netsushisen.commands`) and the top
package's modules (options, pipeline, api, ...) are one layer, the top."""

FOLDERS = ("isa", "asm", "emulator", "host", "kernels", "reports", "debugger", "netsushisen")


def _layer(module: str) -> str | None:
    """The layer of a project module (`netsushisen.isa.limits` -> `netsushisen.isa`,
    `netsushisen.options` and `netsushisen.commands.run` -> the top); None outside."""
    first = _project(module)
    if first is None:
        return None if module != TOP else TOP
    return first if first in RANKS else TOP


def _allowed(source: str, target: str) -> bool:
    """May a module of `source`'s layer depend on `target`? The top package itself is the
    namespace every import passes through (its __init__ imports nothing at module level)."""
    a, b = _layer(source), _layer(target)
    return b is None or target == TOP or a == b or RANKS[b] < RANKS[a]


def _all_modules(overrides: dict[Path, str] | None = None) -> dict[str, tuple[Path, str | None]]:
    """Every module of the tree by name -> (its file, a planted source or None)."""
    overrides = overrides or {}
    out = {_module_name(p): (p, overrides.get(p)) for f in FOLDERS for p in _modules(f)}
    out.update({_module_name(p): (p, src) for p, src in overrides.items()})
    return out


def _resolve(name: str, modules) -> str | None:
    """The module an imported name loads (`netsushisen.isa.limits.read_input` -> the module
    `netsushisen.isa.limits`); None outside the project."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        if ".".join(parts[:k]) in modules:
            return ".".join(parts[:k])
    return None


def _parents(module: str) -> list[str]:
    """The packages importing `module` runs first: a.b.c -> a, a.b."""
    parts = module.split(".")
    return [".".join(parts[:k]) for k in range(1, len(parts))]


def import_graph(overrides: dict[Path, str] | None = None,
                 parents: bool = True) -> dict[str, set[str]]:
    """module -> the project modules its import runs (module-level statements outside `if
    TYPE_CHECKING:`, and with `parents` each one's parent packages and the module's own)."""
    modules = _all_modules(overrides)
    graph: dict[str, set[str]] = {}
    for name, (path, source) in modules.items():
        found = _imports(path, source)
        typing_only = _TYPING_ONLY[(path, source)]
        edges = set(p for p in _parents(name) if p in modules and parents)
        for imported, line, top in found:
            target = _resolve(imported, modules)
            if top and line not in typing_only and target is not None:
                edges.add(target)
                edges.update(p for p in _parents(target) if p in modules and parents)
        edges.discard(name)
        graph[name] = edges
    return graph


def closure_offences(graph: dict[str, set[str]]) -> list[str]:
    """`module: loads X (via a -> b -> X)` for every module whose transitive import loads a
    module of a layer it may not depend on (breadth first: the shortest chain)."""
    out = []
    for start in sorted(graph):
        seen = {start: None}
        queue = [start]
        while queue:
            node = queue.pop(0)
            for nxt in sorted(graph.get(node, ())):
                if nxt not in seen:
                    seen[nxt] = node
                    queue.append(nxt)
        for bad in sorted(m for m in seen if not _allowed(start, m)):
            chain, at = [], bad
            while at is not None:
                chain.append(at)
                at = seen[at]
            out.append(f"{start}: loads {bad} (via {' -> '.join(reversed(chain))})")
    return out


def statement_offences(overrides: dict[Path, str] | None = None) -> list[str]:
    """`file:line: imports X` for every import statement, at any depth, that names a module
    of a layer its module may not depend on."""
    out = []
    for name, (path, source) in sorted(_all_modules(overrides).items()):
        for imported, line, top in _imports(path, source):
            if _project(imported) is not None and not _allowed(name, imported):
                where = "" if top else " (in a function)"
                out.append(f"{path.relative_to(ROOT)}:{line}: imports {imported}{where}")
    return sorted(set(out))


def test_every_import_statement_points_down_the_rank_table():
    assert statement_offences() == []


def test_every_module_loads_only_its_layer_and_lower_ones_transitively():
    assert closure_offences(import_graph()) == []


def test_no_module_level_import_cycle():
    """No two modules import each other at module level, through any chain (options and
    timeline did; a package importing its own submodules is no cycle)."""
    graph = import_graph(parents=False)
    cycles = []
    for start in sorted(graph):
        stack, seen = list(graph[start]), set()
        while stack:
            node = stack.pop()
            if node == start:
                cycles.append(start)
                break
            if node not in seen:
                seen.add(node)
                stack.extend(graph.get(node, ()))
    assert cycles == []


def test_a_planted_function_level_upward_import_is_caught():
    """A late import of reports/ in an emulator module, and of the top package in asm/, fail
    the statement check (planted sources read as if they were modules of the tree)."""
    probe = ROOT / "emulator" / "probe.py"
    planted = statement_offences({probe: "def f():\n    from netsushisen.reports import glossary\n",
                                  ROOT / "asm" / "probe.py": "def g():\n    import netsushisen.options\n"})
    assert "emulator/probe.py:2: imports netsushisen.reports.glossary (in a function)" in planted
    assert "asm/probe.py:2: imports netsushisen.options (in a function)" in planted
    # a peer of the same rank is no dependency either
    assert statement_offences({probe: "import netsushisen.host.scenes\n"}) == [
        "emulator/probe.py:1: imports netsushisen.host.scenes"]


def test_a_planted_transitive_upward_import_is_caught():
    """isa/config.py importing host/ at module level is caught in every module that loads it
    (asm's, the emulator's), with the chain; under `if TYPE_CHECKING:` or in a function it
    loads nothing."""
    config = ROOT / "isa" / "config.py"
    text = config.read_text()
    offences = closure_offences(import_graph({config: text + "\nimport netsushisen.host.scenes\n"}))
    assert any(o.startswith("netsushisen.emulator.machine: loads netsushisen.host.scenes (via "
                            "netsushisen.emulator.machine -> ") for o in offences), offences[:5]
    assert any(o.startswith("netsushisen.isa.config: loads netsushisen.host") for o in offences)
    # a transitive chain alone (the module itself imports nothing upward)
    graph = {"netsushisen.asm.a": {"netsushisen.isa.b"}, "netsushisen.isa.b": {"netsushisen.isa.c"},
             "netsushisen.isa.c": {"netsushisen.reports.d"}, "netsushisen.reports.d": set()}
    assert closure_offences(graph)[0] == ("netsushisen.asm.a: loads netsushisen.reports.d (via "
                                          "netsushisen.asm.a -> netsushisen.isa.b -> "
                                          "netsushisen.isa.c -> netsushisen.reports.d)")
    for guarded in ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                    "    import netsushisen.host.scenes\n",
                    "def f():\n    import netsushisen.host.scenes\n"):
        assert closure_offences(import_graph({config: text + "\n" + guarded})) == []


_PROBE = """
import importlib, json, sys
for name in sys.argv[1:]:
    importlib.import_module(name)
print(json.dumps(sorted(m for m in sys.modules if m.startswith("netsushisen"))))
"""


@pytest.mark.slow
def test_importing_each_layer_in_a_fresh_interpreter_loads_nothing_above_it():
    """The static graph's verdict, confirmed at run time: one fresh interpreter per layer
    imports every module of that layer (all at once, in parallel) and no module of a layer it
    may not depend on is in `sys.modules` afterwards."""
    import json
    import subprocess
    import sys

    modules = _all_modules()
    by_layer: dict[str, list[str]] = {}
    for name in modules:
        if _layer(name) != TOP:
            by_layer.setdefault(_layer(name), []).append(name)
    procs = {layer: subprocess.Popen([sys.executable, "-c", _PROBE, *sorted(names)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     cwd=ROOT.parent)
             for layer, names in by_layer.items()}
    offences = []
    for layer, proc in procs.items():
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err[-2000:]
        offences += [f"{layer}: loads {m}" for m in json.loads(out)
                     if m in modules and not _allowed(layer + ".x", m)]
    assert offences == []
