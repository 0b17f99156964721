"""The opcode table: every instruction's facts, once (after Spike / riscv-opcodes).

The assembler, resource checker, disassembler, both emulator engines and the generated ISA
reference all read `OPCODES`; no mnemonic list is typed anywhere else.

Each row gives: mnemonic; unit class ('int' or 'fp'; SC runs both on its one general unit);
operands; default latency in cycles (a config can override it per processor); whether the unit
is pipelined (an unpipelined unit stays busy for the whole latency); the processors that have
it; the kind of effect; and, for computing operations, `semantics(F, *sources)` where F is the
float type of the machine's precision (numpy float32 or float64).

Operand spec tokens are `kind:type`:
    rd   destination register        rs   source register
    imm  integer expression          fimm float expression
    mem  memory operand [rs + imm]   label code address      port FIFO name
and types i = 32-bit integer, f = float of the machine's precision, w = raw word (moves).

Corner cases, pinned here once for every engine and the golden model:
- Integers are 32-bit two's complement and wrap around; shift amounts use their low 5 bits.
- div/rem truncate toward zero; x/0 = -1 and x%0 = x; INT_MIN/-1 = INT_MIN and INT_MIN%-1 = 0
  (RISC-V's choices: no trap, a defined result).
- FP follows IEEE 754 with round-to-nearest-even, no fused operations, no flush-to-zero:
  x/0 = ±inf, 0/0 = NaN, sqrt(x<0) = NaN, sqrt(-0) = -0, pow as C powf/pow.
- fmin/fmax return NaN if either operand is NaN; fmin(-0,+0) = -0, fmax(-0,+0) = +0.
- flt/fle/feq are ordered: any NaN operand gives 0.
- ftoi truncates, floor rounds toward -inf; both saturate to [INT_MIN, INT_MAX]; NaN gives 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from netsushisen.isa.jit import jitable

from netsushisen.isa.libm import machine_pow
from netsushisen.isa.words import INT_MAX, INT_MIN, wrap32

# ---------------------------------------------------------------------------------------------
# Semantics with corner cases (the only place they are decided)
#
# Every semantics is a plain function `semantics(F, *sources)` of values (integers as Python or
# machine ints, floats as scalars of type F) written so that numba compiles it unchanged: the
# reference engine calls these functions, the compiled engine compiles the very same ones (no
# opcode is typed twice). Helpers they call are `jitable` (isa/jit.py: numba's `register_jitable`,
# registered when the compiled engine is imported): plain Python functions numba can also
# compile. Corner cases are written out: no semantics depends on numpy's error state or on Python
# exceptions. Floating-point arithmetic is the hardware's IEEE 754
# (its overflow to ±inf and its default NaN for invalid operations); pow is the machine's own
# (`machine_pow`, isa/libm.py: basic operations in a fixed order, the same bits on every CPU).


@jitable
def _div(a: int, b: int) -> int:
    if b == 0:
        return -1
    if a == INT_MIN and b == -1:
        return INT_MIN
    q = abs(a) // abs(b)
    return q if (a < 0) == (b < 0) else -q


@jitable
def _rem(a: int, b: int) -> int:
    if b == 0:
        return a
    if a == INT_MIN and b == -1:
        return 0
    return a - _div(a, b) * b


@jitable
def _srl(a: int, b: int) -> int:
    return wrap32((a & 0xFFFFFFFF) >> (b & 31))


@jitable
def _sra(a: int, b: int) -> int:
    return a >> (b & 31)


@jitable
def _fmin(F, a, b):
    if a != a or b != b:
        return F(np.nan)
    if a < b:
        return a
    if b < a:
        return b
    return a if math.copysign(1.0, float(a)) < 0 else b  # equal: -0 wins


@jitable
def _fmax(F, a, b):
    if a != a or b != b:
        return F(np.nan)
    if a > b:
        return a
    if b > a:
        return b
    return b if math.copysign(1.0, float(a)) < 0 else a  # equal: +0 wins


@jitable
def _to_int(x, down: bool) -> int:
    """Truncate toward zero (ftoi) or round toward -inf (floor, `down`); saturate to
    [INT_MIN, INT_MAX]; NaN gives 0."""
    x = float(x)
    if x != x:
        return 0
    if x >= 2147483647.0:
        return INT_MAX
    if x <= -2147483648.0:
        return INT_MIN
    return int(math.floor(x)) if down else int(math.trunc(x))


@jitable
def _fdiv(F, a, b):
    # x/±0 is ±inf by the signs of both, 0/0 and NaN/0 the hardware's default NaN: all of it
    # is what IEEE 754 division gives, so the division itself decides (no trap, no exception).
    return F(a / b)


@jitable
def _fsqrt(F, a):
    # sqrt(-0) = -0; sqrt(x < 0) = the default NaN; both are IEEE 754's square root.
    return F(np.sqrt(a))


def _fpow(F, a, b):
    return F(machine_pow(a, b))


# ---------------------------------------------------------------------------------------------
# The table


@dataclass(frozen=True)
class Operand:
    kind: str  # rd, rs, imm, fimm, mem, label, port
    type: str  # i, f, w, or '' where no value type applies


@dataclass(frozen=True)
class Opcode:
    mnemonic: str
    unit: str
    operands: tuple[Operand, ...]
    latency: int
    pipelined: bool
    procs: frozenset[str]
    kind: str
    """alu, load, store, branch, jump, jumpr, call, ret, send, recv, poll, room, wait, halt, nop"""
    semantics: Callable | None
    doc: str
    space: str | None = None
    """Memory space of a load/store: local, resident or global (through the cache)."""
    implicit_reads: tuple[int, ...] = ()
    implicit_writes: tuple[int, ...] = ()
    result_type: str = ""
    source_types: tuple[str, ...] = field(default=())

    @property
    def is_control(self) -> bool:
        """Transfers control: at most one per bundle."""
        return self.kind in ("branch", "jump", "jumpr", "call", "ret", "halt")

    @property
    def sends_to_port(self) -> bool:
        """Its FIFO operand names a send FIFO (send, room), not a receive FIFO (recv, poll)."""
        return self.kind in ("send", "room")

    @property
    def syntax(self) -> str:
        shown = []
        for o in self.operands:
            shown.append({"rd": "rd", "rs": "rs", "imm": "imm", "fimm": "fimm",
                          "mem": "[rs+imm]", "label": "label", "port": "port"}[o.kind])
        return f"{self.mnemonic} {', '.join(shown)}".strip()


OPCODES: dict[str, Opcode] = {}

ALL = frozenset({"os", "ic", "sc"})
IC_SC = frozenset({"ic", "sc"})


def _op(mnemonic: str, unit: str, operands: str, latency: int, doc: str, *,
        sem: Callable | None = None, kind: str = "alu", pipelined: bool = True,
        procs: frozenset[str] = ALL, space: str | None = None,
        implicit_reads: tuple[int, ...] = (), implicit_writes: tuple[int, ...] = ()) -> None:
    ops = tuple(Operand(*(tok.split(":") + [""])[:2]) for tok in operands.split())
    result = next((o.type for o in ops if o.kind == "rd"), "")
    sources = tuple(o.type for o in ops if o.kind == "rs")
    assert mnemonic not in OPCODES, mnemonic
    OPCODES[mnemonic] = Opcode(mnemonic, unit, ops, latency, pipelined, procs, kind, sem, doc,
                               space, implicit_reads, implicit_writes, result, sources)


I3 = "rd:i rs:i rs:i"
II = "rd:i rs:i imm:i"
F3 = "rd:f rs:f rs:f"

# Integer ALU
_op("add", "int", I3, 1, "rd = rs1 + rs2", sem=lambda F, a, b: wrap32(a + b))
_op("sub", "int", I3, 1, "rd = rs1 - rs2", sem=lambda F, a, b: wrap32(a - b))
_op("mul", "int", I3, 3, "rd = low 32 bits of rs1 * rs2", sem=lambda F, a, b: wrap32(a * b))
_op("div", "int", I3, 12, "rd = rs1 / rs2, truncating; x/0 = -1", sem=lambda F, a, b: _div(a, b),
    pipelined=False)
_op("rem", "int", I3, 12, "rd = rs1 % rs2 (sign of rs1); x%0 = x", sem=lambda F, a, b: _rem(a, b),
    pipelined=False)
_op("and", "int", I3, 1, "rd = rs1 & rs2", sem=lambda F, a, b: a & b)
_op("or", "int", I3, 1, "rd = rs1 | rs2", sem=lambda F, a, b: a | b)
_op("xor", "int", I3, 1, "rd = rs1 ^ rs2", sem=lambda F, a, b: a ^ b)
_op("sll", "int", I3, 1, "rd = rs1 << (rs2 & 31)", sem=lambda F, a, b: wrap32(a << (b & 31)))
_op("srl", "int", I3, 1, "rd = rs1 >> (rs2 & 31), logical", sem=lambda F, a, b: _srl(a, b))
_op("sra", "int", I3, 1, "rd = rs1 >> (rs2 & 31), arithmetic", sem=lambda F, a, b: _sra(a, b))
_op("slt", "int", I3, 1, "rd = 1 if rs1 < rs2 (signed) else 0", sem=lambda F, a, b: int(a < b))
_op("sltu", "int", I3, 1, "rd = 1 if rs1 < rs2 (unsigned) else 0",
    sem=lambda F, a, b: int((a & 0xFFFFFFFF) < (b & 0xFFFFFFFF)))
_op("seq", "int", I3, 1, "rd = 1 if rs1 == rs2 else 0", sem=lambda F, a, b: int(a == b))
_op("sne", "int", I3, 1, "rd = 1 if rs1 != rs2 else 0", sem=lambda F, a, b: int(a != b))
_op("addi", "int", II, 1, "rd = rs + imm", sem=lambda F, a, b: wrap32(a + b))
_op("andi", "int", II, 1, "rd = rs & imm", sem=lambda F, a, b: a & b)
_op("ori", "int", II, 1, "rd = rs | imm", sem=lambda F, a, b: a | b)
_op("xori", "int", II, 1, "rd = rs ^ imm", sem=lambda F, a, b: a ^ b)
_op("slli", "int", II, 1, "rd = rs << (imm & 31)", sem=lambda F, a, b: wrap32(a << (b & 31)))
_op("srli", "int", II, 1, "rd = rs >> (imm & 31), logical", sem=lambda F, a, b: _srl(a, b))
_op("srai", "int", II, 1, "rd = rs >> (imm & 31), arithmetic", sem=lambda F, a, b: _sra(a, b))
_op("slti", "int", II, 1, "rd = 1 if rs < imm (signed) else 0", sem=lambda F, a, b: int(a < b))
_op("li", "int", "rd:i imm:i", 1, "rd = imm (any 32-bit value)", sem=lambda F, a: a)
_op("mov", "int", "rd:w rs:w", 1, "rd = rs (raw word)", sem=lambda F, a: a)
_op("sel", "int", "rd:w rs:i rs:w rs:w", 1, "rd = rs2 if rs1 != 0 else rs3 (raw words)",
    sem=lambda F, c, a, b: a if c != 0 else b)

# FP arithmetic (IEEE, round to nearest even, never fused)
_op("fadd", "fp", F3, 2, "rd = rs1 + rs2", sem=lambda F, a, b: F(a + b))
_op("fsub", "fp", F3, 2, "rd = rs1 - rs2", sem=lambda F, a, b: F(a - b))
_op("fmul", "fp", F3, 3, "rd = rs1 * rs2", sem=lambda F, a, b: F(a * b))
_op("fdiv", "fp", F3, 12, "rd = rs1 / rs2 (x/0 = ±inf, 0/0 = NaN)", sem=_fdiv, pipelined=False)
_op("fsqrt", "fp", "rd:f rs:f", 15, "rd = sqrt(rs) (negative: NaN)", sem=_fsqrt, pipelined=False)
_op("fpow", "fp", F3, 30, "rd = rs1 ** rs2 (isa/libm.py: C99 special cases, same bits everywhere; Phong highlights)", sem=_fpow, pipelined=False,
    procs=frozenset({"sc"}))
_op("fabs", "fp", "rd:f rs:f", 1, "rd = |rs| (clears the sign bit)", sem=lambda F, a: F(abs(a)))
_op("fneg", "fp", "rd:f rs:f", 1, "rd = -rs (flips the sign bit)", sem=lambda F, a: F(-a))
_op("fmin", "fp", F3, 1, "rd = min(rs1, rs2); NaN if either is NaN; -0 < +0", sem=_fmin)
_op("fmax", "fp", F3, 1, "rd = max(rs1, rs2); NaN if either is NaN; -0 < +0", sem=_fmax)
_op("fmov", "fp", "rd:w rs:w", 1, "rd = rs (raw word, on an FP unit)", sem=lambda F, a: a)
_op("lf", "fp", "rd:f fimm:f", 1, "rd = fimm rounded to the machine's precision",
    sem=lambda F, a: F(a))
_op("fsel", "fp", "rd:w rs:i rs:w rs:w", 1, "rd = rs2 if rs1 != 0 else rs3 (on an FP unit)",
    sem=lambda F, c, a, b: a if c != 0 else b)
_op("flt", "fp", "rd:i rs:f rs:f", 1, "rd = 1 if rs1 < rs2 else 0 (NaN: 0)",
    sem=lambda F, a, b: int(bool(a < b)))
_op("fle", "fp", "rd:i rs:f rs:f", 1, "rd = 1 if rs1 <= rs2 else 0 (NaN: 0)",
    sem=lambda F, a, b: int(bool(a <= b)))
_op("feq", "fp", "rd:i rs:f rs:f", 1, "rd = 1 if rs1 == rs2 else 0 (NaN: 0; -0 == +0)",
    sem=lambda F, a, b: int(bool(a == b)))
_op("itof", "fp", "rd:f rs:i", 2, "rd = float(rs), rounded to nearest", sem=lambda F, a: F(a))
_op("ftoi", "fp", "rd:i rs:f", 2, "rd = int(rs) truncated; saturating; NaN: 0",
    sem=lambda F, a: _to_int(a, False))
_op("floor", "fp", "rd:i rs:f", 2, "rd = floor(rs) as an integer; saturating; NaN: 0",
    sem=lambda F, a: _to_int(a, True))

# Memory: word addresses, base register + immediate offset
_op("ld", "int", "rd:w mem:i", 1, "rd = local[rs + imm]", kind="load", space="local")
_op("st", "int", "rs:w mem:i", 1, "local[rs + imm] = rs1", kind="store", space="local")
_op("ldr", "int", "rd:w mem:i", 1, "rd = resident[rs + imm] (read-only; the host writes it)",
    kind="load", space="resident", procs=IC_SC)
_op("ldg", "int", "rd:w mem:i", 1, "rd = global[rs + imm] through the direct-mapped cache",
    kind="load", space="global", procs=IC_SC)

# Communication: the CMU's FIFOs, one word per operation
_op("send", "int", "port: rs:w", 1, "push rs into the send FIFO `port` (stalls while full)",
    kind="send")
_op("recv", "int", "rd:w port:", 1, "pop a word of receive FIFO `port` into rd (stalls while empty)",
    kind="recv")
_op("poll", "int", "rd:i port:", 1, "rd = number of words waiting in receive FIFO `port`",
    kind="poll")
_op("room", "int", "rd:i port:", 1, "rd = number of free words in send FIFO `port` (so a "
    "processor can send a whole message without blocking)", kind="room")
_op("wait", "int", "", 1, "stall until some receive FIFO of this processor holds a word "
    "(so a processor serving two FIFOs sleeps instead of spinning on poll)", kind="wait")

# Control (at most one per bundle; the integer unit)
for _m, _doc, _sem in (
    ("beq", "branch if rs1 == rs2", lambda F, a, b: a == b),
    ("bne", "branch if rs1 != rs2", lambda F, a, b: a != b),
    ("blt", "branch if rs1 < rs2 (signed)", lambda F, a, b: a < b),
    ("bge", "branch if rs1 >= rs2 (signed)", lambda F, a, b: a >= b),
    ("bltu", "branch if rs1 < rs2 (unsigned)", lambda F, a, b: (a & 0xFFFFFFFF) < (b & 0xFFFFFFFF)),
    ("bgeu", "branch if rs1 >= rs2 (unsigned)", lambda F, a, b: (a & 0xFFFFFFFF) >= (b & 0xFFFFFFFF)),
):
    _op(_m, "int", "rs:i rs:i label:", 1, _doc, sem=_sem, kind="branch")
_op("beqz", "int", "rs:i label:", 1, "branch if rs == 0", sem=lambda F, a: a == 0, kind="branch")
_op("bnez", "int", "rs:i label:", 1, "branch if rs != 0", sem=lambda F, a: a != 0, kind="branch")
_op("j", "int", "label:", 1, "jump to label", kind="jump")
_op("jr", "int", "rs:i", 1, "jump to the address in rs", kind="jumpr")
_op("call", "int", "label:", 1, "lr = address of the next bundle; jump to label", kind="call",
    implicit_writes=(63,))
_op("ret", "int", "", 1, "jump to lr", kind="ret", implicit_reads=(63,))
_op("halt", "int", "", 1, "stop this processor", kind="halt")
_op("nop", "int", "", 1, "no operation (occupies no unit)", kind="nop")

del _m, _doc, _sem


def opcodes_for(proc: str) -> dict[str, Opcode]:
    return {m: o for m, o in OPCODES.items() if proc in o.procs}
