"""A command's `--timeline FILE`: the window, the run that writes it, the note printed after.

`render` and `run` take `--timeline FILE [--cycles A:B] [--procs P]` (docs/timeline.md). The
window is checked when the options are read (`timeline_window`: one line if malformed or longer
than MAX_WINDOW); `TimelineRun` is built after the engine (it checks the processors and opens
the file before the run starts) and runs the engine to its end with the window written:
`run_with_timeline` runs the engine to the window's first cycle (the compiled engine there, as
the debugger's fast-forward does), steps the reference engine through the window with
emulator/trace.py's `TimelineTap` feeding one of reports/timeline.py's writers, then lets the
engine finish the run. This glue joins the machine, the progress display and the writers, so it
lives at the top, above all three.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from netsushisen.emulator.trace import TimelineTap, parse_cycles, wanted
from netsushisen.isa.errors import NetsushisenError

if TYPE_CHECKING:
    from netsushisen.emulator.engine import Engine
    from netsushisen.emulator.machine import RunResult
    from netsushisen.progress import RunMonitor


DEFAULT_WINDOW = 100_000
"""Cycles a timeline covers when --cycles does not say (from its first cycle): a whole small
run (render tetra --res 8 is 53,274 cycles), a few seconds on the reference engine."""

MAX_WINDOW = 1_000_000
"""The longest window: the reference engine steps it with the tap and a writer at 16,000
(Kanata) to 23,000 (JSON) cycles per CPU-second, about a minute, and one PE's three processors
fill about 350 MB of Kanata log (220 MB of JSON) per million cycles (render tetra)."""

STEP_CHECK = 2_000
"""Cycles between progress calls (Ctrl-C) while the window is stepped."""


@dataclass(frozen=True)
class Window:
    """The cycles a timeline covers: first included, end excluded; `default` when --cycles did
    not give the end (a note says so if the run goes past it)."""

    first: int
    end: int
    default: bool


@dataclass(frozen=True)
class TimelineRequest:
    """What --timeline asks for (options.timeline_from_args reads it): the file (its extension
    says the format), the window of cycles and the processors shown (name prefixes; None:
    every one). It lives here, beside its window, so options imports the timeline and not the
    reverse."""

    path: str
    window: Window
    processors: list[str] | None


def timeline_window(cycles: str | None) -> Window:
    """`--cycles` for a timeline: 'A:B', 'A:', ':B', 'A' or None; a one-line error when
    malformed or longer than MAX_WINDOW."""
    try:
        first, end = parse_cycles(cycles)
    except ValueError:
        raise NetsushisenError(f"--cycles {cycles!r}: expected A:B, A: or :B (cycles, A "
                               "included, B excluded)") from None
    if end is None:
        return Window(first, first + DEFAULT_WINDOW, True)
    if end == first:
        raise NetsushisenError(f"--cycles {cycles}: the window is empty")
    if end - first > MAX_WINDOW:
        raise NetsushisenError(f"--cycles {cycles}: a timeline covers at most {MAX_WINDOW:,} "
                               f"cycles (this is {end - first:,}); choose a shorter window")
    return Window(first, end, False)


def check_processors(machine, prefixes: list[str] | None) -> None:
    """A one-line error if a --procs prefix names no processor of the machine."""
    names = [core.name for core in machine.cores if core.present]
    for p in prefixes or ():
        if not any(wanted(n, [p]) for n in names):
            raise NetsushisenError(f"--procs {p}: no such processor (the machine has "
                                   f"{', '.join(names)})")


def timeline_note(path: str, tap: TimelineTap, window: Window, run_end: int) -> str:
    """The line a command prints after writing a timeline: the cycles covered, the bundles per
    processor, and the default window's end when the run went past it."""
    bundles = ", ".join(f"{name} {n:,}" for name, n in tap.issued.items())
    note = (f"timeline: wrote {path}: cycles {tap.first:,} to {tap.last:,}"
            + (f", bundles issued: {bundles}" if bundles else ""))
    if tap.last == tap.first and run_end <= window.first:
        note += f" (empty: the run stopped at cycle {run_end:,}, before the window)"
    elif window.default and run_end > window.end:
        note += (f" (the default window of {DEFAULT_WINDOW:,} cycles; the run went on to cycle "
                 f"{run_end:,}: choose the window with --cycles A:B)")
    return note


def run_with_timeline(engine: Engine, monitor: RunMonitor, tap: TimelineTap,
                      window: Window) -> RunResult:
    """Run `engine` to the end with `tap` watching cycles window.first..window.end.

    The engine (the compiled one, by default) runs to the window's first cycle; the reference
    engine steps the window with the tap (the machine state is the engine's, written back, as
    the debugger's fast-forward does); then the engine runs on to the end. `monitor` is the
    command's RunMonitor (progress, Ctrl-C): a Ctrl-C ends the run "interrupted" and the
    timeline is closed at the cycle reached. Returns the RunResult."""
    m = engine.machine
    limit = m.config.max_cycles
    if window.first > 0:
        goal = min(window.first, limit) if limit else window.first
        result = monitor.run(max_cycles=goal)
        if m.status == "max_cycles" and not (limit and m.cycle >= limit):
            m.status, m.error = None, None  # reaching the window is not the run's end
        if monitor.interrupted or m.status is not None:  # ended first: an empty timeline
            tap.start(m)
            tap.close()
            return result if monitor.interrupted else engine.result()
    if m.status is None:
        m.tracer = tap
        m.record_events(True)
        tap.start(m)
        try:
            while m.status is None and m.cycle < window.end and not (limit and m.cycle >= limit):
                m.step()
                if m.cycle % STEP_CHECK == 0:
                    monitor.progress(m.cycle)
        except KeyboardInterrupt:
            monitor.interrupted = True
            return engine.interrupt()
        finally:
            m.tracer = None
            m.record_events(False)
            tap.close()
    if m.status is not None:
        return engine.result()
    return monitor.run()


class TimelineRun:
    """A command's --timeline: built after the engine (checks the request against the machine
    and opens the file: one-line errors before the run starts), `run(monitor)` runs the engine
    to its end with the window written, `note()` is the line to print afterwards."""

    def __init__(self, request: TimelineRequest, engine: Engine):
        from netsushisen.reports.timeline import open_timeline

        check_processors(engine.machine, request.processors)
        if engine.name not in ("reference", "compiled"):
            raise NetsushisenError(f"--timeline steps its window on the reference engine, handed "
                                   f"over from the compiled one; --engine {engine.name} cannot "
                                   "hand over (use compiled or reference)")
        self.request, self.engine = request, engine
        writer, self.out = open_timeline(request.path)
        self.tap = TimelineTap(writer, request.processors)

    def run(self, monitor: RunMonitor) -> RunResult:
        try:
            return run_with_timeline(self.engine, monitor, self.tap, self.request.window)
        finally:
            self.out.close()

    def note(self) -> str:
        return timeline_note(self.request.path, self.tap, self.request.window, self.engine.cycle)
