"""Every malformed source gives exit 1, located error lines, and no traceback (issue 2)."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

LOCATED = re.compile(r"^(?P<file>[^:\s]+):(?P<line>\d+):(?P<col>\d+): error: (?P<msg>.+)$", re.M)

# (name, source, expected line, expected column, a fragment of the message)
CASES = [
    ("unknown_mnemonic", ".proc os\n  fadd r1, r2, r3\n  fmadd r1, r2, r3\n", 3, 3, "unknown mnemonic 'fmadd'"),
    ("operand_count", ".proc ic\n  fadd r1, r2\n", 2, 3, "takes 3 operands"),
    ("operand_kind_register", ".proc ic\n  fadd r1, 5, r3\n", 2, 12, "expected a register"),
    ("operand_kind_memory", ".proc ic\n  ldg r1, r2\n", 2, 11, "expected a memory operand"),
    ("operand_kind_value", ".proc os\n  addi r1, r2, r3\n", 2, 16, "'r3' is a register"),
    ("operand_kind_port", ".proc ic\n  recv r1, host\n", 2, 12, "expected a FIFO port of IC"),
    ("slot_overflow", ".proc ic\n  { add r1, r2, r3 ; sub r4, r5, r6 }\n", 2, 3, "slot overflow: 2 int"),
    ("read_port_overflow", ".proc os\n  { fadd r1, r2, r3 ; fmul r4, r5, r6 ; add r7, r8, r9 }\n", 2, 3,
     "read-port overflow: the bundle reads 6"),
    ("write_port_overflow", ".proc os\n  { li r1, 1 ; li r2, 2 ; lf r3, 1.0 }\n", 2, 3,
     "write-port overflow: the bundle writes 3"),
    ("duplicate_label", ".proc sc\nx: halt\n  nop\nx: halt\n", 4, 1, "duplicate label 'x'"),
    ("undefined_label", ".proc sc\n  j nowhere\n", 2, 5, "undefined symbol 'nowhere'"),
    ("bad_directive", ".proc sc\n  .wrd 5\n  halt\n", 2, 3, "unknown directive .wrd"),
    ("bad_directive_args", ".proc sc\n  .equ 5\n  halt\n", 2, 3, ".equ takes NAME, value"),
    ("unterminated_bundle", ".proc ic\n  { fadd r1, r2, r3\n    fmul r4, r5, r6\n  halt\n", 2, 3, "unterminated bundle"),
    ("missing_include", ".proc os\n  .include \"no_such_file.inc\"\n  halt\n", 2, 12, "cannot find include file"),
    ("syntax_garbage", ".proc os\n  add r1, r2, r3 )\n", 2, 18, "syntax error"),
    ("two_writes", ".proc os\n  { add r1, r2, r3 ; fadd r1, r4, r5 }\n", 2, 3, "r1 is written by 2 operations"),
    ("two_branches", ".proc os\nl: { j l ; beqz r1, l }\n", 2, 4, "more than one control transfer"),
    ("sc_two_ops", ".proc sc\n  { add r1, r2, r3 ; fadd r4, r5, r6 }\n", 2, 3, "one operation per instruction"),
    ("not_on_processor", ".proc os\n  ldr r1, [r2]\n", 2, 3, "'ldr' is not available on OS"),
    ("unterminated_if", ".proc os\n.if 1\n  halt\n", 2, 1, ".if without a matching .endif"),
    ("endif_without_if", ".proc os\n  halt\n.endif\n", 3, 1, ".endif without a matching .if"),
    ("no_proc", "  halt\n", 1, 3, "which processor?"),
    ("immediate_range", ".proc os\n  li r1, 0x1ffffffff\n", 2, 10, "does not fit in 32 bits"),
    ("branch_to_data", ".proc os\n.data\nd: .word 1\n.text\n  j d\n", 5, 5, "is a data label"),
    # .macro / .rept (more in test_macro_errors_name_the_body_line_and_the_invocation)
    ("unterminated_macro", ".proc os\n.macro M a\n  halt\n", 2, 1, "unterminated .macro 'M'"),
    ("unterminated_rept", ".proc os\n  halt\n  .rept 2\n  nop\n", 3, 3, "unterminated .rept"),
    ("endm_without_macro", ".proc os\n  halt\n.endm\n", 3, 1, ".endm without a matching .macro"),
    ("endr_without_rept", ".proc os\n  halt\n  .endr\n", 3, 3, ".endr without a matching .rept"),
    ("unknown_macro", ".proc os\n.macro SAVE a\n  st \\a, [r0]\n.endm\n  SAVEE r1\n", 5, 3,
     "unknown mnemonic or macro 'SAVEE' (did you mean macro 'SAVE'?)"),
    ("macro_too_many_args", ".proc os\n.macro M a\n  halt\n.endm\n  M r1, r2\n", 5, 5,
     "macro 'M' takes 1 argument (a), got 2"),
    ("macro_missing_arg", ".proc os\n.macro M a, b=1\n  halt\n.endm\n  M b=2\n", 5, 5,
     "macro 'M' needs argument 'a' (a, b=1)"),
    ("macro_used_before_definition", ".proc os\n  M\n.macro M\n  halt\n.endm\n", 2, 3,
     "macro 'M' is used before its definition"),
    ("macro_named_like_opcode", ".proc os\n.macro add a\n.endm\n  halt\n", 2, 1,
     "'add' is an instruction; a macro cannot take its name"),
    ("macro_defined_twice", ".proc os\n.macro M\n.endm\n.macro M\n.endm\n  halt\n", 4, 1,
     "macro 'M' is already defined (at"),
    ("rept_bad_count", ".proc os\n.rept 1 - 2\n  nop\n.endr\n  halt\n", 2, 7,
     ".rept needs a count from 0 to"),
    ("macro_bad_header", ".proc os\n.macro 5M a\n.endm\n  halt\n", 2, 8, "bad .macro line"),
    ("macro_param_twice", ".proc os\n.macro N a, a\n.endm\n  halt\n", 2, 13,
     "macro 'N' names parameter 'a' twice"),
    ("stray_backslash", ".proc os\n  addi r1, r1, \\+\n", 2, 16,
     "'\\+' means something only inside a .rept body"),
]


@pytest.mark.parametrize("name,source,line,col,fragment", CASES, ids=[c[0] for c in CASES])
def test_malformed_source_is_located(tmp_path, cli, name, source, line, col, fragment):
    path = tmp_path / f"{name}.s"
    path.write_text(source)
    code, out, err = cli("asm", path, "-o", tmp_path / "out.o")
    assert code == 1
    assert "Traceback" not in err
    errors = [m.groupdict() for m in LOCATED.finditer(err)]
    assert errors, err
    hit = [e for e in errors if fragment in e["msg"]]
    assert hit, f"no error mentioning {fragment!r} in:\n{err}"
    assert (int(hit[0]["line"]), int(hit[0]["col"])) == (line, col), err
    assert hit[0]["file"].endswith(f"{name}.s")
    # the offending source line is shown with a caret under the column
    lines = err.splitlines()
    i = lines.index(next(l for l in lines if fragment in l))
    assert lines[i + 1].strip() == source.splitlines()[line - 1].strip()
    assert lines[i + 2].index("^") - 4 == col - 1
    assert not (tmp_path / "out.o").exists()


def test_empty_file(tmp_path, cli):
    for text in ("", "\n\n   # only a comment\n"):
        path = tmp_path / "empty.s"
        path.write_text(text)
        code, _, err = cli("asm", path, "--proc", "os", "-o", tmp_path / "o.o")
        assert code == 1 and "empty program" in err and "Traceback" not in err


@pytest.mark.parametrize("blob", [b"\x00\x01\x02binary", b".proc os\n  halt\n\xff\xfe\x00garbage", bytes(range(256))])
def test_binary_garbage(tmp_path, cli, blob):
    path = tmp_path / "garbage.s"
    path.write_bytes(blob)
    code, _, err = cli("asm", path, "--proc", "os")
    assert code == 1
    assert "not a text file" in err and "Traceback" not in err
    assert LOCATED.search(err)


def test_missing_source_file(tmp_path, cli):
    code, _, err = cli("asm", tmp_path / "nope.s", "--proc", "os")
    assert code == 1 and "no such source file" in err


def test_every_error_of_a_file_is_reported(tmp_path, cli):
    src = (".proc ic\n"
           "  fadd r1, r2\n"          # operand count
           "  bogus r1\n"             # unknown mnemonic
           "  add r1, r2, r3 )\n"     # syntax
           "  { fadd r1, r2, r3\n"    # unterminated bundle ...
           "  halt\n")
    path = tmp_path / "many.s"
    path.write_text(src)
    code, _, err = cli("asm", path)
    assert code == 1
    lines = sorted(int(m["line"]) for m in LOCATED.finditer(err))
    assert lines == [2, 3, 4, 5]


def test_errors_inside_an_include_name_the_included_file(tmp_path, cli):
    (tmp_path / "inc").mkdir()
    (tmp_path / "inc" / "bad.inc").write_text("  .equ A, 1\n  frobnicate r1\n")
    path = tmp_path / "main.s"
    path.write_text('.proc os\n.include "bad.inc"\n  halt\n')
    code, _, err = cli("asm", path, "-I", tmp_path / "inc")
    assert code == 1
    m = LOCATED.search(err)
    assert m["file"].endswith("bad.inc") and m["line"] == "2"


def test_include_loop_is_reported(tmp_path, cli):
    (tmp_path / "a.inc").write_text('.include "b.inc"\n')
    (tmp_path / "b.inc").write_text('.include "a.inc"\n')
    path = tmp_path / "main.s"
    path.write_text('.proc os\n.include "a.inc"\n  halt\n')
    code, _, err = cli("asm", path)
    assert code == 1 and "include loop" in err


def test_command_line_process_has_no_traceback(tmp_path):
    path = tmp_path / "bad.s"
    path.write_text(".proc os\n  fadd r1\n")
    proc = subprocess.run([sys.executable, "-m", "netsushisen.cli", "asm", str(path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr
    assert re.search(r"bad\.s:2:3: error: 'fadd' takes 3 operands", proc.stderr)


def test_bad_define_and_proc_conflict(tmp_path, cli):
    path = tmp_path / "p.s"
    path.write_text(".proc ic\n  halt\n")
    code, _, err = cli("asm", path, "--proc", "os")
    assert code == 1 and ".proc ic contradicts --proc says os" in err
    code, _, err = cli("asm", path, "-D", "X=1+", "--stats")
    assert code == 1 and "-D" in err and "Traceback" not in err


def test_macro_errors_name_the_body_line_and_the_invocation(tmp_path, cli):
    """An error inside a macro body is reported at the body line (as substituted) with a note
    per enclosing expansion, innermost first — as GNU as and compilers do — each located."""
    path = tmp_path / "m.s"
    path.write_text(".proc ic\n"
                    ".macro INNER op\n"
                    "    \\op r1, r2\n"               # 3: fadd with 2 operands
                    ".endm\n"
                    ".macro OUTER\n"
                    "  .rept 2\n"                      # 6
                    "    INNER fadd\n"                 # 7
                    "  .endr\n"
                    ".endm\n"
                    "    OUTER\n"                      # 10
                    "    halt\n")
    code, _, err = cli("asm", path)
    assert code == 1 and "Traceback" not in err
    lines = err.splitlines()
    heads = [l for l in lines if l.startswith(str(path))]
    first = [f"{path}:3:5: error: 'fadd' takes 3 operands (fadd rd, rs, rs), got 2",
             f"{path}:7:5: note: in expansion of macro 'INNER'",
             f"{path}:6:3: note: in repetition 1 of 2 (.rept)",
             f"{path}:10:5: note: in expansion of macro 'OUTER'"]
    assert heads[:4] == first, err
    assert heads[4].endswith("error: 'fadd' takes 3 operands (fadd rd, rs, rs), got 2")
    assert heads[6] == f"{path}:6:3: note: in repetition 2 of 2 (.rept)"
    # each shows its line, substituted, with a caret under the column
    i = lines.index(first[0])
    assert lines[i + 1].strip() == "fadd r1, r2" and lines[i + 2].index("^") - 4 == 4
    i = lines.index(first[1])
    assert lines[i + 1].strip() == "INNER fadd" and lines[i + 2].index("^") - 4 == 4


def test_macro_recursion_and_unknown_parameter(tmp_path, cli):
    path = tmp_path / "r.s"
    path.write_text(".proc os\n.macro LOOP n\n    LOOP \\n\n.endm\n    LOOP 1\n"
                    ".macro BAD a\n    addi \\a, \\b, 1\n.endm\n    BAD r1\n    halt\n")
    code, _, err = cli("asm", path)
    assert code == 1 and "Traceback" not in err
    assert f"{path}:3:5: error: macro / .rept expansions nested deeper than 64" in err
    # the runaway chain is cut short but still names the first invocation
    assert "note: ... (more expansions)" in err and f"{path}:5:5: note: in expansion of macro 'LOOP'" in err
    assert err.count("note: in expansion of macro 'LOOP'") == 4
    assert (f"{path}:7:14: error: '\\b' is not a parameter of macro 'BAD' (its parameters: a)"
            in err)
    assert f"{path}:9:5: note: in expansion of macro 'BAD'" in err
