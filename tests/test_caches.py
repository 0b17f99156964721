"""The compiled engine's cache heals and cannot be planted (issue 30, item 4;
emulator/compiled/build.py): an entry is checked against the checksums recorded when it was
written, a corrupt one is discarded (and rebuilt) with one line, and the fallback folder in the
temporary folder is this user's own, mode 0700."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from netsushisen.emulator.compiled import build


def _entry(tmp_path: Path) -> Path:
    folder = tmp_path / "0123456789abcdef"
    (folder / "__pycache__").mkdir(parents=True)
    (folder / "__pycache__" / "loop.run_loop-1.py311.nbi").write_bytes(b"index" * 100)
    (folder / "__pycache__" / "loop.run_loop-1.py311.1.nbc").write_bytes(b"code" * 1000)
    build.record_cache(folder)
    return folder


def test_a_sound_entry_passes_and_a_flipped_byte_is_discarded_with_one_line(tmp_path):
    folder = _entry(tmp_path)
    assert build.verify_cache(folder) is None
    data = folder / "__pycache__" / "loop.run_loop-1.py311.1.nbc"
    raw = bytearray(data.read_bytes())
    raw[1234] ^= 0xFF
    data.write_bytes(bytes(raw))
    note = build.verify_cache(folder)
    assert note is not None and "\n" not in note
    assert "loop.run_loop-1.py311.1.nbc does not match its checksum" in note
    assert not (folder / "__pycache__").exists() and not (folder / build.CHECKSUMS).exists()
    assert build.verify_cache(folder) is None  # nothing left to distrust: it is rebuilt


def test_a_truncated_index_or_checksum_file_is_discarded(tmp_path):
    folder = _entry(tmp_path)
    index = folder / "__pycache__" / "loop.run_loop-1.py311.nbi"
    index.write_bytes(index.read_bytes()[:10])
    assert "loop.run_loop-1.py311.nbi" in build.verify_cache(folder)
    folder = _entry(tmp_path / "again")
    (folder / build.CHECKSUMS).write_text("{")
    assert "checksums.json" in build.verify_cache(folder)
    assert not (folder / "__pycache__").exists()


def test_the_fallback_folder_is_this_users_own(tmp_path, monkeypatch):
    monkeypatch.setattr(build.tempfile, "gettempdir", lambda: str(tmp_path))
    own = build._own_temporary()
    assert own == tmp_path / f"netsushisen-cache-{os.getuid()}"
    assert own.stat().st_mode & 0o777 == 0o700
    own.chmod(0o777)  # others may write it (planted, or loosened): refused
    assert build._own_temporary() is None
    own.rmdir()
    (tmp_path / "elsewhere").mkdir(mode=0o700)
    own.symlink_to(tmp_path / "elsewhere")  # a link in its place: refused
    assert build._own_temporary() is None


@pytest.mark.slow  # two compiles of the engine (about 45 s each)
def test_a_corrupted_compiled_cache_is_rebuilt_and_the_run_succeeds(tmp_path):
    env = dict(os.environ, NETSUSHISEN_CACHE=str(tmp_path))
    run = [sys.executable, "-m", "netsushisen.cli", "render", "tetra", "--res", "2", "-q",
           "--engine", "compiled", "-o", str(tmp_path / "t.png")]
    assert subprocess.run(run, env=env, capture_output=True).returncode == 0
    (entry,) = [p for p in (tmp_path / "compiled").iterdir() if p.is_dir()]
    assert (entry / build.CHECKSUMS).exists()
    for f in (entry / "__pycache__").glob("*.nbi"):
        f.write_bytes(f.read_bytes()[: len(f.read_bytes()) // 2])  # truncated indexes
    done = subprocess.run(run, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "was corrupt" in done.stderr and "compiling again" in done.stderr
    done = subprocess.run(run, env=env, capture_output=True, text=True)
    assert done.returncode == 0 and "corrupt" not in done.stderr
