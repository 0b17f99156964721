"""Names that cannot alias (issue 40, item 2): a `.reg` name is bound once per scope, `.unreg`
ends it, a macro's own names vanish at `.endm`, and two names of one register may not both be
live — an error inside a `.sched` region, a warning on the straight lines outside (asm/aliasing.py)."""

from __future__ import annotations

import pytest

from netsushisen.asm.assembler import Assembler, AssemblyError, assemble_text
from netsushisen.kernels import KERNELS


def _errors(src: str) -> list[str]:
    with pytest.raises(AssemblyError) as err:
        assemble_text(src, "ic", filename="t.s")
    return [d.format().splitlines()[0] for d in err.value.diagnostics if d.severity == "error"]


def _warnings(src: str) -> list[str]:
    asm = Assembler("ic")
    asm.assemble_text(src, "t.s")
    return [d.format().splitlines()[0] for d in asm.warnings]


def test_a_redefined_name_is_an_error_naming_both_lines():
    errors = _errors(".reg a = r40\n  li a, 1\n.reg  a = r41\n  halt\n")
    assert errors == ["t.s:3:7: error: 'a' is already a .reg name in this scope (r40, bound at "
                      "t.s:1:6); write .unreg a first to end it"]


def test_unreg_ends_a_name():
    program = assemble_text(".reg a = r40\n  li a, 1\n.unreg a\n.reg a = r41\n  li a, 2\n  halt\n", "ic")
    assert [op.args[0] for (op,) in program.bundles[:2]] == [40, 41]
    assert [(r.name, r.reg, r.start, r.end) for r in program.reg_names] == [("a", 40, 0, 1), ("a", 41, 1, 3)]
    assert _errors(".unreg a\n  halt\n") == [
        "t.s:1:8: error: .unreg takes a .reg name in force here, got 'a'"]
    assert "expected a register" in _errors(".reg a = r40\n.unreg a\n  li a, 1\n  halt\n")[0]


MACRO = """
.reg x = r40
.macro M
.reg x = r50          # shadows the outer x inside the expansion
.reg y = r51          # the macro's own
    li x, 1
    li y, 2
.endm
    M
    M                 # a second expansion declares its names again
    li x, 3
    halt
"""


def test_macro_names_vanish_at_endm():
    program = assemble_text(MACRO, "ic")
    assert [op.args[0] for (op,) in program.bundles[:5]] == [50, 51, 50, 51, 40]
    assert "expected a register" in _errors(MACRO.replace("li x, 3", "li y, 3"))[0]
    twice = MACRO.replace(".reg y = r51", ".reg y = r51\n.reg y = r52")
    assert "'y' is already a .reg name in this scope (r51" in _errors(twice)[0]


REGION = """
.reg g = r40
.reg z = r40
.reg a = r41
.reg b = r42
.sched
    fle g, a, b
    fadd z, a, b
    fsel b, g, a, b
    halt
.endsched
"""


def test_two_live_names_of_one_register_in_a_region_are_an_error():
    """The sphere's dead guard, in small: z's write kills g before g is read."""
    assert _errors(REGION) == ["t.s:8:5: error: 'z' is written while 'g' (also r40) is live: "
                               "'g' is read at t.s:9:5"]
    fixed = REGION.replace(".reg z = r40", ".reg z = r43")
    assert assemble_text(fixed, "ic").bundles
    # a name read after the other's value is dead is fine: z written after g's last read
    later = REGION.replace("    fadd z, a, b\n    fsel b, g, a, b\n", "    fsel b, g, a, b\n    fadd z, a, b\n")
    assert assemble_text(later, "ic").bundles


def test_a_clash_across_a_region_branch_is_found():
    src = REGION.replace("    fadd z, a, b\n", "    fadd z, a, b\n    bnez a, out\n").replace(
        "    fsel b, g, a, b\n    halt\n", "    halt\nout:\n    fsel b, g, a, b\n    halt\n")
    assert "'z' is written while 'g' (also r40) is live" in _errors(src)[0]


def test_outside_regions_a_clash_is_a_warning_on_a_straight_line():
    src = ".reg a = r40\n.reg b = r40\n    { li a, 1 }\n    { li b, 2 }\n    { add r41, a, r0 }\n    halt\n"
    assert _warnings(src) == ["t.s:4:7: warning: 'b' is written while 'a' (also r40) is live: "
                              "'a' is read at t.s:5:7"]
    # a label between them: what reaches it is not known, so nothing is said
    assert _warnings(src.replace("    { add", "l:  { add")) == []


def test_deadout_and_temps_take_names():
    src = """
.reg t0 = r50
.reg t1 = r51
.reg d = r44
.sched
.temps t0 - t1
.deadout d, r45
    fadd d, r1, r2
    halt
.endsched
"""
    asm = Assembler("ic")
    asm.assemble_text(src, "t.s")
    region = asm.st.regions[0]
    assert region.temps == [50, 51] and region.deadout == [44, 45]


def _assert_clean(stage: str, defines: dict) -> None:
    asm = Assembler(stage, defines, [KERNELS])
    asm.assemble_file(KERNELS / f"{stage}.s")  # an aliasing error raises
    assert asm.warnings == [], f"{stage}: {asm.warnings[0].format()}"


def test_bundled_kernels_have_no_aliasing_error_or_warning():
    """Every feature assembled (the generic kernels), and IC's straight-line quadrilateral test."""
    from netsushisen.isa.config import load_config
    from netsushisen.pipeline import kernel_inputs

    defines = kernel_inputs("tetra:1", load_config(None, []), res=2, generic=True).defines
    for stage in ("os", "ic", "sc"):
        _assert_clean(stage, defines)
    _assert_clean("ic", {**defines, "QUADS": 1})


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tetra", "balls", "mount", "rings"])
def test_each_scenes_kernels_have_no_aliasing_error_or_warning(scene):
    from netsushisen.isa.config import load_config
    from netsushisen.paper_machine import PAPER_ORDER
    from netsushisen.pipeline import kernel_inputs

    defines = kernel_inputs(scene, load_config(None, []), res=4).defines
    for extra in ({}, PAPER_ORDER):
        for stage in ("os", "ic", "sc"):
            _assert_clean(stage, {**defines, **extra})


def test_disassembly_with_names_rebinds_with_unreg():
    from netsushisen.asm.disasm import disassemble

    program = assemble_text(".reg a = r40\n  li a, 1\n.unreg a\n.reg a = r41\n  li a, 2\n  halt\n", "ic")
    text = disassemble(program, names=True)
    assert ".unreg a\n.reg a = r41" in text
    assert assemble_text(text).same_program(program)
