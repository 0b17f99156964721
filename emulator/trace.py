"""Line trace: one line per cycle per processor (after PyMTL3's line tracing).

    cycle  processor  pc  label+offset        what happened
       12  pe0.ic      4  loop+1               fadd r1, r2, r3 ; fmul r4, r5, r6
       13  pe0.ic      5  loop+2               stall operand:fmul
       14  pe0.ic      5  loop+2               stall operand:fmul

A processor's lines stop after the bundle holding its `halt`.

A stall line shows the PC the stall is charged to (a hold after a load or a taken branch is
charged to that load or branch). Filters: processors by name prefix (`pe0.ic`, `pe1`, comma
separated) and a cycle range `A:B` (A included, B excluded; either may be left out).
"""

from __future__ import annotations

from typing import TextIO


def parse_cycles(text: str | None) -> tuple[int, int | None]:
    """'A:B', 'A:', ':B' or 'A' → (first, end or None); ValueError if malformed."""
    if not text:
        return 0, None
    a, sep, b = text.partition(":")
    first = int(a) if a.strip() else 0
    if not sep:
        return first, first + 1
    end = int(b) if b.strip() else None
    if first < 0 or (end is not None and end < first):
        raise ValueError(f"bad cycle range {text!r}")
    return first, end


class Tracer:
    def __init__(self, out: TextIO, processors: str | None = None, cycles: str | None = None):
        self.out = out
        self.prefixes = [p.strip() for p in processors.split(",")] if processors else None
        self.first, self.end = parse_cycles(cycles)
        self._halted: set[str] = set()

    def wants(self, name: str) -> bool:
        return self.prefixes is None or any(name == p or name.startswith(p + ".")
                                            for p in self.prefixes)

    def cycle(self, machine, c: int) -> None:
        if c < self.first or (self.end is not None and c >= self.end):
            return
        for core in machine.cores:
            if not core.present or not self.wants(core.name):
                continue
            if core.last_issued:
                b = core.bundles[core.last_pc]
                what = b.text
                if core.halted:
                    self._halted.add(core.name)
            elif core.halted:
                if core.name in self._halted:
                    continue
                self._halted.add(core.name)
                what = "halted"
            else:
                what = "stall " + core.cause
            pc = core.last_pc
            self.out.write(f"{c:>8}  {core.name:<7} {pc:>5}  {core.label(pc):<20.20} {what}\n")
