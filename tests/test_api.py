"""The Python API (issue 25, item 3; docs/api.md) and the flat statistics dump with its one table
of descriptions (item 4).

docs/api.md's latency study runs here as it is written (its block, executed); a result's
`.table(name)` is the report's CSV as a DataFrame (same columns, same values); `__all__` is the
API and every name in it resolves.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import netsushisen as nss

ROOT = Path(__file__).resolve().parents[1]


def doc_block(heading: str) -> str:
    """The first ```python block after `heading` in docs/api.md."""
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    after = text[text.index(heading):]
    return re.search(r"```python\n(.*?)```", after, re.S)[1]


def test_the_latency_walkthrough_runs_as_written(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(doc_block("## A latency study in ten lines"), "docs/api.md", "exec"), scope)
    study = scope["study"]
    assert list(study.columns) == ["fmul", "cycles", "IC dynamic ILP"]
    assert list(study["fmul"]) == [3, 6, 12]
    cycles = list(study["cycles"])
    assert cycles[0] < cycles[1] < cycles[2]  # a slower multiplier costs cycles
    assert study["IC dynamic ILP"].iloc[2] < study["IC dynamic ILP"].iloc[0]
    assert (tmp_path / "fmul_latency.png").stat().st_size > 0


def test_the_program_example_runs_as_written():
    scope: dict = {"nss": nss}
    block = doc_block("## Machine programs without a scene")
    exec(compile(block, "docs/api.md", "exec"), scope)
    assert scope["r"].stats["run"]["status"] == "halted"
    assert scope["r"].extra["engine"].register("pe0.ic", 1) == 7


def test_all_is_the_api():
    assert set(nss.__all__) == {"render", "golden", "run", "assemble", "scene", "Config",
                                "load_stats", "Results", "NetsushisenError", "__version__"}
    for name in nss.__all__:
        assert getattr(nss, name) is not None
    assert sorted(dir(nss)) == sorted(nss.__all__)
    assert callable(nss.render) and nss.render.__module__ == "netsushisen.api"
    with pytest.raises(AttributeError):
        nss.no_such_name  # noqa: B018


@pytest.fixture(scope="module")
def tiny():
    return nss.render("tetra", res=4, engine="compiled")


def test_results_carry_image_ids_rays_and_stats(tiny):
    assert tiny.image.shape == (4, 4, 3) and tiny.image.dtype == np.uint8
    assert tiny.ids.shape == (4, 4) and tiny.ids.dtype == np.int32
    assert tiny.rays["eye"] == 16 and tiny.stats["rays"] == tiny.rays
    assert tiny.stats["run"]["engine"] == "compiled" and tiny.status == "finished"
    golden = nss.golden("tetra", res=4)
    assert np.array_equal(golden.ids, tiny.ids) and np.array_equal(golden.image, tiny.image)
    with pytest.raises(nss.NetsushisenError, match="golden model"):
        golden.table("ilp")


def test_tables_are_the_csv_output(tiny, tmp_path, cli):
    tiny.save(tmp_path / "s.json")
    for report in ("ilp", "stalls", "memory", "annotate"):
        tables = tiny.tables(report)
        assert tables and list(tables)[0] == next(iter(tables))
        for key, frame in tables.items():
            code, out, err = cli("report", report, tmp_path / "s.json", "--format", "csv",
                                 "--table", key)
            assert code == 0, err
            csv = pd.read_csv(io.StringIO(out))
            assert list(frame.columns) == list(csv.columns), (report, key)
            assert len(frame) == len(csv), (report, key)
            empty_as_na = frame.replace("", np.nan)  # CSV writes an empty cell for both
            pd.testing.assert_frame_equal(empty_as_na, csv, check_dtype=False,
                                          check_exact=False, rtol=1e-12)
    assert tiny.table("stalls").equals(tiny.tables("stalls")["causes"])
    assert tiny.table("ilp.slot_fill").equals(tiny.tables("ilp")["slot_fill"])
    with pytest.raises(nss.NetsushisenError, match="no table 'nope'"):
        tiny.table("ilp.nope")


def test_set_and_config_change_the_run():
    base = nss.Config()
    slow = base.with_({"ic.latency.fmul": 9})
    assert base.ic.latency == {} and slow.ic.latency == {"fmul": 9}
    a = nss.render("tetra:1", res=2, config=slow)
    b = nss.render("tetra:1", res=2, set={"ic.latency.fmul": 9})
    assert a.stats["config"] == b.stats["config"] and a.stats["run"] == b.stats["run"]
    assert nss.render("tetra:1", res=2, depth=2).stats["config"]["render"]["max_depth"] == 2
    with pytest.raises(nss.NetsushisenError, match="did you mean 'ic.latency'"):
        base.with_({"ic.latenc.fmul": 6})


def test_run_assemble_scene_and_load_stats(tmp_path):
    prog = nss.assemble(".proc os\n.text\n li r2, 5\n halt\n")
    r = nss.run([prog], engine="reference")
    assert r.stats["run"]["engine"] == "reference" and r.extra["engine"].register("pe0.os", 2) == 5
    assert nss.scene("tetra").n_primitives == 4096
    r.save(tmp_path / "r.json")
    (tmp_path / "r.txt").write_text(r.flat())
    a, b = nss.load_stats(tmp_path / "r.json"), nss.load_stats(tmp_path / "r.txt")
    assert a.table("ilp").equals(b.table("ilp"))


# ---------------------------------------------------------------------------------------------
# report flat and the one table of descriptions


def test_flat_dump_one_described_statistic_per_line(tiny, tmp_path, cli):
    tiny.save(tmp_path / "s.json")
    code, out, err = cli("report", "flat", tmp_path / "s.json")
    assert code == 0, err
    lines = out.splitlines()
    pattern = re.compile(r"(\S+) +(\S+|\"[^\"]*\")  # (.+)")
    names = []
    for line in lines:
        m = pattern.fullmatch(line)
        assert m, line
        assert m[3] != "(not in the table of descriptions)", line
        names.append(m[1])
    assert len(names) == len(set(names))
    by_name = {pattern.fullmatch(line)[1]: line for line in lines}
    ic = tiny.stats["processors"]["pe0.ic"]
    assert by_name["pe0.ic.stalls.cache_hit"].split()[1] == str(ic["stalls"]["cache_hit"])
    assert "(cycles)" in by_name["pe0.ic.stalls.cache_hit"]
    assert by_name["run.engine"].split()[1] == "compiled"
    assert "(cycles; default 8)" in by_name["config.ic_memory.t_g"]
    assert by_name["pe0.ic.cycles"].split()[1] == str(ic["cycles"])


def test_a_statistic_the_table_does_not_know_is_marked(tiny):
    from netsushisen.reports.flat import format_flat

    stats = json.loads(json.dumps(tiny.stats))
    stats["processors"]["pe0.ic"]["new_counter"] = 3
    assert "pe0.ic.new_counter" in format_flat(stats)
    line = next(x for x in format_flat(stats).splitlines() if x.startswith("pe0.ic.new_counter"))
    assert line.endswith("# (not in the table of descriptions)")


def test_flat_dumps_diff_as_the_json_files_do(tmp_path, cli):
    for name, sets in (("a", []), ("b", ["--set", "ic.latency.fmul=6"])):
        code, _, err = cli("render", "tetra:1", "--res", "2", "-q", "-o", tmp_path / f"{name}.png",
                           "--json", tmp_path / f"{name}.json", *sets)
        assert code == 0, err
        cli("report", "flat", tmp_path / f"{name}.json", "-o", tmp_path / f"{name}.txt")
    _, from_json, _ = cli("report", "diff", tmp_path / "a.json", tmp_path / "b.json")
    _, from_flat, _ = cli("report", "diff", tmp_path / "a.txt", tmp_path / "b.txt")
    assert "fmul" in from_json and from_flat == from_json.replace(".json", ".txt")


def test_config_dump_describes_every_field_with_unit_and_default(cli, tmp_path):
    code, out, _ = cli("config", "--dump", "--set", "ic_memory.t_g=16")
    assert code == 0
    lines = out.splitlines()
    t_g = [i for i, line in enumerate(lines) if line == "t_g = 16"]
    assert t_g and lines[t_g[0] - 1].startswith("# Global memory access time on a cache miss")
    assert lines[t_g[0] - 1].endswith("(cycles; default 8)")
    assert "# fmul = 3          # latency of fmul on IC (cycles; default 3)" in lines
    for i, line in enumerate(lines):  # every field under its comment
        if re.fullmatch(r"\w+ = .+", line):
            assert lines[i - 1].startswith("# "), line
    (tmp_path / "c.toml").write_text(out)
    code, out, _ = cli("config", "--check", tmp_path / "c.toml")
    assert code == 0 and out.startswith(f"{tmp_path / 'c.toml'}: ok")


def test_the_kernel_experiment_runs_as_written():
    """issue 42 item 5: a `.sched` loop written, run at three latencies, tabulated."""
    scope: dict = {}
    exec(compile(doc_block("## A kernel experiment, end to end"), "docs/api.md", "exec"), scope)
    study = scope["study"]
    assert list(study.columns) == ["t_r", "cycles", "II", "sum"]
    assert list(study["sum"]) == [248.0] * 3  # sum over k < 64 of (2k mod 5)(2k+1 mod 5)
    assert list(study["cycles"]) == sorted(study["cycles"]) and study["cycles"].is_unique
    assert study["II"].iloc[0] < study["II"].iloc[2]
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    for row in study.itertuples():  # the table the page shows is this run's
        assert f"| {row.t_r} | {row.cycles:,} | {row.II} | {row.sum} |" in text


def test_natural_inputs_of_run_and_a_short_repr(tmp_path):
    """issue 42 item 5: a path, a source string, a Program, a dict of either; an image as a
    path, a dict or the object; a short repr and a notebook view."""
    from netsushisen.isa.images import image_from_json

    src = ".proc ic\n.reg acc = r5\n        lf acc, 68.0\n        ldr r6, [r0 + 1]\n        halt\n"
    path = tmp_path / "k.s"
    path.write_text(src)
    image = {"ic.resident": [0.0, 2.5]}
    (tmp_path / "img.json").write_text(json.dumps(image))
    prog = nss.assemble(path)
    for programs in (str(path), path, src, prog, {"ic": prog}, {"ic": str(path)}, [prog]):
        for img in (image, str(tmp_path / "img.json"), image_from_json(image)):
            r = nss.run(programs, image=img, engine="reference")
            regs = r.registers("ic")
            assert regs.loc["r5", "name"] == "acc" and regs.loc["r5", "float"] == 68.0
            assert regs.loc["r6", "float"] == 2.5 and regs.loc["r5", "int"] == 1116209152
    assert len(repr(r)) < 200 and "halted" in repr(r)
    assert "<table>" in r._repr_html_()
    with pytest.raises(nss.NetsushisenError) as err:
        nss.run(".proc ic\n  nope r1\n  halt\n")
    assert err.value.path == "<string>" and err.value.line == 2


def test_a_render_result_is_short_and_shows_in_a_notebook(tiny):
    assert isinstance(tiny.image, np.ndarray)
    assert len(repr(tiny)) < 2000 and "cycles=" in repr(tiny)
    html = tiny._repr_html_()
    assert "data:image/png;base64," in html and len(html) < 200_000
    bounds = tiny.table("bounds", optimum_ops=0)  # (CP-SAT on the hottest blocks: seconds each)
    assert list(bounds.columns)[:2] == ["processor", "loop"] and len(bounds)
