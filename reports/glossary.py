"""The stall causes the emulator charges, what each means and what a kernel writer can do.

One table (`CAUSES`) feeds both `netsushisen report stalls --explain` and `docs/stalls.md`
(`glossary_markdown()`; a test keeps the file equal to it), so the two cannot drift. The causes
are the reference engine's (emulator/core.py, rule T10 of docs/timing.md): every cycle in which a
processor issues no bundle is charged to exactly one of them, so `cycles = bundles + stalls`.
A cause with a parameter names it after a colon: `operand:fmul` (the mnemonic whose result is
awaited), `fifo_empty:ring` (the FIFO port).
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.reports.tables import Section


@dataclass(frozen=True)
class Cause:
    name: str
    """The cause as the statistics spell it; `<m>` a mnemonic, `<port>` a FIFO port."""
    group: str
    """memory, control, dependence, resource, communication."""
    rule: str
    """The timing rule of docs/timing.md that charges it."""
    charged_to: str
    meaning: str
    remedy: str


CAUSES: tuple[Cause, ...] = (
    Cause("local", "memory", "T6", "the load",
          "a load from local memory is in progress (OS: the `ld` latency; IC/SC: t_r); loads "
          "block issue, so its access time less one cycle is held",
          "keep the value in a register, or load it once outside the loop"),
    Cause("resident", "memory", "T6", "the load",
          "an `ldr` from resident memory is in progress (t_r, less the issue cycle)",
          "fewer loads per primitive; resident data is already the cheapest global data"),
    Cause("cache_hit", "memory", "T6", "the load",
          "an `ldg` that hit the direct-mapped cache is in progress (t_c, less the issue cycle)",
          "make the data resident (more resident memory: `ic_memory` `resident_bytes` or "
          "`resident_share`)"),
    Cause("cache_miss", "memory", "T6", "the load",
          "an `ldg` that missed is in progress (t_g, less the issue cycle; the block is filled "
          "at once)",
          "more resident memory or a larger cache (`ic_memory` `resident_bytes`, `cache_bytes`); "
          "`report memory` gives ρ and μ"),
    Cause("branch", "control", "T7", "the branch",
          "the penalty cycles after a taken branch, `j`, `jr`, `call` or `ret` "
          "(`taken_branch_penalty` in the processor's configuration section)",
          "lay the common path out as the fall-through; merge short branches into `fsel`"),
    Cause("operand:<m>", "dependence", "T3", "the waiting bundle",
          "a source register is not ready (read after write); `<m>` is the operation whose "
          "result arrives last",
          "schedule independent operations between producer and consumer; "
          "`--set ic.latency.<m>=N` (or os, sc) sets its latency"),
    Cause("waw:<m>", "dependence", "T3", "the waiting bundle",
          "a destination register still awaits the result of an earlier `<m>` (write after "
          "write)",
          "write a different register"),
    Cause("unit_busy:<m>", "resource", "T4", "the waiting bundle",
          "too few free units of a class: `<m>` is an unpipelined operation (div, rem, fdiv, "
          "fsqrt, fpow) occupying the first busy unit",
          "spread the unpipelined operations apart, or replace a divide by a multiply"),
    Cause("write_port", "resource", "T5", "the waiting bundle",
          "the bundle's results would complete in a cycle whose register write ports are "
          "taken (OS 2, IC 3, SC 1)",
          "move one of the results to a bundle whose writes land in another cycle"),
    Cause("fifo_empty:<port>", "communication", "T8", "the waiting bundle",
          "`recv` waits for a word in receive FIFO `<port>` (`host`: DIS, OS only; `ring`: "
          "the previous stage through the CMU): the processor is starved by its producer",
          "the producer is the bottleneck: speed it up, or give this stage other work"),
    Cause("fifo_empty:any", "communication", "T8", "the waiting bundle",
          "`wait` sleeps until some receive FIFO holds a word: the processor is idle",
          "none needed here: idle time of a stage that is not the bottleneck"),
    Cause("fifo_full:<port>", "communication", "T8", "the waiting bundle",
          "`send` waits for a free slot in send FIFO `<port>` (`ring`: the next stage; `col`: "
          "the pixel collector): back-pressure from the consumer",
          "the consumer is the bottleneck, or the FIFOs are too shallow (`ring.fifo_depth`)"),
)

ISSUED = "(issued)"
"""Not a stall: the row of the stall report that counts cycles which issued a bundle."""


def lookup(cause: str) -> Cause | None:
    """The table entry of a concrete cause (`operand:fmul` -> `operand:<m>`); None if unknown."""
    for c in CAUSES:
        if c.name == cause:
            return c
    family = cause.split(":", 1)[0]
    return next((c for c in CAUSES if ":" in c.name and c.name.split(":", 1)[0] == family
                 and c.name.endswith(">")), None)


def explain(cause: str) -> str:
    """The meaning of a concrete cause with its parameter filled in; unknown causes say so."""
    if cause == ISSUED:
        return "cycles that issued a bundle (not a stall)"
    c = lookup(cause)
    if c is None:
        return "a cause this glossary does not know (statistics from another version?)"
    if ":" in c.name and c.name.endswith(">"):
        return c.meaning.replace(c.name.split(":", 1)[1], cause.split(":", 1)[1])
    return c.meaning


def glossary_section(causes: list[str] | None = None) -> Section:
    """The glossary as a report section: every cause (None), or the concrete ones given."""
    s = Section("glossary", "Stall causes (docs/stalls.md)", ["cause", "rule", "charged to", "meaning"])
    if causes is None:
        s.columns = ["cause", "rule", "charged to", "meaning", "what to try"]
        s.rows = [[c.name, c.rule, c.charged_to, c.meaning, c.remedy] for c in CAUSES]
        return s
    for cause in causes:
        c = lookup(cause)
        s.rows.append([cause, c.rule if c else None, c.charged_to if c else None, explain(cause)])
    return s


def glossary_markdown() -> str:
    """docs/stalls.md: the table above as Markdown, with how to read the stall reports."""
    lines = [
        "# Stall causes",
        "",
        "<!-- generated from reports/glossary.py by `netsushisen report stalls --explain "
        "--format md -o docs/stalls.md`; do not edit -->",
        "",
        "Every cycle in which a processor issues no bundle is charged to exactly one cause, the "
        "first that applies in the order of rule T10 (docs/timing.md), so for every processor "
        "`cycles = bundles + stall cycles`. Memory and branch stalls are charged to the PC of "
        "the load or branch that holds issue; the others to the PC of the bundle that waits. "
        "`netsushisen report stalls STATS.json` gives the cycles by cause and by code location, "
        "`report annotate` per bundle and per loop, `report stalls STATS.json --explain` adds "
        "the meaning of each cause the run charged, and `report stalls --explain` alone prints "
        "this table.",
        "",
        "A parameter follows a colon: `<m>` is a mnemonic (`operand:fmul`: waiting for an "
        "`fmul` result), `<port>` a FIFO port (`host`, `ring`, `col`).",
        "",
        "| cause | group | rule | charged to | meaning | what to try |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for c in CAUSES:
        lines.append(f"| `{c.name}` | {c.group} | {c.rule} | {c.charged_to} | {c.meaning} | {c.remedy} |")
    lines += ["", f"The stall report's `{ISSUED}` row is not a stall: the cycles that issued a "
              "bundle, so that a processor's rows add up to its cycles.", ""]
    return "\n".join(lines)
