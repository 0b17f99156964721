"""The engine interface: one small surface every engine of the machine implements.

After amaranth's `BaseEngine`: a command, a test or a report builds an engine from (config,
programs, memory image), runs it to an end or a cycle limit (or steps it), and then reads what
the machine did — statistics, frame and id buffers, registers, memories — without knowing which
engine ran. The engines:

    reference   plain Python, cycle by cycle (core.py, pe.py, cmu.py, memories.py, machine.py):
                the specification, and the engine the debugger steps
    compiled    the same machine in numba (emulator/compiled/); after a run its state is
                written back into the reference engine's objects, so everything read through
                this interface (and the debugger's hand-off) works unchanged
    tandem      both in lock step; stops at the first cycle where any state or counter differs

`make_engine(name, ...)` is the one way to get an engine; an unknown name is a one-line error
that lists the engines. The default (DEFAULT_ENGINE) is the compiled engine; where it does not
import, `default_engine()` falls back to the reference engine with one warning line. A long run is stopped safely by raising KeyboardInterrupt
from its progress callback (between cycles or chunks) and ended with `interrupt()`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Callable

import numpy as np

from netsushisen.asm.objects import Program
from netsushisen.isa.errors import ConfigError, Diagnostic
from netsushisen.isa.config import MachineConfig

from netsushisen.emulator import stats as run_stats
from netsushisen.emulator.loads import LoadRecorder, Sink
from netsushisen.isa.images import MemoryImage
from netsushisen.emulator.machine import EXIT_CODES, Machine, RunResult

Progress = Callable[[int], None]
"""Called now and then during a run with the machine cycle reached."""


class Engine(ABC):
    """The interface: how a run is made (`run`, `step`: each engine's own) and how it is read
    (everything else: shared).

    State lives in a reference `Machine` (built here: validation, decoding and memory images
    are one code path for every engine); an engine that computes elsewhere writes its state
    back into that machine before any read, so the readers below serve every engine. An engine
    reaches the machine only through its public methods.
    """

    name: str = ""

    def __init__(self, config: MachineConfig, programs: dict[str, Program | None],
                 image: MemoryImage | None = None):
        self.machine = Machine(config, programs, image)
        self.config = self.machine.config

    # -- running (each engine's own) -----------------------------------------------------------

    @abstractmethod
    def run(self, max_cycles: int | None = None, progress: Progress | None = None,
            every: int = 20000) -> RunResult:
        """Run until the machine ends (halted, finished, fault, deadlock) or `max_cycles`
        (default: config.max_cycles; 0 = none) cycles have run; `progress(cycle)` is called
        about every `every` cycles (an exception it raises stops the run with a whole machine
        behind)."""

    @abstractmethod
    def step(self, cycles: int = 1) -> str | None:
        """Run `cycles` cycles (fewer if the run ends); the status once ended, else None.
        Stepping is not a cycle limit: a run stepped to any cycle goes on."""

    def interrupt(self) -> RunResult:
        """End a run stopped from outside — Ctrl-C, as a KeyboardInterrupt out of `run` raised
        by its progress callback, i.e. between cycles (reference) or chunks (compiled, which
        writes its state back first), so the machine's state is whole: the status becomes
        "interrupted" (exit code 130) unless the run had ended, and statistics, frame and ids
        say what was done so far."""
        m = self.machine
        if m.status is None:
            m.status = "interrupted"
        return self.result()

    @property
    def host_messages(self) -> int:
        """The number of messages in the host stream DIS hands out (known before the run: the
        total of progress_counts()'s second count)."""
        return len(self.machine.dis.messages)

    def progress_counts(self) -> tuple[int, int, int]:
        """(cycle, host messages DIS has started handing out, messages COL has taken): cheap
        live counters for a progress display, valid during a run (from a progress callback)."""
        m = self.machine
        return m.cycle, sum(m.dis.assigned), m.col.messages

    # -- recording ---------------------------------------------------------------------------

    def record_loads(self, processors: list[str] | None = None,
                     sink: Sink | None = None, local: bool = False) -> LoadRecorder:
        """Record every resident (`ldr`) and global (`ldg`, with its cache hit) load of
        `processors` (default: every PE's IC) from now on, in issue order (emulator/loads.py):
        off unless asked for; `local`: also every local `ld` (space LOCAL). Both engines record
        the same stream; read it with `recorder.stream(name)` after the run (or take it piece
        by piece through `sink`)."""
        names = processors if processors is not None else [
            p for p in self.processors() if p.endswith(".ic")]
        for name in names:
            self._core(name)  # an unknown name is a KeyError naming the processors
        rec = LoadRecorder(names, sink)
        for name in names:
            self._core(name).memory.record = rec.buffer(name)
            self._core(name).memory.record_local = local
        self.recorder = rec
        return rec

    recorder: LoadRecorder | None = None

    # -- reading -------------------------------------------------------------------------------

    @property
    def cycle(self) -> int:
        return self.machine.cycle

    @property
    def status(self) -> str | None:
        return self.machine.status

    def result(self) -> RunResult:
        m = self.machine
        return RunResult(m.status, m.cycle, m.error)

    @property
    def exit_code(self) -> int:
        return EXIT_CODES.get(self.machine.status, 0)

    def blocked(self) -> list[tuple[str, str, str]]:
        """After a run that ended `finished` (quiescence, docs/timing.md "End of run"): the
        processors that never halted but wait forever on an empty receive FIFO, as
        (processor, where: "pc 3 (loop)", port: "ring", "host" or "any" for `wait`), in machine
        order. A kernel that serves messages in a loop ends so by design (`render`); a program
        run by hand usually meant to halt. Read from the reference objects, which every engine
        writes its state back into, so every engine gives the same answer."""
        if self.machine.status != "finished":
            return []
        return [(core.name, core.where(core.pc), core.cause.split(":", 1)[1])
                for core in self.machine.cores
                if core.present and not core.halted and core.cause.startswith("fifo_empty:")]

    def statistics(self) -> dict:
        """The run's statistics (schema `netsushisen-stats`, emulator/stats.py), `run.engine`
        naming the engine that ran it (the one field in which two engines' statistics differ)."""
        stats = run_stats.collect(self.machine)
        stats["run"]["engine"] = self.name
        return stats

    def summary(self) -> str:
        return self.machine.summary()

    @property
    def frame(self) -> np.ndarray:
        """COL's frame buffer (height × width × 3, float64)."""
        return self.machine.col.frame

    @property
    def ids(self) -> np.ndarray:
        """COL's hit-id buffer (height × width, int32, −1 where none came)."""
        return self.machine.col.ids

    def processors(self) -> list[str]:
        """Processor names in machine order: pe0.os, pe0.ic, pe0.sc, pe1.os, ..."""
        return [core.name for core in self.machine.cores]

    def _core(self, processor: str):
        for core in self.machine.cores:
            if core.name == processor:
                return core
        raise KeyError(f"no processor {processor!r} (have {', '.join(self.processors())})")

    def register(self, processor: str, reg: int) -> int:
        """Raw word of register `reg` of processor `processor` (e.g. "pe0.ic")."""
        return int(self._core(processor).regs[reg])

    def registers(self, processor: str) -> list[int]:
        return [int(w) for w in self._core(processor).regs]

    def pc(self, processor: str) -> int:
        return self._core(processor).pc

    def memory(self, processor: str, space: str) -> np.ndarray:
        """Raw words of a processor's memory `space`: local, resident or global (read-only
        view of ICGM/SCGM as that processor sees it)."""
        pe, stage = processor.split(".")
        mem = self.machine.pes[int(pe[2:])].memories[stage]
        if space == "local":
            return mem.local.words
        if space == "resident":
            if mem.resident is None:
                raise KeyError(f"{processor} has no resident memory")
            return mem.resident.words
        if space == "global":
            if mem.global_memory is None:
                raise KeyError(f"{processor} has no global memory")
            return mem.global_memory.words
        raise KeyError(f"no memory space {space!r} (local, resident, global)")


class ReferenceEngine(Engine):
    """The specification: the reference `Machine` stepped cycle by cycle in plain Python."""

    name = "reference"

    def run(self, max_cycles: int | None = None, progress: Progress | None = None,
            every: int = 20000) -> RunResult:
        try:
            return ReferenceEngine._run(self, max_cycles, progress, every)
        finally:
            if self.recorder is not None:
                self.recorder.flush()

    def _run(self, max_cycles: int | None, progress: Progress | None, every: int) -> RunResult:
        m = self.machine
        if progress is None:
            return m.run(max_cycles)
        limit = self.config.max_cycles if max_cycles is None else max_cycles
        every = max(every, 1)
        with np.errstate(all="ignore"):  # as Machine.step, once for the whole run
            while m.status is None:
                if limit and m.cycle >= limit:
                    return m.run(max_cycles)  # records the cycle-limit end
                m.step_unguarded()
                if m.cycle % every == 0:
                    progress(m.cycle)  # between cycles: an exception here leaves a whole cycle
        progress(m.cycle)
        return self.result()

    def step(self, cycles: int = 1) -> str | None:
        status = None
        for _ in range(cycles):
            status = self.machine.step()
            if status is not None:
                break
        return status


ENGINES: dict[str, Callable[..., Engine]] = {"reference": ReferenceEngine}
"""Engines by name; the compiled and tandem engines register themselves when importable."""

DEFAULT_ENGINE = "compiled"
"""The engine commands and library calls use unless told otherwise. Where the compiled engine
does not import (numba missing or broken), `default_engine()` falls back to the reference
engine and says so once. Nothing here imports numba: a command that runs no machine does not
pay for it."""

FALLBACK_COST = "about 200 times slower"
"""What the reference engine costs against the compiled one (README, docs/engines.md)."""

_unavailable: dict[str, str] = {}
"""Engines that did not import, with why (the ImportError's message)."""
_warned = False


def default_engine() -> str:
    """DEFAULT_ENGINE if it imports, else "reference" with one warning line on standard error
    (once per process): why the compiled engine is missing and what that costs."""
    global _warned
    _register_optional()
    if DEFAULT_ENGINE in ENGINES:
        return DEFAULT_ENGINE
    if not _warned:
        import sys

        _warned = True
        print(f"netsushisen: warning: the compiled engine is unavailable "
              f"({_unavailable.get(DEFAULT_ENGINE, 'not installed')}); running on the reference "
              f"engine, {FALLBACK_COST} (pip install numba)", file=sys.stderr)
    return "reference"


def _register_optional() -> None:
    if "compiled" in ENGINES or "compiled" in _unavailable:
        return
    try:
        from netsushisen.emulator.compiled import CompiledEngine, TandemEngine
    except ImportError as err:  # numba missing or broken, or the compiled engine not installed
        _unavailable["compiled"] = _unavailable["tandem"] = f"{type(err).__name__}: {err}"
        return
    ENGINES["compiled"] = CompiledEngine
    ENGINES["tandem"] = TandemEngine


def engine_names() -> list[str]:
    _register_optional()
    return sorted(ENGINES)


def check_engine(name: str) -> str:
    """`name` if it is an engine, else a one-line ConfigError naming the engines."""
    names = engine_names()
    if name in _unavailable:
        raise ConfigError(Diagnostic(f"engine {name!r} is unavailable here ({_unavailable[name]}); "
                                     f"engines: {', '.join(names)}"))
    if name not in ENGINES:
        raise ConfigError(Diagnostic(f"unknown engine {name!r} (engines: {', '.join(names)})"))
    return name


def make_engine(name: str, config: MachineConfig, programs: dict[str, Program | None],
                image: MemoryImage | None = None) -> Engine:
    """Build engine `name` for (config, programs, image)."""
    return ENGINES[check_engine(name)](config, programs, image)
