"""Reverse execution for the debugger session: checkpoints, exact replay, going back.

A checkpoint (state.freeze) is taken whenever the machine reaches a cycle that is a
multiple of the interval K, and at cycle 0; it also keeps the session's per-core notes (last
loads, register origins). Going back to cycle T thaws the last checkpoint at or before T and
replays the cycles after it (breakpoint hit counts do not change during a replay): the engine is
deterministic, so the state is exactly the one the machine had.

Edits. `set` changes the state at cycle C: the checkpoints after C are dropped (that future is
gone) and a *pinned* checkpoint of the edited state is kept at C. Whenever a replay or a forward
step arrives at C again, the machine continues from that checkpoint, so the edit is re-applied:
an edit is part of the history, undone by going back before it and redone by stepping over it.

History start. The history begins at `origin`: cycle 0, or the cycle where `--fast-forward`
handed the machine over (its state is the first checkpoint; the cycles before it ran in the
compiled engine and are not recorded). Going back stops there with gdb's "no more
reverse-execution history".

Memory. Beyond `max_checkpoints` unpinned checkpoints the interval doubles and the checkpoints
off the new grid go: memory stays bounded and a step back replays at most K cycles. Backward
searches (reverse-continue, reverse-stepi) replay one checkpoint interval at a time, latest
first, until they find the match.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Callable

from netsushisen.debugger.expressions import DebugError, bundle_lines
from netsushisen.debugger.state import Frozen, freeze, thaw


@dataclass
class Hit:
    """Something that stops a run: a breakpoint or a watchpoint firing in a cycle."""

    cycle: int
    pe: int
    stage: str
    message: str
    number: int


@dataclass
class Stop:
    """How a movement ended: messages to show, and whether the run has ended."""

    messages: list[str] = field(default_factory=list)
    hits: list[Hit] = field(default_factory=list)
    ended: bool = False
    moved: bool = False


@dataclass
class Checkpoint:
    frozen: Frozen
    aux: dict
    pinned: bool = False


class ReverseExecution:
    """Mixed into `debugger.Session`, which provides machine, aux, checkpoints, interval,
    max_checkpoints, origin, _cycle, _index and set_view."""

    origin = 0  # the first cycle of the history

    def _history_start(self, arrived: bool, found_none: str = "") -> str:
        """What to say when going back reaches (arrived) or stands at the history's start;
        `found_none`: what a backward search did not find before it."""
        o = self.origin
        if o == 0:
            if found_none:
                return f"{found_none} before: back at cycle 0"
            return ("reached the start of the run (cycle 0)" if arrived
                    else "already at cycle 0, the start of the run")
        where = (f"cycle {o}, where --fast-forward handed the machine over (the cycles before "
                 f"it ran in the compiled engine and are not recorded)")
        if found_none:
            return f"no more reverse-execution history: {found_none} since {where}; back there"
        if arrived:
            return f"no more reverse-execution history: back at {where}"
        return f"no more reverse-execution history: it starts at {where}"

    def _take_checkpoint(self, pinned: bool = False) -> None:
        c = self.machine.cycle
        self.checkpoints[c] = Checkpoint(freeze(self.machine), copy.deepcopy(self.aux), pinned)
        unpinned = [k for k, v in self.checkpoints.items() if not v.pinned]
        while len(unpinned) > self.max_checkpoints:
            self.interval *= 2
            for k in unpinned:
                if k % self.interval:
                    del self.checkpoints[k]
            unpinned = [k for k, v in self.checkpoints.items() if not v.pinned]

    def edited(self) -> None:
        """The user changed the state (`set`): the future after this cycle is a new one. The
        pinned checkpoint *is* the edit: whenever a replay or a forward step reaches this
        cycle again, the machine continues from it (`_cycle`), so the edit is re-applied."""
        c = self.machine.cycle
        for k in [k for k in self.checkpoints if k > c]:
            del self.checkpoints[k]
        self._take_checkpoint(pinned=True)

    def _restore_before(self, target: int) -> int:
        """Thaw the last checkpoint at or before `target`; its cycle."""
        k = max(k for k in self.checkpoints if k <= target)
        cp = self.checkpoints[k]
        thaw(self.machine, cp.frozen)
        self.aux = copy.deepcopy(cp.aux)
        return k

    def goto_cycle(self, target: int) -> None:
        """Put the machine exactly in its state after `target` cycles (target ≤ now, or on the
        recorded future after a reverse step)."""
        target = max(self.origin, target)
        self._restore_before(target)
        m = self.machine
        index = self._index()
        while m.cycle < target and m.status is None:
            self._cycle(index, replay=True)

    def reverse_step(self, n: int = 1) -> Stop:
        if n < 1:
            raise DebugError("reverse-cycle takes a positive number of cycles")
        now = self.machine.cycle
        if now <= self.origin:
            return Stop([self._history_start(False)])
        target = max(self.origin, now - n)
        self.goto_cycle(target)
        msg = [] if target == now - n else [self._history_start(True)]
        return Stop(msg, moved=True)

    def _search_back(self, matches: Callable[[int, list[Hit]], int], count: int = 1) -> int | None:
        """The cycle c (< the last cycle) of the count-th latest match going back; `matches`
        returns how many matches cycle c holds. Replays one checkpoint interval at a time,
        latest first; leaves the machine anywhere."""
        hi = self.machine.cycle - 1  # cycles strictly before the last one
        found: list[int] = []
        index = self._index()
        while hi > self.origin:
            start = self._restore_before(hi - 1)
            m = self.machine
            seen: list[int] = []
            while m.cycle < hi and m.status is None:
                c = m.cycle
                hits = self._cycle(index, replay=True)
                seen += [c] * matches(c, hits)
            found = seen + found
            if len(found) >= count:
                return found[-count]
            hi = start
        return None

    def reverse_continue(self) -> Stop:
        now = self.machine.cycle
        if now <= self.origin:
            return Stop([self._history_start(False)])
        hits_at: dict[int, list[Hit]] = {}

        def matches(c: int, hits: list[Hit]) -> int:
            if hits:
                hits_at[c] = hits
            return 1 if hits else 0

        c = self._search_back(matches)
        if c is None:
            self.goto_cycle(self.origin)
            return Stop([self._history_start(True, "no breakpoint or watchpoint fired")],
                        moved=True)
        self.goto_cycle(c + 1)
        hits = hits_at[c]
        h = hits[0]
        self.set_view(h.pe, h.stage)
        return Stop([h.message for h in hits], hits=hits, moved=True)

    def reverse_stepi(self, n: int = 1) -> Stop:
        """Back to the stop after the n-th previous bundle the viewed processor issued."""
        if n < 1:
            raise DebugError("reverse-stepi takes a positive number of bundles")
        now = self.machine.cycle
        if now <= self.origin:
            return Stop([self._history_start(False)])
        pe, stage = self.pe, self.stage

        def matches(c: int, hits) -> int:
            return int(self.machine.pes[pe].cores[stage].last_issued)

        c = self._search_back(matches, n)
        if c is None:
            self.goto_cycle(self.origin)
            return Stop([self._history_start(True, f"pe{pe}.{stage} issued fewer than {n} "
                                                   "bundles")], moved=True)
        self.goto_cycle(c + 1)
        return Stop(moved=True)

    def reverse_step_line(self, n: int = 1) -> Stop:
        """gdb's `reverse-step`: back, n times, to the stop at which the viewed processor's PC
        last held other source lines than it holds now (the previous source line; in a
        scheduled region, the previous bundle's lines)."""
        if n < 1:
            raise DebugError("reverse-step takes a positive number of lines")
        pe, stage = self.pe, self.stage
        core = self.machine.pes[pe].cores[stage]
        if not core.present:
            raise DebugError(f"pe{pe}.{stage} has no program")
        program = core.program
        stop = Stop(moved=True)
        for _ in range(n):
            start = bundle_lines(program, self.machine.pes[pe].cores[stage].pc)
            while True:
                stop = self.reverse_stepi(1)
                if stop.messages:  # the start of the history
                    return stop
                if bundle_lines(program, self.machine.pes[pe].cores[stage].pc) != start:
                    break
        return stop

    def checkpoint_info(self) -> list[str]:
        cps = self.checkpoints
        size = sum(cp.frozen.size for cp in cps.values())
        pinned = sorted(k for k, v in cps.items() if v.pinned)
        return [f"{len(cps)} checkpoints, every {self.interval} cycles "
                f"(at most {self.max_checkpoints} before the interval doubles), "
                f"{size / 1024:.1f} KiB compressed",
                f"cycles: {', '.join(str(k) for k in sorted(cps)[:12])}"
                + (" ..." if len(cps) > 12 else ""),
                f"pinned by edits or the start: {', '.join(map(str, pinned))}"
                + ("" if self.origin == 0 else
                   f" (the history starts at cycle {self.origin}: --fast-forward)")]
