"""The assembler's language: directives, expressions, includes, conditional assembly, outputs."""

from __future__ import annotations

import json
import math

import pytest

from netsushisen.asm.assembler import AssemblyError, assemble_file, assemble_text
from netsushisen.asm.listing import listing, static_ilp
from netsushisen.asm.objects import Op, Program
from netsushisen.kernels import KERNELS as KERNELS_DIR


def test_bundles_labels_aliases_constants():
    p = assemble_text("""
.proc ic
.equ CELL_NEXT, 1
.equ SCALE, 2 * (3 + 4) - 1      # 13
.reg dx = r10
start:
    li r1, SCALE << 2
    { fadd r2, dx, r3 ; fmul r4, r5, r6 ; ldg r7, [r1 + CELL_NEXT] }
loop: addi r1, r1, -1
    bnez r1, loop
    halt
""")
    assert p.proc == "ic"
    assert p.bundles[0] == (Op("li", (1, 52)),)
    assert p.bundles[1] == (Op("fadd", (2, 10, 3)), Op("fmul", (4, 5, 6)), Op("ldg", (7, (1, 1))))
    assert p.labels == {"start": ("text", 0), "loop": ("text", 2)}
    assert p.bundles[3] == (Op("bnez", (1, 2)),)


def test_expressions_follow_c():
    p = assemble_text("""
.proc os
    li r1, -7 / 2
    li r2, -7 % 2
    li r3, (1 << 4) | 3 & 1 ^ 2
    li r4, 3 > 2 && !(1 == 2)
    li r5, 0xFFFFFFFF
    li r6, int(2.9) + max(3, 4) + abs(-1)
    lf r7, 1.0 / 3
    lf r8, -inf
    halt
""")
    vals = [b[0].args[1] for b in p.bundles[:8]]
    assert vals[:6] == [-3, -1, 16 | (3 & 1 ^ 2), 1, -1, 2 + 4 + 1]
    assert vals[6] == 1.0 / 3 and vals[7] == -math.inf


def test_memory_operand_forms():
    p = assemble_text(".proc ic\n ld r1, [r2]\n ld r1, [r2 + 3]\n ld r1, [3 + r2]\n ld r1, [r2 - 3]\n"
                      " ld r1, [40]\n halt\n")
    assert [b[0].args[1] for b in p.bundles[:5]] == [(2, 0), (2, 3), (2, 3), (2, -3), (0, 40)]


def test_data_section_and_labels_in_words():
    p = assemble_text("""
.proc sc
.data
table: .word 1, 2, table_end - table
consts: .float 0.5, 1e-3
        .space 2
        .align 4
table_end:
.text
    ld r1, [table + 2]
    halt
""")
    assert p.data == [("i", 1), ("i", 2), ("i", 8), ("f", 0.5), ("f", 1e-3), ("i", 0), ("i", 0), ("i", 0)]
    assert p.labels["table"] == ("data", 0) and p.labels["consts"] == ("data", 3)
    assert p.bundles[0][0].args[1] == (0, 2)


def test_conditional_assembly_with_defines():
    src = """
.proc ic
.ifndef HAS_SPHERES
.equ HAS_SPHERES, 0
.endif
.if HAS_SPHERES && NLIGHTS > 1
    li r1, 1
.elif HAS_SPHERES
    li r1, 2
.else
    li r1, 3
    this line is skipped garbage when HAS_SPHERES is set ???
.endif
    halt
"""
    assert assemble_text(src, defines={"HAS_SPHERES": 1, "NLIGHTS": 3}).bundles[0][0].args == (1, 1)
    assert assemble_text(src, defines={"HAS_SPHERES": 1, "NLIGHTS": 1}).bundles[0][0].args == (1, 2)
    with pytest.raises(AssemblyError) as exc:  # the else branch is assembled and its garbage reported
        assemble_text(src, defines={"NLIGHTS": 1})
    assert "syntax error" in exc.value.format()
    with pytest.raises(AssemblyError) as exc:  # an undefined symbol in .if is an error, not false
        assemble_text(".proc os\n.if NOT_GIVEN\n.endif\n halt\n")
    assert "undefined symbol 'NOT_GIVEN'" in exc.value.format()


def test_nested_conditionals_skip_inner_blocks():
    src = ".proc os\n.if 0\n.if 1\n li r1, 1\n.else\n li r1, 2\n.endif\n.else\n li r1, 3\n.endif\n halt\n"
    assert assemble_text(src).bundles[0][0].args == (1, 3)


def test_include_search_order(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "consts.inc").write_text(".equ K, 7\n")
    (tmp_path / "src" / "local.inc").write_text(".equ J, 5\n")
    main = tmp_path / "src" / "main.s"
    main.write_text('.proc os\n.include "local.inc"\n.include "consts.inc"\n li r1, J + K\n halt\n')
    with pytest.raises(AssemblyError):
        assemble_file(main)
    p = assemble_file(main, include_dirs=[tmp_path / "lib"])
    assert p.bundles[0][0].args == (1, 12)
    assert p.source_map[0].file.endswith("main.s") and p.source_map[0].line == 4


def test_predefined_ring_symbols():
    p = assemble_text(".proc ic\n li r1, DEST_SC << HDR_DEST_SHIFT | 6\n halt\n")
    from netsushisen.isa.ring import make_header, parse_header
    assert p.bundles[0][0].args[1] == make_header(6, 2)
    assert parse_header(p.bundles[0][0].args[1]).dest_name == "sc"


def test_object_file_round_trip(tmp_path, cli):
    src = tmp_path / "k.s"
    src.write_text(".proc ic\n.data\nd: .float 0.1, nan\n.text\nl: { lf r1, 0.1 ; fadd r2, r1, r1 }\n j l\n")
    code, out, err = cli("asm", src, "-o", tmp_path / "k.o")
    assert code == 0, err
    loaded = Program.load(tmp_path / "k.o")
    assert loaded.same_program(assemble_file(src))
    obj = json.loads((tmp_path / "k.o").read_text())
    assert obj["format"] == "netsushisen-object" and obj["proc"] == "ic"
    (tmp_path / "bad.o").write_text("{not json")
    code, _, err = cli("disasm", tmp_path / "bad.o")
    assert code == 1 and "not a netsushisen-object file" in err


def test_listing_and_stats(tmp_path, cli):
    src = tmp_path / "k.s"
    src.write_text(".proc os\nl: { fadd r1, r2, r3 ; fmul r4, r2, r3 ; bnez r5, l }\n"
                   "   { li r8, 1 ; li r9, 2 }\n   j l\n")
    p = assemble_file(src)
    text = listing(p)
    assert "l:" in text and "fadd r1, r2, r3" in text and "k.s:2" in text and "bnez r5, l" in text
    s = static_ilp(p)
    assert s.bundles == 3 and s.ops == 6 and s.ops_per_bundle == 2.0
    assert s.slot_fill == {"int": 4 / 6, "fp": 2 / 6}
    assert s.max_reads == 3 and s.max_writes == 2
    code, out, err = cli("asm", src, "--stats")
    assert code == 0 and "3 bundles, 6 ops, 2.00 ops/bundle" in out
    assert not (tmp_path / "k.o").exists()
    code, out, _ = cli("asm", src, "--listing", "-", "-o", tmp_path / "k.o")
    assert code == 0 and "fmul r4, r2, r3" in out and (tmp_path / "k.o").exists()


# ---- .macro / .rept (GNU as is the model) ---------------------------------------------------

def test_macro_parameters_defaults_keywords_and_joins():
    p = assemble_text("""
.proc ic
.macro LOAD3 ld, base, dst, off=0
\\dst\\()_\\ld:
    { \\ld r1, [\\base + \\off] }
    { \\ld r2, [\\base + (\\off + 1)] ; fadd r3, r4, r5 }
.endm
    LOAD3 ldg, r7, x, off=4
    LOAD3 ldr, r8, y
    LOAD3 base=r9, ld=ldg, dst=z
    halt
""")
    assert p.bundles[0] == (Op("ldg", (1, (7, 4))),)
    assert p.bundles[1] == (Op("ldg", (2, (7, 5))), Op("fadd", (3, 4, 5)))
    assert p.bundles[2] == (Op("ldr", (1, (8, 0))),)
    assert p.bundles[4] == (Op("ldg", (1, (9, 0))),)
    assert {k: v for k, v in p.labels.items() if "_" in k} == {
        "x_ldg": ("text", 0), "y_ldr": ("text", 2), "z_ldg": ("text", 4)}


def test_macro_body_conditionals_nesting_and_counter():
    """.if inside a body is evaluated per expansion; a macro invokes another; \\@ counts
    expansions (unique labels); a bundle's commas stay inside its argument."""
    p = assemble_text("""
.proc os
.macro MAYBE n, what
.if \\n > 1
    \\what
.else
    nop
.endif
.endm
.macro TWICE what
again\\@:
    MAYBE 2, \\what
    MAYBE 0, \\what
.endm
    TWICE halt
    TWICE { ld r1, [r2 + 3] }
""")
    assert [b[0].mnemonic for b in p.bundles] == ["halt", "nop", "ld", "nop"]
    assert p.bundles[2] == (Op("ld", (1, (2, 3))),)
    assert p.labels["again0"] == ("text", 0) and p.labels["again3"] == ("text", 2)


def test_rept_with_iteration_counter_and_nesting():
    p = assemble_text("""
.proc os
.rept 3
    { st r1, [r2 + 2 * \\+] ; addi r3, r3, \\+ }
.endr
.rept 2
.rept 2
    addi r4, r4, \\+
.endr
    nop
.endr
.rept 0
    this is never assembled
.endr
    halt
""")
    assert [b for b in p.bundles[:3]] == [
        (Op("st", (1, (2, 2 * i))), Op("addi", (3, 3, i))) for i in range(3)]
    assert [b[0].args[2] if b[0].mnemonic == "addi" else b[0].mnemonic
            for b in p.bundles[3:9]] == [0, 1, "nop", 0, 1, "nop"]
    assert len(p.bundles) == 10


def test_listing_shows_macro_expansions(tmp_path):
    src = tmp_path / "m.s"
    src.write_text(".proc sc\n.macro TWO a\n    addi \\a, \\a, 1\n    addi \\a, \\a, 2\n.endm\n"
                   "start:\n    TWO r5\n.rept 2\n    nop\n.endr\n    halt\n")
    p = assemble_file(src)
    text = listing(p)
    lines = text.splitlines()
    at = next(i for i, l in enumerate(lines) if "; expands" in l)
    assert lines[at].endswith("m.s:7: TWO r5")
    assert "m.s:3  addi r5, r5, 1" in lines[at + 1] and "m.s:4  addi r5, r5, 2" in lines[at + 2]
    assert sum("expands" in l and ".rept 2  [" in l for l in lines) == 2  # one per repetition
    # the expansion is kept in the object file; a plain bundle has none
    q = Program.from_json(json.loads(json.dumps(p.to_json())))
    assert q.source_map[0].via.endswith("m.s:7: TWO r5") and q.source_map[-1].via == ""
    assert listing(q) == text


def test_kernels_write_their_twins_once():
    """The bundled kernels write a record-reading block once, as a macro of the load (`\\ld`),
    and expand it per memory: no resident-memory load is written out in the IC sources, yet the
    generic IC program has its resident twins (the same count of ldr and ldg in them)."""
    import re

    from netsushisen.pipeline import assemble_kernels

    sources = "".join(p.read_text() for p in KERNELS_DIR.glob("ic*"))
    assert not re.search(r"\bldr\s+\w+,", sources)
    os_src = (KERNELS_DIR / "os.s").read_text()
    assert os_src.count("    ENQUEUE ") == 2 and ".rept 5" in os_src
    from netsushisen.isa.config import MachineConfig
    from netsushisen.pipeline import kernel_inputs

    ic = assemble_kernels(kernel_inputs("tetra:1", MachineConfig(), 4, generic=True).defines)["ic"]
    cell, padr = 26, 34  # the list cell reads: at `cell`, and the next cell's read ahead (`padr`)
    loads = [(op.mnemonic, op.args[1][0] in (cell, padr)) for bundle in ic.bundles for op in bundle
             if op.mnemonic in ("ldr", "ldg")]
    # every twin in both memories; the primitive list (never resident) only with ldg
    assert loads.count(("ldr", False)) > 40 and loads.count(("ldg", False)) == loads.count(("ldr", False))
    assert loads.count(("ldg", True)) > 2 and ("ldr", True) not in loads
