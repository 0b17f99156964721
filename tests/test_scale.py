"""A scene too small for a precision is refused on the golden model and the machine alike, with a
located message (host/scale.py, issue 29); a small scene within the limit renders as the unscaled
one does; `numerics` on a refused scene exits 1 with the reason, never 70."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.isa.errors import NetsushisenError
from netsushisen.host import golden
from netsushisen.host.nff import parse_nff
from netsushisen.host.scale import check_scale, minimum_length
from netsushisen.isa.config import MachineConfig
from netsushisen.numerics import MIXED

_POINTS = ("s", "c", "l", "from", "at", "hither")


def scaled(text: str, k: float) -> str:
    """The NFF text with every position and length multiplied by k (not counts, colours, angles)."""
    out = []
    for line in text.splitlines():
        t = line.split()
        if t and (t[0] in _POINTS or t[0][0] in "-0123456789."):
            line = " ".join(t[:1] + [repr(float(v) * k) for v in t[1:]]) if t[0] in _POINTS else \
                " ".join(repr(float(v) * k) for v in t)
        out.append(line)
    return "\n".join(out) + "\n"


def test_limits_per_precision():
    assert 3e-16 < minimum_length("fp32") < 4e-16 and minimum_length("fp64") < 1e-145


@pytest.mark.parametrize("k", [1e-20, 1e-30])
def test_too_small_is_refused_on_golden_and_machine(cli, tmp_path, k):
    path = tmp_path / "tiny.nff"
    path.write_text(scaled(MIXED, k))
    with pytest.raises(NetsushisenError, match="smallest length"):
        check_scale(parse_nff(path.read_text(), str(path)), "fp32")
    for argv in (("golden", str(path), "--res", "4", "-o", str(tmp_path / "g.png")),
                 ("render", str(path), "--res", "4", "-q", "-o", str(tmp_path / "m.png")),
                 ("numerics", str(path), "--res", "4", "--out", str(tmp_path / "n"))):
        code, _, err = cli(*argv)
        assert code == 1, (argv, err)
        assert err.strip().startswith(str(path)) and "smallest length" in err and "Traceback" not in err
        assert len(err.strip().splitlines()) == 1


def test_small_within_the_limit_renders_as_the_unscaled_scene():
    big, small = parse_nff(MIXED, "m"), parse_nff(scaled(MIXED, 1e-5), "s")
    a = golden.render(big, MachineConfig(), res=8, precision="fp32")
    b = golden.render(small, MachineConfig(), res=8, precision="fp32")
    assert np.array_equal(a.hit_ids, b.hit_ids) and np.array_equal(a.image_u8, b.image_u8)
