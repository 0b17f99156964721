"""Recording a processor's database loads (emulator/loads.py, `Engine.record_loads`): both
engines record the same stream, it sums to the per-word counters, and in the serial ray-tree
mode it is the golden trace's IC access stream in machine order, load by load."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.emulator.loads import LoadRecorder, LoadStream, encode
from netsushisen.emulator.tracesim import TraceCache
from netsushisen.host.golden import render as golden_render
from netsushisen.host.ic_access import machine_order, ordered_stream_chunks
from netsushisen.isa.config import load_config
from netsushisen.isa.regions import GLOBAL, RESIDENT

SMALL = ["ic_memory.cache_share=0.1", "ic_memory.resident_share=0.1"]
"""Small memories: some records resident, the cache misses now and then."""


def _render(engine: str, slots: int = 1, pes: int = 1):
    from netsushisen.pipeline import render

    config = load_config(None, SMALL + ([f"pes={pes}"] if pes > 1 else []))
    defines = {"SERIAL_TREES": 1} if slots == 1 else {}
    r = render("mount:2", config, res=6, slots=slots, defines=defines, engine=engine,
               record_loads=True)
    assert r.run.status in ("halted", "finished"), r.run
    return r


@pytest.fixture(scope="module")
def reference_serial():
    return _render("reference")


def _same(a: LoadStream, b: LoadStream) -> bool:
    return (np.array_equal(a.space, b.space) and np.array_equal(a.address, b.address)
            and np.array_equal(a.hit, b.hit))


def test_codes_round_trip():
    codes = np.array([encode(5, True, False), encode(7, False, True), encode(1 << 30, False, False)])
    s = LoadStream.decode(codes)
    assert s.space.tolist() == [RESIDENT, GLOBAL, GLOBAL]
    assert s.address.tolist() == [5, 7, 1 << 30] and s.hit.tolist() == [False, True, False]
    assert s.counts() == {"resident": 1, "cache": 2, "hits": 1, "misses": 1}


def test_recorder_keeps_pieces_in_order_or_hands_them_to_a_sink():
    rec = LoadRecorder(["pe0.ic"])
    rec.buffer("pe0.ic").extend([encode(1, True, False)])
    rec.add("pe0.ic", np.array([encode(2, False, True)]))  # the appended codes come first
    assert rec.stream("pe0.ic").address.tolist() == [1, 2]
    got = []
    rec = LoadRecorder(["pe0.ic"], sink=lambda p, c: got.append((p, c.tolist())))
    rec.add("pe0.ic", np.array([8]))
    assert got == [("pe0.ic", [8])] and len(rec.stream("pe0.ic")) == 0


def test_recording_is_off_by_default(engine_name):
    from netsushisen.pipeline import prepare

    setup = prepare("mount:2", load_config(), res=4)
    eng = setup.engine(engine_name)
    assert eng.recorder is None
    assert all(core.memory.record is None for core in eng.machine.cores)
    with pytest.raises(KeyError, match="no processor"):
        eng.record_loads(["pe7.ic"])


def test_stream_sums_to_the_counters_and_is_the_traces_in_serial_mode(engine_name,
                                                                     reference_serial,
                                                                     monkeypatch):
    """Each engine's stream (the compiled engine's through a buffer of 64 loads, so it is
    handed back between many chunks) equals the reference engine's, sums to IC's per-word
    counters, and in serial mode is the golden trace's stream in machine order with the cache
    hits of the trace-driven cache."""
    from netsushisen.emulator.compiled import state

    monkeypatch.setattr(state, "RECORD_CAPACITY", 64)
    r = _render(engine_name)
    s = r.engine.recorder.stream("pe0.ic")
    assert _same(s, reference_serial.engine.recorder.stream("pe0.ic"))
    m = r.stats["memory"]["pe0.ic"]
    c = s.counts()
    assert c["resident"] == m["resident"]["accesses"] > 0
    assert (c["cache"], c["hits"], c["misses"]) == (m["cache"]["accesses"], m["cache"]["hits"],
                                                    m["cache"]["misses"])
    assert 0 < c["misses"] < c["cache"]
    setup = r.setup
    golden = golden_render(setup.scene, setup.config, res=6, keep_trace=True,
                           grid=setup.images.layout.grid)
    parts = list(ordered_stream_chunks(setup.images.layout, golden, machine_order(golden)))
    space = np.concatenate([p[0] for p in parts])
    address = np.concatenate([p[1] for p in parts])
    assert np.array_equal(s.space, space) and np.array_equal(s.address, address)
    cache = r.stats["memory"]["pe0.ic"]["cache"]
    model = TraceCache(cache["sets"] * cache["block_bytes"], cache["block_bytes"],
                       setup.config.word_bytes)
    assert np.array_equal(s.hit[s.space == GLOBAL], model.replay(address[space == GLOBAL]))


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
def test_normal_mode_and_several_pes_record_alike(engine_name, monkeypatch):
    """Several rays in flight on two PEs: each IC's stream, recorded on its own, equals the
    reference engine's and sums to that IC's counters."""
    from netsushisen.emulator.compiled import state

    monkeypatch.setattr(state, "RECORD_CAPACITY", 100)
    runs = {e: _render(e, slots=8, pes=2) for e in {"reference", engine_name}}
    r = runs[engine_name]
    assert r.engine.recorder.processors == ["pe0.ic", "pe1.ic"]
    for pe in ("pe0.ic", "pe1.ic"):
        s = r.engine.recorder.stream(pe)
        assert len(s) > 0 and _same(s, runs["reference"].engine.recorder.stream(pe))
        m = r.stats["memory"][pe]
        assert s.counts()["cache"] == m["cache"]["accesses"]
        assert s.counts()["hits"] == m["cache"]["hits"]


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
def test_each_pes_stream_is_its_pixels_serial_trace(engine_name):
    """Four PEs in serial mode: PE k's IC loads are, load by load, the golden trace's stream of
    the pixels k, k + 4, ... in machine order (`pe_orders`: the static distribution) — what the
    trace-driven path's PE-count reading replays."""
    from netsushisen.host.ic_access import pe_orders

    r = _render(engine_name, slots=1, pes=4)
    setup = r.setup
    golden = golden_render(setup.scene, setup.config, res=6, keep_trace=True,
                           grid=setup.images.layout.grid)
    for k, order in enumerate(pe_orders(golden, 4)):
        s = r.engine.recorder.stream(f"pe{k}.ic")
        parts = list(ordered_stream_chunks(setup.images.layout, golden, order))
        assert len(s) > 0 and np.array_equal(s.address, np.concatenate([p[1] for p in parts]))
        assert np.array_equal(s.space, np.concatenate([p[0] for p in parts]))
