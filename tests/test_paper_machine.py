"""`paper --on-machine` beyond per-word counters: per-reference counts from IC's recorded load
stream (netsushisen/paper_machine.py) against the trace-driven sweep's, and the ray-order study
(the machine's stream mapped back to the sweep's reference layout and replayed)."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.emulator.loads import LoadStream
from netsushisen.host.catalog import load_scene
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


# -- the findings' reading on the machine (lists in IC's local memory) -----------------------------


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
def test_lists_local_render_is_the_same_picture_and_its_counters_are_the_findings(engine_name):
    """IC built with LISTS_LOCAL reads the list cells from its local memory: the same image
    and ids as the default build, the same list loads now local reads (none through the cache),
    and its counters and per-reference counts equal the trace path's in the findings' reading
    (`SweepStream(lists_cached=False)`: list loads `local.primitive_list`)."""
    from netsushisen.pipeline import render
    from netsushisen.paper_machine import FINDINGS_LOCAL_WORDS, findings_config

    config = findings_config(load_scene("mount:2"), load_config(None, SMALL))
    assert config.ic.local_words == FINDINGS_LOCAL_WORDS and config.ic_memory.cache_share is None
    kw = dict(res=6, slots=1, defines={"SERIAL_TREES": 1}, engine=engine_name)
    default, local = render("mount:2", config, **kw), render("mount:2", config, lists_local=True, **kw)
    assert np.array_equal(default.hit_ids, local.hit_ids)
    assert np.array_equal(default.image_u8, local.image_u8)
    d, m = default.stats["memory"]["pe0.ic"], local.stats["memory"]["pe0.ic"]
    assert "global.primitive_list" not in m["regions"]
    assert m["regions"]["local.primitive_list"]["accesses"] \
        == d["regions"]["global.primitive_list"]["accesses"] > 0
    assert m["cache"]["accesses"] == d["regions"]["global.shape_data"]["accesses"]
    classic = render("mount:2", config, lists_local=True, kernel_dir="classic", **kw)
    assert np.array_equal(classic.hit_ids, default.hit_ids)  # the classic set reads them too
    assert classic.stats["memory"]["pe0.ic"]["regions"]["local.primitive_list"] \
        == m["regions"]["local.primitive_list"]
    out = machine_check("mount:2", 6, load_config(None, SMALL), engine_name, lists_local=True)
    assert out["equal"] and out["ref_equal"], (out["difference"], out["ref_difference"])
    refs = out["ref_machine"]
    assert refs["local.primitive_list"] == m["regions"]["local.primitive_list"]["accesses"]
    assert refs["ref.resident"] > 0 and 0 < refs["ref.hits"] < refs["ref.cache"]


@pytest.fixture(scope="module")
def lists_local_run():
    from netsushisen.pipeline import render
    from netsushisen.paper_machine import findings_config

    config = findings_config(load_scene("mount:2"), load_config(None, SMALL))
    r = render("mount:2", config, res=6, slots=1, defines={"SERIAL_TREES": 1},
               engine="compiled", record_loads=True, lists_local=True)
    golden = golden_render(r.setup.scene, r.setup.config, res=6, keep_trace=True,
                           grid=r.setup.images.layout.grid)
    return r, golden


def test_the_wrong_reading_makes_the_lists_local_check_differ(lists_local_run):
    """The findings' reading on the machine is compared in that reading only: the trace path
    with the lists cached (the machine's default reading) gives other cache hits."""
    from netsushisen.emulator.loads import LOCAL
    from netsushisen.paper_machine import local_lists

    r, golden = lists_local_run
    s = local_lists(r.engine.recorder.stream("pe0.ic"))
    assert np.count_nonzero(s.space == LOCAL) \
        == r.stats["memory"]["pe0.ic"]["regions"]["local.primitive_list"]["accesses"]
    right = reference_check(r.setup, golden, [s], lists_cached=False)
    assert right["ref_equal"], right["ref_difference"]
    wrong = reference_check(r.setup, golden, [s], lists_cached=True)
    assert not wrong["ref_equal"] and wrong["ref_difference"].startswith("ref.hits:")
    assert wrong["ref_trace"]["ref.hits"] < right["ref_trace"]["ref.hits"]
    # the machine's stream with the list loads dropped is no longer the findings' stream
    keep = s.space != LOCAL
    short = LoadStream(s.space[keep], s.address[keep], s.hit[keep])
    got = reference_check(r.setup, golden, [short], lists_cached=False)
    assert not got["ref_equal"] and "local.primitive_list" in got["ref_difference"]


def test_lists_that_do_not_fit_ic_local_memory_are_a_config_error():
    from netsushisen.host.databases import IC_LISTS_BASE, build_images
    from netsushisen.isa.errors import ConfigError

    scene = load_scene("mount:2")
    config = load_config(None, [f"ic.local_words={IC_LISTS_BASE + 10}"])
    assert build_images(scene, config).ic_local is None  # the default build: nothing placed
    with pytest.raises(ConfigError, match=r"the lists \(\d+ words\) at IC local address 4096 do "
                                          r"not fit ic.local_words = 4106; raise ic.local_words"):
        build_images(scene, config, lists_local=True)
