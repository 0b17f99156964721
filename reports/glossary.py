"""What the stall causes mean and what a kernel writer can do: `report stalls --explain` and
docs/stalls.md.

The causes themselves, with their rule, meaning, remedy and colour, are one table in
isa/stalls.py (`CAUSES`), which the engines charge from; this module only renders it — as a
report section and as docs/stalls.md (`glossary_markdown()`; a test keeps the file equal to
it), so the two cannot drift. Every cycle in which a processor issues no bundle is charged to
exactly one cause (rule T10 of docs/timing.md), so `cycles = bundles + stalls`. A cause with a
parameter names it after a colon: `operand:fmul` (the mnemonic whose result is awaited),
`fifo_empty:ring` (the FIFO port).
"""

from __future__ import annotations

from netsushisen.isa.stalls import CAUSES, ISSUED_COLOUR, OTHER_COLOUR, Cause, lookup
from netsushisen.reports.tables import Section

ISSUED = "(issued)"
"""Not a stall: the row of the stall report that counts cycles which issued a bundle."""


def explain(cause: str) -> str:
    """The meaning of a concrete cause with its parameter filled in; unknown causes say so."""
    if cause == ISSUED:
        return "cycles that issued a bundle (not a stall)"
    c = lookup(cause)
    if c is None:
        return "a cause this glossary does not know (statistics from another version?)"
    if c.placeholder:
        return c.meaning.replace(c.placeholder, cause.split(":", 1)[1])
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
        "<!-- generated from isa/stalls.py by `netsushisen report stalls --explain "
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
        "| cause | group | rule | charged to | meaning | what to try | plot colour |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for c in CAUSES:
        lines.append(f"| `{c.name}` | {c.group} | {c.rule} | {c.charged_to} | {c.meaning} | "
                     f"{c.remedy} | `{c.colour}` |")
    lines += ["", f"The stall report's `{ISSUED}` row is not a stall: the cycles that issued a "
              "bundle, so that a processor's rows add up to its cycles.", "",
              "Every plot (`report stalls --plot`, `report annotate --plot`) draws a cause in the "
              "colour above, a family's parameters (`operand:fmul`, `operand:fadd`) in shades of "
              f"it, the issued cycles in `{ISSUED_COLOUR}` and the causes it does not name one by "
              f"one (`other`) in `{OTHER_COLOUR}`.", ""]
    return "\n".join(lines)


__all__ = ["CAUSES", "Cause", "ISSUED", "explain", "glossary_markdown", "glossary_section",
           "lookup"]
