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
