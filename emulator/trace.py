"""Line trace: one line per cycle per processor (after PyMTL3's line tracing), and the event
tap a pipeline timeline is written from.

    cycle  processor  pc  label+offset        what happened
       12  pe0.ic      4  loop+1               fadd r1, r2, r3 ; fmul r4, r5, r6
       13  pe0.ic      5  loop+2               stall operand:fmul
       14  pe0.ic      5  loop+2               stall operand:fmul

A processor's lines stop after the bundle holding its `halt`.

A stall line shows the PC the stall is charged to (a hold after a load or a taken branch is
charged to that load or branch). Filters: processors by name prefix (`pe0.ic`, `pe1`, comma
separated) and a cycle range `A:B` (A included, B excluded; either may be left out).

Timeline events (`TimelineTap`, the same hook: `machine.tracer`): per cycle and processor, the
bundle issued (`Issued`: its operations with the unit instance each occupies, the cycle each
completes and the registers it writes) or the stall (`Stalled`: cause, the PC it is charged to,
whether it is a hold after an earlier bundle); per PE, FIFO occupancy when it changes
(`FifoLevel`; a FIFO empty until then has none); per cache miss, the address (`CacheMiss`).
The events are plain records handed to a sink as they happen (reports/timeline.py writes them
to Kanata or trace-event files), so the writers never see the machine and memory stays bounded
however long the window.
`run_with_timeline` runs an engine to the window's first cycle (the compiled engine there, as
the debugger's fast-forward does), steps the reference engine through the window with the tap,
then lets the engine finish the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple, Protocol, TextIO

from netsushisen.asm.regnames import named_text, register_names
from netsushisen.errors import NetsushisenError
from netsushisen.isa.stalls import HOLD_CAUSES  # a hold after an earlier bundle, T10 rule 1

if TYPE_CHECKING:
    from netsushisen.emulator.engine import Engine
    from netsushisen.emulator.machine import RunResult
    from netsushisen.options import TimelineRequest
    from netsushisen.progress import RunMonitor


def parse_cycles(text: str | None) -> tuple[int, int | None]:
    """'A:B', 'A:', ':B' or 'A' → (first, end or None); ValueError if malformed."""
    if not text:
        return 0, None
    a, sep, b = text.partition(":")
    first = int(a) if a.strip() else 0
    if not sep:
        return first, first + 1
    end = int(b) if b.strip() else None
    if first < 0 or (end is not None and end < first):
        raise ValueError(f"bad cycle range {text!r}")
    return first, end


def parse_processors(text: str | None) -> list[str] | None:
    """'pe0.ic,pe1' → ['pe0.ic', 'pe1'] (name prefixes); None or '' → None (every processor)."""
    if not text:
        return None
    return [p.strip() for p in text.split(",") if p.strip()] or None


def wanted(name: str, prefixes: list[str] | None) -> bool:
    """Whether processor `name` (pe0.ic) matches one of the prefixes (pe0.ic, pe0; None: all)."""
    return prefixes is None or any(name == p or name.startswith(p + ".") for p in prefixes)


def bundle_text(core, pc: int) -> str:
    """The bundle's text for a trace line, registers with their `.reg` names (`pri/r29`)."""
    program = core.program
    if program is None or not program.reg_names:
        return core.bundles[pc].text
    return named_text(program, pc) or "(empty)"


class Tracer:
    def __init__(self, out: TextIO, processors: str | None = None, cycles: str | None = None):
        self.out = out
        self.prefixes = parse_processors(processors)
        self.first, self.end = parse_cycles(cycles)
        self._halted: set[str] = set()

    def wants(self, name: str) -> bool:
        return wanted(name, self.prefixes)

    def cycle(self, machine, c: int) -> None:
        if c < self.first or (self.end is not None and c >= self.end):
            return
        for core in machine.cores:
            if not core.present or not self.wants(core.name):
                continue
            if core.last_issued:
                what = bundle_text(core, core.last_pc)
                if core.halted:
                    self._halted.add(core.name)
            elif core.halted:
                if core.name in self._halted:
                    continue
                self._halted.add(core.name)
                what = "halted"
            else:
                what = "stall " + core.cause
            pc = core.last_pc
            self.out.write(f"{c:>8}  {core.name:<7} {pc:>5}  {core.label(pc):<20.20} {what}\n")


# ---------------------------------------------------------------------------------------------
# Timeline events: what a pipeline viewer needs, as plain records (named tuples: a window makes
# one per processor and cycle, and they are the cheapest records Python builds)




class ProcessorInfo(NamedTuple):
    """A processor the timeline shows: `thread` is its index among the machine's processors
    (pe0.os 0, pe0.ic 1, ...), `units` its unit instances in a fixed order (int0, int1, fp0,
    ...)."""

    name: str
    pe: int
    stage: str
    thread: int
    units: tuple[str, ...]


class Start(NamedTuple):
    """The window opens at `cycle` (the machine's state is that after cycle - 1)."""

    cycle: int
    processors: tuple[ProcessorInfo, ...]
    fifos: tuple[tuple[int, str, int], ...]  # (PE, FIFO name, capacity) whose occupancy follows


class OpRecord(NamedTuple):
    """One operation of an issued bundle: `unit` the unit instance it runs on (an index into the
    processor's `units`), `done` the cycle its result is written (the start of that cycle) or,
    without a result, the cycle it leaves its unit; `writes` the registers it writes."""

    text: str
    mnemonic: str
    unit: int
    done: int
    writes: tuple[int, ...]


class Issued(NamedTuple):
    cycle: int
    processor: str
    pc: int
    label: str  # label+offset
    text: str  # the bundle as the assembler prints it
    ops: tuple[OpRecord, ...]
    serial: int  # the processor's bundles issued before this one, since the run began
    reads: tuple[int, ...]  # the registers it reads


class Stalled(NamedTuple):
    cycle: int
    processor: str
    pc: int  # the PC the stall is charged to (the statistics' stalls_by_pc)
    label: str
    text: str  # the bundle at pc
    cause: str
    hold: bool  # a hold after the bundle at pc issued (HOLD_CAUSES), not a wait to issue


class FifoLevel(NamedTuple):
    cycle: int  # occupancy at the end of this cycle
    pe: int
    fifo: str
    words: int


class CacheMiss(NamedTuple):
    cycle: int
    processor: str
    address: int
    cache_set: int
    region: str | None  # the database region of the address (image regions), if known


Event = Issued | Stalled | FifoLevel | CacheMiss


class TimelineSink(Protocol):
    """Where a TimelineTap's events go (reports/timeline.py's writers)."""

    def begin(self, start: Start) -> None: ...

    def event(self, event: Event) -> None: ...

    def close(self, end: int) -> None: ...


class TimelineTap:
    """`machine.tracer` for a timeline: turns each cycle of the reference engine into events for
    `sink`, for the processors matching `processors` (name prefixes; None: every one present).
    Needs `machine.record_events(True)` (the loads of a cycle, for cache-miss addresses):
    `run_with_timeline` sets that up and clears the per-cycle event lists."""

    def __init__(self, sink: TimelineSink, processors: list[str] | None = None):
        self.sink = sink
        self.prefixes = processors
        self.cores: list = []
        self.issued: dict[str, int] = {}  # bundles issued in the window, per processor
        self.first = self.last = 0
        self._fifos: list[tuple[int, object]] = []
        self._levels: list[int] = []
        self._misses: list[int] = []
        self._lanes: dict[str, tuple[dict[str, int], tuple[str, ...]]] = {}
        self._bundles: dict[tuple[str, int], tuple] = {}

    def start(self, machine) -> None:
        """Open the window at the machine's current cycle: name the processors and FIFOs, and
        give every FIFO's occupancy now."""
        from netsushisen.isa.processors import PROCESSORS

        infos = []
        for i, core in enumerate(machine.cores):
            if not core.present or not wanted(core.name, self.prefixes):
                continue
            pe, stage = core.name.split(".")
            proc = PROCESSORS[stage]
            units, first = [], {}
            for unit, n in proc.units.items():
                first[unit] = len(units)
                units += [f"{unit}{k}" for k in range(n)]
            self._lanes[core.name] = (first, tuple(units))
            infos.append(ProcessorInfo(core.name, int(pe[2:]), stage, i, tuple(units)))
            self.cores.append(core)
            self.issued[core.name] = 0
        shown = {info.pe for info in infos}
        self._fifos = [(pe.index, f) for pe in machine.pes if pe.index in shown
                       for f in pe.ring.fifos()]
        self._levels = [len(f) for _, f in self._fifos]
        self._misses = [core.memory.global_accesses for core in self.cores]
        self.first = self.last = machine.cycle
        self.sink.begin(Start(machine.cycle, tuple(infos),
                              tuple((pe, f.name, f.capacity) for pe, f in self._fifos)))
        for (pe, f), n in zip(self._fifos, self._levels):
            if n:  # a FIFO's track starts with its first word (most link channels stay empty)
                self.sink.event(FifoLevel(machine.cycle, pe, f.name, n))

    def _static(self, core, pc: int) -> tuple:
        """What never changes about the bundle at `pc` of `core`, worked out once: label, text,
        and per operation (text, mnemonic, unit instance, registers written, kind, latency)."""
        key = (core.name, pc)
        info = self._bundles.get(key)
        if info is None:
            b = core.bundles[pc]
            first, _ = self._lanes[core.name]
            used: dict[str, int] = {}
            names = register_names(core.program).labels(pc) if core.program else None
            ops = []
            for d in b.ops:
                if not d.unit:
                    continue
                k = used.get(d.unit, 0)
                used[d.unit] = k + 1
                ops.append((d.op.format(None, names), d.m, first[d.unit] + k,
                            tuple(r for r in d.op.writes() if r), d.kind, d.lat))
            info = self._bundles[key] = (core.label(pc), bundle_text(core, pc), tuple(ops),
                                         tuple(r for r in b.reads if r))
        return info

    def cycle(self, machine, c: int) -> None:
        sink = self.sink
        for k, core in enumerate(self.cores):
            if core.last_issued:
                self._issue(core, c)
            elif not core.halted:
                cause = core.cause
                pc = core.last_pc
                label, text, _, _ = self._static(core, pc)
                sink.event(Stalled(c, core.name, pc, label, text, cause, cause in HOLD_CAUSES))
            misses = core.memory.global_accesses
            if misses != self._misses[k]:
                self._miss(core, c, misses - self._misses[k])
                self._misses[k] = misses
        levels = self._levels
        for j, (pe, f) in enumerate(self._fifos):
            n = len(f.q)
            if n != levels[j]:
                levels[j] = n
                sink.event(FifoLevel(c, pe, f.name, n))
        for core in machine.cores:
            if core.events:
                core.events.clear()
        self.last = c + 1

    def _issue(self, core, c: int) -> None:
        pc = core.last_pc
        label, text, static, reads = self._static(core, pc)
        held = core.hold_pc == pc and core.hold_mem_until > c + 1  # a hold set by this issue
        ready_at = core.ready_at
        ops = []
        for op_text, m, unit, writes, kind, lat in static:
            if writes:
                done = ready_at[writes[0]]
            elif kind == "load":
                done = core.hold_mem_until if held else c + 1
            else:
                done = c + lat
            ops.append(OpRecord(op_text, m, unit, done, writes))
        self.issued[core.name] += 1
        self.sink.event(Issued(c, core.name, pc, label, text, tuple(ops), core.bundles_issued - 1,
                               reads))

    def _miss(self, core, c: int, n: int) -> None:
        mem = core.memory
        loads = [e for e in core.events or () if e[0] == "load" and e[2] == "global"]
        for e in loads[-n:] if n <= len(loads) else loads:
            addr = e[3]
            region = None
            if mem.global_regions is not None:
                r = mem.global_regions.lookup(addr)
                region = r.name if r is not None else None
            self.sink.event(CacheMiss(c, core.name, addr, e[4], region))

    def close(self) -> None:
        self.sink.close(self.last)


# ---------------------------------------------------------------------------------------------
# Running a window


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
