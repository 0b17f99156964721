"""Fast-forward (`netsushisen debug --fast-forward CYCLE|LOCATION`): the compiled engine runs the
machine to a point, then the session takes the machine over and steps the reference engine.

Targets:

    12000, 0x2ee0, 1_000_000     a cycle: the session starts after that many cycles
    loop, loop+3, *7             a code location of the viewed processor (--pe, --proc)
    ic:loop, ic.loop             ... of another processor of the viewed PE
    pe1.sc:color, pe1.sc.color   ... of another PE's processor

A location (what `break` takes; `*ADDRESS` and the `PROC:` spelling as in gdb) is reached the
first time the processor *arrives* there: after a cycle at whose end its PC (the next bundle to
issue) is the location's address. The PC it has at cycle 0 does not count (every program starts
at address 0): a location there means the next time the processor comes back to it. The
processor then shows the bundle at the location as the next one (`->`); `stepi` issues it.

The compiled engine (emulator/compiled/) runs and writes its whole state back into the reference
`Machine` it was built around; that machine is the session's from then on — identical to the
one the reference engine reaches by stepping there itself (the tests compare the canonical
state dumps, state.py). Reverse execution starts at the hand-off: its first checkpoint is that
state, and going back stops there ("no more reverse-execution history").

A run that ends first (halt, quiescence, deadlock, fault, cycle limit) hands over its end state
with a note, and the session starts there for inspection; so does Ctrl-C during the
fast-forward (at the cycle reached). An unknown label or a bad target is a `DebugError`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from netsushisen.debugger.expressions import Context, DebugError
from netsushisen.isa.errors import NetsushisenError

ENGINE = "compiled"

_CYCLE = re.compile(r"^(?:\d[\d_]*|0[xX][0-9a-fA-F_]+)$")
_SPELLING = re.compile(r"^(?:(?P<pe>pe\d+)[.:])?(?:(?P<proc>os|ic|sc)[.:])?\*?(?P<rest>.*)$", re.S)


@dataclass
class Target:
    """A parsed `--fast-forward`: a cycle, or a location (pe, stage, address) to arrive at."""

    text: str
    cycle: int | None = None
    pe: int = 0
    stage: str = ""
    address: int = 0

    @property
    def processor(self) -> str:
        return f"pe{self.pe}.{self.stage}"

    def describe(self, machine) -> str:
        if self.cycle is not None:
            return f"cycle {self.cycle}"
        core = machine.pes[self.pe].cores[self.stage]
        return f"{self.processor} {core.where(self.address)}"


def parse_target(text: str, machine, pe: int, stage: str) -> Target:
    """`--fast-forward TEXT` on `machine` (at cycle 0), viewing `pe`.`stage`."""
    t = text.strip()
    if not t:
        raise DebugError("--fast-forward takes a cycle or a location (a label, ic:loop, *ADDRESS)")
    if _CYCLE.match(t):
        return Target(t, cycle=int(t.replace("_", ""), 0))
    if re.match(r"^-\s*\d", t):
        raise DebugError(f"--fast-forward: a cycle is at least 0, not {t}")
    m = _SPELLING.match(t)
    location = "".join(f"{q}." for q in (m["pe"], m["proc"]) if q) + m["rest"]
    try:
        where_pe, where_stage, address = Context(machine, pe, stage).location(location)
    except DebugError as err:
        raise DebugError(f"--fast-forward {t}: {err}") from None
    return Target(t, pe=pe if where_pe is None else where_pe, stage=where_stage, address=address)


def fast_forward(factory, target_text: str, pe: int, stage: str | None, stage_of):
    """Build the machine through the compiled engine and run it to the target.

    `stage_of(machine)` is the processor viewed by default. Returns (machine, target, messages):
    the machine after the run, the parsed target, and the notes to show at the start."""
    try:
        engine = factory.engine(ENGINE)
    except NetsushisenError as err:
        raise DebugError(f"--fast-forward needs the compiled engine: "
                         f"{err.format().splitlines()[0]}") from None
    m = engine.machine
    if not 0 <= pe < len(m.pes):
        raise DebugError(f"no PE {pe} (the machine has {len(m.pes)})")
    target = parse_target(target_text, m, pe, stage or stage_of(m))
    limit = m.config.max_cycles
    try:
        if target.cycle is not None:
            goal = min(target.cycle, limit) if limit else target.cycle
            if goal > m.cycle:
                engine.step(goal - m.cycle)
            if m.status is None and m.cycle < target.cycle:
                m.run(limit)  # at the cycle limit: ends the run as a stepped session would
        else:
            core = m.pes[target.pe].cores[target.stage]
            arrived = False
            if core.pc == target.address:  # where it stands at cycle 0 does not count
                _leave(m, target)
                core = m.pes[target.pe].cores[target.stage]
                arrived = (m.status is None and core.last_issued and core.pc == target.address
                           and core.last_pc == target.address)  # a bundle that loops on itself
            if m.status is None and not arrived:
                engine.run_to_pc(target.processor, target.address)
    except KeyboardInterrupt:
        return m, target, [f"fast-forward to {target.describe(m)} interrupted at cycle "
                           f"{m.cycle}: the session starts there; reverse execution cannot go "
                           f"back before it"]
    return m, target, _outcome(m, target)


def _leave(m, target: Target) -> None:
    """Step the reference engine until the processor has issued the bundle at the target (it
    stands there at cycle 0), so that only a later arrival counts."""
    core = m.pes[target.pe].cores[target.stage]
    limit = m.config.max_cycles
    while m.status is None and not (core.last_issued and core.last_pc == target.address):
        if core.halted:
            return
        if limit and m.cycle >= limit:
            return  # the compiled run words the limit
        m.step()


def _outcome(m, target: Target) -> list[str]:
    where = target.describe(m)
    if m.status is None:
        if target.cycle is not None:
            what = f"cycle {m.cycle} reached"
        else:
            what = f"{where} reached after {m.cycle} cycle{'' if m.cycle == 1 else 's'}"
        return [f"fast-forward: {what} with the compiled engine; the reference engine takes "
                f"over here (reverse execution cannot go back before cycle {m.cycle})"]
    if target.cycle is not None and m.cycle == target.cycle:
        return [f"fast-forward: cycle {m.cycle} reached with the compiled engine; the run "
                f"ended in it ({m.status})"]
    return [f"fast-forward: the run ended at cycle {m.cycle} ({m.status}) before reaching "
            f"{where}: the session starts at the end of the run"]
