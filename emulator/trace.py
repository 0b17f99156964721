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
The records are isa/events.py's. Running a command's timeline (the window, the hand-over from
the compiled engine, the note printed afterwards) is command glue: netsushisen/timeline.py.
"""

from __future__ import annotations

from typing import TextIO

from netsushisen.asm.regnames import named_text, register_names
from netsushisen.isa.events import (CacheMiss, Event, FifoLevel, Issued, OpRecord, ProcessorInfo,
                                    Stalled, Start, TimelineSink)
from netsushisen.isa.stalls import HOLD_CAUSES  # a hold after an earlier bundle, T10 rule 1



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
# Timeline events: what a pipeline viewer needs, as plain records (isa/events.py)


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
