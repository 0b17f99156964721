"""Long runs from the command line (netsushisen/progress.py): the default engine, the progress
display only on a terminal, and Ctrl-C that stops `render` and `run` at a whole cycle, writes
what exists (statistics with run.status "interrupted", the partial image and ids) and exits 130.

The Ctrl-C tests run the command in a subprocess with standard error on a pseudo-terminal: the
progress bar showing a cycle count is how the test knows the run has started before it sends
SIGINT. Every wait is bounded."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from netsushisen.emulator.engine import DEFAULT_ENGINE, default_engine, engine_names
from netsushisen.isa.config import load_config
from netsushisen.progress import RunMonitor

COMPILED = "compiled" in engine_names()
LOOP = "loop: addi r1, r1, 1\n      j loop\n"

pty = pytest.importorskip("pty")


# ---------------------------------------------------------------------------------------------
# The default engine and --trace


def test_compiled_is_the_default_engine_where_it_imports(cli, tmp_path, monkeypatch):
    assert default_engine() == ("compiled" if COMPILED else "reference")
    assert DEFAULT_ENGINE == "compiled" or not COMPILED
    from netsushisen import pipeline as render

    used = []
    make = render.make_engine
    monkeypatch.setattr(render, "make_engine", lambda name, *a: used.append(name) or make(name, *a))
    code, out, err = cli("render", "tetra:1", "--res", "2", "-o", tmp_path / "t.png", "--quiet")
    assert code == 0, err
    assert used == [default_engine()]


def test_trace_takes_the_reference_engine(cli, tmp_path):
    (tmp_path / "ic.s").write_text("start: nop\n halt\n")
    code, out, err = cli("run", "--ic", tmp_path / "ic.s", "--trace", "-q")
    assert code == 0, err
    assert out.splitlines()[0].split()[:4] == ["0", "pe0.ic", "0", "start"]
    if COMPILED:
        code, out, err = cli("run", "--ic", tmp_path / "ic.s", "--trace", "--engine", "compiled")
        assert code == 1 and out == "" and "Traceback" not in err
        assert len(err.strip().splitlines()) == 1
        assert "--trace needs --engine reference" in err


def test_no_progress_output_when_stderr_is_not_a_terminal(cli, tmp_path):
    code, out, err = cli("render", "tetra:1", "--res", "3", "-o", tmp_path / "t.png")
    assert code == 0 and err == ""
    assert "\x1b" not in out


# ---------------------------------------------------------------------------------------------
# Stopping between cycles / chunks leaves a whole machine


def test_an_interrupted_run_is_a_whole_machine(engine_name):
    """A KeyboardInterrupt out of the progress callback stops every engine at a cycle boundary:
    its statistics are the reference engine's at that cycle, status "interrupted"."""
    from netsushisen.pipeline import prepare

    setup = prepare("balls:1", load_config(None, []), res=4)
    engine = setup.engine(engine_name)
    monitor = RunMonitor(engine, engine.host_messages, show=False)
    monitor.every = 1000
    plain = monitor.progress

    def progress(cycle: int) -> None:
        plain(cycle)
        monitor.requested = True  # as the SIGINT handler does: stop at the next call

    monitor.progress = progress
    result = monitor.run()
    assert monitor.interrupted and result.status == "interrupted" and result.exit_code == 130
    assert engine.exit_code == 130 and 0 < engine.cycle < 40929
    got = engine.statistics()
    assert got["run"]["status"] == "interrupted" and got["run"]["cycles"] == engine.cycle
    for name, p in got["processors"].items():
        assert p["cycles"] == p["bundles"] + p["stall_cycles"], name
    ref = setup.engine("reference")
    ref.run(max_cycles=engine.cycle)
    want = ref.statistics()
    for s in (got, want):
        s["run"].pop("status"), s["run"].pop("message"), s["run"].pop("engine")
    assert got == want
    assert np.array_equal(engine.frame, ref.frame) and np.array_equal(engine.ids, ref.ids)


# ---------------------------------------------------------------------------------------------
# Ctrl-C in a real process


class Terminal:
    """A command line run with standard error on a pseudo-terminal (drained in a thread, so the
    progress bar never blocks on a full terminal buffer); standard output is a pipe."""

    def __init__(self, *argv: str, cwd: Path):
        master, slave = pty.openpty()
        env = dict(os.environ, TERM="xterm", COLUMNS="120", NETSUSHISEN_DEBUG="")
        self.proc = subprocess.Popen([sys.executable, "-m", "netsushisen.cli", *map(str, argv)],
                                     stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL,
                                     cwd=cwd, env=env)
        os.close(slave)
        self.master = master
        self.err = bytearray()
        self.out = b""
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        while True:
            try:
                data = os.read(self.master, 4096)
            except OSError:  # the last writer closed the terminal
                return
            if not data:
                return
            self.err.extend(data)

    def wait_for(self, pattern: str, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and self.proc.poll() is None:
            if re.search(pattern, self.err.decode(errors="replace")):
                return True
            time.sleep(0.05)
        return False

    def interrupt(self, timeout: float) -> int:
        self.proc.send_signal(signal.SIGINT)
        self.out, _ = self.proc.communicate(timeout=timeout)
        return self.proc.returncode

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        os.close(self.master)

    def stderr_text(self) -> str:
        time.sleep(0.2)  # the drain thread's last read
        return self.err.decode(errors="replace")


RUNNING = r"[1-9][\d,]* cycles"
"""The progress bar once the machine has run: a non-zero cycle count."""


def test_ctrl_c_during_render_writes_the_partial_image_and_statistics(tmp_path):
    term = Terminal("render", "balls", "--res", "32", "--engine", "reference", "-o", "b.png",
                    "--ids", "ids.npy", "--json", "b.json", cwd=tmp_path)
    try:
        assert term.wait_for(r"\b[1-9]\d\d,\d{3} cycles", timeout=120), term.stderr_text()
        code = term.interrupt(timeout=60)  # after 100,000 cycles: some pixels are done
    finally:
        term.close()
    err = term.stderr_text()
    assert code == 130, err
    last = [line for line in re.split(r"[\r\n]", err) if line.strip()][-1]
    assert "netsushisen render: interrupted at cycle" in last and "Traceback" not in err
    stats = json.loads((tmp_path / "b.json").read_text())
    assert stats["run"]["status"] == "interrupted"
    assert 100_000 <= stats["run"]["cycles"] < 4_000_000  # the whole render: ~5.4 M cycles
    assert 0 < stats["dis"]["messages_per_pe"][0] < 32 * 32
    assert stats["rays"]["eye"] == 32 * 32
    from PIL import Image

    assert Image.open(tmp_path / "b.png").size == (32, 32)
    ids = np.load(tmp_path / "ids.npy")
    assert ids.shape == (32, 32) and (ids < 0).any()  # the pixels not done yet
    assert "interrupted after" in term.out.decode()  # the summary of what was done


def test_ctrl_c_during_run_writes_the_statistics(tmp_path, engine_name):
    (tmp_path / "os.s").write_text(LOOP)
    term = Terminal("run", "--os", "os.s", "--engine", engine_name, "--json", "s.json",
                    "--frame", "f.npy", cwd=tmp_path)
    try:
        assert term.wait_for(RUNNING, timeout=180), term.stderr_text()
        code = term.interrupt(timeout=60)
    finally:
        term.close()
    err = term.stderr_text()
    assert code == 130, err
    assert "netsushisen run: interrupted at cycle" in err and "Traceback" not in err
    stats = json.loads((tmp_path / "s.json").read_text())
    assert stats["run"]["status"] == "interrupted" and stats["run"]["cycles"] > 0
    os_ = stats["processors"]["pe0.os"]
    assert os_["cycles"] == stats["run"]["cycles"] == os_["bundles"] + os_["stall_cycles"]
    assert (tmp_path / "f.npy").exists()
