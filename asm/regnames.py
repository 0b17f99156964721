"""The `.reg` names of a program, by address: what the listing, the disassembler, the trace,
the timeline and the debugger show beside a register (`pri/r29`) and what the debugger
accepts for one.

The assembler records each name's scope (`Program.reg_names`: name, register, first bundle,
end): a name means the register of its latest `.reg` before the bundle, so a redefinition
ends the previous scope. Kernels give one register several names at once (temporaries reused
by each intersection test: `t_ndy`, `t_h1z`, ... all r51); at an address the name shown is
the one the source used last — in that bundle's own source line, else in the nearest bundle
before it that names the register — and otherwise the latest defined.
"""

from __future__ import annotations

import re

from netsushisen.asm.objects import Program
from netsushisen.isa.processors import register_name

_WORD = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
LOOKBACK = 64  # bundles searched back for the name the source used last


class RegisterNames:
    """The name table of one program, with the per-address choices cached."""

    def __init__(self, program: Program):
        self.program = program
        self.scopes = list(program.reg_names)
        self._words: dict[int, set[str]] = {}
        self._at: dict[int, dict[int, str]] = {}
        self._labels: dict[int, dict[int, str]] = {}

    def __bool__(self) -> bool:
        return bool(self.scopes)

    def bindings(self, pc: int) -> dict[str, int]:
        """Every name in force at bundle `pc` -> its register."""
        return {s.name: s.reg for s in self.scopes if s.start <= pc < s.end}

    def register(self, name: str, pc: int) -> int | None:
        """The register `name` means at `pc`; a name not in force there but with one register
        over the whole program means that one (gdb would say "not in scope"; a kernel writer
        asking for `pri` anywhere means r29). None: no such name, or ambiguous here."""
        regs = {s.reg for s in self.scopes if s.name == name}
        for s in self.scopes:
            if s.name == name and s.start <= pc < s.end:
                return s.reg
        return regs.pop() if len(regs) == 1 else None

    def known(self, name: str) -> bool:
        return any(s.name == name for s in self.scopes)

    def describe(self, name: str) -> str:
        """Where a name is in force: `r5 at 0..11, r6 at 12..40`."""
        return ", ".join(f"r{s.reg} at {s.start}..{s.end - 1}" for s in self.scopes
                         if s.name == name)

    def _source_words(self, pc: int) -> set[str]:
        words = self._words.get(pc)
        if words is None:
            smap = self.program.source_map
            text = smap[pc].text.split("#", 1)[0] if pc < len(smap) else ""
            words = self._words[pc] = set(_WORD.findall(text))
        return words

    def names(self, pc: int) -> dict[int, str]:
        """Register -> the name to show for it at `pc` (registers without a name are absent)."""
        hit = self._at.get(pc)
        if hit is not None:
            return hit
        by_reg: dict[int, list] = {}
        for s in self.scopes:
            if s.start <= pc < s.end:
                by_reg.setdefault(s.reg, []).append(s)
        out: dict[int, str] = {}
        for reg, scopes in by_reg.items():
            if len(scopes) == 1:
                out[reg] = scopes[0].name
                continue
            names = {s.name for s in scopes}
            first = min(s.start for s in scopes)
            chosen = scopes[-1].name  # the latest defined
            for a in range(pc, max(first, pc - LOOKBACK) - 1, -1):
                used = names & self._source_words(a)
                if used:
                    chosen = max(used, key=lambda n: max(i for i, s in enumerate(scopes)
                                                         if s.name == n))
                    break
            out[reg] = chosen
        self._at[pc] = out
        return out

    def labels(self, pc: int) -> dict[int, str]:
        """Register -> `name/rN` at `pc`, for `Op.format(reg_names=...)`."""
        hit = self._labels.get(pc)
        if hit is None:
            hit = self._labels[pc] = {r: f"{n}/{register_name(r)}"
                                      for r, n in self.names(pc).items()}
        return hit

    def label(self, reg: int, pc: int) -> str:
        """`pri/r29`, or `r29` where the register has no name."""
        name = self.names(pc).get(reg)
        return f"{name}/{register_name(reg)}" if name else register_name(reg)


_TABLES: dict[int, tuple[Program, RegisterNames]] = {}


def register_names(program: Program) -> RegisterNames:
    """The name table of a program, built once per program object."""
    hit = _TABLES.get(id(program))
    if hit is None or hit[0] is not program:
        if len(_TABLES) > 64:
            _TABLES.clear()
        hit = _TABLES[id(program)] = (program, RegisterNames(program))
    return hit[1]


def named_text(program: Program, pc: int, code_labels: dict[int, str] | None = None,
               sep: str = " ; ") -> str:
    """The bundle at `pc` as text with `name/rN` registers (the trace's and timeline's text)."""
    labels = register_names(program).labels(pc)
    return sep.join(op.format(code_labels, labels) for op in program.bundles[pc])
