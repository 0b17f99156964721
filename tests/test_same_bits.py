"""Same inputs, same bits — on every x86-64 CPU and library build, not just on this one.

What a CPU changes under the same wheels: OpenBLAS picks its kernels by the CPU (with FMA or not,
another summation order: numpy's `@`, `dot` and 1-D `linalg.norm` go through it), numpy picks
its SIMD loops (sin, cos, exp, power: `NPY_DISABLE_CPU_FEATURES`), and glibc picks FMA or plain
variants of pow, sin, exp … (`GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA`). The host's arithmetic
(camera, rays, shape records, grid, oracle) uses IEEE basic operations in a fixed order and
`fpow` is isa/libm.py's, so none of these may change a golden image, an id or a pow result. Each
test runs the same work in a child process under those switches (the ones this CPU can take:
they only turn features off) and compares bytes.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SWITCHES = {
    "OPENBLAS_CORETYPE": "Prescott",
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",
    "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA",
}


@functools.lru_cache(maxsize=None)
def _plain(code: str) -> str:
    """The code's output with no switch (once per module)."""
    return _child(code)


def _child(code: str, **env: str) -> str:
    full = {**os.environ, **env}
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:  # numpy < 2
        features = {}
    if "NPY_DISABLE_CPU_FEATURES" in env:  # numpy refuses to disable what it cannot dispatch to
        from numpy._core._multiarray_umath import __cpu_dispatch__ as dispatch
        full["NPY_DISABLE_CPU_FEATURES"] = " ".join(f for f in env["NPY_DISABLE_CPU_FEATURES"].split()
                                                    if f in dispatch and features.get(f))
        if not full["NPY_DISABLE_CPU_FEATURES"]:
            del full["NPY_DISABLE_CPU_FEATURES"]
    out = subprocess.run([sys.executable, "-c", code], env=full, capture_output=True, text=True,
                         timeout=240)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip()


POW = """
import hashlib, numpy as np
from netsushisen.isa.libm import machine_pow_array
rng = np.random.default_rng(7)
a = rng.random(4000) * 3; b = rng.random(4000) * 60 - 30; b[::4] = np.round(b[::4])
print(hashlib.sha256(machine_pow_array(a, b).tobytes()
                     + machine_pow_array(a.astype(np.float32), b.astype(np.float32)).tobytes()).hexdigest())
"""

GOLDEN = """
import hashlib, sys
from netsushisen.host.catalog import load_scene
from netsushisen.host.golden import render
h = hashlib.sha256()
for name in ("balls", "tetra"):
    r = render(load_scene(name), res=12)
    h.update(r.hit_ids.tobytes()); h.update(r.image.tobytes()); h.update(r.image_u8.tobytes())
print(h.hexdigest())
"""


@pytest.mark.parametrize("switch", sorted(SWITCHES))
def test_fpow_gives_the_same_bits_whatever_the_cpu_dispatches(switch):
    """glibc's pow under `-FMA` rounds other bits (the old `fpow` failed this test)."""
    assert _child(POW, **{switch: SWITCHES[switch]}) == _plain(POW)


def test_golden_images_and_ids_whatever_the_cpu_dispatches():
    """balls (Phong highlights through fpow, spheres) and tetra (polygons) at 12×12: one child with
    every switch on, one with none."""
    assert _child(GOLDEN, **SWITCHES) == _plain(GOLDEN)


def test_the_coplanar_scene_text_is_the_same_bits_under_another_blas():
    """The numerics test's scene is built with basic operations (its old `np.linalg.norm` / `@`
    went through BLAS and gave this very test another scene on an AVX-512 machine)."""
    code = ("import hashlib, importlib.util; s = importlib.util.spec_from_file_location('t', %r); "
            "t = importlib.util.module_from_spec(s); s.loader.exec_module(t); "
            "print(hashlib.sha256(t._plane_scene(t._coplanar).encode()).hexdigest())"
            % str(Path(__file__).with_name("test_numerics_cli.py")))
    assert _child(code, OPENBLAS_CORETYPE="Prescott") == _child(code)


def test_pow_keeps_c99s_cases_and_exact_integer_powers():
    """A few facts of the definition (isa/libm.py) that a rewrite could lose."""
    from netsushisen.isa.libm import machine_pow, pow64
    assert pow64(3.0, 2.0) == 9.0 and pow64(10.0, 3.0) == 1000.0 and pow64(2.0, -1074.0) == 5e-324
    assert pow64(-2.0, 3.0) == -8.0 and np.isnan(pow64(-2.0, 0.5)) and pow64(float("nan"), 0.0) == 1.0
    assert machine_pow(np.float32(2), np.float32(128)) == np.float32(np.inf)
    assert abs(pow64(0.7, 33.3) / 0.7 ** 33.3 - 1) < 1e-14
    rng = np.random.default_rng(3)
    for x, y in zip(rng.random(200) * 4, rng.random(200) * 20 - 10):
        assert abs(pow64(float(x), float(y)) / float(x) ** float(y) - 1) < 2e-14
