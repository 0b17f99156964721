"""The whole machine: N PEs sharing ICGM and SCGM, DIS in front, COL and the frame buffer behind.

One cycle (`Machine.step`): DIS pushes host words into the PEs' host FIFOs (deciding from the
state at the start of the cycle), every PE steps its processors and CMUs, COL pops pixel words;
by the FIFO rule (cmu.py) the order does not matter. Then the end-of-run rules are checked.

DIS. The host stream (image key `host`) is a sequence of messages, each a header word and
`length` payload words. Static distribution: message i goes to PE i mod N, all assigned up
front. Dynamic (load-aware, demand-driven): a message is assigned when DIS starts it, to a PE
that has taken everything it was given (its host port is not in the middle of a message and its
host FIFO is empty), the one with the smallest load (words in its CMU FIFOs and links) among
those, lowest index on a tie; at most one message is assigned per cycle. Each PE's host port
pushes one word per cycle while its host FIFO has room. DIS runs first in a cycle, so it sees the
state at the start of the cycle.

COL. Pops at most one word per cycle from each PE's `col` FIFO (SC's `send col`). A pixel
message is a header (dest COL, length 4; cls and tag free) and 4 words: pixel index (integer),
then R, G, B (floats of the machine's precision), added into a float64 frame buffer
(height × width × 3, pixel index = y × width + x). An ID message (dest COL, length 2) is a pixel
index and a primitive id, written into the hit-id buffer (int32, −1 where none came; the eye
ray's hit, docs/kernels.md). Any other length, or a pixel outside the frame (image key `frame`),
is a run-time fault.

End of a run (checked after every cycle, first match wins):
  fault     a processor or CMU faulted (exit 2)
  halted    every present processor of every PE has halted and every col FIFO and COL are empty
  finished  quiescence: DIS has nothing left, every PE is idle (every processor halted or
            waiting on an empty receive FIFO, no word in any FIFO or link) and COL is empty
  deadlock  some PE made no progress (pe.py) for ring.deadlock_cycles consecutive cycles while
            not idle (exit 3; the report names every FIFO's occupancy and held channel, and each
            processor's PC and wait reason); or every PE is idle and COL holds an incomplete
            pixel message (`col_report`); or the run would end `halted` or `finished` while a
            processor has stopped in the middle of sending a message on the ring
            (`unsent_messages`, `unsent_report`)
  max_cycles  config.max_cycles cycles have run (exit 4)
Words left in FIFOs when a run ends `halted` are counted in the statistics (`left_in_flight`).
No message is lost silently: a processor that halts (or waits forever) after sending part of a
message leaves words that can never be delivered — in COL, its send FIFO, links or a receive
FIFO — and the run ends `deadlock` (exit 3) with a report naming the processor, its PC, the
words never sent and where the message's words are, never `halted` or `finished` (exit 0).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from netsushisen.asm.objects import Program
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import STAGES
from netsushisen.isa.ring import DESTS, parse_header
from netsushisen.isa.words import word_format, wrap32

from netsushisen.emulator.cmu import RingFault
from netsushisen.emulator.core import RunFault
from netsushisen.isa.images import MemoryImage
from netsushisen.emulator.memories import Memory
from netsushisen.emulator.pe import PE

DEST_NAMES = {v: k for k, v in DESTS.items()}
EXIT_CODES = {"halted": 0, "finished": 0, "fault": 2, "deadlock": 3, "max_cycles": 4,
              "interrupted": 130}


class DeadlockError(NetsushisenError):
    exit_code = 3


class CycleLimit(NetsushisenError):
    exit_code = 4


@dataclass
class Dis:
    """The load distributor (see the module docstring). Its state is a few integers per PE (the
    message being pushed and the next word of it), so snapshots stay small."""

    messages: list[list[int]]
    dynamic: bool
    n_pes: int
    next_msg: int = 0  # dynamic: the next message to assign
    current: list[int] = field(default_factory=list)  # per PE: message being pushed, or -1
    offset: list[int] = field(default_factory=list)  # per PE: its next word
    upcoming: list[int] = field(default_factory=list)  # static: per PE, its next message
    assigned: list[int] = field(default_factory=list)  # messages started per PE
    words_sent: int = 0

    def __post_init__(self) -> None:
        self.current = [-1] * self.n_pes
        self.offset = [0] * self.n_pes
        self.upcoming = list(range(self.n_pes))
        self.assigned = [0] * self.n_pes

    def exhausted(self) -> bool:
        if any(c >= 0 for c in self.current):
            return False
        if self.dynamic:
            return self.next_msg >= len(self.messages)
        return all(u >= len(self.messages) for u in self.upcoming)

    def _start(self, i: int, msg: int) -> None:
        self.current[i], self.offset[i] = msg, 0
        self.assigned[i] += 1

    def step(self, c: int, pes: list[PE]) -> None:
        n_msgs = len(self.messages)
        if self.dynamic and self.next_msg < n_msgs:
            idle = [i for i in range(self.n_pes) if self.current[i] < 0 and not pes[i].ring.host.q]
            if idle:
                loads = {i: pes[i].ring.ring_words() for i in idle}
                self._start(min(idle, key=lambda k: (loads[k], k)), self.next_msg)
                self.next_msg += 1
        for i in range(self.n_pes):
            pe = pes[i]
            pe.dis_moved = False
            if self.current[i] < 0:
                if self.dynamic or self.upcoming[i] >= n_msgs:
                    continue
                self._start(i, self.upcoming[i])
                self.upcoming[i] += self.n_pes
            f = pe.ring.host
            if f.free(c) > 0:
                msg = self.messages[self.current[i]]
                f.push(c, msg[self.offset[i]])
                self.offset[i] += 1
                if self.offset[i] == len(msg):
                    self.current[i] = -1
                self.words_sent += 1
                pe.dis_moved = True


class Col:
    """The pixel collector and the frame buffer."""

    def __init__(self, n_pes: int, frame: tuple[int, int] | None, precision: str):
        self.width, self.height = frame or (0, 0)
        self.frame = np.zeros((self.height, self.width, 3), dtype=np.float64)
        self.ids = np.full((self.height, self.width), -1, dtype=np.int32)
        self.partial: list[list[int]] = [[] for _ in range(n_pes)]  # words of a message so far
        self.wf = word_format(precision)
        self.messages = 0
        self.words = 0

    def busy(self) -> bool:
        return any(self.partial)

    # the faults COL reports (every engine reports them with these words)

    @staticmethod
    def header_fault(pe: str, c: int, header: int) -> RunFault:
        h = parse_header(header)
        return RunFault(f"{pe} COL", c, f"COL takes pixel messages (dest COL, length 4) and ID "
                        f"messages (length 2), got header {header:#x} (dest {h.dest}, length "
                        f"{h.length})")

    def pixel_fault(self, pe: str, c: int, pixel: int) -> RunFault:
        return RunFault(f"{pe} COL", c, f"pixel {pixel} outside the {self.width}x{self.height} "
                        "frame (image key `frame`)")

    def step(self, c: int, pes: list[PE]) -> None:
        for i, pe in enumerate(pes):
            pe.col_moved = False
            f = pe.ring.col
            if not f.ready(c):
                continue
            w = f.pop(c)
            pe.col_moved = True
            self.words += 1
            part = self.partial[i]
            part.append(w)
            h = parse_header(part[0])
            if h.dest != DESTS["col"] or h.length not in (2, 4):
                raise self.header_fault(pe.name, c, part[0])
            if len(part) == h.length + 1:
                pixel = wrap32(part[1])
                if not 0 <= pixel < self.width * self.height:
                    raise self.pixel_fault(pe.name, c, pixel)
                y, x = divmod(pixel, self.width)
                if h.length == 2:
                    self.ids[y, x] = wrap32(part[2])
                else:
                    for k in range(3):
                        self.frame[y, x, k] += float(self.wf.to_float(part[2 + k]))
                self.messages += 1
                part.clear()


@dataclass
class RunResult:
    status: str  # halted, finished, deadlock, fault, max_cycles, interrupted (Engine.interrupt)
    cycles: int
    error: NetsushisenError | None = None

    @property
    def exit_code(self) -> int:
        return EXIT_CODES[self.status]


class Machine:
    """Build with programs (one per stage, run on every PE) and an optional memory image."""

    def __init__(self, config: MachineConfig, programs: dict[str, Program | None],
                 image: MemoryImage | None = None):
        config.validate()
        self.config = config
        self.programs = {s: programs.get(s) for s in STAGES}
        for s, p in self.programs.items():
            if p is not None and p.proc != s:
                raise NetsushisenError(f"the program given for {s.upper()} is a {p.proc.upper()} program")
        self.image = image
        wf = word_format(config.precision)
        self.globals: dict[str, Memory] = {}
        for stage, name in (("ic", "icgm"), ("sc", "scgm")):
            words = image.global_memory(name, wf) if image else np.zeros(0, dtype=wf.word_dtype)
            self.globals[stage] = Memory(name.upper(), words)
        self.pes = [PE(i, config, self.programs, self.globals, image) for i in range(config.pes)]
        host = image.host_words(wf) if image else []
        self.dis = Dis(split_messages(host, image.source if image else "<image>"),
                       config.distribution == "dynamic", config.pes)
        self.col = Col(config.pes, image.frame if image else None, config.precision)
        self.cycle = 0
        self.status: str | None = None
        self.error: NetsushisenError | None = None
        self.no_progress = [0] * config.pes
        self.tracer = None
        self._active = [core for pe in self.pes for core in pe.active]

    # -- stepping -------------------------------------------------------------------------------

    @property
    def cores(self):
        return [core for pe in self.pes for core in pe.cores.values()]

    def step(self) -> str | None:
        """Run one cycle; returns the run's status once it has ended (else None)."""
        with np.errstate(all="ignore"):  # IEEE results (±inf, NaN) are the semantics, not errors
            return self.step_unguarded()

    def step_unguarded(self) -> str | None:
        """`step` without numpy's error-state guard: for a caller that runs many cycles inside
        one `np.errstate(all="ignore")` (the reference engine's run) and so pays for it once."""
        if self.status is not None:
            return self.status
        c = self.cycle
        try:
            self.dis.step(c, self.pes)
            for pe in self.pes:
                try:
                    pe.step(c)
                except RingFault as err:
                    raise RunFault(f"{pe.name} CMU", c, str(err)) from None
            self.col.step(c, self.pes)
        except RunFault as err:
            self.cycle = c + 1
            self.status, self.error = "fault", err
            for core in self.cores:
                core.drain()
            return self.status
        self.cycle = c + 1
        if self.tracer is not None:
            self.tracer.cycle(self, c)
        self.status = self._check_end()
        if self.status is not None:
            for core in self.cores:
                core.drain()
        return self.status

    def run(self, max_cycles: int | None = None) -> RunResult:
        limit = self.config.max_cycles if max_cycles is None else max_cycles
        with np.errstate(all="ignore"):
            while self.status is None:
                if limit and self.cycle >= limit:
                    self.status = "max_cycles"
                    self.error = CycleLimit(f"cycle limit reached: {limit} cycles (max_cycles); "
                                            "the run did not end")
                    break
                self.step_unguarded()
        return RunResult(self.status, self.cycle, self.error)

    def _check_end(self) -> str | None:
        active = self._active
        if all(core.halted for core in active) and self.col_empty():
            return self._unless_unsent("halted")
        # A PE where a processor issued this cycle is neither idle nor stuck: only the others
        # need the (costly) idle test, and the run can only be finished if none issued.
        issued = [pe.issued() for pe in self.pes]
        idle: list[bool | None] = [None] * len(self.pes)
        if not any(issued):
            idle = [pe.idle() for pe in self.pes]
            if all(idle) and self.dis.exhausted():
                if self.col_empty():
                    return self._unless_unsent("finished")
                if not any(len(pe.ring.col) for pe in self.pes):  # nothing can complete COL's message
                    self.error = DeadlockError(self.col_report())
                    return "deadlock"
        limit = self.config.ring.deadlock_cycles
        for i, pe in enumerate(self.pes):
            if issued[i] or pe.progressed() or (idle[i] if idle[i] is not None else pe.idle()):
                self.no_progress[i] = 0
                continue
            self.no_progress[i] += 1
            if self.no_progress[i] >= limit:
                self.error = DeadlockError(self.deadlock_report(pe))
                return "deadlock"
        return None

    def _unless_unsent(self, status: str) -> str:
        """`status` (halted, finished) unless a message was left incomplete: then deadlock."""
        if self.unsent_messages():
            self.error = DeadlockError(self.unsent_report())
            return "deadlock"
        return status

    def unsent_messages(self) -> list[tuple[PE, str, int, int | None]]:
        """The processors in the middle of sending a message on the ring: (PE, stage, words of
        the message never sent, its header if still in the send FIFO else None). A send FIFO
        has one producer, its processor; its CMU knows how many words of the message it is
        passing are still to come (`remaining`), and the FIFO's words after those are whole
        messages (header + length words) unless the processor stopped mid-way."""
        out = []
        for pe in self.pes:
            for cmu in pe.ring.cmus:
                need = cmu.remaining[0] if cmu.route[0] is not None else 0
                header = None
                for w in cmu.inputs[0].words():
                    if need == 0:
                        header, need = w, parse_header(w).length
                    else:
                        need -= 1
                if need:
                    out.append((pe, cmu.stage, need, header))
        return out

    def col_empty(self) -> bool:
        return not self.col.busy() and all(len(pe.ring.col) == 0 for pe in self.pes)

    # -- reports --------------------------------------------------------------------------------

    def deadlock_report(self, pe: PE) -> list[Diagnostic]:
        n = self.no_progress[pe.index]
        lines = [Diagnostic(f"deadlock in {pe.name} at cycle {self.cycle}: no progress for {n} "
                            "cycles, every processor waiting on a FIFO or halted")]
        for core in pe.cores.values():
            if not core.present:
                state = "absent (no program)"
            elif core.halted:
                state = "halted"
            else:
                state = f"waiting on {core.cause}"
            lines.append(Diagnostic(f"  {core.name}: {core.where(core.pc)}: {state}",
                                    severity="note"))
        for f in pe.ring.fifos():
            if len(f) or f.name.rsplit(".", 1)[-1] in ("os", "ic", "sc", "host", "col") \
                    or not self.config.ring.buffer_pool:
                lines.append(Diagnostic(f"  FIFO {f.name}: {len(f)}/{f.capacity} words",
                                        severity="note"))
        for cmu in pe.ring.cmus:
            for text in cmu.describe_locks():
                lines.append(Diagnostic(f"  CMU {cmu.stage}: {text}", severity="note"))
        return lines

    def col_report(self) -> list[Diagnostic]:
        lines = [Diagnostic(f"deadlock at cycle {self.cycle}: every PE is idle but COL holds an "
                            "incomplete pixel message")]
        for i, part in enumerate(self.col.partial):
            if part:
                lines.append(Diagnostic(f"  from pe{i}: {len(part)} of 5 words received",
                                        severity="note"))
        return lines

    def unsent_report(self) -> list[Diagnostic]:
        lines = [Diagnostic(f"deadlock at cycle {self.cycle}: every processor has halted or is "
                            "waiting, but a message was left incomplete: its sender stopped before "
                            "its last word, so it can never be delivered")]
        unsent = self.unsent_messages()
        for pe in dict.fromkeys(u[0] for u in unsent):  # each PE once, in order
            for _, stage, need, header in (u for u in unsent if u[0] is pe):
                core = pe.cores[stage]
                where = (f"halted at {core.where(core.last_pc)}" if core.halted
                         else f"{core.where(core.pc)}: waiting on {core.cause}")
                if header is None:
                    what = "its header has left the send FIFO"
                else:
                    h = parse_header(header)
                    what = (f"header {header & 0xFFFFFFFF:#x} (dest {DEST_NAMES[h.dest]}, "
                            f"length {h.length}) still in FIFO {pe.ring.send[stage].name}")
                lines.append(Diagnostic(f"  {core.name}: {where}, with "
                                        f"{need} word{'s' if need != 1 else ''} of its message "
                                        f"on `ring` never sent; {what}", severity="note"))
            for f in pe.ring.fifos():
                if len(f):
                    lines.append(Diagnostic(f"  FIFO {f.name}: {len(f)}/{f.capacity} words",
                                            severity="note"))
            for cmu in pe.ring.cmus:
                for text in cmu.describe_locks():
                    lines.append(Diagnostic(f"  CMU {cmu.stage}: {text}", severity="note"))
        return lines

    def summary(self) -> str:
        lines = [f"status {self.status}, {self.cycle} cycles, {self.config.pes} PE"
                 f"{'s' if self.config.pes != 1 else ''}"]
        for core in self.cores:
            if not core.present:
                continue
            ipc = core.ops / core.cycles if core.cycles else 0.0
            stalls = sum(core.stalls.values())
            top = ", ".join(f"{k} {v}" for k, v in sorted(core.stalls.items(),
                                                          key=lambda kv: (-kv[1], kv[0]))[:3])
            lines.append(f"  {core.name}: {core.cycles} cycles, {core.bundles_issued} bundles, "
                         f"{core.ops} ops ({ipc:.2f}/cycle), {stalls} stall cycles"
                         + (f" [{top}]" if top else ""))
        if self.col.messages:
            lines.append(f"  COL: {self.col.messages} pixel messages")
        return "\n".join(lines)

    # -- debugger support ----------------------------------------------------------------------

    def record_events(self, on: bool = True) -> None:
        """Keep per-cycle events (register writes, loads with cache set, stores) in each core's
        `events` list; the caller clears them between cycles."""
        for core in self.cores:
            core.events = [] if on else None

    def snapshot(self) -> dict:
        """The full mutable state (a deep copy); `restore` returns the machine to it exactly.
        Programs, the config and the global memories (read-only during a run) are shared."""
        memo = self._shared_memo()
        return copy.deepcopy({"pes": self.pes, "dis": self.dis, "col": self.col,
                              "cycle": self.cycle, "status": self.status, "error": self.error,
                              "no_progress": self.no_progress}, memo)

    def restore(self, snap: dict) -> None:
        state = copy.deepcopy(snap, self._shared_memo())
        self.pes, self.dis, self.col = state["pes"], state["dis"], state["col"]
        self.cycle, self.status, self.error = state["cycle"], state["status"], state["error"]
        self.no_progress = state["no_progress"]
        self._active = [core for pe in self.pes for core in pe.active]

    def _shared_memo(self) -> dict:
        memo = {id(self.config): self.config, id(self.dis.messages): self.dis.messages}
        for p in self.programs.values():
            if p is not None:
                memo[id(p)] = p
        for g in self.globals.values():
            memo[id(g)] = g
        for pe in self.pes:  # resident memories are read-only during a run: share the arrays
            for mem in pe.memories.values():
                if mem.resident is not None:
                    memo[id(mem.resident.words)] = mem.resident.words
        for pe in self.pes:
            for core in pe.cores.values():
                memo[id(core.bundles)] = core.bundles
        if self.image is not None:
            memo[id(self.image)] = self.image
        return memo


def split_messages(words: list[int], source: str) -> list[list[int]]:
    """The host stream as messages (header + payload), checked to be complete."""
    out = []
    i = 0
    while i < len(words):
        n = parse_header(words[i]).length
        if i + 1 + n > len(words):
            raise NetsushisenError(Diagnostic(
                f"host: the message at word {i} (header {words[i]:#x}) announces {n} payload "
                f"words but only {len(words) - i - 1} follow", file=source))
        out.append(list(words[i:i + 1 + n]))
        i += 1 + n
    return out


__all__ = ["Machine", "RunResult", "DeadlockError", "RunFault", "CycleLimit"]
