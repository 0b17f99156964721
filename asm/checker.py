"""The resource checker: what one bundle may ask of its processor (README, "Assembly language").

Per bundle: operations per unit class within the unit count, distinct register reads within the
read ports, register writes within the write ports, no register written twice, at most one
control transfer, and on SC one operation per instruction. Everything only knowable at run time
(a source not ready, a busy divider, write ports oversubscribed at completion, a cache miss, an
empty FIFO) is not checked here: the emulator interlocks and counts it as a stall.
"""

from __future__ import annotations

from collections import Counter

from netsushisen.asm.objects import Op
from netsushisen.isa.processors import Processor, register_name


def bundle_usage(proc: Processor, ops: tuple[Op, ...] | list[Op]) -> dict:
    """Units, read ports and write ports one bundle uses (nops use nothing)."""
    real = [op for op in ops if op.opcode.kind != "nop"]
    units = Counter(proc.unit(op.opcode.unit) for op in real)
    reads = sorted({r for op in real for r in op.reads()})
    writes = [r for op in real for r in op.writes()]
    return {"ops": len(real), "units": dict(units), "reads": reads, "writes": writes,
            "control": [op.mnemonic for op in real if op.opcode.is_control]}


def check_bundle(proc: Processor, ops: tuple[Op, ...] | list[Op]) -> list[str]:
    """Every resource rule this bundle breaks, as messages (empty when it fits)."""
    problems: list[str] = []
    u = bundle_usage(proc, ops)
    name = proc.name.upper()
    if not proc.vliw and len(ops) > 1:
        problems.append(f"{name} is sequential: one operation per instruction, this bundle has {len(ops)}")
    for unit, n in sorted(u["units"].items()):
        have = proc.units.get(unit, 0)
        if n > have:
            problems.append(f"slot overflow: {n} {unit} operations in one bundle, "
                            f"{name} has {have} {unit} unit{'s' if have != 1 else ''}")
    if len(u["reads"]) > proc.read_ports:
        regs = ", ".join(register_name(r) for r in u["reads"])
        problems.append(f"read-port overflow: the bundle reads {len(u['reads'])} distinct registers "
                        f"({regs}), {name} has {proc.read_ports} read ports")
    if len(u["writes"]) > proc.write_ports:
        problems.append(f"write-port overflow: the bundle writes {len(u['writes'])} registers, "
                        f"{name} has {proc.write_ports} write ports")
    for reg, n in sorted(Counter(u["writes"]).items()):
        if n > 1:
            problems.append(f"{register_name(reg)} is written by {n} operations of one bundle")
    if len(u["control"]) > 1:
        problems.append("more than one control transfer in one bundle: " + ", ".join(u["control"]))
    return problems
