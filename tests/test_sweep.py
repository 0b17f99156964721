"""`netsushisen sweep`: spec checking, points on Dask (LocalCluster and a separately started
scheduler), the content-key cache, failed and lost points, and Ctrl-C."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import load_config
from netsushisen.pipeline import render
from netsushisen.sweep import evaluate, load_spec, points

import distributed  # noqa: F401,E402  a dependency (dask[distributed]): never skipped

SMALL = """\
scenes = ["tetra", "balls"]
res = 8
{extra}
[vary]
"ic_memory.cache_bytes" = [1024, 4096, 16384]
"""


def write(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def rows(out: Path) -> list[dict]:
    with open(out / "results.csv", newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


# -- the spec -------------------------------------------------------------------------------------


def test_points_are_scenes_times_the_product_of_the_axes(tmp_path):
    spec = load_spec(write(tmp_path, """\
scenes = ["tetra", "balls"]
res = 4
[vary]
"ic_memory.cache_bytes" = [1024, 2048]
"ic_memory.t_g" = {start = 4, stop = 12, step = 4}
[zip]
"ring.fifo_depth" = [32, 64]
"ring.link_buffer_words" = [2, 4]
"""))
    pts = points(spec)
    assert len(pts) == 2 * 2 * 3 * 2
    assert spec.fields == ["ic_memory.cache_bytes", "ic_memory.t_g", "ring.fifo_depth",
                           "ring.link_buffer_words"]
    zipped = {(dict(p.values)["ring.fifo_depth"], dict(p.values)["ring.link_buffer_words"]) for p in pts}
    assert zipped == {(32, 2), (64, 4)}  # varied together, not crossed
    assert sorted({dict(p.values)["ic_memory.t_g"] for p in pts}) == [4, 8, 12]


def test_derived_fields_and_parameters(tmp_path):
    spec = load_spec(write(tmp_path, """\
scenes = ["tetra"]
res = 4
[vary]
local = [0.1, 0.5]
split = {start = 0.0, stop = 1.0, step = 0.5}
[derive]
"ic_memory.resident_share" = "local * split"
"ic_memory.cache_share" = "local * (1 - split)"
"""))
    pts = points(spec)
    assert len(pts) == 6
    v = dict(pts[1].values)
    assert (v["local"], v["split"]) == (0.1, 0.5)
    assert v["ic_memory.resident_share"] == 0.1 * 0.5
    assert v["ic_memory.cache_share"] == 0.1 * (1 - 0.5)
    assert "local=0.1" not in " ".join(pts[1].sets)  # a parameter is no configuration field
    assert "ic_memory.cache_share=0.05" in pts[1].sets


@pytest.mark.parametrize("text, message, line", [
    ('scenes = ["tetra"]\n[vary]\n"ic_memory.cache_bites" = [1, 2]\n', "unknown configuration field", 3),
    ('scenes = ["tetra"]\n[vary]\n"ring.fifo_depth" = [64, -3]\n', "ring.fifo_depth must be at least 1", 3),
    ('scenes = ["tetra"]\nres = 0\n[vary]\n"ring.fifo_depth" = [64]\n', "'res' must be", 2),
    ('scenes = ["tetra"]\n[zip]\n"ring.fifo_depth" = [32, 64]\n"ring.link_buffer_words" = [2]\n',
     "equal lengths", None),
    ('scenes = ["tetra"]\n[vary]\nx = [1]\n[derive]\n"ic_memory.cache_share" = "y * 2"\n',
     "unknown name 'y'", 5),
    ('scenes = ["tetra"]\n[vary]\nx = [1]\n[derive]\n"ic_memory.cache_share" = "__import__(1)"\n',
     "only numbers", 5),
    ('scenes = ["tetra"]\nsteps = 3\n[vary]\n"ring.fifo_depth" = [64]\n', "unknown key 'steps'", 2),
    ('scenes = ["tetra"]\n', "nothing to vary", None),
])
def test_a_bad_spec_is_a_located_error_before_anything_runs(tmp_path, text, message, line):
    path = write(tmp_path, text)
    with pytest.raises(NetsushisenError) as err:
        load_spec(path)
    d = next(d for d in err.value.diagnostics if message in d.message)
    assert d.file == str(path)
    assert d.line == line


def test_evaluate_is_arithmetic_only():
    assert evaluate("a * (1 - b) + 2 ** 3", {"a": 2, "b": 0.5}) == 9.0
    with pytest.raises(ValueError):
        evaluate("a.b", {"a": 1})


# -- running ------------------------------------------------------------------------------------


@pytest.mark.heavy  # [reference]: 1.5 M reference-engine cycles, under -m slow
def test_a_small_sweep_on_a_local_cluster_then_a_rerun_computes_nothing(tmp_path, cli, engine_name):
    spec = write(tmp_path, SMALL.format(extra=f'engine = "{engine_name}"'))
    out = tmp_path / "out"
    code, text, err = cli("sweep", spec, "--out", out, "--workers", "2")
    assert code == 0, err
    assert text.strip().splitlines()[-1] == "sweep: 6 points, 6 computed, 0 cached, 0 failed"
    table = rows(out)
    assert [(r["scene"], r["ic_memory.cache_bytes"]) for r in table] == [
        (s, c) for s in ("tetra", "balls") for c in ("1024", "4096", "16384")]
    assert all(r["status"] == "finished" for r in table)
    assert len(list((out / "points").glob("*.json"))) == 6
    # a point's cycles are a direct render's with the same settings
    direct = render("balls", load_config(None, ["ic_memory.cache_bytes=4096"]), res=8,
                    engine=engine_name)
    assert int(table[4]["cycles"]) == direct.run.cycles
    point = json.loads((out / "points" / f"{table[4]['key']}.json").read_text())
    assert point["stats"]["run"]["cycles"] == direct.run.cycles
    # bigger caches miss less: the columns carry the memory figures
    mu = [float(r["mu.all"]) for r in table[:3]]
    assert mu[0] < mu[1] < mu[2]
    ic = point["stats"]["processors"]["pe0.ic"]["stalls"]
    assert {k.removeprefix("stall.pe0.ic.") for k, v in table[4].items()
            if k.startswith("stall.pe0.ic.") and v != ""} == {k for k, n in ic.items() if n}
    assert int(table[4]["stall.pe0.ic.cache_miss"]) == ic["cache_miss"]
    import pyarrow.parquet as pq
    assert pq.read_table(out / "results.parquet").num_rows == 6
    code, text, _ = cli("sweep", spec, "--out", out, "--workers", "2")
    assert code == 0
    assert text.strip().splitlines()[-1] == "sweep: 6 points, 0 computed, 6 cached, 0 failed"


def test_a_worker_killed_mid_sweep_loses_no_point(tmp_path):
    from dask.distributed import Client, LocalCluster

    from netsushisen.sweep import run_sweep
    spec = load_spec(write(tmp_path, SMALL.replace("res = 8", "res = 12").format(extra="")))
    out = tmp_path / "out"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        pids = list(client.run(os.getpid).values())

        def kill_one_when_a_point_is_done():
            deadline = time.time() + 120
            while time.time() < deadline and not list((out / "points").glob("*.json")):
                time.sleep(0.05)
            os.kill(pids[0], signal.SIGKILL)

        killer = threading.Thread(target=kill_one_when_a_point_is_done)
        killer.start()
        summary = run_sweep(spec, out, "compiled", scheduler=cluster.scheduler_address)
        killer.join()
    assert (summary.computed, summary.failed) == (6, 0)
    assert [r["status"] for r in rows(out)] == ["finished"] * 6


def test_a_scheduler_and_two_workers_started_apart(tmp_path, dask_apart):
    """`dask scheduler` and two `dask worker`s as separate processes on the loopback address."""
    address = dask_apart(2)
    spec = write(tmp_path, SMALL.format(extra=""))
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "netsushisen.cli", "sweep", str(spec), "--out",
                           str(out), "--scheduler", address], capture_output=True, text=True,
                          timeout=240)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "sweep: 6 points, 6 computed, 0 cached, 0 failed"


def test_an_unreachable_scheduler_is_one_line(tmp_path, cli):
    spec = write(tmp_path, SMALL.format(extra=""))
    code, _, err = cli("sweep", spec, "--out", tmp_path / "out", "--scheduler", "tcp://127.0.0.1:9")
    assert code == 1
    assert "cannot connect" in err and "Traceback" not in err


def test_ctrl_c_keeps_every_finished_point(tmp_path):
    spec = write(tmp_path, SMALL.replace("res = 8", "res = 24").format(extra=""))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "netsushisen.cli", "sweep", str(spec), "--out",
                             str(out), "--workers", "2"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 180
    while time.time() < deadline and not list((out / "points").glob("*.json")):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)  # as Ctrl-C at a terminal: the whole process group
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "(interrupted)" in stdout.strip().splitlines()[-1]
    assert len(stderr.strip().splitlines()) <= 1, stderr  # no worker's traceback
    finished = list((out / "points").glob("*.json"))
    assert 1 <= len(finished) < 6
    assert len(rows(out)) == len(finished)
    assert "Traceback" not in stderr


def test_failed_corrupt_and_repeated_points_heal_on_the_next_run(tmp_path, cli):
    """issue 30 item 4: a failed point is computed again on the next run (`--no-retry` keeps it);
    a truncated or edited point file is named and computed again; repeated points count once,
    so the summary's counts add up."""
    spec = write(tmp_path, 'scenes = ["tetra"]\nres = 8\n[vary]\nmax_cycles = [500, 0]\n')
    out = tmp_path / "out"
    code, text, _ = cli("sweep", spec, "--out", out, "--workers", "1")  # the sweep goes on
    assert (code, text.strip().splitlines()[-1]) == (1, "sweep: 2 points, 2 computed, 0 cached, 1 failed")
    assert [r["status"] for r in rows(out)] == ["max_cycles", "finished"]
    code, text, _ = cli("sweep", spec, "--out", out, "--no-retry")
    assert (code, text.strip().splitlines()[-1]) == (1, "sweep: 2 points, 0 computed, 2 cached, 1 failed")
    failed, finished = sorted((out / "points").glob("*.json"),
                              key=lambda p: json.loads(p.read_text())["status"] != "max_cycles")
    point = json.loads(failed.read_text())
    point["error"] = "edited"
    failed.write_text(json.dumps(point))
    finished.write_text(finished.read_text()[:100])
    code, text, err = cli("sweep", spec, "--out", out, "--workers", "1", "--no-retry")
    assert text.strip().splitlines()[-1] == "sweep: 2 points, 2 computed, 0 cached, 1 failed"
    notes = err.strip().splitlines()
    assert any(failed.stem in n and "does not match its checksum" in n for n in notes), notes
    assert any(finished.stem in n and "is not whole JSON" in n for n in notes), notes
    assert [r["status"] for r in rows(out)] == ["max_cycles", "finished"]
    code, text, _ = cli("sweep", spec, "--out", out, "--workers", "1")  # retried: fails again
    assert text.strip().splitlines()[-1] == "sweep: 2 points, 1 computed, 1 cached, 1 failed"
    twice = write(tmp_path, 'scenes = ["tetra", "tetra"]\nres = 8\n[vary]\nmax_cycles = [500, 0]\n')
    code, text, _ = cli("sweep", twice, "--out", out, "--no-retry")
    assert text.strip().splitlines()[-1] == \
        "sweep: 2 points (2 more repeat one), 0 computed, 2 cached, 1 failed"


def test_an_out_that_is_a_regular_file_is_refused_before_work(tmp_path, cli):
    """issue 46 Why 4: `--out FILE` was a NotADirectoryError after the first point."""
    spec = tmp_path / "s.toml"
    spec.write_text('scenes = ["tetra:1"]\nres = 4\n[vary]\n"ic_memory.cache_bytes" = [1024]\n')
    out = tmp_path / "results"
    out.write_text("keep")
    code, _, err = cli("sweep", spec, "--out", out, "--scheduler", "tcp://127.0.0.1:9")
    assert code == 1 and "Traceback" not in err
    assert err.strip() == (f"{out}: error: the output folder is a file (or a dangling link): "
                           "give a folder")
    assert out.read_text() == "keep"
