"""One stage processor (OS, IC or SC), cycle by cycle: the reference timing model.

Everything about an operation — unit class, operands, default latency, pipelining, semantics —
comes from `isa.opcodes.OPCODES` and `isa.processors`; everything numeric about timing comes
from `MachineConfig`. This module is the specification the compiled engine must match.

Timing rules (docs/timing.md has worked examples)
-------------------------------------------------
T1  Issue. At most one bundle (SC: one operation) issues per cycle, in program order.
T2  Operands. All operations of a bundle read their source registers at issue. A result of an
    operation issued in cycle c with latency L is written at the start of cycle c + L and is
    readable by a bundle issuing in c + L or later; a bundle never sees its own results.
    Latency = `config.<proc>.latency[mnemonic]`, else the opcode table's default.
T3  Scoreboard. A bundle does not issue while one of its sources is pending (RAW) or one of its
    destinations is pending (WAW). r0 is never pending and always reads 0; writes to it vanish.
T4  Units. A pipelined unit accepts one operation per cycle. An unpipelined unit (div, rem,
    fdiv, fsqrt, fpow) is busy for the operation's whole latency: issued in c, the unit accepts
    again in c + L. A bundle needs, per unit class, as many units free in its issue cycle as it
    has operations of that class (nop uses no unit). SC's one 'gen' unit runs everything.
T5  Write ports. Register writes that complete in the same cycle may not exceed the processor's
    write ports (OS 2, IC 3, SC 1); a bundle whose writes would oversubscribe some cycle does not
    issue.
T6  Loads block. A load issued in c with access time T (memories.py: local/resident t_r, cache
    hit t_c, miss t_g; OS local: the `ld` latency) holds issue until c + T and its result is
    readable at c + T; the T − 1 held cycles are memory stalls: `local`, `resident`,
    `cache_hit`, `cache_miss`. Stores write local memory at issue, after the bundle's loads
    have read. Two loads in one bundle (OS): the longer access time holds issue.
T7  Control. A branch reads its operands at issue; if taken (and for j, jr, call, ret) the next
    bundle issues in c + 1 + taken_branch_penalty; the penalty cycles are `branch` stalls. If the
    same bundle also holds a load, the held cycles count as the memory cause first, the rest as
    `branch`. `call` writes lr (= next bundle's address) with its latency.
T8  FIFOs. `recv` pops a word that is visible in its receive FIFO (cmu.py: pushed at least the
    FIFO's delay earlier); `send` pushes into a send FIFO with a free slot (counted from the
    occupancy at the start of the cycle). A bundle that needs more words, or more slots, than
    available does not issue. `poll` gives the words visible at issue (before the bundle's own
    pops); `room` the free slots of a send FIFO at issue (before the bundle's own pushes).
    `wait` issues only when some receive FIFO has a visible word (`fifo_empty:any`
    otherwise): a processor that serves two FIFOs sleeps there and counts as idle.
T9  halt stops the processor after its bundle issues. Its `cycles` = halt cycle + 1; a
    processor that never halts counts every cycle of the run. For every processor
    cycles == bundles + sum(stalls).

Stall attribution (T10): a cycle without issue is charged to exactly one cause, the first that
applies in this order:
    1. a hold from an earlier bundle: its memory cause, then `branch`   (charged to that
       bundle's PC)
    2. `operand:<m>`   a source pending; m = mnemonic producing the source that is ready last
    3. `waw:<m>`       a destination pending (first in bundle order)
    4. `unit_busy:<m>` not enough free units of a class; m = the op occupying the first busy one
    5. `write_port`    the bundle's results would oversubscribe the write ports in some cycle
    6. `fifo_empty:<port>` (then `fifo_empty:any` for `wait`), then `fifo_full:<port>`
Causes 2–6 are charged to the PC of the waiting bundle.
"""

from __future__ import annotations

import struct
from collections import Counter

from netsushisen.asm.objects import Op, Program
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.processors import LINK_REGISTER, PROCESSORS, Processor
from netsushisen.isa.stalls import (BRANCH, FIFO_ANY, FIFO_EMPTY, FIFO_FULL, OPERAND, UNIT_BUSY,
                                    WAW, WRITE_PORT, stall)
from netsushisen.isa.words import word_format, wrap32

from netsushisen.emulator.cmu import Fifo
from netsushisen.emulator.memories import MemoryFault, MemorySystem

_OPERAND, _WAW, _UNIT_BUSY, _FIFO_EMPTY, _FIFO_FULL = (stall(f, "") for f in (
    OPERAND, WAW, UNIT_BUSY, FIFO_EMPTY, FIFO_FULL))
"""The causes' prefixes, the parameter appended as each stall is charged (isa/stalls.py)."""


class RunFault(NetsushisenError):
    """A run-time fault: processor, PC (label+offset) and cycle. Exit code 2."""

    exit_code = 2

    def __init__(self, where: str, cycle: int, message: str, pc: int | None = None,
                 label: str | None = None):
        self.where, self.cycle, self.pc, self.label, self.detail = where, cycle, pc, label, message
        shown = "" if pc is None else f" pc {pc}" + ("" if label in (None, str(pc)) else f" ({label})")
        loc = f"{where}{shown} cycle {cycle}"
        super().__init__(Diagnostic(f"run-time fault: {message}", file=loc))


class DOp:
    """An operation decoded once for execution (fields read straight from the opcode table)."""

    __slots__ = ("op", "m", "kind", "unit", "lat", "pipelined", "sem", "args", "rd", "rtype",
                 "base", "offset", "space", "port", "target", "src", "nwrites")

    def __init__(self, op: Op, proc: Processor, config: MachineConfig):
        oc = OPCODES[op.mnemonic]
        core_cfg = getattr(config, proc.name)
        self.op, self.m, self.kind = op, op.mnemonic, oc.kind
        self.unit = None if oc.kind == "nop" else proc.unit(oc.unit)
        self.lat = core_cfg.latency.get(op.mnemonic, oc.latency)
        self.pipelined = oc.pipelined
        self.sem = oc.semantics
        self.rtype = oc.result_type
        self.rd = self.base = self.offset = self.port = self.target = self.src = None
        self.space = oc.space
        args = []  # semantics arguments: ('r', reg, type) or ('k', constant)
        for operand, a in zip(oc.operands, op.args):
            if operand.kind == "rd":
                self.rd = a
            elif operand.kind == "rs":
                args.append(("r", a, operand.type))
                if self.src is None:
                    self.src = a
            elif operand.kind in ("imm", "fimm"):
                args.append(("k", a, ""))
            elif operand.kind == "mem":
                self.base, self.offset = a
            elif operand.kind == "label":
                self.target = a
            elif operand.kind == "port":
                self.port = a
        self.args = tuple(args)
        self.nwrites = len(op.writes())


class DBundle:
    """A bundle decoded once: its ops and what the issue checks need."""

    __slots__ = ("ops", "reads", "writes", "units", "loads", "recvs", "sends", "writers",
                 "text", "n_ops", "alu", "waits")

    def __init__(self, ops: tuple[Op, ...], proc: Processor, config: MachineConfig):
        self.ops = [DOp(op, proc, config) for op in ops]
        self.reads = tuple(sorted({r for op in ops for r in op.reads()}))
        self.writes = tuple(r for op in ops for r in op.writes())
        self.units = tuple(Counter(d.unit for d in self.ops if d.unit).items())
        self.loads = [d for d in self.ops if d.kind == "load"]
        self.recvs = tuple(Counter(d.port for d in self.ops if d.kind == "recv").items())
        self.sends = tuple(Counter(d.port for d in self.ops if d.kind == "send").items())
        self.waits = any(d.kind == "wait" for d in self.ops)
        self.writers = [d for d in self.ops if d.nwrites]
        self.n_ops = sum(1 for d in self.ops if d.kind != "nop")
        self.text = " ; ".join(op.format() for op in ops) or "(empty)"


def validate_program(program: Program) -> None:
    """Reject a program this processor cannot run (a hand-edited or foreign object file): every
    bundle must pass the assembler's resource checker, use only this processor's opcodes and
    ports, and branch inside the program."""
    from netsushisen.asm.checker import check_bundle

    proc = program.processor
    problems: list[Diagnostic] = []
    n = len(program.bundles)
    for i, bundle in enumerate(program.bundles):
        found = list(check_bundle(proc, bundle))
        for op in bundle:
            oc = OPCODES[op.mnemonic]
            if proc.name not in oc.procs:
                found.append(f"{proc.name.upper()} has no {op.mnemonic!r} instruction")
            for operand, a in zip(oc.operands, op.args):
                if operand.kind == "port":
                    ports = proc.send_ports if oc.sends_to_port else proc.recv_ports
                    if a not in ports:
                        found.append(f"{op.mnemonic}: {proc.name.upper()} has no port {a!r}")
                elif operand.kind == "label" and not 0 <= a < n:
                    found.append(f"{op.mnemonic}: target {a} is outside the program (0..{n - 1})")
                elif operand.kind in ("rd", "rs") and not 0 <= a < proc.registers:
                    found.append(f"{op.mnemonic}: no register r{a}")
        loc = program.source_map[i] if i < len(program.source_map) else None
        for msg in found:
            problems.append(Diagnostic(f"bundle {i}: {msg}", file=loc.file if loc else None,
                                       line=loc.line if loc else None))
    if problems:
        raise NetsushisenError(problems)


class Core:
    """Registers, scoreboard, units and counters of one processor; `step(c)` runs cycle c."""

    def __init__(self, name: str, proc: str, program: Program | None, config: MachineConfig,
                 memory: MemorySystem, recv_ports: dict[str, Fifo], send_ports: dict[str, Fifo]):
        self.name = name  # e.g. "pe0.ic"
        self.proc: Processor = PROCESSORS[proc]
        self.program = program
        self.present = program is not None
        if program is not None:
            validate_program(program)
        self.bundles = [DBundle(b, self.proc, config) for b in program.bundles] if program else []
        self.memory = memory
        self.recv_ports, self.send_ports = recv_ports, send_ports
        self.penalty = getattr(config, proc).taken_branch_penalty
        self.write_ports = self.proc.write_ports
        wf = word_format(config.precision)
        self.F = wf.float_type
        self.mask = wf.mask
        self._fp32 = config.precision == "fp32"
        self._unpack_f = struct.Struct("<f" if self._fp32 else "<d").unpack
        self._pack_w = struct.Struct("<I" if self._fp32 else "<Q").pack
        self._pack_f = struct.Struct("<f" if self._fp32 else "<d").pack
        self._unpack_w = struct.Struct("<I" if self._fp32 else "<Q").unpack
        self.events: list | None = None  # set to a list to record per-cycle events
        self.reset()

    # -- state ---------------------------------------------------------------------------------

    def reset(self) -> None:
        n = self.proc.registers
        self.regs = [0] * n
        self.ready_at = [0] * n
        self.producer = [""] * n
        self.pending: dict[int, list[tuple[int, int]]] = {}  # cycle -> [(reg, word)]
        self.busy = {u: [0] * k for u, k in self.proc.units.items()}  # unit -> busy-until cycles
        self.occupant = {u: [""] * k for u, k in self.proc.units.items()}
        self.pc = 0
        self.halted = not self.present
        self.hold_until = 0
        self.hold_mem_until = 0
        self.hold_cause = ""
        self.hold_pc = 0
        self.cycles = 0
        self.bundles_issued = 0
        self.ops = 0
        self.ops_by_unit: dict[str, int] = {}
        self.ops_by_mnemonic: dict[str, int] = {}
        self.stalls: dict[str, int] = {}
        self.stalls_by_pc: dict[int, dict[str, int]] = {}
        self.bundles_by_pc: dict[int, int] = {}  # issue counts: with stalls_by_pc, cycles per PC
        # what the last cycle did (trace, debugger, deadlock detector)
        self.last_pc = 0
        self.last_issued = False
        self.cause = "halted" if self.halted else ""

    # -- word <-> value ------------------------------------------------------------------------

    def value(self, word: int, t: str):
        if t == "f":
            return self.F(self._unpack_f(self._pack_w(word))[0])
        if t == "i":
            return wrap32(word)
        return word

    def word(self, v, t: str) -> int:
        if t == "f":
            return self._unpack_w(self._pack_f(v))[0]
        if t == "i":
            return wrap32(int(v)) & self.mask
        return int(v) & self.mask

    def label(self, pc: int) -> str:
        return self.program.label_at(pc) if self.program is not None else str(pc)

    def where(self, pc: int) -> str:
        """'pc 12 (loop+3)', or 'pc 12' where no label precedes it."""
        label = self.label(pc)
        return f"pc {pc}" if label == str(pc) else f"pc {pc} ({label})"

    def pc_fault(self, c: int) -> RunFault:
        """The fault of a PC outside the program (every engine reports it with these words)."""
        return self.fault(c, f"pc {self.pc} is outside the program (0..{len(self.bundles) - 1})")

    def fault(self, c: int, message: str, pc: int | None = None) -> RunFault:
        pc = self.pc if pc is None else pc
        return RunFault(self.name, c, message, pc, self.label(pc))

    # -- one cycle -----------------------------------------------------------------------------

    def _stall(self, cause: str, pc: int) -> None:
        self.stalls[cause] = self.stalls.get(cause, 0) + 1
        by = self.stalls_by_pc.get(pc)
        if by is None:
            by = self.stalls_by_pc[pc] = {}
        by[cause] = by.get(cause, 0) + 1
        self.cause = cause
        self.last_pc = pc

    def step(self, c: int) -> None:
        """Run cycle c: write back results due now, then issue the bundle at PC or stall."""
        done = self.pending.pop(c, None)
        if done is not None:
            regs = self.regs
            for r, w in done:
                regs[r] = w
            if self.events is not None:
                self.events.extend(("reg", self.name, r, w) for r, w in done)
        self.last_issued = False
        if self.halted:
            return
        self.cycles += 1
        if c < self.hold_until:
            self._stall(self.hold_cause if c < self.hold_mem_until else BRANCH, self.hold_pc)
            return
        pc = self.pc
        if not 0 <= pc < len(self.bundles):
            raise self.pc_fault(c)
        b = self.bundles[pc]
        ready_at = self.ready_at

        # 2. operands (RAW): charge the source that is ready last
        worst = -1
        worst_t = c
        for r in b.reads:
            if ready_at[r] > worst_t:
                worst, worst_t = r, ready_at[r]
        if worst >= 0:
            return self._stall(_OPERAND + self.producer[worst], pc)
        # 3. destinations (WAW)
        for r in b.writes:
            if ready_at[r] > c:
                return self._stall(_WAW + self.producer[r], pc)
        # 4. units
        for unit, n in b.units:
            busy = self.busy[unit]
            free = 0
            for t in busy:
                if t <= c:
                    free += 1
            if free < n:
                first = next(i for i, t in enumerate(busy) if t > c)
                return self._stall(_UNIT_BUSY + self.occupant[unit][first], pc)
        # load timing (the base register is ready: checked above)
        load_t = None
        if b.loads:
            load_t = {}
            for d in b.loads:
                addr = wrap32(self.regs[d.base]) + d.offset
                load_t[id(d)] = (addr,) + self.memory.access_time(d.space, addr)
        # 5. write ports
        if b.writers:
            due: dict[int, int] = {}
            for d in b.writers:
                t = c + (load_t[id(d)][1] if d.kind == "load" else d.lat)
                due[t] = due.get(t, 0) + d.nwrites
            for t, n in due.items():
                if len(self.pending.get(t, ())) + n > self.write_ports:
                    return self._stall(WRITE_PORT, pc)
        # 6. FIFOs
        for port, n in b.recvs:
            f = self.recv_ports[port]
            if (f.visible(c) if n > 1 else int(f.ready(c))) < n:
                return self._stall(_FIFO_EMPTY + port, pc)
        if b.waits and not any(f.ready(c) for f in self.recv_ports.values()):
            return self._stall(FIFO_ANY, pc)
        for port, n in b.sends:
            if self.send_ports[port].free(c) < n:
                return self._stall(_FIFO_FULL + port, pc)
        self._issue(c, pc, b, load_t)

    def _schedule(self, rd: int | None, word: int, t: int, m: str) -> None:
        if not rd:  # None or r0
            return
        self.pending.setdefault(t, []).append((rd, word))
        self.ready_at[rd] = t
        self.producer[rd] = m

    def _issue(self, c: int, pc: int, b: DBundle, load_t: dict | None) -> None:
        regs = self.regs
        F = self.F
        next_pc = pc + 1
        taken = False
        hold_mem = c + 1
        mem_cause = ""
        late = []  # FIFO operations and stores: after every op has read its operands
        for d in b.ops:
            kind = d.kind
            if kind == "alu":
                vals = [self.value(regs[a], t) if k == "r" else a for k, a, t in d.args]
                self._schedule(d.rd, self.word(d.sem(F, *vals), d.rtype), c + d.lat, d.m)
            elif kind == "load":
                addr, t_acc, cause = load_t[id(d)]
                try:
                    w, cache_set = self.memory.load(d.space, addr)
                except MemoryFault as err:
                    raise self.fault(c, str(err), pc) from None
                if self.events is not None:
                    self.events.append(("load", self.name, d.space, addr, cache_set))
                self._schedule(d.rd, w, c + t_acc, d.m)
                if c + t_acc > hold_mem:
                    hold_mem, mem_cause = c + t_acc, cause
            elif kind == "branch":
                vals = [self.value(regs[a], t) for k, a, t in d.args]
                if d.sem(F, *vals):
                    next_pc, taken = d.target, True
            elif kind == "jump":
                next_pc, taken = d.target, True
            elif kind == "jumpr":
                next_pc, taken = wrap32(regs[d.src]), True
            elif kind == "call":
                self._schedule(LINK_REGISTER, self.word(pc + 1, "i"), c + d.lat, d.m)
                next_pc, taken = d.target, True
            elif kind == "ret":
                next_pc, taken = wrap32(regs[LINK_REGISTER]), True
            elif kind == "poll":
                n = self.recv_ports[d.port].visible(c)
                self._schedule(d.rd, self.word(n, "i"), c + d.lat, d.m)
            elif kind == "room":
                n = self.send_ports[d.port].free(c)
                self._schedule(d.rd, self.word(n, "i"), c + d.lat, d.m)
            elif kind == "halt":
                self.halted = True
            elif kind not in ("nop", "wait"):
                late.append(d)
        for d in late:
            if d.kind == "recv":
                self._schedule(d.rd, self.recv_ports[d.port].pop(c), c + d.lat, d.m)
            elif d.kind == "send":
                self.send_ports[d.port].push(c, regs[d.src])
            else:  # store
                addr = wrap32(regs[d.base]) + d.offset
                try:
                    self.memory.store(addr, regs[d.src])
                except MemoryFault as err:
                    raise self.fault(c, str(err), pc) from None
                if self.events is not None:
                    self.events.append(("store", self.name, "local", addr, regs[d.src]))
        for d in b.ops:  # occupy unpipelined units for their whole latency
            if not d.pipelined:
                busy = self.busy[d.unit]
                i = next(i for i, t in enumerate(busy) if t <= c)
                busy[i] = c + d.lat
                self.occupant[d.unit][i] = d.m
        # counters
        self.bundles_issued += 1
        self.bundles_by_pc[pc] = self.bundles_by_pc.get(pc, 0) + 1
        self.ops += b.n_ops
        for d in b.ops:
            if d.unit:
                self.ops_by_unit[d.unit] = self.ops_by_unit.get(d.unit, 0) + 1
                self.ops_by_mnemonic[d.m] = self.ops_by_mnemonic.get(d.m, 0) + 1
        self.last_issued = True
        self.last_pc = pc
        self.cause = "halted" if self.halted else ""
        self.pc = next_pc
        if taken or hold_mem > c + 1:
            self.hold_until = max(hold_mem, c + 1 + self.penalty if taken else 0)
            self.hold_mem_until = hold_mem
            self.hold_cause = mem_cause
            self.hold_pc = pc

    def drain(self) -> None:
        """Write every result still in flight (the run has ended; makes the final state whole)."""
        for t in sorted(self.pending):
            for r, w in self.pending[t]:
                self.regs[r] = w
        self.pending.clear()

    # -- views ---------------------------------------------------------------------------------

    def waiting_on_fifo(self) -> str | None:
        """The FIFO cause this processor stalled on in its last cycle, if any."""
        if not self.halted and not self.last_issued \
                and self.cause.startswith((_FIFO_EMPTY, _FIFO_FULL)):
            return self.cause
        return None

    def idle(self) -> bool:
        """Halted (or absent), or waiting on an empty receive FIFO."""
        return self.halted or (not self.last_issued and self.cause.startswith(FIFO_EMPTY))

    def stats(self) -> dict:
        by_pc = {}
        for pc, causes in sorted(self.stalls_by_pc.items()):
            by_pc[str(pc)] = {"label": self.label(pc), "stalls": dict(sorted(causes.items()))}
        return {
            "present": self.present,
            "halted": self.halted and self.present,
            "pc": self.pc,
            "cycles": self.cycles,
            "bundles": self.bundles_issued,
            "ops": self.ops,
            "ops_by_unit": dict(sorted(self.ops_by_unit.items())),
            "ops_by_mnemonic": dict(sorted(self.ops_by_mnemonic.items())),
            "stalls": dict(sorted(self.stalls.items())),
            "stall_cycles": sum(self.stalls.values()),
            "stalls_by_pc": by_pc,
            "bundles_by_pc": {str(pc): n for pc, n in sorted(self.bundles_by_pc.items())},
        }
