"""tools/mutate.py, the mutation-testing driver (docs/mutation.md): its pure parts — which
mutants are set aside as annotations, the seeded sample, the config checks, --retest's reading
of an earlier run. The run itself (cosmic-ray on copies of the tree) is the documented command,
not part of the test suite."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

TOOL = Path(__file__).resolve().parents[1] / "tools" / "mutate.py"


@pytest.fixture(scope="module")
def mutate():
    spec = importlib.util.spec_from_file_location("mutate_tool", TOOL)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module   # dataclasses resolve string annotations through it
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules[spec.name]


def _mutant(module: str, line: int, col: int, operator="core/NumberReplacer", occurrence=0):
    spec = SimpleNamespace(module_path=Path(module), start_pos=(line, col), operator_name=operator,
                           occurrence=occurrence)
    return SimpleNamespace(mutations=[spec])


def test_mutants_inside_annotations_are_set_aside_only_under_future_annotations(mutate, tmp_path):
    lazy = tmp_path / "lazy.py"
    lazy.write_text("from __future__ import annotations\n"
                    "def f(a: int | None = 1) -> dict[str, int]:\n"
                    "    x: list[int] = [a | 2]\n"
                    "    return x\n")
    eager = tmp_path / "eager.py"
    eager.write_text("def f(a: int | None = 1):\n    return a\n")
    spans = {str(lazy): mutate.annotation_spans(lazy), str(eager): mutate.annotation_spans(eager)}
    # line 2: `int | None` (col 9..19) and the return annotation (col 28..42); line 3:
    # `list[int]` (col 7..16) is an annotation, `a | 2` (col 20) is code
    assert mutate.in_annotation(_mutant(str(lazy), 2, 13), spans)
    assert mutate.in_annotation(_mutant(str(lazy), 2, 30), spans)
    assert not mutate.in_annotation(_mutant(str(lazy), 2, 22), spans)   # the default value 1
    assert not mutate.in_annotation(_mutant(str(lazy), 3, 20), spans)
    assert not mutate.in_annotation(_mutant(str(eager), 1, 13), spans)  # evaluated at def time


def test_the_sample_is_seeded_and_of_the_asked_size(mutate):
    group = SimpleNamespace(name="g", opt_in=False)
    other = SimpleNamespace(name="h", opt_in=False)
    mutants = [(group, _mutant("m.py", i, 0, occurrence=i)) for i in range(100)] + \
              [(other, _mutant("n.py", i, 0, occurrence=i)) for i in range(50)]
    a = mutate.choose(mutants, 30, 18, set(), [])
    assert len(a) == 30 and a == mutate.choose(mutants, 30, 18, set(), [])
    assert a != mutate.choose(mutants, 30, 19, set(), [])
    assert len(mutate.choose(mutants, 0, 18, set(), [])) == 150            # 0: every mutant
    assert {g.name for g, _ in mutate.choose(mutants, 20, 18, {"h"}, [])} == {"h"}
    named = mutate.choose(mutants, 30, 18, set(), ["n.py:core/NumberReplacer:7"])
    assert [w.mutations[0].occurrence for _, w in named] == [7]
    with pytest.raises(mutate.MutateError, match="no mutant x.py:core/NumberReplacer:0"):
        mutate.choose(mutants, 30, 18, set(), ["x.py:core/NumberReplacer:0"])


def test_an_opt_in_group_is_run_only_when_named(mutate):
    usual = SimpleNamespace(name="g", opt_in=False)
    extra = SimpleNamespace(name="compiled", opt_in=True)
    mutants = [(usual, _mutant("m.py", i, 0, occurrence=i)) for i in range(40)] + \
              [(extra, _mutant("c.py", i, 0, occurrence=i)) for i in range(40)]
    assert {g.name for g, _ in mutate.choose(mutants, 0, 18, set(), [])} == {"g"}
    assert {g.name for g, _ in mutate.choose(mutants, 10, 18, {"compiled"}, [])} == {"compiled"}
    # the other groups' sample does not move when an opt-in group is added
    assert mutate.choose(mutants, 10, 18, set(), []) == mutate.choose(mutants[:40], 10, 18, set(), [])


def test_mutants_are_kept_to_the_named_functions(mutate, tmp_path, monkeypatch):
    module = tmp_path / "m.py"
    module.write_text("def a():\n    return 1\n\n\n@deco\ndef b():\n    return 2\n")
    monkeypatch.setattr(mutate, "PROJECT", tmp_path)
    assert mutate.function_spans(module) == {"a": (1, 2), "b": (5, 7)}
    only_b = mutate.Group("g", ("m.py",), ("t.py",), functions=("b",))
    assert not mutate.in_functions(_mutant("m.py", 2, 11), only_b)
    assert mutate.in_functions(_mutant("m.py", 7, 11), only_b)
    assert mutate.in_functions(_mutant("m.py", 2, 11), mutate.Group("g", ("m.py",), ("t.py",)))


def test_a_compiled_group_runs_its_tests_on_the_compiled_engine_with_its_own_cache(mutate, tmp_path):
    ref = mutate.test_command(tmp_path / "project", mutate.Group("g", ("m.py",), ("t.py",)))
    comp = mutate.test_command(tmp_path / "project",
                               mutate.Group("g", ("m.py",), ("t.py",), engine="compiled"))
    assert "--engine reference" in ref and "NETSUSHISEN_CACHE" not in ref
    assert "--engine compiled" in comp and f"NETSUSHISEN_CACHE={tmp_path / 'numba-cache'}" in comp


def test_config_errors_name_the_file_and_the_entry(mutate, tmp_path):
    bad = tmp_path / "m.toml"
    bad.write_text('[[group]]\nname = "g"\nmodules = ["isa/nope.py"]\ntests = ["tests/test_isa.py"]\n')
    with pytest.raises(mutate.MutateError, match=r"group 'g': module 'isa/nope.py' does not exist"):
        mutate.load_settings(bad)
    bad.write_text('[[group]]\nname = "g"\nmodules = ["isa/words.py"]\ntests = ["tests/test_isa.py"]\n'
                   '[[equivalent]]\nmodule = "isa/words.py"\n')
    with pytest.raises(mutate.MutateError, match=r"equivalent #1: missing operator, occurrence"):
        mutate.load_settings(bad)
    bad.write_text('[[group]]\nname = "g"\nmodules = ["isa/words.py"]\ntests = ["tests/test_isa.py"]\n'
                   'engine = "fast"\n')
    with pytest.raises(mutate.MutateError, match=r"group 'g': engine 'fast' is not reference or compiled"):
        mutate.load_settings(bad)
    bad.write_text('[[group]]\nname = "g"\nmodules = ["isa/words.py"]\ntests = ["tests/test_isa.py"]\n'
                   'functions = ["nope"]\n')
    with pytest.raises(mutate.MutateError, match=r"group 'g': no function nope in isa/words.py"):
        mutate.load_settings(bad)
    settings = mutate.load_settings()   # the project's own file is valid
    assert settings.sample >= 300 and all(e.reason for e in settings.equivalents)


def test_retest_keeps_the_kills_and_runs_the_rest_again(mutate, tmp_path):
    rows = [dict(group="g", module="m.py", operator="op", occurrence=i, line=i, status=s,
                 seconds=1.0, diff="", note="") for i, s in enumerate(["killed", "survived", "equivalent"])]
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"info": {}, "counts": {}, "mutants": rows}))
    kept, again = mutate.earlier(path)
    assert [o.occurrence for o in kept] == [0] and again == ["m.py:op:1", "m.py:op:2"]
    assert mutate.summary(kept + [mutate.Outcome(**rows[1])])["score"] == 50.0
    path.write_text("{}")
    with pytest.raises(mutate.MutateError, match="not a results.json"):
        mutate.earlier(path)
