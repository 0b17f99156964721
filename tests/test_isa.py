"""The ISA tables: consistent, documented from one source, and corner cases pinned."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.processors import PROCESSORS
from netsushisen.isa.reference import markdown
from netsushisen.isa.ring import make_header, parse_header
from netsushisen.isa.words import FP32, FP64, wrap32

DOCS = Path(__file__).resolve().parents[1] / "docs" / "isa.md"


def test_committed_reference_is_fresh():
    assert DOCS.read_text() == markdown(), "docs/isa.md is stale: run `netsushisen isa --markdown -o docs/isa.md`"


def test_cli_writes_the_reference(tmp_path, cli):
    code, out, _ = cli("isa", "--markdown")
    assert code == 0 and out == markdown()
    for name in OPCODES:
        assert f"| `{name}` |" in out


def test_table_is_consistent():
    for m, o in OPCODES.items():
        assert o.unit in ("int", "fp")
        assert o.procs and o.procs <= set(PROCESSORS)
        if o.kind in ("alu", "branch"):
            assert o.semantics is not None, m
        if o.kind in ("load", "store"):
            assert o.space in ("local", "resident", "global")
            for p in o.procs:
                assert o.space in PROCESSORS[p].memories, (m, p)
        assert sum(op.kind == "rd" for op in o.operands) <= 1


def test_paper_processor_configs():
    os_, ic, sc = PROCESSORS["os"], PROCESSORS["ic"], PROCESSORS["sc"]
    assert (os_.units, os_.read_ports, os_.write_ports) == ({"int": 2, "fp": 2}, 5, 2)
    assert (ic.units, ic.read_ports, ic.write_ports) == ({"int": 1, "fp": 3}, 6, 3)
    assert sc.units == {"gen": 1} and not sc.vliw


def sem(name, F, *args):
    return OPCODES[name].semantics(F, *args)


def test_integer_corner_cases():
    F = np.float32
    assert sem("add", F, 2 ** 31 - 1, 1) == -(2 ** 31)
    assert sem("mul", F, 65536, 65536) == 0
    assert sem("div", F, 7, 0) == -1 and sem("rem", F, 7, 0) == 7
    assert sem("div", F, -(2 ** 31), -1) == -(2 ** 31) and sem("rem", F, -(2 ** 31), -1) == 0
    assert sem("div", F, -7, 2) == -3 and sem("rem", F, -7, 2) == -1
    assert sem("sll", F, 1, 33) == 2 and sem("srl", F, -1, 28) == 15 and sem("sra", F, -16, 2) == -4
    assert sem("sltu", F, -1, 1) == 0 and sem("slt", F, -1, 1) == 1
    assert wrap32(0xFFFFFFFF) == -1


@pytest.mark.parametrize("F", [np.float32, np.float64])
def test_float_corner_cases(F):
    nan, inf = F(np.nan), F(np.inf)
    assert sem("fdiv", F, F(1), F(0)) == inf and sem("fdiv", F, F(-1), F(0)) == -inf
    assert math.isnan(sem("fdiv", F, F(0), F(0)))
    assert math.isnan(sem("fsqrt", F, F(-1)))
    r = sem("fsqrt", F, F(-0.0))
    assert r == 0 and math.copysign(1, r) < 0
    assert math.isnan(sem("fmin", F, nan, F(1))) and math.isnan(sem("fmax", F, F(1), nan))
    assert math.copysign(1, sem("fmin", F, F(0.0), F(-0.0))) < 0
    assert math.copysign(1, sem("fmax", F, F(-0.0), F(0.0))) > 0
    assert sem("flt", F, nan, F(1)) == 0 and sem("fle", F, nan, nan) == 0 and sem("feq", F, nan, nan) == 0
    assert sem("feq", F, F(0.0), F(-0.0)) == 1
    assert sem("ftoi", F, nan) == 0 and sem("ftoi", F, F(-2.7)) == -2 and sem("floor", F, F(-2.5)) == -3
    assert sem("ftoi", F, F(1e20)) == 2 ** 31 - 1 and sem("floor", F, -inf) == -(2 ** 31)
    for name in ("fadd", "fsub", "fmul", "fdiv"):
        assert type(sem(name, F, F(1.1), F(3.3))) is F
    assert sem("lf", F, 0.1) == F(0.1)


def test_fp32_rounds_each_operation():
    F = np.float32
    a, b = F(16777216.0), F(1.0)  # 2**24: the next float32 is 2**24 + 2
    assert sem("fadd", F, a, b) == a
    assert sem("fadd", np.float64, np.float64(a), np.float64(b)) == 16777217.0


@pytest.mark.parametrize("fmt", [FP32, FP64])
def test_words_round_trip(fmt):
    for v in (0, 1, -1, 2 ** 31 - 1, -(2 ** 31), 12345):
        assert fmt.to_int(fmt.from_int(v)) == v
    for x in (0.0, -0.0, 1.5, -3.25, math.inf, 1e-30):
        w = fmt.from_float(x)
        assert float(fmt.to_float(w)) == float(fmt.float_type(x))
        assert math.copysign(1, float(fmt.to_float(w))) == math.copysign(1, x)
    assert math.isnan(fmt.to_float(fmt.from_float(math.nan)))
    assert fmt.from_float(1.0) != fmt.from_int(1)


def test_ring_header_round_trip():
    for length, dest, cls, tag in ((0, 0, 0, 0), (255, 3, 15, 65535), (9, 1, 2, 7)):
        h = parse_header(make_header(length, dest, cls, tag))
        assert (h.length, h.dest, h.cls, h.tag) == (length, dest, cls, tag)
    with pytest.raises(ValueError):
        make_header(256, 0)
