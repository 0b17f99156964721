"""IC's early rejection of sphere and cylinder misses (docs/kernels.md, "Early rejection") takes
effect: in a render, most tests that reach its branch leave there, before golden's division and
the second half of golden's chain; so do the range rejections before the sphere's and the
cylinder's sqrt, the cylinder's axial rejection and the quadrilateral's sign rejection beside
golden's division, and the quadrilateral's plane rejection (docs/kernels.md, "Range and plane
rejections") for a good share of the tests that reach them. That it never changes a result is
the kernel bench's business (tests/test_kernel_ic.py, with mutants of it) and the renders' against the golden model
(tests/test_render.py); this checks that it is not dead code that leaves everything to golden's
chain, which would give the same pictures at the old cost."""

from __future__ import annotations

import pytest

from netsushisen.isa.config import load_config
from netsushisen.paper_machine import PAPER_ORDER
from netsushisen.pipeline import render


def _pcs_of(program, text: str) -> list[int]:
    """Bundle addresses holding an operation of a source line that contains `text`."""
    return [pc for pc, locs in enumerate(program.op_sources) if any(text in loc.text for loc in locs)]


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
@pytest.mark.parametrize("spec,branch", [("rings:2", "bnez c_q6"), ("balls:2", "bnez s_ego")])
def test_most_failed_tests_leave_at_the_early_branch(spec, branch, engine_name):
    result = render(spec, load_config(None, []), res=8, engine=engine_name)
    ic = result.setup.programs["ic"]
    pcs = _pcs_of(ic, branch)
    assert pcs, f"no bundle holds {branch!r}"
    issued = {int(k): int(v) for k, v in result.stats["processors"]["pe0.ic"]["bundles_by_pc"].items()}
    reached = sum(issued.get(pc, 0) for pc in pcs)
    stayed = sum(issued.get(pc + 1, 0) for pc in pcs)   # fell through into golden's chain
    assert reached > 100
    assert stayed < 0.5 * reached, f"{stayed} of {reached} tests went on to golden's chain"


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
@pytest.mark.parametrize("spec,exits,share", [
    ("rings:2", ("bnez c_mn, to_cell1", "bnez c_mr, list_end"), 0.3),     # cylinder: range
    ("mount", ("bnez s_mf, to_cell0", "bnez s_R, list_end"), 0.5),        # sphere: range
    ("balls:2", ("bnez v_qm, cell_loop", "beqz v_qa, list_end"), 0.5),     # quad: plane
    ("rings:2", ("bnez c_dg, to_cell1", "bnez c_dV, list_end"), 0.1),      # cylinder: zB, no quotient
    ("balls:2", ("bnez v_s1, cell_loop", "bnez v_s0, list_end"), 0.5),     # quad: t's sign
])
def test_range_and_plane_rejections_take_effect(spec, exits, share, engine_name):
    result = render(spec, load_config(None, []), res=8, engine=engine_name)
    ic = result.setup.programs["ic"]
    issued = {int(k): int(v) for k, v in result.stats["processors"]["pe0.ic"]["bundles_by_pc"].items()}
    first = _pcs_of(ic, exits[0])
    assert first, f"no bundle holds {exits[0]!r}"
    reached = sum(issued.get(pc, 0) for pc in first)
    left = sum(issued.get(pc, 0) - issued.get(pc + 1, 0) for text in exits for pc in _pcs_of(ic, text))
    assert reached > 50
    assert left > share * reached, f"{left} of {reached} tests left at the rejection"


def _issued(result, texts: tuple[str, ...]) -> int:
    ic = result.setup.programs["ic"]
    issued = result.stats["processors"]["pe0.ic"]["bundles_by_pc"]
    pcs = {pc for text in texts for pc in _pcs_of(ic, text)}
    assert pcs, f"no bundle holds {texts!r}"
    return sum(int(issued.get(str(pc), 0)) for pc in pcs)


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
def test_reading_ahead_and_reading_less_take_effect(engine_name):
    """docs/kernels.md, "Reading ahead, reading less": by default most of rings' cells come read
    ahead by the test before them (cell_read without cell_loop's loads), the cylinder reads L and the
    triangle its normal only for the tests that go on; in the paper's load order (PRELOAD=0,
    LAZY_WORDS=0) every cell is read at cell_loop and every test reads its whole record."""
    config = load_config(None, [])
    for defines, ahead in (({}, True), (PAPER_ORDER, False)):
        rings = render("rings:2", config, res=8, engine=engine_name, defines=defines)
        cell_read = rings.setup.programs["ic"].labels["cell_read"][1]
        cells = int(rings.stats["processors"]["pe0.ic"]["bundles_by_pc"].get(str(cell_read), 0))
        read = _issued(rings, ("ldg npri, [cell + CELL_PRIORITY]", "ldg pri, [cell + CELL_PRIORITY]"))
        length, base = (_issued(rings, (f"c_{w}, [shp + CYL_{w2}]",)) for w, w2 in (("len", "LENGTH"),
                                                                                  ("bx", "BASE")))
        tetra = render("tetra", config, res=8, engine=engine_name, defines=defines)
        normal, vertex = (_issued(tetra, (f"[shp + POLY_{w}]", f"[shp + (POLY_{w} + 0)]"))
                          for w in ("NORMAL", "VERTICES"))  # (first words: linear, hand-bundled)
        assert cells > 500 and base > 300 and vertex > 100
        if ahead:
            assert read < 0.6 * cells and length < 0.6 * base and normal < 0.6 * vertex
        else:
            assert read == cells and length == base and normal == vertex
