"""The ring cannot deadlock: OS never blocks in `send` (docs/kernels.md "Deadlock freedom").

With FIFOs as shallow as the kernels allow (the longest message, HIT: 21 words) the old OS
deadlocked: OS blocked sending a VISIT to IC, IC sending a HIT to SC, SC sending a RAY to OS,
whose receive FIFO was full — a cycle of full FIFOs. Now OS checks `room` before every message and,
while it does not fit, drains the ring (RAY into the overflow queue, DONE frees its slot, NEXT is
put aside for `main`). The renders must still agree with the golden model exactly: ray counts, hit
ids, IC references per primitive. The renders run once per engine (`engine_name`,
tests/conftest.py; marked `heavy`, so the reference and tandem runs are under `-m slow`);
results are read from the render's statistics and buffers. That a deadlock, when one happens,
ends alike on both engines (exit code, report, statistics) is tests/test_engine_identity.py's.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from netsushisen.emulator.stats import ic_reference_counts
from netsushisen.pipeline import longest_message, render
from netsushisen.isa.errors import ConfigError
from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import render as golden_render
from netsushisen.isa.config import load_config
from netsushisen.kernels import protocol

pytestmark = pytest.mark.heavy  # kernel renders: [reference] under -m slow (tests/conftest.py)

RES = 8
MIN_DEPTH = longest_message()[1]


def test_the_minimum_depth_is_the_longest_message():
    p = protocol()
    assert longest_message() == ("HIT", 1 + p["LEN_HIT"]) == ("HIT", 21)
    assert MIN_DEPTH >= 1 + p["LEN_VISIT_FIRST"]  # OS's longest message fits its send FIFO


@lru_cache(maxsize=None)
def _golden(spec: str):
    return golden_render(load_scene(spec), load_config(None, []), res=RES)


def _check(spec: str, sets: list[str], engine: str, **kw):
    scene = load_scene(spec)
    machine = render(scene, load_config(None, sets), res=RES, engine=engine, **kw)
    golden = _golden(spec)
    assert machine.run.status == "finished", machine.run.error and machine.run.error.format()
    assert machine.rays == golden.rays
    np.testing.assert_array_equal(machine.hit_ids, golden.hit_ids)
    diff = np.abs(machine.image_u8.astype(int) - golden.image_u8.astype(int)).max(axis=2)
    assert np.mean(diff <= 2) >= 0.995
    assert np.array_equal(ic_reference_counts(machine.stats, scene.n_primitives), golden.references)
    assert machine.visible_primitives == golden.visible_primitives
    return machine


def _os_bundles_at(machine, label: str) -> int:
    program = machine.setup.programs["os"]
    pc = program.labels[label][1]
    return machine.stats["processors"]["pe0.os"]["bundles_by_pc"].get(str(pc), 0)


@pytest.mark.parametrize("pool", [True, False], ids=["buffer_pool", "no_buffer_pool"])
@pytest.mark.parametrize("spec", ["rings:2", "balls:2"])
def test_shallowest_fifos_do_not_deadlock(spec, pool, engine_name):
    """These configurations deadlocked before; now OS drains the ring while its send FIFO is full
    (the drain really runs: rays queued, DONEs taken, NEXTs deferred and resumed)."""
    machine = _check(spec, [f"ring.fifo_depth={MIN_DEPTH}", f"ring.buffer_pool={str(pool).lower()}"],
                     engine_name)
    assert _os_bundles_at(machine, "drain_next") > 0
    assert _os_bundles_at(machine, "from_defer") == _os_bundles_at(machine, "drain_next")
    assert _os_bundles_at(machine, "drain_done") > 0


def test_serial_mode_with_the_shallowest_fifos(engine_name):
    _check("mount:2", [f"ring.fifo_depth={MIN_DEPTH}"], engine_name, slots=1,
           defines={"SERIAL_TREES": 1})


def test_fifos_shallower_than_the_longest_message_are_rejected():
    config = load_config(None, [f"ring.fifo_depth={MIN_DEPTH - 1}"])
    with pytest.raises(ConfigError) as err:
        render("rings:2", config, res=RES)
    text = err.value.format()
    assert "\n" not in text and text.startswith("config: error: ring.fifo_depth must be at least 21")
    assert "HIT" in text and f"got {MIN_DEPTH - 1}" in text
