"""The kernels' message protocol, read from kernels/protocol.inc (defined once, used by the
kernels and by Python)."""

from __future__ import annotations

import pytest

from netsushisen.asm.assembler import AssemblyError, read_constants
from netsushisen.host.golden import EYE, REFLECTION, REFRACTION, SHADOW
from netsushisen.isa.ring import DESTS, parse_header
from netsushisen.kernels import protocol


def test_headers_decode_to_their_tag_destination_length_and_class():
    p = protocol()
    expect = {  # header: (tag, dest, length, class)
        "HDR_RAY_TO_OS": (p["TAG_RAY"], "os", 13, 0), "HDR_VISIT_FIRST": (p["TAG_VISIT_FIRST"], "ic", 18, 0),
        "HDR_VISIT": (p["TAG_VISIT"], "ic", 5, 0), "HDR_NEXT": (p["TAG_NEXT"], "os", 1, 1),
        "HDR_DONE": (p["TAG_DONE"], "os", 1, 1), "HDR_HIT": (p["TAG_HIT"], "sc", 20, 0),
        "HDR_COLOR": (p["TAG_COLOR"], "sc", 4, 0), "HDR_PIXEL": (0, "col", 4, 0),
        "HDR_ID": (p["TAG_ID"], "col", 2, 0), "HDR_MISS": (p["TAG_MISS"], "sc", 4, 0),
        "HDR_SHADED": (p["TAG_SHADED"], "os", 1, 0),
    }
    for name, (tag, dest, length, cls) in expect.items():
        h = parse_header(p[name])
        assert (h.tag, h.dest, h.length, h.cls) == (tag, DESTS[dest], length, cls), name
    assert len({p[k] for k in p if k.startswith("TAG_")}) == 10


def test_a_visit_carries_a_second_leaf_or_none():
    """VISIT / VISIT_FIRST end with a second leaf B (cell_B, t_exit_B), so IC walks two leaves of
    a ray per message; cell_B = CELL_NONE (no list cell has a negative address) when OS has none."""
    p = protocol()
    assert p["LEN_VISIT"] == 3 + 2 and p["LEN_VISIT_FIRST"] == 3 + p["RAY_WORDS"] + 2
    assert p["CELL_NONE"] < 0


def test_shaded_follows_the_rays_sc_sent_before_it():
    """Serial mode (SERIAL_TREES): SHADED (pixel) goes SC -> OS in RAY's buffer class, so on the
    SC -> OS link it never overtakes the RAYs of the hit it reports."""
    p = protocol()
    assert (p["TAG_SHADED"], p["LEN_SHADED"]) == (10, 1)
    shaded, ray = parse_header(p["HDR_SHADED"]), parse_header(p["HDR_RAY_TO_OS"])
    assert (shaded.dest, shaded.cls) == (ray.dest, ray.cls) == (DESTS["os"], p["CLS_WORK"])
    assert p["CLS_WORK"] != p["CLS_ANSWER"]
    assert "SERIAL_TREES" not in p  # a kernel switch (default 0 in os.s and sc.s), not a constant


def test_ray_kinds_match_the_golden_model():
    p = protocol()
    assert (p["KIND_EYE"], p["KIND_REFLECTION"], p["KIND_REFRACTION"], p["KIND_SHADOW"]) == \
        (EYE, REFLECTION, REFRACTION, SHADOW)


def test_read_constants_reports_errors(tmp_path):
    bad = tmp_path / "bad.inc"
    bad.write_text(".equ A, 1\n.equ B, A +\n")
    with pytest.raises(AssemblyError) as exc:
        read_constants(bad)
    assert "bad.inc:2" in exc.value.format()
    ok = tmp_path / "ok.inc"
    ok.write_text(".equ A, 2\n.if X\n.equ B, A * 3\n.endif\n")
    assert read_constants(ok, {"X": 1}) == {"A": 2, "B": 6}
