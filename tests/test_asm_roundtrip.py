"""assemble → disassemble → assemble gives the identical program (hypothesis), and no mutated
source ever makes the assembler raise anything but its own located error (fuzz)."""

from __future__ import annotations

import functools
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from program_strategies import random_bundles

from netsushisen.asm.assembler import AssemblyError, assemble_file, assemble_text, kernels_dir
from netsushisen.asm.disasm import disassemble
from netsushisen.asm.objects import Op, Program
from netsushisen.isa.errors import NetsushisenError

SOURCES = sorted(kernels_dir().rglob("*.s"))


@functools.lru_cache(maxsize=1)
def scene_defines() -> dict:
    """The stage kernels are assembled per scene: the symbols of a small scene, every feature on."""
    from netsushisen.pipeline import kernel_defines
    from netsushisen.host.catalog import load_scene
    from netsushisen.host.databases import build_images
    from netsushisen.isa.config import MachineConfig

    return kernel_defines(build_images(load_scene("tetra:1"), MachineConfig()), generic=True)

INTS = st.integers(-(2 ** 31), 2 ** 31 - 1)
FLOATS = st.floats(allow_nan=True, allow_infinity=True)
REGS = st.integers(0, 63)
LABEL_NAMES = st.from_regex(r"L_[a-z0-9_]{1,6}", fullmatch=True)


@st.composite
def programs(draw, proc: str) -> Program:
    n = draw(st.integers(1, 10))
    bundles = random_bundles(draw, proc, n, regs=REGS, imms=INTS, floats=FLOATS, offsets=INTS,
                             last_label=n - 1, min_ops=0, empty=Op("halt"))
    data = draw(st.lists(st.one_of(INTS.map(lambda v: ("i", v)), FLOATS.map(lambda v: ("f", v))),
                         max_size=6))
    names = draw(st.lists(LABEL_NAMES, unique=True, max_size=5))
    labels = {}
    for name in names:
        if data and draw(st.booleans()):
            labels[name] = ("data", draw(st.integers(0, len(data))))
        else:
            labels[name] = ("text", draw(st.integers(0, n)))
    return Program(proc, bundles, data, labels)


@pytest.mark.parametrize("proc", ["os", "ic", "sc"])
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_disassembly_reassembles_identically(proc, data):
    original = data.draw(programs(proc))
    source = disassemble(original)
    first = assemble_text(source, filename="gen.s")
    assert first.same_program(original), source
    second = assemble_text(disassemble(first), filename="gen2.s")
    assert second.same_program(first)


@pytest.mark.parametrize("path", SOURCES, ids=[p.name for p in SOURCES])
def test_real_sources_round_trip(path):
    program = assemble_file(path, defines=scene_defines())
    again = assemble_text(disassemble(program), filename="re.s")
    assert again.same_program(program)


MUTATION_ALPHABET = list("{}[]();:,.#\"+-*/<>=&|^!~ \n\t0123456789abcxyzr") + ["\x00", "é", "\\"]


@st.composite
def mutations(draw):
    path = draw(st.sampled_from(SOURCES))
    text = path.read_text()
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["delete", "insert", "replace", "dup_line", "drop_line", "truncate"]))
        i = draw(st.integers(0, max(len(text) - 1, 0)))
        if kind == "delete":
            text = text[:i] + text[i + draw(st.integers(1, 8)):]
        elif kind == "insert":
            text = text[:i] + draw(st.sampled_from(MUTATION_ALPHABET)) + text[i:]
        elif kind == "replace":
            text = text[:i] + draw(st.sampled_from(MUTATION_ALPHABET)) + text[i + 1:]
        else:
            lines = text.split("\n")
            j = draw(st.integers(0, len(lines) - 1))
            if kind == "dup_line":
                lines.insert(j, lines[j])
            elif kind == "drop_line":
                del lines[j]
            else:
                lines = lines[:j]
            text = "\n".join(lines)
    return path, text


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=mutations())
def test_mutated_sources_never_escape_as_tracebacks(case):
    path, text = case
    try:
        assemble_text(text, filename=path.name, defines=scene_defines(), include_dirs=[path.parent])
    except AssemblyError as err:
        assert err.diagnostics and all(d.message for d in err.diagnostics)
        assert "Traceback" not in err.format()
    except NetsushisenError:
        pass


def test_the_simple_statement_parser_gives_larks_ast():
    """`report bounds` re-assembles a statistics file's listing, and Lark took a millisecond a
    line of it (issue 46): one-line statements of names, integers and `[base + offset]` skip it
    (asm/parser.py `_simple_statement`). Every statement of the shipped kernels and a listing,
    and near-misses that must go to Lark, get the same statement either way."""
    from netsushisen.asm import parser as P
    from netsushisen.asm.bounds import program_from_listing
    from netsushisen.emulator.stats import program_listing

    root = Path(__file__).resolve().parents[1]
    texts = [p.read_text() for p in sorted((root / "kernels").rglob("*.s"))]
    near = ["x: y: ld r1, [r2 + 3]", "{ }", "{ a ; }", "a:", "li r1, -5", "ld r1, [7]",
            "  add  r1 ,r2,  r3  ", "li r1, 0x10", "li r1, 1e5", "li r1, 1.5", "b -", "f r1, - 3",
            "ld r1, [r2 - 1]", "li r1,", "x: { nop }", "{nop;nop}", "ld r1, [r2 + r3]",
            "li r1, 5 ;", "a , b", "li r1, 1_000", "ld r1, [r2 + 3] ]", "li r1, (2)"]
    texts.append("\n".join(near))
    simple = lark = 0
    for text in texts:
        chunks, _ = P.split_statements(text, "k.s")
        for c in chunks:
            fast = P._simple_statement(c)
            try:
                labels, item = P._ToAst(c).transform(P._parse_text(c.text))
            except Exception:
                assert fast is None, c.text  # a syntax error: Lark must say where
                continue
            if fast is None:
                lark += 1
                continue
            simple += 1
            assert fast == P.Statement(labels, item, P.Loc(c.file, c.line, 1, c.via),
                                       c.source_lines), c.text
    assert simple > 1000 and lark > 100  # both paths taken
    program = assemble_text(".proc ic\nstart: { li r1, -1 ; fadd r3, r4, r5 }\n    ld r2, [r1 + 4]\n"
                            "    st r2, [r1]\n    beq r1, r0, start\n    halt\n")
    assert program_from_listing(program_listing(program), "ic").same_program(program)
