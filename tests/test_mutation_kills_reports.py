"""Tests written to kill mutants that survived tools/mutate.py in emulator/tracesim.py
(docs/mutation.md): every expected number worked out by hand in the comments."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from netsushisen.host.databases import GLOBAL, plan_layout
from netsushisen.host.catalog import load_scene
from netsushisen.isa.config import MachineConfig
from netsushisen.emulator.tracesim import SweepStream, TraceMemory


def test_sweep_figures_by_hand():
    # 10 resident loads and 50 cache accesses (30 shape data + 20 list cells) of which 20 hit
    # (15 + 5); t_r, t_c, t_g = 1, 2, 8.
    # all:   rho = 10/60, mu = 20/50 = 0.4, t = (10*1 + 20*2 + 30*8)/60 = 290/60,
    #        model = rho + (1 - rho)(8 - 6 mu) = 1/6 + 5/6 * 5.6 = 290/60
    # shape: rho = 10/40 = 0.25, mu = 15/30 = 0.5, t = (10 + 15*2 + 15*8)/40 = 4,
    #        model = 0.25 + 0.75 * (8 - 3) = 4
    # ref (per primitive reference): 4 resident, 8 through the cache of which 6 hit:
    #        rho = 1/3, mu = 0.75, t = (4 + 6*2 + 2*8)/12 = 32/12, model = 1/3 + 2/3 * 3.5 = 32/12
    counts = {"resident.shape_data": 10, "local.primitive_list": 0, "global.shape_data": 30,
              "global.primitive_list": 20, "hits.shape_data": 15, "hits.primitive_list": 5,
              "ref.resident": 4, "ref.cache": 8, "ref.hits": 6}
    f = SweepStream.figures(SimpleNamespace(counts=counts))
    assert f["all"]["loads"] == 60 and f["all"]["resident"] == 10 and f["all"]["cache_hits"] == 20
    assert f["all"]["rho"] == pytest.approx(1 / 6) and f["all"]["mu"] == pytest.approx(0.4)
    assert f["all"]["miss_rate"] == pytest.approx(0.6)
    assert f["all"]["t_measured"] == pytest.approx(290 / 60)
    assert f["all"]["t_model"] == pytest.approx(290 / 60)
    assert f["shape"]["loads"] == 40 and f["shape"]["rho"] == pytest.approx(0.25)
    assert f["shape"]["mu"] == pytest.approx(0.5)
    assert f["shape"]["t_measured"] == pytest.approx(4.0) and f["shape"]["t_model"] == pytest.approx(4.0)
    assert f["ref"]["loads"] == 12 and f["ref"]["rho"] == pytest.approx(1 / 3)
    assert f["ref"]["mu"] == pytest.approx(0.75) and f["ref"]["miss_rate"] == pytest.approx(0.25)
    assert f["ref"]["t_measured"] == pytest.approx(32 / 12)
    assert f["ref"]["t_model"] == pytest.approx(32 / 12)


@pytest.mark.parametrize("addresses, bad", [([0, 5, 100, 7], 100), ([3, -2, 60], -2)])
def test_trace_memory_names_the_first_address_outside(addresses, bad):
    mem = TraceMemory(128, 64, 4, resident_words=0, global_words=50)
    with pytest.raises(ValueError, match=rf"^global memory address {bad} is outside 0\.\.49$"):
        mem.replay(np.full(len(addresses), GLOBAL), np.array(addresses))


def test_sweep_runs_cut_at_a_new_record_a_step_back_or_a_gap():
    # every record in ICGM; with no configuration the longest step within a run is one word
    cfg = MachineConfig()
    cfg.ic_memory.resident_share = 0.0
    lay = plan_layout(load_scene("tetra:1"), cfg)
    p = int(np.argmax(lay.record_size))
    a = int(lay.record_address[p])
    assert lay.record_size[p] >= 3
    stream = SweepStream(lay, [], cfg.word_bytes)
    # a list cell pair (1, 2); record p's words a, a+1, a+2; back to a; a gap of 2 to a+2
    r = stream.runs(np.array([1, 2, a, a + 1, a + 2, a, a + 2]))
    first, span, loads, prim = r.first, r.span, r.loads, r.prim
    assert first.tolist() == [1, a, a, a + 2]
    assert span.tolist() == [1, 2, 0, 0]
    assert loads.tolist() == [2, 3, 1, 1]
    assert prim.tolist() == [-1, p, p, p]
