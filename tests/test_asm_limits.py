"""The resource checker at exactly each limit (accepted) and one over (rejected), per processor."""

from __future__ import annotations

import pytest

from netsushisen.asm.assembler import AssemblyError, assemble_text
from netsushisen.isa.processors import PROCESSORS


def _assemble(proc: str, body: str):
    return assemble_text(f".proc {proc}\n{body}\n  halt\n", filename="limits.s")


def _bundle(ops: list[str]) -> str:
    return "  { " + " ; ".join(ops) + " }"


def _rejects(proc: str, body: str, fragment: str) -> None:
    with pytest.raises(AssemblyError) as exc:
        _assemble(proc, body)
    assert fragment in exc.value.format()


# Unit slots: ops that read nothing, so only the unit count binds (li: int, lf: fp).
@pytest.mark.parametrize("proc", ["os", "ic"])
@pytest.mark.parametrize("unit,make", [("int", lambda i: f"li r{i + 1}, {i}"),
                                       ("fp", lambda i: f"lf r{i + 1}, {i}.5")])
def test_unit_slots(proc, unit, make):
    p = PROCESSORS[proc]
    n = p.units[unit]
    writes_ok = n <= p.write_ports
    ops = [make(i) for i in range(n)]
    if writes_ok:
        prog = _assemble(proc, _bundle(ops))
        assert len(prog.bundles[0]) == n
    over = [make(i) for i in range(n + 1)]
    _rejects(proc, _bundle(over), f"slot overflow: {n + 1} {unit} operations")


def test_ic_three_fp_units_at_limit_and_over():
    # IC: 3 FP units, 6 read ports, 3 write ports -> three 2-source FP ops exactly fit.
    ok = ["fadd r1, r10, r11", "fmul r2, r12, r13", "fsub r3, r14, r15"]
    assert len(_assemble("ic", _bundle(ok)).bundles[0]) == 3
    _rejects("ic", _bundle(ok + ["fadd r4, r10, r11"]), "slot overflow: 4 fp")


@pytest.mark.parametrize("proc", ["os", "ic"])
def test_read_ports(proc):
    p = PROCESSORS[proc]
    r = p.read_ports
    # exactly r distinct registers read (shared registers count once), within units and writes
    if proc == "os":  # 2 int + 2 fp units, 5R/2W: a store reads 2, a send reads 1, a branch reads 2
        at = ["st r10, [r11]", "fadd r1, r12, r13", "fsub r2, r12, r14"]  # r10 r11 r12 r13 r14
        over = ["st r10, [r11]", "fadd r1, r12, r13", "fsub r2, r14, r15"]  # 6 distinct
    else:  # IC: 1 int + 3 fp, 6R/3W
        at = ["fadd r1, r10, r11", "fmul r2, r12, r13", "fsub r3, r14, r15"]
        over = ["fadd r1, r10, r11", "fmul r2, r12, r13", "fsel r3, r14, r15, r16"]
    _assemble(proc, _bundle(at))
    _rejects(proc, _bundle(over), f"read-port overflow: the bundle reads {r + 1} distinct registers")


def test_shared_sources_count_once():
    # OS: 4 ops reading the same 2 registers use 2 read ports (and 2 write ports)
    _assemble("os", _bundle(["add r1, r10, r11", "st r10, [r11]", "fadd r2, r10, r11", "fmul r0, r10, r11"]))


@pytest.mark.parametrize("proc", ["os", "ic", "sc"])
def test_write_ports(proc):
    p = PROCESSORS[proc]
    w = p.write_ports
    units = [u for u, n in p.units.items() for _ in range(n)]
    makers = {"int": lambda i: f"li r{i + 1}, {i}", "fp": lambda i: f"lf r{i + 1}, {i}.5",
              "gen": lambda i: f"li r{i + 1}, {i}"}
    ops = [makers[u](i) for i, u in enumerate(units)]
    if proc == "sc":  # sequential, one general unit and one write port: a second write in a
        # bundle is one over the ports (and the unit, and SC's one operation per instruction)
        assert (w, units) == (1, ["gen"])
        ops.append(makers["gen"](1))
    _assemble(proc, _bundle(ops[:w]))
    # one more write than the ports allow, still within the unit counts
    _rejects(proc, _bundle(ops[:w + 1]), f"write-port overflow: the bundle writes {w + 1}")


def test_writes_to_r0_use_no_port():
    _assemble("os", _bundle(["li r0, 1", "li r1, 2", "lf r2, 1.0", "lf r0, 2.0"]))


def test_sc_is_sequential():
    _assemble("sc", "  fadd r1, r2, r3\n  { fmul r4, r5, r6 }")
    _rejects("sc", _bundle(["fadd r1, r2, r3", "fmul r4, r5, r6"]), "one operation per instruction")


def test_one_control_transfer_per_bundle():
    _assemble("os", "l:" + _bundle(["beq r1, r2, l", "add r3, r4, r5"]))
    _rejects("os", "l:" + _bundle(["beq r1, r2, l", "halt"]), "more than one control transfer")


def test_call_writes_the_link_register():
    # call writes lr implicitly: with two other writes OS's two write ports overflow
    _assemble("os", "f:" + _bundle(["call f", "li r1, 1"]))
    _rejects("os", "f:" + _bundle(["call f", "li r1, 1", "lf r2, 1.0"]), "write-port overflow")
