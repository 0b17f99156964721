"""Tandem: the reference and the compiled engine in lock step (after TCE's ttasim-tandem).

Both engines run the same machine in chunks of cycles; after each chunk their whole state —
every register, result in flight, unit, hold, counter, memory word, cache tag, FIFO word, CMU
lock, DIS and COL — is compared. On a difference the chunk is bisected from its start (the
reference engine's snapshot): the twin runs k cycles in one call, its shortcuts on, against the
reference's k cycles, which finds the cycle where they part even when only a shortcut (running
ahead, sleeping, a quiet skip) causes it. The run stops with exit code 5 and a message naming
that cycle, the processor, its PC and the field, with both values; a difference no rerun
reproduces is reported for the chunk's cycle range instead. A tandem run costs about twice the
reference engine's time (the twin and the comparisons), and a difference at most 13 chunk
reruns more. A user runs it (`--engine tandem`) when a custom kernel behaves differently on
the two engines; the tests run it to hold the compiled engine to the specification.
"""

from __future__ import annotations

import numpy as np

from netsushisen.isa.errors import Diagnostic, NetsushisenError

from netsushisen.emulator.compiled.state import LAYOUT
from netsushisen.emulator.engine import Engine, Progress
from netsushisen.emulator.machine import Machine, RunResult

CHUNK = 4096


class TandemMismatch(NetsushisenError):
    """The engines disagree (exit code 5)."""

    exit_code = 5


def canonical(machine: Machine) -> dict[str, object]:
    """Every piece of state both engines must agree on, by a readable field name: the scalar
    fields of the compiled engine's layout table (state.LAYOUT), then the structures."""
    out: dict[str, object] = {"cycle": machine.cycle, "status": machine.status,
                              "no_progress": list(machine.no_progress)}
    for component in LAYOUT:
        out.update(component.values(machine))
    for core in machine.cores:
        n = core.name
        out[f"{n}.ops"] = core.ops
        out[f"{n}.regs"] = np.array(core.regs, dtype=object)
        out[f"{n}.ready_at"] = np.array(core.ready_at, dtype=object)
        out[f"{n}.producer"] = list(core.producer)
        out[f"{n}.pending"] = sorted((t, tuple(v)) for t, v in core.pending.items())
        out[f"{n}.busy"] = sorted(core.busy.items())
        out[f"{n}.occupant"] = sorted(core.occupant.items())
        for f in ("stalls", "ops_by_unit", "ops_by_mnemonic", "bundles_by_pc"):
            out[f"{n}.{f}"] = sorted(getattr(core, f).items())
        out[f"{n}.stalls_by_pc"] = sorted((pc, sorted(c.items()))
                                          for pc, c in core.stalls_by_pc.items())
        mem = core.memory
        out[f"{n}.local"] = mem.local.words
        out[f"{n}.local.counts"] = (sorted(mem.local.region_counts.regions.items()),
                                    sorted(mem.local.region_counts.primitives.items()))
        if mem.resident is not None:
            out[f"{n}.resident.counts"] = (sorted(mem.resident.region_counts.regions.items()),
                                           sorted(mem.resident.region_counts.primitives.items()))
        if mem.cache is not None:
            out[f"{n}.cache.tags"] = mem.cache.tags
            out[f"{n}.global.counts"] = (sorted(mem.global_counts.regions.items()),
                                         sorted(mem.global_counts.primitives.items()))
    for pe in machine.pes:
        for f in pe.ring.fifos():
            out[f"{f.name}"] = (list(f.q), f.pops if f.pop_cycle == machine.cycle - 1 else 0)
        for cmu in pe.ring.cmus:
            out[f"{pe.name}.cmu.{cmu.stage}"] = (list(cmu.route), list(cmu.remaining),
                                                 list(cmu.link_owner))
    d = machine.dis
    out["dis"] = (list(d.current), list(d.offset), list(d.upcoming), list(d.assigned))
    col = machine.col
    out["col"] = [list(p) for p in col.partial]
    out["col.frame"] = col.frame
    out["col.ids"] = col.ids
    return out


def first_difference(a: dict, b: dict) -> tuple[str, str, str] | None:
    """(field, reference value, compiled value) of the first field that differs, or None."""
    for key, va in a.items():
        vb = b.get(key)
        if isinstance(va, np.ndarray):
            if va.shape != np.shape(vb) or not np.array_equal(va, vb):
                if va.shape == np.shape(vb):
                    i = int(np.flatnonzero(np.asarray(va != vb).ravel())[0])
                    return f"{key}[{i}]", _show(va.ravel()[i]), _show(np.asarray(vb).ravel()[i])
                return key, str(va.shape), str(np.shape(vb))
        elif va != vb:
            path, va, vb = _narrow(va, vb)
            return key + path, _show(va), _show(vb)
    return None


def _narrow(a, b, path: str = "") -> tuple[str, object, object]:
    """The innermost differing element of two equal-shaped nested lists or tuples (a queue of
    FIFO words, a CMU's routes), so the message shows the word that differs, not a prefix."""
    while isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return f"{path} (length)", f"{len(a)}: {_show(a)}", f"{len(b)}: {_show(b)}"
        i = next(i for i, (x, y) in enumerate(zip(a, b)) if x != y)
        a, b, path = a[i], b[i], f"{path}[{i}]"
    return path, a, b


def _show(v) -> str:
    return f"{int(v):#x}" if isinstance(v, (int, np.integer)) and not isinstance(v, bool) \
        else str(v)[:200]


class TandemEngine(Engine):
    """The reference engine (its machine is this engine's) with a compiled twin beside it."""

    name = "tandem"

    def __init__(self, config, programs, image=None, chunk: int = CHUNK):
        from netsushisen.emulator.compiled import CompiledEngine

        super().__init__(config, programs, image)
        self.twin = CompiledEngine(config, programs, image)
        self.chunk = chunk

    def run(self, max_cycles: int | None = None, progress: Progress | None = None,
            every: int = 20000) -> RunResult:
        m, t = self.machine, self.twin.machine
        limit = self.config.max_cycles if max_cycles is None else max_cycles
        while m.status is None:
            if limit and m.cycle >= limit:
                break
            n = self.chunk if not limit else min(self.chunk, limit - m.cycle)
            self._chunk(n)
            if progress is not None:
                progress(m.cycle)
        if m.status is None:
            m.run(max_cycles)
            t.run(max_cycles)
            self._compare(m.cycle)
        return self.result()

    def step(self, cycles: int = 1) -> str | None:
        done = 0
        while done < cycles and self.machine.status is None:
            n = min(self.chunk, cycles - done)
            self._chunk(n)
            done += n
        return self.machine.status

    def _chunk(self, n: int) -> None:
        m = self.machine
        snap = m.snapshot()
        start = m.cycle
        self._advance(m, n)
        ran = m.cycle - start
        self.twin.step(ran)
        end = canonical(m), canonical(self.twin.machine)
        if first_difference(*end) is None:
            return
        k = self._bisect(snap, ran)
        if k is not None:
            self._rerun(snap, k)
            self._compare(start + k)
        self._chunk_mismatch(start, start + ran, *end)

    @staticmethod
    def _advance(machine: Machine, n: int) -> None:
        for _ in range(n):
            if machine.step() is not None:
                break

    def _rerun(self, snap: dict, k: int) -> None:
        """Both engines from the chunk's start snapshot for k cycles: the reference cycle by
        cycle, the compiled twin in one call, shortcuts on (running ahead, sleeping, quiet
        skips), as in the chunk that differed."""
        m, t = self.machine, self.twin.machine
        m.restore(snap)
        t.restore(snap)
        self._advance(m, k)
        self.twin.step(m.cycle - snap["cycle"])

    def _bisect(self, snap: dict, n: int) -> int | None:
        """A k (1..n) such that the compiled twin run from the chunk's start for k − 1 cycles
        agrees with the reference and for k cycles does not (the first such k when a
        difference, once made, persists) — found by bisection, not by stepping, because a
        difference that only the compiled engine's shortcuts cause (a processor run ahead, a
        sleep, a quiet skip) shows only when the twin runs many cycles in one call, never when
        it is stepped one cycle at a time. At most log2(n) + 1 reruns of the chunk, so a
        difference costs a tandem run at most 13 chunks more (CHUNK = 4096). None if no rerun
        reproduces the difference (a state the snapshot does not carry)."""
        self._rerun(snap, n)
        if first_difference(canonical(self.machine), canonical(self.twin.machine)) is None:
            return None
        lo, hi = 0, n
        while hi - lo > 1:
            mid = (lo + hi) // 2
            self._rerun(snap, mid)
            if first_difference(canonical(self.machine), canonical(self.twin.machine)) is None:
                lo = mid
            else:
                hi = mid
        return hi

    def _chunk_mismatch(self, first: int, last: int, ref: dict, comp: dict) -> None:
        field, a, b = first_difference(ref, comp)
        raise TandemMismatch(Diagnostic(
            f"engines differ at the end of cycles {first}..{last - 1} (the difference could not "
            f"be narrowed to one cycle): {field}: reference {a}, compiled {b}"))

    def _compare(self, cycle: int) -> None:
        diff = first_difference(canonical(self.machine), canonical(self.twin.machine))
        if diff is None:
            return
        field, ref, comp = diff
        proc = field.split(".")[0] + "." + field.split(".")[1] if field.startswith("pe") else ""
        where = ""
        for core in self.machine.cores:
            if core.name == proc:
                where = f" ({core.name} {core.where(core.last_pc)})"
        raise TandemMismatch(Diagnostic(
            f"engines differ after cycle {cycle - 1}{where}: {field}: reference {ref}, "
            f"compiled {comp}"))
