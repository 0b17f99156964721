"""IC's early rejection of sphere and cylinder misses (docs/kernels.md, "Early rejection") takes
effect: in a render, most tests that reach its branch leave there, before golden's division and
the second half of golden's chain. That it never changes a result is the kernel bench's business
(tests/test_kernel_ic.py, with mutants of it) and the renders' against the golden model
(tests/test_render.py); this checks that it is not dead code that leaves everything to golden's
chain, which would give the same pictures at the old cost."""

from __future__ import annotations

import pytest

from netsushisen.isa.config import load_config
from netsushisen.pipeline import render


def _pcs_of(program, text: str) -> list[int]:
    """Bundle addresses holding an operation of a source line that contains `text`."""
    return [pc for pc, locs in enumerate(program.op_sources) if any(text in loc.text for loc in locs)]


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
@pytest.mark.parametrize("spec,branch", [("rings:2", "bnez c_ego"), ("balls:2", "bnez s_ego")])
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
