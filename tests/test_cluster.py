"""The one Dask layer of the multi-run commands (netsushisen/cluster.py): `paper` and `accuracy`
against a separately started `dask scheduler` + worker give the default run's results; a
`--scheduler` that is not Dask is one line on every command that takes it; Ctrl-C keeps every
finished row; results come in input order."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from netsushisen import cluster
from netsushisen.cluster import Task, run_tasks

import distributed  # noqa: F401,E402  a dependency (dask[distributed]): never skipped

COMMANDS = {  # every command that takes --scheduler, with the arguments of a tiny run
    "sweep": lambda tmp: [str(_spec(tmp)), "--out", str(tmp / "sw")],
    "paper": lambda tmp: ["--res", "4", "--scenes", "tetra:1", "--out", str(tmp / "p"), "--quiet"],
    "accuracy": lambda tmp: ["tetra:1", "--res", "4", "--axes", "prepass", "--repeats", "1",
                             "--out", str(tmp / "a"), "--quiet"],
    "numerics": lambda tmp: ["tetra:1", "--res", "4", "--out", str(tmp / "n"), "--quiet"],
}


def _spec(tmp: Path) -> Path:
    p = tmp / "spec.toml"
    p.write_text('scenes = ["tetra:1"]\nres = 4\n[vary]\n"ic_memory.cache_bytes" = [1024, 2048]\n')
    return p


class _Server:
    """A TCP server on the loopback address that answers every connection with `reply` at once
    (an HTTP server that speaks first, or garbage), in a thread."""

    def __init__(self, reply: bytes) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.reply = reply
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            try:
                conn.sendall(self.reply)
                conn.settimeout(1)
                conn.recv(65536)
            except OSError:
                pass
            conn.close()

    def close(self) -> None:
        self.sock.close()


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("reply", [b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok",
                                   bytes(range(256)) * 4], ids=["http", "garbage"])
def test_a_scheduler_that_is_not_dask_is_one_line(tmp_path, cli, command, reply):
    """issue 30: Dask's reader took "HTTP/1.1" for a frame length (an exabyte allocation)."""
    if command not in _with_scheduler():
        pytest.fail(f"{command} has no --scheduler")
    server = _Server(reply)
    try:
        code, out, err = cli(command, *COMMANDS[command](tmp_path), "--scheduler", server.address)
    finally:
        server.close()
    assert code == 1 and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert f"--scheduler {server.address}: cannot connect (not a Dask scheduler: it answered" in err
    assert "allocate" not in err


def _with_scheduler() -> set[str]:
    import argparse
    import importlib
    out = set()
    for name in COMMANDS:
        parser = argparse.ArgumentParser()
        importlib.import_module(f"netsushisen.commands.{name}").configure(parser)
        if any("--scheduler" in a.option_strings for a in parser._actions):
            out.add(name)
    return out


def test_nothing_listening_is_one_line(tmp_path, cli):
    with socket.create_server(("127.0.0.1", 0)) as s:
        port = s.getsockname()[1]  # closed again below: nothing listens there
    code, _, err = cli("accuracy", *COMMANDS["accuracy"](tmp_path), "--scheduler", f"tcp://127.0.0.1:{port}")
    assert code == 1 and "cannot connect" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("host", ["a" * 400, "exa mple", "-"], ids=["label-too-long", "space", "dash"])
def test_an_impossible_host_name_is_one_line(tmp_path, cli, host):
    """A host no resolver takes (the idna codec refuses a label over 63 characters) was an
    internal error (the fuzz corpus's scheduler-14)."""
    code, _, err = cli("accuracy", *COMMANDS["accuracy"](tmp_path), "--scheduler", f"tcp://{host}:9")
    assert code == 1 and "Traceback" not in err and "internal error" not in err, err
    assert "--scheduler" in err and len(err.strip().splitlines()) == 1, err


def _slow_square(x: int, delay: float) -> int:
    time.sleep(delay)
    return x * x


def _emits(n: int, emit=None) -> int:
    for i in range(n):
        emit(i)
    return n


def test_results_go_by_index_not_by_completion_and_parts_before_their_result(monkeypatch):
    """The first task is the slowest: it finishes after the second, and its result still lands
    at index 0. (Workers as threads here: the layer is the same, the start cheaper.)"""
    monkeypatch.setattr(cluster, "IN_PROCESS", True)
    order, results, parts = [], {}, []

    def done(i, r):
        order.append(i)
        results[i] = r
    tasks = [Task(_slow_square, (3, 2.0), "slow"), Task(_slow_square, (4, 0.0), "fast"),
             Task(_emits, (3,), "emits", emits=True)]
    outcome = run_tasks(tasks, done, workers=2, on_item=lambda i, x: parts.append((i, x, i in results)))
    assert not outcome.interrupted and outcome.done == {0, 1, 2}
    assert order.index(1) < order.index(0) and results == {0: 9, 1: 16, 2: 3}
    assert parts == [(2, 0, False), (2, 1, False), (2, 2, False)]


def _raises() -> None:
    raise ValueError("bad")


def test_a_task_error_is_raised_or_handed_on(monkeypatch):
    monkeypatch.setattr(cluster, "IN_PROCESS", True)
    with pytest.raises(ValueError, match="bad"):
        run_tasks([Task(_raises, (), "raises")], lambda i, r: None, workers=1)
    errors = []
    run_tasks([Task(_raises, (), "raises")], lambda i, r: None, workers=1,
              on_error=lambda i, e: errors.append((i, str(e))))
    assert errors == [(0, "bad")]


# -- a scheduler and a worker started apart (conftest.py: dask_apart) -------------------------


def _run(*argv: str, timeout: float = 240) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "netsushisen.cli", *argv], capture_output=True,
                          text=True, timeout=timeout)


def _csv(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


TIMED = {"seconds", "timing", "time_share", "main_seconds", "golden_seconds", "seconds_full", "speedup"}


def _untimed(row: dict) -> dict:
    return {k: (_untimed(v) if isinstance(v, dict) else v) for k, v in row.items() if k not in TIMED}


@pytest.mark.slow  # about 40 s: a scheduler, a worker, and each command twice
def test_paper_and_accuracy_on_a_scheduler_started_apart_equal_the_default_run(tmp_path, dask_apart):
    scheduler = dask_apart(1)
    base = ["--res", "6", "--scenes", "tetra:1", "balls:1", "--quiet"]
    here = _run("paper", *base, "--out", str(tmp_path / "p0"))
    there = _run("paper", *base, "--out", str(tmp_path / "p1"), "--scheduler", scheduler)
    assert here.returncode == 0 and there.returncode == 0, there.stderr
    names = sorted(p.name for p in (tmp_path / "p0").glob("*.csv"))
    assert "table1.csv" in names and len(names) >= 4
    for name in names:
        assert _csv(tmp_path / "p0" / name) == _csv(tmp_path / "p1" / name), name

    acc = ["tetra:1", "balls:1", "--res", "4", "--axes", "precision,prepass", "--repeats", "1", "--quiet"]
    here = _run("accuracy", *acc, "--out", str(tmp_path / "a0"))
    there = _run("accuracy", *acc, "--out", str(tmp_path / "a1"), "--scheduler", scheduler)
    assert here.returncode == 0 and there.returncode == 0, there.stderr
    a0, a1 = (json.loads((tmp_path / d / "accuracy.json").read_text()) for d in ("a0", "a1"))
    assert a1["ran_on"] == f"the Dask cluster at {scheduler}"
    for axis in ("precision", "prepass"):
        rows0 = [_untimed(r) for r in a0["axes"][axis]]
        assert [r["scene"] for r in rows0][0] == "tetra" and rows0[-1]["scene"] == "balls"
        assert rows0 == [_untimed(r) for r in a1["axes"][axis]]


# -- Ctrl-C -----------------------------------------------------------------------------------


def _interrupt_after(argv: list[str], needle: str, timeout: float = 180) -> tuple[int, str, list[str]]:
    """Run a command, send Ctrl-C (to its process group, as a terminal does) once a line of its
    standard error contains `needle`; (exit code, stdout, stderr lines)."""
    proc = subprocess.Popen([sys.executable, "-m", "netsushisen.cli", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    lines = []
    deadline = time.time() + timeout
    for line in proc.stderr:
        lines.append(line.rstrip("\n"))
        if needle in line or time.time() > deadline:
            break
    os.killpg(proc.pid, signal.SIGINT)
    stdout, rest = proc.communicate(timeout=120)
    return proc.returncode, stdout, lines + rest.splitlines()


def test_ctrl_c_on_accuracy_writes_every_finished_row(tmp_path):
    """issue 30 item 6: the rows of a scene × axis still running are written too, not only
    whole units. Ctrl-C comes right after the depth axis's first row (its truth); eight depths
    are still to run."""
    out = tmp_path / "acc"
    code, _, err = _interrupt_after(["accuracy", "tetra:1", "--res", "12", "--axes", "depth",
                                     "--repeats", "1", "--workers", "1", "--out", str(out)],
                                    "tetra depth: depth ")
    assert code == 130, err
    assert "Traceback" not in "\n".join(err)
    finished = [line.split(": ", 1)[1].split(" done")[0] for line in err
                if line.startswith("tetra depth: depth ")]
    data = json.loads((out / "accuracy.json").read_text())
    assert data["interrupted"] is True
    settings = [r["setting"] for r in data["axes"]["depth"]]
    assert settings == finished and 1 <= len(settings) < 9, err  # the unit had not finished
    assert data["axes"]["depth"][0]["truth"] is True
    assert err[-1] == (f"netsushisen accuracy: interrupted; wrote the finished rows to {out}/: "
                       f"depth ({len(settings)} rows)")


# paper's Ctrl-C (one worker and two): tests/test_interrupts.py


# -- the result cache -------------------------------------------------------------------------


def test_paper_reuses_its_finished_runs_and_heals_a_damaged_one(tmp_path, cli, monkeypatch):
    monkeypatch.setattr(cluster, "IN_PROCESS", True)  # the cache is the point here: a cheap cluster
    argv = ["paper", "--res", "4", "--scenes", "tetra:1", "mount:1", "--out", tmp_path / "p", "--workers", "1"]
    code, first, err = cli(*argv)
    assert code == 0, err
    assert "runs from" not in first
    tables = {p.name: p.read_text() for p in (tmp_path / "p").glob("*.csv")}
    runs = sorted((tmp_path / "p" / "runs").glob("*.json"))
    assert len(runs) == 2
    code, second, err = cli(*argv)
    assert code == 0 and f"(2 runs from {tmp_path / 'p'}/runs/)" in second, err
    assert {p.name: p.read_text() for p in (tmp_path / "p").glob("*.csv")} == tables
    runs[0].write_text(runs[0].read_text().replace('"res": 4', '"res": 5'))  # edited
    code, third, err = cli(*argv)
    assert code == 0 and "(1 runs from" in third
    assert f"{runs[0]} does not match its checksum (edited or damaged): computing it again" in err
    assert {p.name: p.read_text() for p in (tmp_path / "p").glob("*.csv")} == tables


@pytest.mark.slow  # about 8 s: three runs
def test_accuracy_reuses_a_finished_scene_axis_unit_and_fresh_measures_again(tmp_path, cli):
    argv = ["accuracy", "tetra:1", "--res", "4", "--axes", "precision", "--repeats", "1", "--out",
            tmp_path / "a", "--workers", "1", "--quiet"]
    assert cli(*argv)[0] == 0
    rows = json.loads((tmp_path / "a" / "accuracy.json").read_text())["axes"]
    code, out, err = cli(*argv[:-1])
    assert code == 0 and f"(1 scene × axis units from {tmp_path / 'a'}/runs/)" in out, err
    again = json.loads((tmp_path / "a" / "accuracy.json").read_text())["axes"]
    assert again == rows  # timings included: the cached unit's own
    cli(*argv, "--fresh")
    fresh = json.loads((tmp_path / "a" / "accuracy.json").read_text())["axes"]
    assert [_untimed(r) for r in fresh["precision"]] == [_untimed(r) for r in rows["precision"]]
    assert [r["timing"] for r in fresh["precision"]] != [r["timing"] for r in rows["precision"]]


HALF_FRAMES = {  # a Dask greeting's 8-byte length, then less than it announced (issue 46 Why 4)
    "length-only": struct.pack("<Q", 16),
    "half-header": struct.pack("<Q", 16) + b"\x01\x00\x00",
    "short-frame": struct.pack("<Q", 8) + struct.pack("<Q", 1) + b"\x00",
    "bad-msgpack": struct.pack("<Q", 24) + struct.pack("<Q", 1) + struct.pack("<Q", 8) + b"\xc1" * 8,
}


@pytest.mark.parametrize("reply", sorted(HALF_FRAMES))
@pytest.mark.parametrize("command", ["sweep", "numerics"])
def test_a_scheduler_that_answers_half_a_frame_is_one_line(tmp_path, cli, command, reply):
    """A server that begins like Dask, then breaks its own protocol: one line, exit 1, within the
    greeting's time (Dask's reader raised struct.error: internal error, exit 70)."""
    import time

    server = _Server(HALF_FRAMES[reply])
    start = time.monotonic()
    try:
        code, out, err = cli(command, *COMMANDS[command](tmp_path), "--scheduler", server.address)
    finally:
        server.close()
    assert code == 1 and "Traceback" not in err and "internal error" not in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert f"--scheduler {server.address}: cannot connect" in err
    assert time.monotonic() - start < 30
