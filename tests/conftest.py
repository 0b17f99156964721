"""Shared fixtures. Tests that read ../shared skip with a reason when it is absent: users clone
only the project."""

from __future__ import annotations

from pathlib import Path

import pytest

PROJECT = Path(__file__).resolve().parents[1]
SHARED = PROJECT.parent / "shared"


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
