"""`paper --on-machine` beyond per-word counters: per-reference counts from IC's recorded load
stream (netsushisen/paper_machine.py) against the trace-driven sweep's, and the ray-order study
(the machine's stream mapped back to the sweep's reference layout and replayed)."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.emulator.loads import LoadStream
from netsushisen.host.golden import render as golden_render
from netsushisen.host.ic_access import load_primitives, to_reference
from netsushisen.isa.config import load_config
from netsushisen.isa.regions import GLOBAL
from netsushisen.paper import analyse_scene
from netsushisen.paper_machine import (machine_check, ray_order_study, reference_check,
                                       trace_references)
from netsushisen.reports.paper_data import PaperOptions

SMALL = ["ic_memory.cache_share=0.1", "ic_memory.resident_share=0.1"]


def _config():
    return load_config(None, SMALL)


def test_per_reference_counts_on_the_machine_equal_the_sweeps(engine_name):
    out = machine_check("mount:2", 6, _config(), engine_name)
    assert out["equal"] and out["ref_equal"], (out["difference"], out["ref_difference"])
    m = out["ref_machine"]
    assert m["ref.resident"] > 0 and 0 < m["ref.hits"] < m["ref.cache"]


@pytest.fixture(scope="module")
def serial_run():
    from netsushisen.pipeline import render

    r = render("mount:2", _config(), res=6, slots=1, defines={"SERIAL_TREES": 1},
               engine="reference", record_loads=True)
    setup = r.setup
    golden = golden_render(setup.scene, setup.config, res=6, keep_trace=True,
                           grid=setup.images.layout.grid)
    return setup, golden, r.engine.recorder.stream("pe0.ic")


def test_a_changed_stream_makes_the_reference_check_differ(serial_run):
    """The check is not blind: one hit flag turned into a miss (a reference through the cache
    then misses), or one test's list cells dropped (that fetch is no reference any more),
    makes it name the count that moved."""
    setup, golden, s = serial_run
    assert reference_check(setup, golden, [s])["ref_equal"]
    prim, _ = load_primitives(setup.images.layout, s.space, s.address)
    # the first load of a reference through the cache, which hit
    cand = np.flatnonzero((prim >= 0) & (s.space == GLOBAL) & s.hit & (np.roll(prim, 1) == -1))
    hit = s.hit.copy()
    hit[cand[0]] = False
    got = reference_check(setup, golden, [LoadStream(s.space, s.address, hit)])
    assert not got["ref_equal"] and got["ref_difference"].startswith("ref.hits:")
    assert got["ref_machine"]["ref.hits"] == got["ref_trace"]["ref.hits"] - 1
    cells = np.flatnonzero(prim < 0)[:2]
    keep = np.ones(len(prim), bool)
    keep[cells] = False
    got = reference_check(setup, golden, [LoadStream(s.space[keep], s.address[keep], s.hit[keep])])
    assert not got["ref_equal"] and "ref." in got["ref_difference"]
    want = trace_references(setup, golden)
    assert got["ref_machine"]["ref.resident"] + got["ref_machine"]["ref.cache"] == \
        want["ref.resident"] + want["ref.cache"] - 1


def test_loads_map_back_to_the_reference_layout(serial_run):
    from netsushisen.host.databases import plan_layout
    from netsushisen.host.ic_access import ordered_stream_chunks, machine_order
    from netsushisen.paper_sweep import sized_config

    setup, golden, s = serial_run
    lay = setup.images.layout
    assert np.any(lay.record_space != GLOBAL)  # some records resident: the mapping moves them
    reference = plan_layout(setup.scene, sized_config(setup.config, 1, 0.0, 0.0),
                            setup.prepass.priorities, lay.grid)
    want = np.concatenate([a for _, a in ordered_stream_chunks(reference, golden,
                                                               machine_order(golden))])
    assert np.array_equal(to_reference(lay, reference, s.space, s.address), want)
    with pytest.raises(ValueError, match="in no shape record"):
        load_primitives(lay, np.array([GLOBAL]), np.array([lay.list_words
                                                           + int(lay.shape_words) + 5]))


@pytest.mark.parametrize("options", [PaperOptions(), PaperOptions("records+lists", "cache")],
                         ids=["records-local", "records+lists-cache"])
def test_ray_order_study_in_serial_mode_is_the_trace_path(options):
    """The study's machinery, fed the machine's serial-mode stream, gives the trace-driven
    path's Figures 4–5 exactly (so what moves in the normal mode is the order)."""
    config = load_config()
    study = ray_order_study("mount:2", 6, config, "compiled", options=options, serial=True)
    trace = analyse_scene("mount:2", 6, config, options=options)
    assert study["fig4"] == trace.fig4 and study["fig5"] == trace.fig5
    normal = ray_order_study("mount:2", 6, config, "compiled", options=options)
    assert normal["loads"] == study["loads"] and normal["fig5"] != study["fig5"]


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
def test_pes_split_the_trace_as_the_machine_splits_the_pixels(engine_name):
    """Four PEs in serial mode: each PE's IC counters equal the trace-driven model of its own
    pixels' rays (static distribution: sample i to PE i mod 4) on its own memories, and the
    per-reference counts summed over the PEs equal the sweep's split replay."""
    config = load_config(None, SMALL + ["pes=4"])
    out = machine_check("mount:2", 6, config, engine_name)
    assert out["equal"] and out["ref_equal"], (out["difference"], out["ref_difference"])
    one = machine_check("mount:2", 6, _config(), engine_name)
    # same references, but four cold caches miss more than one
    assert (out["ref_machine"]["ref.resident"] + out["ref_machine"]["ref.cache"]
            == one["ref_machine"]["ref.resident"] + one["ref_machine"]["ref.cache"])
    assert out["ref_machine"]["ref.hits"] < one["ref_machine"]["ref.hits"]


def test_pe_orders_partition_the_serial_order(serial_run):
    from netsushisen.host.ic_access import machine_order, pe_orders

    _, golden, _ = serial_run
    parts = pe_orders(golden, 4)
    assert sorted(np.concatenate(parts).tolist()) == sorted(machine_order(golden).tolist())
    for k, o in enumerate(parts):
        assert np.all(golden.trace_pixel[o] % 4 == k)
        assert np.all(np.diff(golden.trace_pixel[o]) >= 0)  # pixel by pixel
