"""Breakpoints and watchpoints of a debugger session: what they are, how they are made,
numbered, enabled, conditioned and ignored (gdb's `break`, `tbreak`, `watch`, `rwatch`,
`awatch`, `enable`, `disable`, `condition`, `ignore`, `delete`), and how a cycle's issued
bundles, register writes, stores and loads make them fire.

A *crossing* is a cycle in which a breakpoint's bundle issues on a matching processor, or a
watched word is written (watch, awatch) or read (rwatch, awatch), and the condition, evaluated
after that cycle, holds. Every crossing counts as a hit; `ignore N COUNT` lets the next COUNT
crossings pass without stopping (gdb). Replays (reverse execution) neither count hits nor use
up ignore counts, so going back and forth does not change them. A temporary breakpoint (tbreak)
is deleted when it stops the run.

Reads: a word of local or resident memory is read by its own processor; a word of a global
memory (icgm, scgm) by any PE's processor, and a read watchpoint's report names every reader of
the cycle and, through the cache, whether each hit or missed.
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.debugger.expressions import Context, DebugError, Place, short_word
from netsushisen.debugger.reverse import Hit


@dataclass
class Breakpoint:
    number: int  # 0: `until`'s own temporary breakpoint (not listed)
    pe: int | None  # None: every PE
    stage: str
    address: int
    label: str
    condition: str | None = None
    temporary: bool = False  # tbreak (and until): deleted when it stops the run
    hits: int = 0
    enabled: bool = True
    ignore: int = 0  # crossings still to let pass (`ignore N COUNT`)
    where: str = ""  # FILE:LINE of the bundle, for `info breakpoints`

    @property
    def kind(self) -> str:
        return "breakpoint"

    def place_text(self) -> str:
        where = (f"pe{self.pe}." if self.pe is not None else "") + f"{self.stage} pc {self.address}"
        if self.label != str(self.address):
            where += f" ({self.label})"
        return where

    def describe(self) -> str:
        cond = f" if {self.condition}" if self.condition else ""
        what = "temporary breakpoint" if self.temporary else "breakpoint"
        return f"{what} {self.number} at {self.place_text()}{cond}"


WATCH_TYPES = {"watch": "watchpoint", "rwatch": "read watchpoint", "awatch": "acc watchpoint"}


@dataclass
class Watchpoint:
    number: int
    place: Place
    hits: int = 0
    kind: str = "watch"  # watch (writes), rwatch (reads), awatch (both)
    enabled: bool = True
    condition: str | None = None
    ignore: int = 0

    @property
    def reads(self) -> bool:
        return self.kind in ("rwatch", "awatch")

    @property
    def writes(self) -> bool:
        return self.kind in ("watch", "awatch")

    def describe(self) -> str:
        return f"{WATCH_TYPES[self.kind]} {self.number} on {self.place.name(qualify=True)}"


def _reader(core, cache_hit: bool | None) -> str:
    """Who read a watched word: 'ldg at pe1.ic pc 3 (loop+3), cache miss'."""
    pc = core.last_pc
    ops = [op.mnemonic for op in core.program.bundles[pc] if op.opcode.kind == "load"]
    cache = "" if cache_hit is None else f", cache {'hit' if cache_hit else 'miss'}"
    return f"{ops[0] if ops else 'load'} at {core.name} pc {pc} ({core.label(pc)}){cache}"


def read_key(place: Place, core_name: str) -> tuple:
    """What identifies a memory word's reads: a global word is read by any PE, a local or
    resident word by its own processor."""
    if place.region in ("icgm", "scgm"):
        return (place.region, place.index)
    return (place.region, core_name, place.index)


class Breakpoints:
    """Mixed into `debugger.Session`, which provides machine, pe, stage, context, aux,
    breakpoints, watchpoints and _next_number."""

    def _number(self) -> int:
        n = self._next_number
        self._next_number += 1
        return n

    def add_breakpoint(self, location: str, condition: str | None = None,
                       temporary: bool = False, until: bool = False) -> Breakpoint:
        ctx = self.context()
        pe, stage, addr = ctx.location(location)
        if condition:
            Context(self.machine, self.pe if pe is None else pe, stage).value(condition)
        program = self.machine.programs[stage]
        label = program.label_at(addr)
        smap = program.source_map
        where = f"{smap[addr].file}:{smap[addr].line}" if addr < len(smap) else ""
        bp = Breakpoint(0 if until else self._number(), pe, stage, addr, label,
                        condition or None, temporary or until, where=where)
        if not until:
            self.breakpoints[bp.number] = bp
        return bp

    def add_watchpoint(self, text: str, kind: str = "watch") -> Watchpoint:
        ctx = self.context()
        if text.startswith("*"):  # gdb's `watch *ADDR`: the word at ADDR of the data memory
            place = ctx.memory_ref(text[1:].strip())
            text = place.name()
        else:
            place = ctx.place(text)
        if place is None:
            try:
                place = ctx.memory_ref(text)
            except DebugError:
                place = None
        if kind != "watch":
            if place is None or place.kind != "mem":
                raise DebugError(f"{kind} takes a memory word (local[E], resident[E], icgm[E], "
                                 f"scgm[E], a data label), not {text!r}: registers are read by "
                                 "almost every bundle")
        elif place is None or place.kind == "pc":
            raise DebugError(f"watch takes a register or a local memory word, not {text!r}")
        if place.kind == "reg" and place.index == 0:
            raise DebugError("r0 is never written")
        if kind == "watch" and place.kind == "mem" and place.region != "local":
            raise DebugError(f"{place.region} memory is read-only during a run: nothing writes "
                             f"it (rwatch {text} stops where it is read)")
        wp = Watchpoint(self._number(), place, kind=kind)
        self.watchpoints[wp.number] = wp
        return wp

    def item(self, number: int) -> Breakpoint | Watchpoint:
        found = self.breakpoints.get(number) or self.watchpoints.get(number)
        if found is None:
            raise DebugError(f"no breakpoint or watchpoint {number}")
        return found

    def items(self) -> list[Breakpoint | Watchpoint]:
        """Breakpoints and watchpoints in number order (`info breakpoints`)."""
        both = [*self.breakpoints.values(), *self.watchpoints.values()]
        return sorted(both, key=lambda b: b.number)

    def delete(self, number: int | None = None) -> int:
        if number is None:
            n = len(self.breakpoints) + len(self.watchpoints)
            self.breakpoints.clear()
            self.watchpoints.clear()
            return n
        if number in self.breakpoints:
            del self.breakpoints[number]
        elif number in self.watchpoints:
            del self.watchpoints[number]
        else:
            raise DebugError(f"no breakpoint or watchpoint {number}")
        return 1

    def set_enabled(self, numbers: list[int] | None, on: bool) -> int:
        """`enable`/`disable` N... (every one without numbers); how many changed state."""
        chosen = self.items() if numbers is None else [self.item(n) for n in numbers]
        changed = sum(1 for b in chosen if b.enabled != on)
        for b in chosen:
            b.enabled = on
        return changed

    def set_condition(self, number: int, condition: str | None) -> Breakpoint | Watchpoint:
        b = self.item(number)
        if condition:
            if isinstance(b, Breakpoint):
                Context(self.machine, self.pe if b.pe is None else b.pe, b.stage).value(condition)
            else:
                Context(self.machine, b.place.pe, b.place.stage).value(condition)
        b.condition = condition or None
        return b

    def set_ignore(self, number: int, count: int) -> Breakpoint | Watchpoint:
        if count < 0:
            raise DebugError("ignore takes a count of 0 or more")
        b = self.item(number)
        b.ignore = count
        return b

    # -- one cycle ---------------------------------------------------------------------------

    def _passes(self, b: Breakpoint | Watchpoint, ctx: Context, replay: bool) -> str | bool:
        """Whether a crossing of `b` stops: its condition holds (an error in it stops, with the
        error's text), and it is not one of the crossings `ignore` lets pass. A crossing counts
        as a hit either way (gdb); replays (reverse execution) neither count nor ignore."""
        if b.condition:
            try:
                ok = ctx.value(b.condition)
            except DebugError as err:
                return f"error in condition {b.condition!r}: {err}"
            if not ok:
                return False
        if replay:
            return True
        b.hits += 1
        if b.ignore > 0:
            b.ignore -= 1
            return False
        return True

    def _check_breakpoint(self, bp: Breakpoint, pe: int, core, c: int, replay: bool) -> Hit | None:
        if bp.pe is not None and bp.pe != pe:
            return None
        ok = self._passes(bp, Context(self.machine, pe, bp.stage), replay)
        if ok is False:
            return None
        what = ("until" if bp.number == 0 else
                f"{'temporary ' if bp.temporary else ''}breakpoint {bp.number}")
        if isinstance(ok, str):
            return Hit(c, pe, bp.stage, f"{what}: {ok}", bp.number)
        cond = f" [{bp.condition}]" if bp.condition else ""
        return Hit(c, pe, bp.stage, f"{what}: pe{pe}.{bp.stage} issued pc {bp.address} "
                   f"({core.label(bp.address)}) in cycle {c}{cond}", bp.number)

    def _check_watches(self, watches, old, written, read, c: int, replay: bool) -> list[Hit]:
        m = self.machine
        hits = []
        ctx = self.context()
        for w in watches:
            p = w.place
            core = m.pes[p.pe].cores[p.stage]
            key = (p.kind, core.name, p.index)
            name = p.name(qualify=True)
            rkey = read_key(p, core.name) if p.kind == "mem" else None
            if w.writes and key in written:
                new = written[key]
                text = (f"{self._show(core, p, old[w.number])} -> {self._show(core, p, new)} in "
                        f"cycle {c} ({self._write_origin(core, p, c)})")
            elif w.writes and m.status is not None and ctx.read_word(p) != old[w.number]:
                new = ctx.read_word(p)  # a result in flight written when the run ended
                text = (f"{self._show(core, p, old[w.number])} -> {self._show(core, p, new)} in "
                        f"cycle {c} (a result in flight, written when the run ended)")
            elif w.reads and rkey in read:
                value = self._show(core, p, old[w.number])
                text = f"read {value} in cycle {c} ({'; '.join(_reader(*r) for r in read[rkey])})"
            else:
                continue
            ok = self._passes(w, Context(m, p.pe, p.stage), replay)
            if ok is False:
                continue
            what = f"{WATCH_TYPES[w.kind]} {w.number}"
            if isinstance(ok, str):
                hits.append(Hit(c, p.pe, p.stage, f"{what}: {ok}", w.number))
            else:
                hits.append(Hit(c, p.pe, p.stage, f"{what}: {name}: {text}", w.number))
        return hits

    @staticmethod
    def _show(core, place: Place, word: int) -> str:
        if place.view == "f":
            return str(core.value(word, "f"))
        if place.view in ("x", "u"):
            return f"0x{word & core.mask:x}" if place.view == "x" else str(word & core.mask)
        return short_word(core, word)

    def _write_origin(self, core, place: Place, c: int) -> str:
        if place.kind == "mem":
            pc = core.last_pc
            return f"st at pc {pc} ({core.label(pc)})"
        origin = self.aux[core.name]["origin"].get(place.index)
        if origin is None:
            return "written back"
        pc, issued = origin
        ops = [op for op in core.program.bundles[pc] if place.index in op.writes()]
        what = ops[0].mnemonic if ops else "result"
        return f"{what} at pc {pc} ({core.label(pc)}), issued in cycle {issued}"

    def _retire_temporary(self, hits: list[Hit]) -> None:
        """A tbreak that stopped the run is deleted (gdb: `Disp del`)."""
        for h in hits:
            bp = self.breakpoints.get(h.number)
            if bp is not None and bp.temporary:
                del self.breakpoints[h.number]
