"""Long machine runs on the command line: a progress display, and Ctrl-C that keeps what was done.

    monitor = RunMonitor(engine, total=n_eye_rays, unit="eye rays", label="balls 32x32",
                         show=not args.quiet)
    with monitor:
        result = monitor.run()          # engine.run with the monitor's progress callback
    if monitor.interrupted: ...         # Ctrl-C: result.status == "interrupted"

What `render` and `run` share (netsushisen/commands/):

- **Progress.** On a terminal (standard error a TTY) and unless quiet, a rich progress bar on
  standard error: the share of the host messages DIS has handed out (for `render`, the eye
  rays; known up front), machine cycles, the rate in machine cycles per second and an ETA, from
  `Engine.progress_counts()`. When standard error is not a terminal nothing is drawn (no escape
  codes in logs).
- **Ctrl-C.** While the monitor is active the first SIGINT only asks the run to stop: the
  progress callback raises KeyboardInterrupt at its next call, which engines make between cycles
  (reference) or between chunks (compiled, after writing its state back), so the machine's state
  is whole; `run()` then ends the run with `Engine.interrupt()` (status "interrupted") and the
  command writes the statistics, image and ids gathered so far and exits 130. A second Ctrl-C
  interrupts at once (e.g. while the compiled engine is still being compiled).
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from collections import deque

from netsushisen.emulator.engine import Engine, RunResult

COMPILING = "compiling the engine (first run: about a minute)"
"""The status while the compiled engine loads: whole even at 80 columns."""

EVERY = {"reference": 5_000, "tandem": 4_096, "compiled": 200_000}
"""Cycles between progress calls per engine: about 10 calls a second at each engine's speed,
which is also how soon a Ctrl-C is answered. (The compiled engine's call into compiled code
costs well under a millisecond, so 200,000-cycle chunks cost it nothing measurable.)"""

INTERRUPTED = 130
"""The exit code of a run stopped by Ctrl-C (128 + SIGINT, as shells report it)."""


def _rate(cycles_per_second: float) -> str:
    if cycles_per_second >= 1e6:
        return f"{cycles_per_second / 1e6:.2f} M cycles/s"
    return f"{cycles_per_second / 1e3:.0f} k cycles/s"


class RunMonitor:
    """Progress display and safe Ctrl-C around one `Engine.run` (see the module docstring).

    `total` is the number of host messages the run will hand out (0: none, then the bar only
    shows that the machine runs); `unit` names them ("eye rays", "host messages")."""

    def __init__(self, engine: Engine, total: int, unit: str = "host messages", label: str = "",
                 show: bool = True):
        self.engine = engine
        self.total = int(total)
        self.unit = unit
        self.label = label or engine.name
        self.every = EVERY.get(engine.name, 20_000)
        self.requested = False  # a Ctrl-C asked the run to stop
        self.interrupted = False  # the run was stopped by Ctrl-C
        self._show = show and sys.stderr.isatty()
        self._bar = None
        self._task = None
        self._samples: deque[tuple[float, int]] = deque()
        self._old_handler = None
        self._started = False

    # -- context: SIGINT handler and display ----------------------------------------------------

    def __enter__(self) -> RunMonitor:
        if threading.current_thread() is threading.main_thread():  # only it takes signals
            old = signal.getsignal(signal.SIGINT)
            self._old_handler = old if old is not None else signal.default_int_handler
            signal.signal(signal.SIGINT, self._on_sigint)
        if self._show:
            self._start_display()
        return self

    def __exit__(self, *exc) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None
        if self._old_handler is not None:
            signal.signal(signal.SIGINT, self._old_handler)
            self._old_handler = None

    def _on_sigint(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True  # stop at the next progress call; a second Ctrl-C stops at once
        if self._bar is not None:
            self._bar.update(self._task, status="stopping (Ctrl-C again: at once)")

    # -- running --------------------------------------------------------------------------------

    def run(self, max_cycles: int | None = None) -> RunResult:
        """`engine.run` with this monitor's progress callback; a Ctrl-C ends it "interrupted"."""
        try:
            return self.engine.run(max_cycles, progress=self.progress, every=self.every)
        except KeyboardInterrupt:
            self.interrupted = True
            return self.engine.interrupt()

    def progress(self, cycle: int) -> None:
        """The engines' progress callback: raises KeyboardInterrupt once a Ctrl-C came."""
        if self.requested:
            raise KeyboardInterrupt
        if self._bar is not None:
            self._update()

    # -- display --------------------------------------------------------------------------------

    def _start_display(self) -> None:
        from rich.console import Console
        from rich.table import Column
        from rich.progress import (BarColumn, Progress, TaskProgressColumn, TextColumn,
                                   TimeElapsedColumn, TimeRemainingColumn)

        known = self.total > 0
        # the status (while the engine compiles) comes right after the label: on a narrow
        # terminal rich shortens the last columns, and the message must stay whole
        status = COMPILING if self.engine.name in ("compiled", "tandem") else ""
        self._status_width = Column(min_width=len(status), no_wrap=True)
        columns = [TextColumn("{task.description}",
                              table_column=Column(min_width=len(self.label), no_wrap=True)),
                   TextColumn("{task.fields[status]}", table_column=self._status_width),
                   BarColumn(bar_width=24)]
        if known:
            columns += [TaskProgressColumn(),
                        TextColumn(f"{{task.completed:,.0f}}/{{task.total:,.0f}} {self.unit}")]
        columns += [TextColumn("{task.fields[cycles]}"), TextColumn("{task.fields[rate]}")]
        columns += [TimeRemainingColumn() if known else TimeElapsedColumn()]
        self._bar = Progress(*columns, console=self.console or Console(stderr=True),
                             transient=True)
        self._task = self._bar.add_task(self.label, total=self.total if known else None,
                                        cycles="", rate="", status=status)
        self._bar.start()

    console = None
    """The console the bar is drawn on (None: standard error's; tests give one of 80 columns)."""

    def _update(self) -> None:
        cycle, handed, _ = self.engine.progress_counts()
        now = time.perf_counter()
        samples = self._samples
        samples.append((now, cycle))
        while len(samples) > 2 and now - samples[0][0] > 5.0:  # the rate over the last seconds
            samples.popleft()
        rate = ""
        if len(samples) >= 2 and now > samples[0][0]:
            rate = _rate((cycle - samples[0][1]) / (now - samples[0][0]))
        fields = {"cycles": f"{cycle:,} cycles", "rate": rate}
        if not self._started:
            self._started = True
            fields["status"] = ""
            self._status_width.min_width = None  # its room goes back to the counters
        if self.total > 0:
            fields["completed"] = min(handed, self.total)
        self._bar.update(self._task, **fields)
