"""The engine interface (emulator/engine.py) and the compiled engine's state layout table
(emulator/compiled/state.py: ARRAYS, LAYOUT), from which flatten, write-back and the tandem
comparison are derived (docs/engines.md)."""

from __future__ import annotations

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.engine import ENGINES, Engine, ReferenceEngine, engine_names
from netsushisen.isa.config import load_config
from netsushisen.isa.images import image_from_json

pytestmark = pytest.mark.skipif("compiled" not in engine_names(),
                                reason="the compiled engine does not import (numba missing)")

SOURCES = {
    "ic": """
        li r1, 3
    loop:
        ldg r2, [r1 + 0]
        ldg r3, [r1 + 64]
        addi r1, r1, 1
        slti r4, r1, 40
        bnez r4, loop
        send ring, r0
        halt
    """,
    "os": "recv r1, ring\nhalt\n",
}


def _image():
    return image_from_json({"icgm": [float(i) for i in range(128)]})


def _programs():
    return {p: assemble_text(s, proc=p) for p, s in SOURCES.items()}


def test_the_interface_is_abstract_and_every_engine_implements_it():
    config = load_config(None, [])
    with pytest.raises(TypeError):
        Engine(config, _programs())  # run and step are each engine's own
    for name, cls in ENGINES.items():
        assert issubclass(cls, Engine) and cls.name == name
        assert not getattr(cls, "__abstractmethods__", None), name
    assert ReferenceEngine is not Engine


def test_layout_round_trip_restores_every_field():
    """flatten a machine caught mid-run, write the arrays back into a fresh machine: every
    field the tandem engine compares agrees — the table covers what the run changed."""
    from netsushisen.emulator.compiled import state as S
    from netsushisen.emulator.compiled.tandem import canonical, first_difference

    config = load_config(None, [])
    ran = ReferenceEngine(config, _programs(), _image())
    ran.step(57)
    assert ran.status is None
    assert ran.machine.pes[0].memories["ic"].cache.accesses > 0
    fresh = ReferenceEngine(config, _programs(), _image())
    st = S.flatten(ran.machine)
    S.write_back(st, fresh.machine)
    assert first_difference(canonical(ran.machine), canonical(fresh.machine)) is None
    # and a table field written back wrong is caught by name
    st.arrays["cs"][1, S.C_CACHE_HITS] += 1
    S.write_back(st, fresh.machine)
    field, ref, comp = first_difference(canonical(ran.machine), canonical(fresh.machine))
    assert field == "pe0.ic.cache.hits" and int(comp, 16) == int(ref, 16) + 1


def test_arrays_table_gives_the_loop_its_arguments():
    from netsushisen.emulator.compiled import state as S

    st = S.flatten(ReferenceEngine(load_config(None, []), _programs(), _image()).machine)
    assert set(st.arrays) == set(S.ARRAYS)
    for name, spec in S.ARRAYS.items():
        if spec.dtype in ("int64", "int32", "float64"):
            assert str(st.arrays[name].dtype) == spec.dtype, name
    assert S.READ_ONLY == {k for k, v in S.ARRAYS.items() if v.read_only}
    assert "ctags" not in S.READ_ONLY and "ops" in S.READ_ONLY
