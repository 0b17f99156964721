"""Symbolic registers (issue 40, item 1): `.vreg` names in `.sched` regions get registers from
the region's pool (asm/allocation.py); linear assembly written with them alone runs on both
engines and gives the serial (`--no-schedule`) result, and a pool too small is one located
error, exit 1."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

import netsushisen as nss
from netsushisen.asm.assembler import Assembler, AssemblyError

PROGRAMS = Path(__file__).resolve().parent / "programs"


def _run(source: Path, schedule: bool, engine: str, regs: tuple[int, ...]) -> tuple[list[int], int]:
    program = Assembler("ic", schedule=schedule).assemble_file(source)
    result = nss.run({"ic": program}, engine=engine)
    assert result.status == "halted"
    eng = result.extra["engine"]
    return [eng.register("pe0.ic", r) & 0xFFFFFFFF for r in regs], len(program.bundles)


def _word(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", np.float32(x)))[0]


@pytest.mark.parametrize("pipelined", [False, True])
def test_a_dot_product_in_vreg_names(pipelined, engine_name, tmp_path):
    source = PROGRAMS / "vreg_dot.s"
    if pipelined:  # software-pipelined: its copies in the pool's registers the names left
        source = tmp_path / "dot.s"
        source.write_text((PROGRAMS / "vreg_dot.s").read_text().replace("loop:", ".pipeline\nloop:"))
    (got,), scheduled = _run(source, True, engine_name, (5,))
    (serial,), n_serial = _run(source, False, engine_name, (5,))
    xs = np.float32([1, 2, 3, 4, 5, 6, 7, 8])
    ys = np.float32([0.5, -1, 2, 0.25, 1.5, -2, 3, 1])
    want = np.float32(0)
    for x, y in zip(xs, ys):
        want = np.float32(want + np.float32(x * y))
    assert got == serial == _word(want)
    assert scheduled != n_serial  # the regions were scheduled, not left as written


def test_a_sphere_test_in_vreg_names(engine_name):
    got, _ = _run(PROGRAMS / "vreg_sphere.s", True, engine_name, (5, 6))
    serial, _ = _run(PROGRAMS / "vreg_sphere.s", False, engine_name, (5, 6))
    f = np.float32
    o, d, c, r2 = f([0.25, -1.5, 0.5]), f([0.6, 0.0, 0.8]), f([1.0, 0.5, 2.0]), f(2.25)
    oc = o - c
    b = f(f(oc[0] * d[0]) + f(oc[1] * d[1])) + f(oc[2] * d[2])
    q = oc - b * d
    qq = f(f(q[0] * q[0]) + f(q[1] * q[1])) + f(q[2] * q[2])
    assert got == serial == [_word(r2 - qq), _word(b)]


def test_the_names_get_registers_from_the_pool_and_show_in_the_name_table():
    program = Assembler("ic").assemble_file(PROGRAMS / "vreg_sphere.s")
    names = {r.name: r.reg for r in program.reg_names}
    assert names["disc"] == 5 and names["bout"] == 6  # pinned
    assert all(40 <= names[n] <= 59 for n in ("ox", "cx", "b", "qq"))
    from netsushisen.asm.regnames import register_names

    table = register_names(program)
    pc = next(pc for pc, b in enumerate(program.bundles) if any(op.mnemonic == "fsub" for op in b))
    assert any(n in table.names(pc).values() for n in ("ocx", "ocy", "ocz", "disc"))


def test_a_pool_two_registers_too_small_is_one_located_error(cli, tmp_path):
    """The sphere test needs 10 registers (the ray, the centre, r2 live at `ld rr`)."""
    src = tmp_path / "sph.s"
    src.write_text((PROGRAMS / "vreg_sphere.s").read_text().replace(".temps r40-r59", ".temps r40-r47"))
    code, out, err = cli("asm", str(src), "-o", str(tmp_path / "s.o"))
    assert code == 1
    lines = [ln for ln in err.splitlines() if ": error: " in ln]
    assert lines == [f"{src}:20:9: error: 9 values live at ld cz (pool .temps r40-r47 has 8): "
                     "cx cy cz dx dy dz ox oy oz"]
    enough = src.read_text().replace(".temps r40-r47", ".temps r40-r49")
    src.write_text(enough)
    assert cli("asm", str(src), "-o", str(tmp_path / "s.o"))[0] == 0


@pytest.mark.parametrize("text,says", [
    (".sched\n.temps r40-r45\n.vreg a\n  fadd r1, a, a\n  halt\n.endsched\n",
     ".vreg a is read before it is written"),
    (".vreg a\n  halt\n", ".vreg outside a .sched region"),
    (".sched\n.vreg r3\n  halt\n.endsched\n", "'r3' is already a register or a symbol"),
])
def test_vreg_mistakes(text, says):
    with pytest.raises(AssemblyError) as err:
        Assembler("ic").assemble_text(".proc ic\n" + text, "t.s")
    assert says in err.value.diagnostics[0].message


def test_temps_auto_leaves_every_physical_register_alone():
    src = """
.proc ic
.reg keep = r40
    { li keep, 7 }
.sched
.temps auto
.vreg x, y
    li x, 1
    addi y, x, 2
    add keep, keep, y
    halt
.endsched
"""
    program = Assembler("ic").assemble_text(src, "t.s")
    names = {r.name: r.reg for r in program.reg_names}
    assert names["x"] not in (0, 40, 63) and names["y"] not in (0, 40, 63)
