"""The compiled engine: the whole machine in numba, cycle for cycle the reference engine.

    build.py   the loop module: opcode dispatchers generated from the opcode table + loop.py,
               cached on disk under a hash of its sources
    loop.py    the machine's cycle (core, memories, CMU ring, DIS, COL, end of run) over arrays
    bits.py    words as integers and floats in compiled code
    state.py   the machine's state as arrays, read from and written back into the reference
               engine's objects
    tandem.py  both engines in lock step, stopping at the first difference

The engine builds the reference `Machine` (validation, decoding, memory images: one code path
for both engines), flattens its state into arrays, runs the compiled loop in chunks (progress,
Ctrl-C), and writes the state back — so statistics, reports, fault and deadlock messages and
the debugger's hand-off are produced by the reference engine's own code from the same state.
"""

from __future__ import annotations

import time

import numpy as np

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.jit import register_with_numba

register_with_numba()  # the ISA's semantics, marked for numba (isa/jit.py), before any compile

from netsushisen.emulator.core import RunFault
from netsushisen.emulator.engine import Engine, Progress, ReferenceEngine
from netsushisen.emulator.machine import DeadlockError, RunResult
from netsushisen.emulator.memories import MemoryFault
from netsushisen.emulator.cmu import col_on_ring
from netsushisen.emulator.compiled import state as S
from netsushisen.emulator.compiled.build import load, run_loop

CHUNK = 2_000_000
"""Cycles per call into compiled code: progress reports and Ctrl-C come between calls."""


_ENDS_ANYWHERE = (S.S_RUNNING, S.S_HALTED, S.S_FINISHED, S.S_STOPPED)
"""The ends the loop can reach with processors run ahead of the machine (state.py C_AHEAD):
none can end a run while a processor is busy on its own."""


def _chunk(loop, st: S.State) -> int:
    """One call into the compiled loop. One that ends in a fault or a deadlock is done again
    from the same start with no processor running ahead (state.py G_AHEAD), so the report sees
    every processor in the cycle the run ended in, as the reference engine does."""
    g = st.arrays["g"]
    if not g[S.G_AHEAD]:
        return run_loop(loop, st.args())
    start = {k: v.copy() for k, v in st.arrays.items()
             if isinstance(v, np.ndarray) and k not in S.READ_ONLY}
    code = run_loop(loop, st.args())
    if code in _ENDS_ANYWHERE:
        return code
    for k, v in start.items():
        st.arrays[k][...] = v
    g[S.G_AHEAD] = 0
    return run_loop(loop, st.args())


class CompiledEngine(Engine):
    """The machine in numba: flatten the reference machine's state, run the loop in chunks,
    write the state back (so every reader of `Engine` serves it unchanged)."""

    name = "compiled"

    def run(self, max_cycles: int | None = None, progress: Progress | None = None,
            every: int = CHUNK) -> RunResult:
        m = self.machine
        if m.status is not None:
            return self.result()
        if m.tracer is not None:  # per-cycle tracing is the reference engine's job
            return ReferenceEngine.run(self, max_cycles, progress)
        limit = self.config.max_cycles if max_cycles is None else max_cycles
        loop = load(self.config.precision)
        start, cpu = time.perf_counter(), time.process_time()
        st = S.flatten(m)
        self.phases = {"flatten": time.perf_counter() - start, "write_back": 0.0,
                       "flatten_cpu": time.process_time() - cpu, "write_back_cpu": 0.0}
        self._live = st
        g = st.arrays["g"]
        if self._stop is not None:
            g[S.G_STOP_P], g[S.G_STOP_PC] = self._stop
            g[S.G_AHEAD] = 0  # a stop point may come in any cycle: no processor runs ahead
        code = S.S_RUNNING
        lrec = st.arrays["lrec"]
        recorded = int(st.arrays["cs"][:, S.C_RECORD].sum())
        try:
            while True:
                until = g[S.G_CYCLE] + max(every, 1)
                if recorded:  # a chunk cannot fill the buffer: two loads a cycle at most
                    until = min(until, g[S.G_CYCLE] + max(1, (len(lrec) - 1) // (2 * recorded)))
                if limit:
                    until = min(until, limit)
                st.arrays["until"] = int(until)
                code = _chunk(loop, st)
                if recorded:
                    self._take_loads(lrec)
                if code != S.S_RUNNING:
                    break
                if progress is not None:
                    progress(int(g[S.G_CYCLE]))
                if limit and g[S.G_CYCLE] >= limit:
                    break
        finally:  # Ctrl-C between chunks leaves a consistent machine behind
            self._live = None
            start, cpu = time.perf_counter(), time.process_time()
            S.write_back(st, m)
            self.phases["write_back"] = time.perf_counter() - start
            self.phases["write_back_cpu"] = time.process_time() - cpu
        if code == S.S_STOPPED:
            return self.result()
        if code == S.S_RUNNING:
            return m.run(max_cycles)  # the cycle limit: the reference words its end
        self._finish(code, st)
        if progress is not None:
            progress(m.cycle)
        return self.result()

    def _take_loads(self, lrec: np.ndarray) -> None:
        """Hand the loads recorded in the chunk to the recorder, processor by processor, and
        empty the buffer."""
        proc, codes = S.record_codes(lrec)
        names = self.processors()
        for p in np.unique(proc).tolist():
            self.recorder.add(names[p], codes[proc == p])
        lrec[0] = 0

    _live: S.State | None = None
    phases: dict[str, float] = {}
    """Wall seconds of the last `run`'s fixed stages around the cycle loop: `flatten` (the
    reference machine's state into arrays: the engine's load, ~0.2 s at 16x16 whatever the
    cycles) and `write_back`, in wall seconds and (`_cpu`) this process's CPU seconds. The accuracy study charges them to load and read-out, so a run's
    machine seconds follow its cycles (netsushisen/accuracy_runs.py)."""
    _stop: tuple[int, int] | None = None

    def run_to_pc(self, processor: str, pc: int, max_cycles: int | None = None) -> str | None:
        """Run until `processor`'s next bundle is the one at `pc` (checked after each cycle,
        so a PC it starts at does not count), the run ends, or `max_cycles` is reached. The
        machine's status after (None: stopped at the PC or at the limit)."""
        self._stop = (self.processors().index(processor), pc)
        try:
            self.run(max_cycles)
        finally:
            self._stop = None
        m = self.machine
        if m.status == "max_cycles" and max_cycles is not None:
            m.status, m.error = None, None
        return m.status

    def progress_counts(self) -> tuple[int, int, int]:
        st = self._live
        if st is None:
            return super().progress_counts()
        a = st.arrays
        return int(a["g"][S.G_CYCLE]), int(a["dasg"].sum()), int(a["col"][S.L_MESSAGES])

    def step(self, cycles: int = 1) -> str | None:
        """Run `cycles` cycles in compiled code (the run may end sooner)."""
        m = self.machine
        if m.status is not None:
            return m.status
        self.run(max_cycles=m.cycle + cycles)
        if m.status == "max_cycles":  # stepping is not a limit: the run goes on
            m.status, m.error = None, None
        return m.status

    def _finish(self, code: int, st: S.State) -> None:
        """Set status and error as machine.Machine.step would have, then drain the cores."""
        m = self.machine
        finfo = st.arrays["finfo"]
        if code == S.S_HALTED:
            m.status = "halted"
        elif code == S.S_FINISHED:
            m.status = "finished"
        elif code == S.S_DEADLOCK_COL:
            m.status, m.error = "deadlock", DeadlockError(m.col_report())
        elif code == S.S_DEADLOCK_MSG:
            m.status, m.error = "deadlock", DeadlockError(m.unsent_report())
        elif code == S.S_DEADLOCK_PE:
            m.status, m.error = "deadlock", DeadlockError(m.deadlock_report(m.pes[int(finfo[1])]))
        elif code == S.S_FAULT:
            m.status, m.error = "fault", self._fault(finfo)
        else:  # pragma: no cover - the loop returns only the codes above
            raise NetsushisenError(Diagnostic(f"internal error: compiled loop status {code}"))
        for core in m.cores:
            core.drain()

    def _fault(self, finfo: np.ndarray) -> RunFault:
        m = self.machine
        c = m.cycle - 1
        kind = int(finfo[0])
        if kind == S.F_PC:
            return m.cores[int(finfo[1])].pc_fault(c)
        if kind == S.F_MEMORY:
            core = m.cores[int(finfo[1])]
            space, addr = S.SPACES[int(finfo[3])], int(finfo[4])
            try:  # the reference memory words the fault (the access fails before any effect)
                if space == "local":
                    core.memory.local.check(addr)
                core.memory.load(space, addr)
            except MemoryFault as err:
                return core.fault(c, str(err), int(finfo[2]))
        mask = (1 << (8 * self.config.word_bytes)) - 1
        if kind == S.F_RING_COL:
            pe = m.pes[int(finfo[3])]
            stage = pe.ring.cmus[int(finfo[1]) % 3].stage
            return RunFault(f"{pe.name} CMU", c, col_on_ring(stage, int(finfo[2]) & mask))
        if kind == S.F_COL_HEADER:
            return m.col.header_fault(m.pes[int(finfo[1])].name, c, int(finfo[2]) & mask)
        if kind == S.F_COL_PIXEL:
            return m.col.pixel_fault(m.pes[int(finfo[1])].name, c, int(finfo[2]))
        raise NetsushisenError(Diagnostic(f"internal error: compiled loop fault kind {kind}"))


from netsushisen.emulator.compiled.tandem import TandemEngine  # noqa: E402

__all__ = ["CompiledEngine", "TandemEngine"]
