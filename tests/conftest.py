"""Shared fixtures. Tests that read ../shared skip with a reason when it is absent: users clone
only the project.

Engines (PyMTL3 style: a behaviour test is written once and rerun on every model of the machine):
a test that takes `engine_name` runs once per engine of `emulator/engine.py` — ids `[reference]`,
`[compiled]`, `[tandem]` — and builds its machine with `make_engine(engine_name, ...)`,
`harness.run_machine(engine_name, ...)` or `harness.run_stage(..., engine=engine_name)`, reading
the run only through the engine interface. `pytest --engine compiled` (repeatable) restricts
the runs to the named engines.
"""

from __future__ import annotations

from pathlib import Path

import pytest

PROJECT = Path(__file__).resolve().parents[1]
SHARED = PROJECT.parent / "shared"


def pytest_addoption(parser):
    parser.addoption("--engine", action="append", default=[], metavar="NAME",
                     help="run the engine-parametrised tests on this engine only (repeatable; "
                          "default: every engine that imports)")


def engines(config) -> list[str]:
    from netsushisen.emulator.engine import check_engine, engine_names
    from netsushisen.errors import ConfigError

    chosen = config.getoption("--engine")
    try:
        return [check_engine(name) for name in chosen] if chosen else engine_names()
    except ConfigError as err:
        raise pytest.UsageError(f"--engine: {err.format()}") from None


def pytest_generate_tests(metafunc):
    """`engine_name`: one run of the test per engine."""
    if "engine_name" in metafunc.fixturenames:
        names = engines(metafunc.config)
        metafunc.parametrize("engine_name", names, ids=names)


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
