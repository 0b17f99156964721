"""The stall causes: one table of every cause the emulator charges, the home of each fact about it.

A cycle in which a processor issues no bundle is charged to exactly one cause (rule T10 of
docs/timing.md), so `cycles = bundles + stall cycles`. This table says, per cause, its name as
the statistics spell it, its group, the timing rule that charges it, whether it is a hold after
an earlier bundle (charged to that bundle's PC) or a wait of the bundle about to issue, what it
means, what a kernel writer can try, and the colour every plot draws it in. The reference core
(emulator/core.py) and the memories charge the names defined here, the compiled engine numbers
them (emulator/compiled/state.py), the timeline marks the holds, and the glossary
(`report stalls --explain`, docs/stalls.md) and the plots (`report stalls --plot`,
`report annotate --plot`) read the rest. It lives in isa/ because it is a machine fact that
the emulator and the reports both read (and reports/ imports no emulator).

A cause with a parameter names it after a colon: `operand:fmul` (the mnemonic whose result is
awaited), `fifo_empty:ring` (the FIFO port); the table's entry for such a family is spelled
with the parameter's placeholder (`operand:<m>`, `fifo_empty:<port>`).
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.isa.opcodes import OPCODES


@dataclass(frozen=True)
class Cause:
    name: str
    """The cause as the statistics spell it; `<m>` a mnemonic, `<port>` a FIFO port."""
    group: str
    """memory, control, dependence, resource, communication."""
    rule: str
    """The timing rule of docs/timing.md that charges it."""
    hold: bool
    """A hold after an earlier bundle (charged to that bundle's PC: a load or a branch, rule
    T10.1), rather than a wait of the bundle about to issue (charged to its own PC)."""
    meaning: str
    remedy: str
    colour: str
    """The colour every plot draws it in (hex RGB); a family's parameters get shades of it."""

    @property
    def charged_to(self) -> str:
        """Whose PC the cycles are charged to, in words."""
        return {"memory": "the load", "control": "the branch"}[self.group] if self.hold \
            else "the waiting bundle"

    @property
    def family(self) -> str:
        """The part before the colon (`operand` of `operand:<m>`), the whole name otherwise."""
        return self.name.split(":", 1)[0]

    @property
    def placeholder(self) -> str | None:
        """`<m>` or `<port>` for a family with a parameter; None for a cause without one."""
        tail = self.name.split(":", 1)[1] if ":" in self.name else ""
        return tail if tail.startswith("<") else None


LOCAL, RESIDENT, CACHE_HIT, CACHE_MISS, BRANCH = "local", "resident", "cache_hit", "cache_miss", \
    "branch"
OPERAND, WAW, UNIT_BUSY, WRITE_PORT = "operand", "waw", "unit_busy", "write_port"
FIFO_EMPTY, FIFO_ANY, FIFO_FULL = "fifo_empty", "fifo_empty:any", "fifo_full"
"""The names (or, for a family with a parameter, the family) the engines charge."""

CAUSES: tuple[Cause, ...] = (
    Cause(LOCAL, "memory", "T6", True,
          "a load from local memory is in progress (OS: the `ld` latency; IC/SC: t_r); loads "
          "block issue, so its access time less one cycle is held",
          "keep the value in a register, or load it once outside the loop", "#9ecae1"),
    Cause(RESIDENT, "memory", "T6", True,
          "an `ldr` from resident memory is in progress (t_r, less the issue cycle)",
          "fewer loads per primitive; resident data is already the cheapest global data",
          "#4292c6"),
    Cause(CACHE_HIT, "memory", "T6", True,
          "an `ldg` that hit the direct-mapped cache is in progress (t_c, less the issue cycle)",
          "make the data resident (more resident memory: `ic_memory` `resident_bytes` or "
          "`resident_share`)", "#08519c"),
    Cause(CACHE_MISS, "memory", "T6", True,
          "an `ldg` that missed is in progress (t_g, less the issue cycle; the block is filled "
          "at once)",
          "more resident memory or a larger cache (`ic_memory` `resident_bytes`, `cache_bytes`); "
          "`report memory` gives ρ and μ", "#d62728"),
    Cause(BRANCH, "control", "T7", True,
          "the penalty cycles after a taken branch, `j`, `jr`, `call` or `ret` "
          "(`taken_branch_penalty` in the processor's configuration section)",
          "lay the common path out as the fall-through; merge short branches into `fsel`",
          "#8c564b"),
    Cause(f"{OPERAND}:<m>", "dependence", "T3", False,
          "a source register is not ready (read after write); `<m>` is the operation whose "
          "result arrives last",
          "schedule independent operations between producer and consumer; "
          "`--set ic.latency.<m>=N` (or os, sc) sets its latency", "#ff7f0e"),
    Cause(f"{WAW}:<m>", "dependence", "T3", False,
          "a destination register still awaits the result of an earlier `<m>` (write after "
          "write)",
          "write a different register", "#bcbd22"),
    Cause(f"{UNIT_BUSY}:<m>", "resource", "T4", False,
          "too few free units of a class: `<m>` is an unpipelined operation (div, rem, fdiv, "
          "fsqrt, fpow) occupying the first busy unit",
          "spread the unpipelined operations apart, or replace a divide by a multiply",
          "#9467bd"),
    Cause(WRITE_PORT, "resource", "T5", False,
          "the bundle's results would complete in a cycle whose register write ports are "
          "taken (OS 2, IC 3, SC 1)",
          "move one of the results to a bundle whose writes land in another cycle", "#e377c2"),
    Cause(f"{FIFO_EMPTY}:<port>", "communication", "T8", False,
          "`recv` waits for a word in receive FIFO `<port>` (`host`: DIS, OS only; `ring`: "
          "the previous stage through the CMU): the processor is starved by its producer",
          "the producer is the bottleneck: speed it up, or give this stage other work",
          "#2ca02c"),
    Cause(FIFO_ANY, "communication", "T8", False,
          "`wait` sleeps until some receive FIFO holds a word: the processor is idle",
          "none needed here: idle time of a stage that is not the bottleneck", "#98df8a"),
    Cause(f"{FIFO_FULL}:<port>", "communication", "T8", False,
          "`send` waits for a free slot in send FIFO `<port>` (`ring`: the next stage; `col`: "
          "the pixel collector): back-pressure from the consumer",
          "the consumer is the bottleneck, or the FIFOs are too shallow (`ring.fifo_depth`)",
          "#17becf"),
)

FIFO_PORTS = ("ring", "host", "col")
"""The FIFO ports a `<port>` parameter names (receive: ring, host; send: ring, col)."""

PARAMETERS: dict[str, tuple[str, ...]] = {"<m>": ("",) + tuple(OPCODES), "<port>": FIFO_PORTS}
"""Every value a placeholder takes: `<m>` any mnemonic (or "" when the producer is unknown),
`<port>` a FIFO port."""

HOLD_CAUSES = frozenset(c.name for c in CAUSES if c.hold)
"""Causes that are a hold after an earlier bundle (T10 rule 1), charged to that bundle's PC."""

ISSUED_COLOUR = "#b0b0b0"
"""Plots draw the cycles that issued a bundle in grey (no cause uses it)."""
OTHER_COLOUR = "#404040"
"""Plots draw the causes they do not name one by one (`other`) in dark grey."""


def stall(family: str, parameter: str) -> str:
    """The concrete cause of a family with a parameter: stall(OPERAND, "fmul") == "operand:fmul"."""
    return f"{family}:{parameter}"


def lookup(cause: str) -> Cause | None:
    """The table entry of a concrete cause (`operand:fmul` -> `operand:<m>`); None if unknown
    (including a parameter the placeholder cannot take)."""
    for c in CAUSES:
        if c.name == cause:
            return c
    family, _, parameter = cause.partition(":")
    return next((c for c in CAUSES if c.placeholder and c.family == family
                 and parameter in PARAMETERS[c.placeholder]), None)


def concrete_causes() -> tuple[str, ...]:
    """Every concrete cause an engine may charge, in table order (each family expanded over its
    placeholder's values)."""
    out: list[str] = []
    for c in CAUSES:
        if c.placeholder is None:
            out.append(c.name)
        else:
            out += [stall(c.family, p) for p in PARAMETERS[c.placeholder]]
    return tuple(out)


def _shade(colour: str, amount: float) -> str:
    """`colour` mixed toward white (amount > 0) or black (amount < 0) by |amount|."""
    rgb = [int(colour[i:i + 2], 16) for i in (1, 3, 5)]
    target = 255 if amount > 0 else 0
    mixed = [round(v + (target - v) * abs(amount)) for v in rgb]
    return "#" + "".join(f"{v:02x}" for v in mixed)


SHADES = (0.0, 0.4, -0.35, 0.65, -0.55, 0.2, -0.2)
"""How the parameters of one family are told apart: the n-th value of the placeholder (in
PARAMETERS order) is the family's colour shaded by SHADES[n % len(SHADES)]."""


def colour(cause: str) -> str:
    """The plot colour of a concrete cause: its entry's colour, shaded for a family's parameter
    (the same cause is the same colour in every plot); OTHER_COLOUR for an unknown cause."""
    c = lookup(cause)
    if c is None:
        return OTHER_COLOUR
    if c.placeholder is None:
        return c.colour
    parameter = cause.partition(":")[2]
    return _shade(c.colour, SHADES[PARAMETERS[c.placeholder].index(parameter) % len(SHADES)])


__all__ = ["BRANCH", "CACHE_HIT", "CACHE_MISS", "CAUSES", "Cause", "FIFO_ANY", "FIFO_EMPTY",
           "FIFO_FULL", "FIFO_PORTS", "HOLD_CAUSES", "ISSUED_COLOUR", "LOCAL", "OPERAND",
           "OTHER_COLOUR", "PARAMETERS", "RESIDENT", "UNIT_BUSY", "WAW", "WRITE_PORT", "colour",
           "concrete_causes", "lookup", "stall"]
