"""The debugger's engine side: a session over one machine — stepping by cycles or bundles,
breakpoints, watchpoints, checkpoints and exact reverse execution.

The machine comes from a *factory* (`build() -> Machine`): `ProgramsFactory` for raw programs
(`netsushisen debug --os ... --ic ...`), `SceneFactory` for a scene's render setup
(`netsushisen debug SCENE`, the machine `netsushisen render` runs).

Time. The session always stands between two cycles: `machine.cycle` cycles have run, and "the
last cycle" is `machine.cycle - 1`. Every stop describes what happened in the last cycle: which
bundle each processor issued, or why it stalled.

Breakpoints and watchpoints (breakpoints.py, mixed in): numbered, enabled, conditioned,
ignored, temporary; checked in every cycle `_cycle` runs.

Stops. Moving forward always stops at the end of the run (halt, quiescence, deadlock, fault,
cycle limit), at a breakpoint (the cycle in which the bundle at its address *issues* on a
matching processor, and its condition, evaluated after that cycle, is true), at a watchpoint
(a cycle in which the watched register is written back or the watched local word is stored —
every write, even of the same value), or on an interrupt (Ctrl-C), and otherwise when its own
count is done.

Reverse execution (reverse.py): checkpoints every K cycles (default 2048) and exact
deterministic replay; `set` edits are pinned checkpoints, so they stay part of the history that
replays and forward steps go through.

Fast-forward (fastforward.py, `--fast-forward CYCLE|LOCATION`): the factory's compiled engine
runs the machine to a cycle or to a processor's arrival at a location, and the session takes
over the machine it wrote its state back into. The history starts there (`origin`): the first
checkpoint is the hand-off state, reverse execution stops at it, and `restart` returns to it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

from netsushisen.debugger.breakpoints import WATCH_TYPES, Breakpoint, Breakpoints, Watchpoint
from netsushisen.debugger.expressions import Context, DebugError, Place, bundle_lines
from netsushisen.debugger.fastforward import fast_forward
from netsushisen.debugger.reverse import Checkpoint, Hit, ReverseExecution, Stop
from netsushisen.debugger.state import Frozen, thaw
from netsushisen.debugger.view import bundle_text, focus_pc
from netsushisen.emulator.machine import CycleLimit, Machine
from netsushisen.isa.processors import LINK_REGISTER, STAGES


class MachineFactory(Protocol):
    description: str

    def build(self) -> Machine: ...

    def engine(self, name: str): ...


@dataclass
class ProgramsFactory:
    """A machine from programs, an optional memory image and a configuration."""

    config: object
    programs: dict
    image: object = None
    description: str = "programs"

    def build(self) -> Machine:
        return Machine(self.config, self.programs, self.image)

    def engine(self, name: str):
        """Engine `name` (emulator/engine.py) over the same inputs: `--fast-forward`."""
        from netsushisen.emulator.engine import make_engine

        return make_engine(name, self.config, self.programs, self.image)


class SceneFactory:
    """Scene mode: the render pipeline's host work (grid, pre-pass, images, kernels, eye rays;
    a `netsushisen.pipeline.RenderSetup`) is done once; every `build()` (the start, `restart`)
    makes a fresh Machine from it."""

    def __init__(self, setup):
        self.setup = setup
        self.description = (f"scene {setup.scene.name}, {setup.res}x{setup.res}"
                            f"{' corners' if setup.corners else ''}, "
                            f"{'generic' if setup.generic else 'specialised'} kernels")

    def build(self):
        return self.setup.machine()

    def engine(self, name: str):
        return self.setup.engine(name)


END_TEXT = {"halted": "every processor halted", "finished": "quiescent: nothing left to do",
            "deadlock": "no progress: see the report", "fault": "run-time fault",
            "max_cycles": "cycle limit reached"}


class Session(Breakpoints, ReverseExecution):
    def __init__(self, factory: MachineFactory, *, pe: int = 0, stage: str | None = None,
                 checkpoint_interval: int = 2048, max_checkpoints: int = 256,
                 fast_forward: str | None = None):
        if checkpoint_interval < 1:
            raise DebugError("the checkpoint interval must be at least 1 cycle")
        self.factory = factory
        self.base_interval = checkpoint_interval
        self.max_checkpoints = max(2, max_checkpoints)
        self.breakpoints: dict[int, Breakpoint] = {}
        self.watchpoints: dict[int, Watchpoint] = {}
        self._next_number = 1
        self.last_hits: list[int] = []  # the breakpoints that stopped the last movement
        self.interrupt = False  # set by a signal handler: stop between cycles
        self.trace_out: Callable[[str], None] | None = None  # `trace on`: one line per cycle
        self.fast_forward = fast_forward  # `--fast-forward` target text, or None
        self.handoff: Frozen | None = None  # the fast-forward's hand-off state (`restart`)
        self.origin = 0  # the first cycle of the history: 0, or where the fast-forward stopped
        self.start_messages: list[str] = []  # notes for the front end to show at the start
        self._build(pe, stage)

    # -- the machine and the view --------------------------------------------------------------

    @staticmethod
    def _first_stage(machine) -> str:
        present = [s for s in STAGES if machine.programs.get(s) is not None]
        return present[0] if present else "os"

    def _build(self, pe: int = 0, stage: str | None = None) -> None:
        if self.handoff is not None:  # restart after a fast-forward: back to the hand-off
            thaw(self.machine, self.handoff)
        elif self.fast_forward is not None:
            self.machine, target, self.start_messages = fast_forward(
                self.factory, self.fast_forward, pe, stage, self._first_stage)
            if target.cycle is None:  # view the processor that was fast-forwarded
                pe, stage = target.pe, target.stage
            if self.machine.error is not None:  # the run ended first: what ended it
                self.start_messages += self.machine.error.format().splitlines()
        else:
            self.machine = self.factory.build()
        self.machine.record_events(True)
        if not 0 <= pe < len(self.machine.pes):
            raise DebugError(f"no PE {pe} (the machine has {len(self.machine.pes)})")
        self.pe = pe
        self.stage = stage or self._first_stage(self.machine)
        self.origin = self.machine.cycle
        self.interval = self.base_interval
        self.checkpoints: dict[int, Checkpoint] = {}
        # per core: last ldg (addr, set, hit, cycle), last ldr (addr, cycle), and, per register,
        # the (pc, cycle) of the bundle whose result it waits for or last received
        self.aux: dict = {c.name: {"ldg": None, "ldr": None, "origin": {}, "issued_at": {}}
                          for c in self.machine.cores}
        if self.machine.cycle:  # after a fast-forward: what the last cycle tells
            self._seed_notes()
        self.previous_regs: dict[str, list[int]] = {}
        self.mark_stop()
        self._take_checkpoint(pinned=True)
        if self.fast_forward is not None and self.handoff is None:
            self.handoff = self.checkpoints[self.origin].frozen

    def _seed_notes(self) -> None:
        """The session's notes start empty at a fast-forward's hand-off (the compiled engine
        keeps none); the bundle each processor issued in the last cycle gives the origin of
        the results it has in flight."""
        c = self.machine.cycle - 1
        for core in self.machine.cores:
            if core.present and core.last_issued:
                origin = self.aux[core.name]["origin"]
                for r in core.bundles[core.last_pc].writes:
                    origin[r] = (core.last_pc, c)

    def restart(self) -> None:
        """A fresh machine from the factory, or back to the fast-forward's hand-off state
        (breakpoints and watchpoints stay, edits are lost)."""
        self._build(self.pe, self.stage)

    def context(self, pe: int | None = None, stage: str | None = None) -> Context:
        return Context(self.machine, self.pe if pe is None else pe, stage or self.stage)

    @property
    def core(self):
        return self.machine.pes[self.pe].cores[self.stage]

    def set_view(self, pe: int | None = None, stage: str | None = None) -> None:
        if pe is not None:
            if not 0 <= pe < len(self.machine.pes):
                raise DebugError(f"no PE {pe} (the machine has {len(self.machine.pes)}: "
                                 f"0..{len(self.machine.pes) - 1})")
            self.pe = pe
        if stage is not None:
            if stage not in STAGES:
                raise DebugError(f"no processor {stage!r}: choose os, ic or sc")
            self.stage = stage

    def mark_stop(self) -> None:
        """Remember the registers now, so the next screen highlights what changed."""
        self.previous_regs = {c.name: list(c.regs) for c in self.machine.cores}

    @property
    def ended(self) -> bool:
        return self.machine.status is not None

    def end_message(self) -> str:
        m = self.machine
        text = f"run ended at cycle {m.cycle}: {m.status} ({END_TEXT.get(m.status, m.status)})"
        return text

    def end_report(self) -> list[str]:
        lines = [self.end_message()]
        if self.machine.error is not None:
            lines += self.machine.error.format().splitlines()
        return lines

    # -- breakpoints and watchpoints -----------------------------------------------------------

    def _index(self, temp: list[Breakpoint] = ()) -> dict[tuple[str, int], list[Breakpoint]]:
        """Enabled breakpoints by (stage, address), for the per-cycle check."""
        index: dict[tuple[str, int], list[Breakpoint]] = {}
        for bp in [*self.breakpoints.values(), *temp]:
            if bp.enabled:
                index.setdefault((bp.stage, bp.address), []).append(bp)
        return index

    def _cycle(self, index: dict | None = None, replay: bool = False) -> list[Hit]:
        """Run one cycle (taking a checkpoint first when due); the breakpoints and watchpoints
        that fired in it."""
        m = self.machine
        c = m.cycle
        if c % self.interval == 0 and c not in self.checkpoints:
            self._take_checkpoint()
        limit = m.config.max_cycles
        if limit and c >= limit:
            m.status = "max_cycles"
            m.error = CycleLimit(f"cycle limit reached: {limit} cycles (max_cycles); the run did "
                                 "not end")
            return []
        watches = [w for w in self.watchpoints.values() if w.enabled]
        old = {}
        if watches:
            ctx = self.context()
            for w in watches:
                old[w.number] = ctx.read_word(w.place)
        m.step()
        hits: list[Hit] = []
        written: dict[tuple, int] = {}
        read: dict[tuple, list] = {}  # read_key -> [(core, cache hit: True/False/None), ...]
        for pe in m.pes:
            for core in pe.active:
                aux = self.aux[core.name]
                ev = core.events
                if ev:
                    for e in ev:
                        kind = e[0]
                        if kind == "reg":  # ("reg", core, register, word)
                            written[("reg", core.name, e[2])] = e[3]
                        elif kind == "store":  # ("store", core, "local", address, word)
                            written[("mem", core.name, e[3])] = e[4]
                        elif e[2] == "global":  # ("load", core, space, address, cache set)
                            misses = pe.memories[core.proc.name].cache.misses
                            hit = misses == aux.get("misses", 0)
                            aux["ldg"] = (e[3], e[4], hit, c)
                            aux["misses"] = misses
                            region = "icgm" if core.proc.name == "ic" else "scgm"
                            read.setdefault((region, e[3]), []).append((core, hit))
                        else:
                            if e[2] == "resident":
                                aux["ldr"] = (e[3], c)
                            read.setdefault((e[2], core.name, e[3]), []).append((core, None))
                    ev.clear()
                if core.last_issued:
                    pc = core.last_pc
                    aux["issued_at"][pc] = c  # `info loop`: when the loop head last issued
                    origin = aux["origin"]
                    for r in core.bundles[pc].writes:
                        origin[r] = (pc, c)
                    if index:
                        for bp in index.get((core.proc.name, pc), ()):
                            hit = self._check_breakpoint(bp, pe.index, core, c, replay)
                            if hit is not None:
                                hits.append(hit)
        if watches:
            hits += self._check_watches(watches, old, written, read, c, replay)
        edit = self.checkpoints.get(m.cycle)
        if edit is not None and edit.pinned:  # an edit made at this point of the history
            self._restore_before(m.cycle)
        if self.trace_out is not None and not replay:
            self._trace(c)
        return hits

    def _trace(self, c: int) -> None:
        for core in self.machine.pes[self.pe].cores.values():
            if not core.present:
                continue
            if core.last_issued:
                what = bundle_text(core.program, core.last_pc)
            elif core.halted:
                continue
            else:
                what = "stall " + core.cause
            pc = core.last_pc
            self.trace_out(f"{c:>8}  {core.name:<7} {pc:>5}  {core.label(pc):<20.20} {what}")

    # -- moving forward ------------------------------------------------------------------------

    def advance(self, done: Callable[[int], bool] | None = None, *, max_cycles: int | None = None,
                temp: list[Breakpoint] = ()) -> Stop:
        """Run cycles until `done(cycle)` after some cycle, `max_cycles` cycles, a breakpoint or
        watchpoint, an interrupt or the end of the run."""
        m = self.machine
        if m.status is not None:
            return Stop([self.end_message() + "; nothing more to run (reverse-step, restart "
                         "or inspect)"], ended=True)
        self.interrupt = False
        self.last_hits = []
        n = 0
        stop = Stop(moved=True)
        index = self._index(temp)
        while True:
            hits = self._cycle(index)
            n += 1
            c = m.cycle - 1
            self._retire_temporary(hits)
            self.last_hits = [h.number for h in hits if h.number]
            if m.status is not None:
                stop.hits = hits
                stop.messages = [h.message for h in hits] + self.end_report()
                stop.ended = True
                return stop
            if hits:
                stop.hits = hits
                stop.messages = [h.message for h in hits]
                h = hits[0]
                self.set_view(h.pe, h.stage)
                return stop
            if done is not None and done(c):
                return stop
            if max_cycles is not None and n >= max_cycles:
                return stop
            if self.interrupt:
                self.interrupt = False
                stop.messages = [f"interrupted after cycle {c}"]
                return stop

    def step(self, n: int = 1) -> Stop:
        if n < 1:
            raise DebugError("cycle takes a positive number of cycles")
        return self.advance(max_cycles=n)

    def stepi(self, n: int = 1, over_calls: bool = False, by_line: bool = False) -> Stop:
        """Run until the viewed processor has issued n bundles (`nexti`: a `call` counts as one
        bundle with everything up to its return). `by_line` (gdb's `step`/`next`): n source
        lines instead — a line ends when the next bundle (the PC) holds other source lines than
        the bundle the line started at, or the code jumps back to that bundle (a loop on one
        line). In a scheduled region a bundle holds several lines and the lines come in the
        schedule's order, as gdb steps optimised code."""
        if n < 1:
            raise DebugError(f"{'step' if by_line else 'stepi'} takes a positive number")
        pe, stage = self.pe, self.stage
        if not self.core.present:
            raise DebugError(f"pe{pe}.{stage} has no program")
        if self.core.halted and not self.ended:
            raise DebugError(f"pe{pe}.{stage} has halted; use cycle or continue")
        count = [0]
        ret_to = [None]
        program = self.core.program
        line_at = [self.core.pc, bundle_lines(program, self.core.pc)]

        def done(c: int) -> bool:
            core = self.machine.pes[pe].cores[stage]
            if not core.last_issued:
                return False
            pc = core.last_pc
            if ret_to[0] is not None:
                if pc != ret_to[0]:
                    return False
                ret_to[0] = None
            elif over_calls and any(op.mnemonic == "call" for op in core.program.bundles[pc]):
                ret_to[0] = pc + 1
                return False
            if core.halted:
                return True
            if by_line:
                lines = bundle_lines(program, core.pc)
                if lines == line_at[1] and core.pc != line_at[0]:
                    return False  # still in the line
                line_at[:] = [core.pc, lines]
            count[0] += 1
            return count[0] >= n

        stop = self.advance(done)
        if not stop.hits and not stop.ended and self.core.halted:
            stop.messages.append(f"pe{pe}.{stage} halted")
        return stop

    def cont(self, times: int = 1) -> Stop:
        """`continue`; `continue N` first sets the ignore count of the breakpoint the run
        stopped at to N-1, as gdb does."""
        if times > 1 and not self.last_hits:  # gdb: the argument is ignored, with a note
            stop = self.advance()
            stop.messages.insert(0, "not stopped at any breakpoint; argument ignored")
            return stop
        if times > 1:
            b = self.item(self.last_hits[0])
            b.ignore = times - 1
            stop = self.advance()
            kind = "breakpoint" if isinstance(b, Breakpoint) else WATCH_TYPES[b.kind]
            stop.messages.insert(0, f"will ignore next {times - 1} crossings of {kind} "
                                    f"{b.number}")
            return stop
        return self.advance()

    def finish(self) -> Stop:
        """Run until the viewed processor issues the `ret` that leaves its current subroutine:
        calls made on the way nest, and their returns do not count."""
        pe, stage = self.pe, self.stage
        core = self.core
        if not core.present:
            raise DebugError(f"pe{pe}.{stage} has no program")
        if core.regs[LINK_REGISTER] == 0:
            raise DebugError('"finish" not meaningful in the outermost frame: lr is 0, no call '
                             "has been made")
        start = core.label(focus_pc(core))
        depth = [0]

        def done(c: int) -> bool:
            core = self.machine.pes[pe].cores[stage]
            if not core.last_issued:
                return False
            for op in core.program.bundles[core.last_pc]:
                if op.mnemonic == "call":
                    depth[0] += 1
                elif op.mnemonic == "ret":
                    if depth[0] == 0:
                        return True
                    depth[0] -= 1
            return False

        stop = self.advance(done)
        core = self.core
        stop.messages.insert(0, f"run till exit from pc {start}")
        if not stop.hits and not stop.ended and (pe, stage) == (self.pe, self.stage):
            ret = core.last_pc
            stop.messages.append(f"finish: pe{pe}.{stage} returned: ret at pc {ret} "
                                 f"({core.label(ret)}) in cycle {self.machine.cycle - 1}, back "
                                 f"to pc {core.pc} ({core.label(core.pc)})")
        return stop

    def until(self, location: str | None = None) -> Stop:
        """Run until the viewed processor issues the bundle at `location` (a temporary
        breakpoint); without one, until it issues a bundle past the current one (out of a loop)."""
        if location:
            bp = self.add_breakpoint(location, until=True)
            return self.advance(temp=[bp])
        pe, stage = self.pe, self.stage
        here = self.core.last_pc

        def done(c: int) -> bool:
            core = self.machine.pes[pe].cores[stage]
            return core.last_issued and core.last_pc > here

        return self.advance(done)

    # -- edits --------------------------------------------------------------------------------

    def set_place(self, place: Place, value) -> tuple[int, int]:
        """Write a value; (old word, new word). Pins a checkpoint (reverse.py: edits)."""
        if self.ended:
            raise DebugError(self.end_message() + ": the state can no longer change")
        ctx = self.context()
        word = ctx.word_of(place, value)
        old = ctx.read_word(place)
        ctx.write_word(place, word)
        self.edited()
        return old, word
