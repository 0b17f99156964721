"""Names that cannot alias: two names of one register may not both hold a value at once.

A `.reg` name is a writer's promise that the register holds that name's value. Kernels give one
register several names (temporaries reused test after test), which is sound only while at most
one of them is live — the sphere test's early-rejection guard `s_g1` shared r40 with `s_Zt`,
whose write killed the guard before it was read (issue 40). This module finds such points:
a write through name B of register R while another name A of R is live (A's value is read
later through A, with no write through A between).

Liveness is per (name, register) pair, and only a write through the same name ends it, so a
value written as B and read as A is also caught: A is live across B's write. A raw register
operand (`r40`) is a name of its own. Inside a `.sched` region the region's whole control flow
is known (its branches, its loops), so a clash is an error; outside regions only the straight
line between labels and control transfers is, so a clash there is a warning (the assembler
cannot know what a jump's target reads). Exits are taken as reading nothing: values live out of
a region are the next code's business, and a false alarm would be worse than a miss.
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.asm.expressions import names_in
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.processors import ZERO_REGISTER, register_name

Name = tuple[str, int]  # (name as written, register)


@dataclass(frozen=True)
class NamedAccess:
    """The names one bundle (or one region operation) reads and writes."""

    reads: tuple[Name, ...]
    writes: tuple[Name, ...]


@dataclass(frozen=True)
class Clash:
    """At operation `at`, `writer` is written while `live` (same register) is read later, at
    operation `read`."""

    at: int
    writer: str
    live: str
    reg: int
    read: int


def operand_names(instr, register_of) -> NamedAccess:
    """The names an instruction reads and writes: each register operand as written (a `.reg`
    name, or the register's own name), implicit ones by register. `register_of(name)` is the
    register a name denotes in force at the instruction, or None."""
    opcode = OPCODES[instr.mnemonic]
    reads: list[Name] = []
    writes: list[Name] = []
    for spec, operand in zip(opcode.operands, instr.operands):
        if spec.kind in ("rd", "rs") and operand.expr[0] == "name":
            name = operand.expr[1]
            reg = register_of(name)
            if reg is not None and reg != ZERO_REGISTER:
                (writes if spec.kind == "rd" else reads).append((_canonical(name, reg), reg))
        elif spec.kind == "mem" and operand.kind == "mem":
            for name, _ in names_in(operand.expr):
                reg = register_of(name)
                if reg is not None and reg != ZERO_REGISTER:
                    reads.append((_canonical(name, reg), reg))
    reads += [(register_name(r), r) for r in opcode.implicit_reads if r != ZERO_REGISTER]
    writes += [(register_name(r), r) for r in opcode.implicit_writes if r != ZERO_REGISTER]
    return NamedAccess(tuple(reads), tuple(writes))


def _canonical(name: str, reg: int) -> str:
    """A register's own spellings (r63, lr) are one name."""
    return register_name(reg) if name == register_name(reg) or name in ("zero", "lr") or \
        (name.startswith("r") and name[1:].isdigit()) else name


def merge(accesses: list[NamedAccess]) -> NamedAccess:
    """A bundle's accesses: every operation reads at issue, before any of them writes."""
    return NamedAccess(tuple(n for a in accesses for n in a.reads),
                       tuple(n for a in accesses for n in a.writes))


def clashes(ops: list[NamedAccess], succ: list[tuple[int, ...]]) -> list[Clash]:
    """Every write through one name of a register while another name of it is live (module
    docstring). `succ[i]`: the operations control may reach right after operation i."""
    n = len(ops)
    live_out: list[frozenset[Name]] = [frozenset()] * n
    live_in: list[frozenset[Name]] = [frozenset()] * n
    changed = True
    while changed:  # backward dataflow to a fixed point (regions are small)
        changed = False
        for i in range(n - 1, -1, -1):
            out = frozenset().union(*(live_in[j] for j in succ[i])) if succ[i] else frozenset()
            new_in = frozenset(ops[i].reads) | (out - frozenset(ops[i].writes))
            if out != live_out[i] or new_in != live_in[i]:
                live_out[i], live_in[i], changed = out, new_in, True
    found = []
    for i, op in enumerate(ops):
        written = {name for name, _ in op.writes}
        for writer, reg in op.writes:
            for name, r in sorted(live_out[i]):
                if r == reg and name != writer and name not in written:
                    found.append(Clash(i, writer, name, reg, _next_read(ops, succ, i, (name, r))))
    return found


def _next_read(ops: list[NamedAccess], succ: list[tuple[int, ...]], at: int, name: Name) -> int:
    """The nearest operation after `at` that reads `name`'s value (breadth first)."""
    seen = set()
    todo = list(succ[at])
    while todo:
        nxt = []
        for j in todo:
            if j in seen:
                continue
            seen.add(j)
            if name in ops[j].reads:
                return j
            if name not in ops[j].writes:
                nxt.extend(succ[j])
        todo = nxt
    return at


def successors(kinds: list[str], targets: list[int | None], limit: set[int] | None = None
               ) -> list[tuple[int, ...]]:
    """Control successors of a run of operations (or bundles) by their control kind ("" for
    none) and branch target (an index in the run, or None for outside it). `limit`: indices
    that start a new straight line (labels): the line before them does not flow on (used
    outside regions, where what a label's other predecessors do is not known)."""
    n = len(kinds)
    out = []
    for i, kind in enumerate(kinds):
        nxt = []
        falls = (kind in ("", "branch") or (kind == "call" and limit is None)) and i + 1 < n
        if falls and not (limit is not None and i + 1 in limit):
            nxt.append(i + 1)
        if limit is None and kind in ("branch", "jump") and targets[i] is not None:
            nxt.append(targets[i])
        out.append(tuple(nxt))
    return out
