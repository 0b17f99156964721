"""Pipeline timelines a viewer opens: Kanata logs (Konata) and trace-event JSON (Perfetto).

`render` / `run --timeline FILE` hand the events of the window (emulator/trace.py's
`TimelineTap`: bundles issued, stalls, FIFO occupancy, cache misses) to one of these writers as
they happen; both write as they go, so memory stays bounded however long the window is (what
the Kanata writer holds is the bundles still in flight and the commands scheduled for their
future cycles). docs/timeline.md gives the mapping from machine events to each format.

Kanata (FILE.kanata or FILE.log), the log format of Konata (docs/kanata-log-format.md of
github.com/shioyadan/Konata, version 0004): one instruction row per issued bundle of a shown
processor, its thread id the processor's index (pe0.os 0, pe0.ic 1, pe0.sc 2, pe1.os 3, ...).

    lane 0         `Is` the issue cycle
    lane 1         the stalls charged to the bundle, one stage per run of one cause (`operand:fmul`,
                   `fifo_empty:ring`, ...): before its issue while it waits, after it for a hold
                   (`cache_miss`, `branch`, ...), as the statistics' stalls_by_pc charge them
    lane 2 + u     per operation, on its unit instance u (int0, int1, fp0, ...): `X.<mnemonic>`
                   from issue until the result is written, then `Wb` (labelled with the
                   registers) in the cycle it is written; an operation without a result ends
                   its `X` stage when it leaves the unit
    W              wake-up arrows (type 0) to a bundle from the bundles whose results it reads
                   that were written while it waited to issue, or as it issued

A row is retired (R type 0) once its last stage has ended and its processor has moved on. Rows
retired as flushed (R type 1) are not bundles issued in the window: the stalls of a bundle
issued before the window (a hold carried in) or of one still waiting when the window closed.

Trace events (FILE.json), the JSON Object Format of the Trace Event Format (Chrome's
about:tracing, Perfetto's ui.perfetto.dev): one process per PE (pid = PE index), one thread per
processor (tid = 0 OS, 1 IC, 2 SC), named by metadata events; 1 µs of the trace is one machine
cycle. Each issued bundle is a complete event (`X`, dur 1, name label+offset); each run of
stall cycles with one cause and one charged PC is a complete event named by the cause; every
FIFO's occupancy is a counter (`C`, name the FIFO) of its PE; each cache miss is a thread-scoped
instant event (`i`, name `cache_miss`, args address, set, region).
"""

from __future__ import annotations

import heapq
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.events import CacheMiss, Event, FifoLevel, Issued, Stalled, Start
from netsushisen.isa.outputs import replacing
from netsushisen.isa.processors import STAGES

KANATA_SUFFIXES = (".kanata", ".log")
JSON_SUFFIXES = (".json",)
STAGE_TID = {stage: i for i, stage in enumerate(STAGES)}  # os 0, ic 1, sc 2


def timeline_format(path: str) -> str:
    """'kanata' or 'json' by the file's extension; a one-line error for any other."""
    suffix = Path(path).suffix.lower()
    if suffix in KANATA_SUFFIXES:
        return "kanata"
    if suffix in JSON_SUFFIXES:
        return "json"
    raise NetsushisenError(f"--timeline {path}: the extension says the format: .kanata or .log "
                           f"(a Kanata log for Konata) or .json (trace events for Perfetto)")


def open_timeline(path: str) -> tuple[KanataWriter | TraceEventWriter, TextIO]:
    """The writer for `path` and the open file (opened now, before any work, so a bad path is
    a one-line error up front)."""
    kind = timeline_format(path)
    try:
        out = replacing(path, "w", encoding="utf-8", newline="\n")  # in place when closed
    except NetsushisenError as err:
        raise NetsushisenError(f"--timeline {path}: {err.diagnostics[0].message}") from None
    return (KanataWriter(out) if kind == "kanata" else TraceEventWriter(out)), out


def _clean(text: str) -> str:
    """Kanata fields are tab separated, one command a line."""
    return text.replace("\t", " ").replace("\n", " ")


# ---------------------------------------------------------------------------------------------
# Kanata


@dataclass(slots=True)
class _Row:
    id: int
    processor: str
    pc: int
    issued: bool = False
    carried: bool = False  # the stalls of a bundle issued before the window
    stall: str | None = None  # the stall stage open on lane 1
    stall_end: int = 0  # the cycle after its last stall cycle
    busy_until: int = 0  # the cycle its last stage ends
    issue_cycle: int = -1
    opened: int = 0  # the cycle of its `I`
    retire_at: int | None = None  # the cycle of its `R`, once scheduled
    stalls: dict[str, int] = field(default_factory=dict)


class KanataWriter:
    """Writes a Kanata 0004 log (see the module docstring) to `out` as events arrive."""

    def __init__(self, out: TextIO):
        self.out = out
        self.now = 0
        self.rows = 0  # instruction ids given out
        self.retired = 0  # the next retire id
        self.first = 0
        self._seq = 0
        self._queue: list[tuple[int, int, str, object]] = []  # (cycle, seq, kind, payload)
        self._current: dict[str, _Row] = {}
        self._threads: dict[str, int] = {}
        self._writer: dict[tuple[str, int], tuple[_Row, int]] = {}  # register -> (row, written)

    # -- the sink interface ----------------------------------------------------------------------

    def begin(self, start: Start) -> None:
        self.first = self.now = start.cycle
        self._threads = {p.name: p.thread for p in start.processors}
        self.out.write(f"Kanata\t0004\nC=\t{start.cycle}\n")

    def event(self, e: Event) -> None:
        if isinstance(e, Issued):
            self._advance(e.cycle)
            self._issue(e)
        elif isinstance(e, Stalled):
            self._advance(e.cycle)
            self._stall(e)

    def close(self, end: int) -> None:
        """The window ended before cycle `end`: retire every row, write what is scheduled."""
        self._advance(end)
        for row in list(self._current.values()):
            self._retire(row, end)
        self._current.clear()
        self._advance(None)

    # -- rows ---------------------------------------------------------------------------------

    def _put(self, cycle: int, kind: str, payload: object) -> None:
        # never behind what is written: cycle deltas stay non-negative whatever comes
        heapq.heappush(self._queue, (max(cycle, self.now), self._seq, kind, payload))
        self._seq += 1

    def _line(self, cycle: int, text: str) -> None:
        self._put(cycle, "line", text)

    def _advance(self, cycle: int | None) -> None:
        """Write every command scheduled before `cycle` (None: all of them), in cycle order."""
        q, out = self._queue, self.out
        while q and (cycle is None or q[0][0] < cycle):
            t, _, kind, payload = heapq.heappop(q)
            if t > self.now:
                out.write(f"C\t{t - self.now}\n")
                self.now = t
            if kind == "line":
                out.write(payload)
            else:  # "R": retire ids are serial in the order rows retire
                row_id, flush = payload
                out.write(f"R\t{row_id}\t{self.retired}\t{1 if flush else 0}\n")
                if not flush:
                    self.retired += 1

    def _open(self, cycle: int, processor: str, pc: int, label: str, text: str,
              carried: bool = False) -> _Row:
        old = self._current.get(processor)
        if old is not None:
            self._retire(old, cycle)
        row = _Row(self.rows, processor, pc, carried=carried, opened=cycle)
        self.rows += 1
        self._current[processor] = row
        what = f"{processor} {pc:>4} {label}: {text}"
        if carried:
            what += f" (issued before cycle {self.first})"
        self._line(cycle, f"I\t{row.id}\t{pc}\t{self._threads[processor]}\n"
                          f"L\t{row.id}\t0\t{_clean(what)}\n")
        return row

    def _end_stall(self, row: _Row) -> None:
        if row.stall is not None:
            self._line(row.stall_end, f"E\t{row.id}\t1\t{row.stall}\n")
            row.stall = None

    def _retire(self, row: _Row, cycle: int) -> None:
        self._end_stall(row)
        t = max(row.busy_until, row.stall_end, cycle)
        if row.issued:
            info = f"issued at cycle {row.issue_cycle}"
        elif row.carried:
            info = f"issued before cycle {self.first}, the window's first"
        else:
            info = "not issued in the window"
        if row.stalls:
            info += "; stalls: " + ", ".join(f"{k} {v}" for k, v in row.stalls.items())
        self._line(t, f"L\t{row.id}\t1\t{_clean(info)}\n")
        self._put(t, "R", (row.id, not row.issued))
        row.retire_at = t

    def _stall(self, e: Stalled) -> None:
        row = self._current.get(e.processor)
        if e.hold:
            if row is None or row.pc != e.pc or not (row.issued or row.carried):
                row = self._open(e.cycle, e.processor, e.pc, e.label, e.text, carried=True)
        elif row is None or row.pc != e.pc or row.issued or row.carried:
            row = self._open(e.cycle, e.processor, e.pc, e.label, e.text)
        if row.stall != e.cause or row.stall_end != e.cycle:
            self._end_stall(row)
            self._line(e.cycle, f"S\t{row.id}\t1\t{_clean(e.cause)}\n")
            row.stall = e.cause
        row.stall_end = e.cycle + 1
        row.stalls[e.cause] = row.stalls.get(e.cause, 0) + 1

    def _issue(self, e: Issued) -> None:
        c = e.cycle
        row = self._current.get(e.processor)
        if row is None or row.pc != e.pc or row.issued or row.carried:
            row = self._open(c, e.processor, e.pc, e.label, e.text)
        self._end_stall(row)
        row.issued, row.issue_cycle = True, c
        rid = row.id
        self._line(c, f"S\t{rid}\t0\tIs\n")
        self._line(c + 1, f"E\t{rid}\t0\tIs\n")
        for r in e.reads:  # wake-up arrows from the bundles whose results it waited for
            producer = self._writer.get((e.processor, r))
            if producer is not None:
                prow, written = producer
                if written >= row.opened and (prow.retire_at is None or prow.retire_at > c):
                    self._line(c, f"W\t{rid}\t{prow.id}\t0\n")
        end = c + 1
        for op in e.ops:
            lane = 2 + op.unit
            stage = f"X.{op.mnemonic}"
            self._line(c, f"S\t{rid}\t{lane}\t{stage}\nL\t{rid}\t2\t{_clean(op.text)}\n")
            done = max(op.done, c + 1)
            if op.writes:
                for r in op.writes:
                    self._writer[e.processor, r] = (row, done)
                regs = ", ".join(f"r{r}" for r in op.writes)
                self._line(done, f"E\t{rid}\t{lane}\t{stage}\nS\t{rid}\t{lane}\tWb\n"
                                 f"L\t{rid}\t2\t{regs}\n")
                self._line(done + 1, f"E\t{rid}\t{lane}\tWb\n")
                end = max(end, done + 1)
            else:
                self._line(done, f"E\t{rid}\t{lane}\t{stage}\n")
                end = max(end, done)
        row.busy_until = end


# ---------------------------------------------------------------------------------------------
# Trace events (JSON)


class TraceEventWriter:
    """Writes trace-event JSON (see the module docstring) to `out` as events arrive: the
    `traceEvents` array is written one event a line, and closed by `close`."""

    def __init__(self, out: TextIO):
        self.out = out
        self._first_event = True
        self._where: dict[str, tuple[int, int]] = {}  # processor -> (pid, tid)
        self._span: dict[str, list] = {}  # processor -> [cause, pc, label, hold, start, end]
        self.first = 0

    def _write(self, event: dict) -> None:
        sep = "" if self._first_event else ",\n"
        self._first_event = False
        self.out.write(sep + json.dumps(event, separators=(",", ":")))

    def begin(self, start: Start) -> None:
        self.first = start.cycle
        other = {"tool": "netsushisen", "clock": "1 us of the trace = 1 machine cycle",
                 "first_cycle": start.cycle,
                 "processors": [p.name for p in start.processors]}
        self.out.write('{"displayTimeUnit":"ms","otherData":'
                       + json.dumps(other, separators=(",", ":")) + ',\n"traceEvents":[\n')
        for pe in sorted({p.pe for p in start.processors}):
            self._write({"name": "process_name", "ph": "M", "ts": 0, "pid": pe, "tid": 0,
                         "args": {"name": f"pe{pe}"}})
            self._write({"name": "process_sort_index", "ph": "M", "ts": 0, "pid": pe, "tid": 0,
                         "args": {"sort_index": pe}})
        for p in start.processors:
            tid = STAGE_TID[p.stage]
            self._where[p.name] = (p.pe, tid)
            self._write({"name": "thread_name", "ph": "M", "ts": 0, "pid": p.pe, "tid": tid,
                         "args": {"name": f"{p.name} ({p.stage.upper()})"}})
            self._write({"name": "thread_sort_index", "ph": "M", "ts": 0, "pid": p.pe,
                         "tid": tid, "args": {"sort_index": tid}})

    def event(self, e: Event) -> None:
        if isinstance(e, Issued):
            self._flush_span(e.processor)
            pid, tid = self._where[e.processor]
            self._write({"name": e.label, "cat": "bundle", "ph": "X", "ts": e.cycle, "dur": 1,
                         "pid": pid, "tid": tid,
                         "args": {"pc": e.pc, "bundle": e.text, "serial": e.serial,
                                  "ops": len(e.ops)}})
        elif isinstance(e, Stalled):
            span = self._span.get(e.processor)
            if span is not None and span[0] == e.cause and span[1] == e.pc and span[5] == e.cycle:
                span[5] = e.cycle + 1
            else:
                self._flush_span(e.processor)
                self._span[e.processor] = [e.cause, e.pc, e.label, e.hold, e.cycle, e.cycle + 1]
        elif isinstance(e, FifoLevel):
            self._write({"name": e.fifo, "cat": "fifo", "ph": "C", "ts": e.cycle, "pid": e.pe,
                         "tid": 0, "args": {"words": e.words}})
        elif isinstance(e, CacheMiss):
            pid, tid = self._where[e.processor]
            self._write({"name": "cache_miss", "cat": "memory", "ph": "i", "s": "t",
                         "ts": e.cycle, "pid": pid, "tid": tid,
                         "args": {"address": e.address, "set": e.cache_set,
                                  "region": e.region}})

    def _flush_span(self, processor: str) -> None:
        span = self._span.pop(processor, None)
        if span is None:
            return
        cause, pc, label, hold, start, end = span
        pid, tid = self._where[processor]
        self._write({"name": cause, "cat": "stall", "ph": "X", "ts": start, "dur": end - start,
                     "pid": pid, "tid": tid,
                     "args": {"pc": pc, "charged_to": label, "hold": hold}})

    def close(self, end: int) -> None:
        for processor in list(self._span):
            self._flush_span(processor)
        self.out.write("\n]}\n")


__all__ = ["KanataWriter", "TraceEventWriter", "open_timeline", "timeline_format"]
