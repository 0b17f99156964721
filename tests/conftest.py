"""Shared fixtures. Tests that read ../shared skip with a reason when it is absent: users clone
only the project.

Engines (PyMTL3 style: a behaviour test is written once and rerun on every model of the machine):
a test that takes `engine_name` runs once per engine of `emulator/engine.py` — ids `[reference]`,
`[compiled]`, `[tandem]` — and builds its machine with `make_engine(engine_name, ...)`,
`harness.run_machine(engine_name, ...)` or `harness.run_stage(..., engine=engine_name)`, reading
the run only through the engine interface. `pytest --engine compiled` (repeatable) restricts
the runs to the named engines.

Which engine runs are in the default suite (a rule, applied in `pytest_generate_tests` below):
  - `[reference]` and `[compiled]` always, except that an engine test marked
    `@pytest.mark.heavy` (a kernel render of 100k+ cycles) has its `[reference]` run under
    `-m slow` only: the compiled run checks the kernels, and tests/test_engine_identity.py holds
    the compiled engine to the reference engine's outputs (every render axis at small sizes,
    faults, deadlocks, random programs).
  - `[tandem]` only in the unit-level modules of TANDEM_IN_DEFAULT (timing, semantics, opcode
    vectors, memories, ring, machine, `run`, the stage bench: a few thousand cycles each);
    everywhere else (stage kernels, renders) `[tandem]` runs under `-m slow` only.
`pytest --engine NAME` turns the rule off: the named engines run every engine test.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

# shared test helpers (program_strategies.py) import by name from this folder
sys.path.insert(0, str(Path(__file__).parent))

PROJECT = Path(__file__).resolve().parents[1]
SHARED = PROJECT.parent / "shared"


def pytest_addoption(parser):
    parser.addoption("--engine", action="append", default=[], metavar="NAME",
                     help="run the engine-parametrised tests on this engine only (repeatable; "
                          "default: every engine that imports)")


def engines(config) -> list[str]:
    from netsushisen.emulator.engine import check_engine, engine_names
    from netsushisen.isa.errors import ConfigError

    chosen = config.getoption("--engine")
    try:
        return [check_engine(name) for name in chosen] if chosen else engine_names()
    except ConfigError as err:
        raise pytest.UsageError(f"--engine: {err.format()}") from None


TANDEM_IN_DEFAULT = frozenset({
    "test_emulator_timing", "test_emulator_semantics", "test_opcode_vectors",
    "test_emulator_memory", "test_emulator_ring", "test_emulator_machine", "test_emulator_cli",
    "test_harness",
})
"""Modules whose `[tandem]` runs stay in the default suite (see the module docstring)."""


def _slow_run(metafunc, name: str, names: list[str]) -> bool:
    """Whether engine `name`'s run of this test belongs under `-m slow` only (the rule above)."""
    if metafunc.config.getoption("--engine"):
        return False
    if name == "tandem":
        return Path(metafunc.module.__file__).stem not in TANDEM_IN_DEFAULT
    if name == "reference" and "compiled" in names:
        return metafunc.definition.get_closest_marker("heavy") is not None
    return False


def pytest_configure(config):
    config.addinivalue_line("markers", "heavy: an engine test (engine_name) whose [reference] "
                            "run is slow-only (tests/conftest.py)")


def pytest_generate_tests(metafunc):
    """`engine_name`: one run of the test per engine; which runs are slow-only is the rule of
    the module docstring."""
    if "engine_name" in metafunc.fixturenames:
        names = engines(metafunc.config)
        metafunc.parametrize("engine_name", [
            pytest.param(n, id=n, marks=[pytest.mark.slow] if _slow_run(metafunc, n, names) else [])
            for n in names])


@pytest.fixture
def shared_spd() -> Path:
    spd = SHARED / "spd"
    if not spd.is_dir():
        pytest.skip("../shared/spd not present: the SPD scene files are only beside the project "
                    "in the developers' workspace")
    return spd


@pytest.fixture
def cli(capsys):
    """Run the netsushisen command line in-process: returns (exit code, stdout, stderr)."""
    from netsushisen.cli import main

    def run(*argv: str) -> tuple[int, str, str]:
        code = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return code, out, err

    return run


@pytest.fixture
def dask_apart(tmp_path):
    """start(workers) -> address: `dask scheduler` and `workers` single-threaded `dask worker`s
    as separate processes on the loopback address, stopped after the test."""
    import json
    import subprocess
    import time

    bindir = Path(sys.executable).parent
    dask_cli = [str(bindir / "dask")] if (bindir / "dask").exists() else [sys.executable, "-m", "dask"]
    procs: list[subprocess.Popen] = []

    def start(workers: int = 1) -> str:
        sched_file = tmp_path / "scheduler.json"
        procs.append(subprocess.Popen(dask_cli + ["scheduler", "--host", "127.0.0.1", "--port", "0",
                                                  "--no-dashboard", "--scheduler-file", str(sched_file)],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.time() + 60
        while not sched_file.exists() and time.time() < deadline:
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        for _ in range(workers):
            procs.append(subprocess.Popen(dask_cli + ["worker", address, "--nthreads", "1", "--no-dashboard"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        return address

    yield start
    for p in procs:
        p.terminate()
    for p in procs:
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
