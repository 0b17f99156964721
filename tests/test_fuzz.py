"""Zero internal errors on hostile input (issue 30, item 2): the corpus of tests/fuzz/corpus.py.

By default a sample — the first cases of each category and the review's regressions — runs in
this process through `netsushisen.cli.main` (cheap: no interpreter start a case); under
`-m slow` the whole corpus runs through tests/fuzz/run.py, a process a case, with its time
limit and memory ceiling. The rule either way: exit 0, or exit 1 with an `error:` line; never
exit 70, never a traceback."""

from __future__ import annotations

import os
import tempfile

import pytest

from fuzz import corpus
from fuzz import run as runner
from netsushisen.cli import main

QUICK = 5  # cases a category in the default run


def _sample() -> list[corpus.Case]:
    with tempfile.TemporaryDirectory() as tmp:
        every = corpus.cases(QUICK, corpus.base_stats(tmp))
    fast = [c for c in every
            if c.category not in ("spec", "scheduler")  # a well-formed spec would connect
            and c.name not in ("many-spheres", "coincident", "rept-nest", "equ-200k")]
    fast += [c for c in every if c.name in ("scheduler-0", "scheduler-7", "scheduler-16")]
    return fast


@pytest.mark.parametrize("case", _sample(), ids=lambda c: c.name)
def test_a_sample_of_the_corpus_never_breaks_the_rule(case, tmp_path, monkeypatch, capsys):
    for name, data in case.files.items():
        (tmp_path / name).write_bytes(data)
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("NETSUSHISEN_DEBUG", raising=False)
    if case.python:  # the API and cache cases: only the API's own errors may come out
        import netsushisen as nss

        monkeypatch.setenv("NETSUSHISEN_CACHE", os.environ.get("NETSUSHISEN_CACHE", ""))
        try:
            exec(compile(case.python, case.name, "exec"), {"nss": nss})
            code, err = 0, ""
        except nss.NetsushisenError as error:
            code, err = 1, str(error)
    else:
        code = main(list(case.argv))
        err = capsys.readouterr().err
    assert code in (0, 1), (code, err)
    assert "internal error" not in err and "Traceback" not in err, err
    if code == 1:
        assert "error:" in err


def test_the_rule_itself_flags_what_it_should():
    case = corpus.Case("set", "x", ())
    ok = runner.Outcome(case, 1, 0.5, 100 << 20, "config: error: pes must be at least 1\n")
    assert ok.problem() is None
    assert runner.Outcome(case, 70, 0.5, 0, "netsushisen: internal error: X").problem()
    assert runner.Outcome(case, 1, 0.5, 0, "Traceback (most recent call last):\n").problem()
    assert runner.Outcome(case, None, 61.0, 0, "").problem()
    assert runner.Outcome(case, 1, 0.5, runner.MEMORY_CEILING + 1, "error: x").problem()
    assert runner.Outcome(case, 1, 0.5, 0, "").problem()


@pytest.mark.slow  # the whole corpus, a process a case: several minutes
def test_the_whole_corpus_never_breaks_the_rule(capsys):
    assert runner.main(["--per-category", "40"]) == 0, capsys.readouterr()
