"""Nothing lost on Ctrl-C: a real SIGINT sent to a real process of `render`, `paper` and
`accuracy` (`run`'s and the reference engine's `render` are in tests/test_long_runs.py, `sweep`'s
in tests/test_sweep.py): each writes what it has — statistics, partial image, finished scenes —
says so in one line and exits 130. Every wait is bounded."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest


pytest.importorskip("pty")
from test_long_runs import Terminal  # noqa: E402  (tests/ is on sys.path: conftest.py)



class Piped(Terminal):
    """A command line run with standard error on a pipe, drained in a thread: what a log or a
    CI job sees (no progress bar; one line per finished scene). Waits as `Terminal` does."""

    def __init__(self, *argv: str, cwd: Path):  # noqa: super().__init__ would open a terminal
        env = dict(os.environ, NETSUSHISEN_DEBUG="")
        self.proc = subprocess.Popen([sys.executable, "-m", "netsushisen.cli", *map(str, argv)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     stdin=subprocess.DEVNULL, cwd=cwd, env=env)
        self.err = bytearray()
        self._thread = threading.Thread(target=self._drain, daemon=True)
        self._thread.start()

    def _drain(self) -> None:
        for chunk in iter(lambda: self.proc.stderr.read1(4096), b""):
            self.err.extend(chunk)

    def interrupt(self, timeout: float) -> int:
        self.proc.send_signal(signal.SIGINT)
        self.out = self.proc.stdout.read()
        self.proc.wait(timeout=timeout)
        self._thread.join(timeout=5)
        return self.proc.returncode

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def interrupted_after(run: Terminal, pattern: str, timeout: float) -> str:
    """SIGINT once `pattern` shows on standard error; the command must exit 130 with no
    traceback. Returns standard error."""
    try:
        assert run.wait_for(pattern, timeout=timeout), run.stderr_text()
        code = run.interrupt(timeout=60)
    finally:
        run.close()
    err = run.stderr_text()
    assert code == 130 and "Traceback" not in err, err
    return err


def test_ctrl_c_during_a_compiled_render_writes_the_partial_image_and_statistics(tmp_path):
    """The compiled engine stops between chunks, writes its state back and the render writes
    what was done (the reference engine's run: tests/test_long_runs.py)."""
    term = Terminal("render", "balls", "--res", "128", "--engine", "compiled", "-o", "b.png",
                    "--ids", "ids.npy", "--json", "b.json", cwd=tmp_path)
    # after a million cycles; the whole render: ~90 M
    err = interrupted_after(term, r"\b[1-9][\d,]*,\d{3},\d{3} cycles", timeout=240)
    assert "netsushisen render: interrupted at cycle" in err
    stats = json.loads((tmp_path / "b.json").read_text())
    assert stats["run"]["status"] == "interrupted"
    assert 1_000_000 <= stats["run"]["cycles"] < 60_000_000
    assert 0 < stats["dis"]["messages_per_pe"][0] < 128 * 128
    ids = np.load(tmp_path / "ids.npy")
    assert ids.shape == (128, 128) and (ids < 0).any() and (ids >= 0).any()
    assert (tmp_path / "b.png").stat().st_size > 0


def test_ctrl_c_during_paper_writes_the_finished_scenes(tmp_path):
    run = Piped("paper", "--res", "48", "--scenes", "tetra", "balls", "--out", "p", "--jobs", "1",
                cwd=tmp_path)  # one worker: scenes finish in order
    err = interrupted_after(run, r"tetra: trace-driven path done in", timeout=240)
    assert err.strip().splitlines()[-1] == ("netsushisen paper: interrupted; finished tetra, not "
                                            "balls; wrote what was finished to p/")
    report = (tmp_path / "p" / "report.md").read_text()
    assert "tetra" in report and "balls" in report  # balls named as not finished
    table1 = (tmp_path / "p" / "table1.csv").read_text()
    assert "tetra" in table1 and "balls" not in table1


def test_ctrl_c_during_a_parallel_paper_stops_the_workers_and_keeps_the_finished(tmp_path):
    run = Piped("paper", "--res", "48", "--scenes", "tetra", "balls", "mount", "rings", "--out", "p",
                "--jobs", "2", cwd=tmp_path)
    err = interrupted_after(run, r"trace-driven path done in", timeout=240)
    last = err.strip().splitlines()[-1]
    assert last.startswith("netsushisen paper: interrupted; finished ") and "wrote what was finished to p/" in last
    finished = last.split("finished ")[1].split(", not ")[0].split(", ")
    table1 = (tmp_path / "p" / "table1.csv").read_text()
    assert finished and all(name in table1 for name in finished)
    assert "Incomplete run" in (tmp_path / "p" / "report.md").read_text()


@pytest.mark.slow
def test_ctrl_c_during_accuracy_writes_the_finished_axes(tmp_path):
    run = Piped("accuracy", "tetra", "balls", "--res", "16", "--axes", "depth", "--out", "a",
                cwd=tmp_path)
    err = interrupted_after(run, r"tetra depth: done at", timeout=300)
    data = json.loads((tmp_path / "a" / "accuracy.json").read_text())
    rows = data["axes"]["depth"]
    assert err.strip().splitlines()[-1] == ("netsushisen accuracy: interrupted; wrote the finished "
                                            f"rows to a/: depth ({len(rows)} rows)")
    tetra = [r for r in rows if r["scene"] == "tetra"]
    assert len(tetra) == 9 and len(rows) - len(tetra) < 9  # tetra whole, balls's rows so far
