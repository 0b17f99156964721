"""Hypothesis strategies shared by the test modules (tests/conftest.py puts this folder on the
import path): random programs whose every bundle passes the assembler's resource checker."""

from __future__ import annotations

from hypothesis import strategies as st

from netsushisen.asm.checker import check_bundle
from netsushisen.asm.objects import Op
from netsushisen.isa.opcodes import opcodes_for
from netsushisen.isa.processors import PROCESSORS


def random_bundles(draw, proc: str, n: int, *, regs, imms, floats, offsets, last_label: int,
                   min_ops: int, empty: Op) -> list[tuple[Op, ...]]:
    """n bundles for processor `proc`: each draws min_ops..issue width operations (nop aside)
    and keeps those the resource checker accepts (`empty` stands in for a bundle left with
    none); operands from the given strategies, branch targets 0..last_label."""
    p = PROCESSORS[proc]
    ops_of = [o for o in opcodes_for(proc).values() if o.kind != "nop"]

    def arg(kind: str, opcode):
        if kind in ("rd", "rs"):
            return draw(regs)
        if kind == "imm":
            return draw(imms)
        if kind == "fimm":
            return draw(floats)
        if kind == "mem":
            return (draw(regs), draw(offsets))
        if kind == "label":
            return draw(st.integers(0, last_label))
        ports = p.send_ports if opcode.sends_to_port else p.recv_ports
        return draw(st.sampled_from(ports))

    bundles = []
    for _ in range(n):
        ops: list[Op] = []
        for _ in range(draw(st.integers(min_ops, p.issue_width))):
            oc = draw(st.sampled_from(ops_of))
            op = Op(oc.mnemonic, tuple(arg(o.kind, oc) for o in oc.operands))
            if not check_bundle(p, ops + [op]):
                ops.append(op)
        bundles.append(tuple(ops) or (empty,))
    return bundles
