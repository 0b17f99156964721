"""The timeline's events: the records the machine's tap emits and the timeline writers read.

A pipeline timeline (`render/run --timeline`, docs/timeline.md) is the reference engine's cycles
as plain records: per cycle and processor, the bundle issued (`Issued`: its operations with the
unit instance each occupies, the cycle each completes and the registers it writes) or the stall
(`Stalled`: cause, the PC it is charged to, whether it is a hold after an earlier bundle); per
PE, FIFO occupancy when it changes (`FifoLevel`); per cache miss, the address (`CacheMiss`).
emulator/trace.py's `TimelineTap` makes them and reports/timeline.py's writers read them, so the
records live below both (as the memory-image encoding does): the writers never see the machine.
Named tuples: a window makes one per processor and cycle, and they are the cheapest records
Python builds.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol


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


__all__ = ["CacheMiss", "Event", "FifoLevel", "Issued", "OpRecord", "ProcessorInfo", "Stalled",
           "Start", "TimelineSink"]
