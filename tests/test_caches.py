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


def test_an_entry_folder_that_is_a_dangling_link_is_replaced(tmp_path, capsys):
    """issue 46 Why 5: FileExistsError on every rerun."""
    outside = tmp_path / "outside"
    root = tmp_path / "compiled"
    root.mkdir()
    (root / "0123456789abcdef").symlink_to(outside / "entry")
    folder = build._entry(root, "0123456789abcdef")
    assert folder.is_dir() and not folder.is_symlink() and not outside.exists()
    assert "was not a folder (a link or a file): discarded" in capsys.readouterr().err
    (tmp_path / "real").mkdir()
    (root / "fedcba9876543210").symlink_to(tmp_path / "real")  # a live link: not followed either
    assert not build._entry(root, "fedcba9876543210").is_symlink()
    assert (tmp_path / "real").is_dir()


@pytest.mark.parametrize("garbage", [b"17\n" + b"x" * 40, b"\x80\x04garbage", b""])
def test_numbas_files_without_checksums_are_discarded(tmp_path, garbage):
    """issue 46 Why 5: garbage .nbi in an entry without checksums.json reached numba
    (ValueError: invalid literal for int(), UnpicklingError) on every rerun."""
    folder = tmp_path / "0123456789abcdef"
    (folder / "__pycache__").mkdir(parents=True)
    (folder / "__pycache__" / "loop.run_loop-1.py311.nbi").write_bytes(garbage)
    note = build.verify_cache(folder)
    assert note is not None and "numba's files have no checksums.json" in note
    assert not (folder / "__pycache__").exists()
    assert build.verify_cache(folder) is None


def test_a_live_compile_without_checksums_yet_is_left_alone(tmp_path):
    """Another process compiling into the entry (its marker names a live process id) is at
    work, not corrupt; a marker whose process is gone is not."""
    folder = tmp_path / "0123456789abcdef"
    (folder / "__pycache__").mkdir(parents=True)
    (folder / "__pycache__" / "loop.run_loop-1.py311.nbi").write_bytes(b"partial")
    (folder / f"{build.COMPILING}{os.getppid()}").touch()
    assert build.verify_cache(folder) is None and (folder / "__pycache__").exists()
    (folder / f"{build.COMPILING}{os.getppid()}").unlink()
    (folder / f"{build.COMPILING}{2 ** 22 + 7}").touch()  # above pid_max: no such process
    assert "no checksums.json" in build.verify_cache(folder)


def test_links_inside_an_entry_are_never_followed(tmp_path):
    secret = tmp_path / "secret"
    secret.write_bytes(b"keep")
    folder = _entry(tmp_path / "a")
    (folder / "__pycache__" / "loop.run_loop-1.py311.nbi").unlink()
    (folder / "__pycache__" / "loop.run_loop-1.py311.nbi").symlink_to(secret)
    assert "nbi does not match its checksum" in build.verify_cache(folder)
    folder = tmp_path / "b" / "0123456789abcdef"
    folder.mkdir(parents=True)
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "x.nbi").write_bytes(b"keep")
    (folder / "__pycache__").symlink_to(tmp_path / "elsewhere")
    assert "__pycache__ is not a folder" in build.verify_cache(folder)
    assert not os.path.lexists(folder / "__pycache__")
    assert (tmp_path / "elsewhere" / "x.nbi").read_bytes() == b"keep" and secret.read_bytes() == b"keep"


def test_the_writability_probe_never_writes_through_a_link(tmp_path, monkeypatch):
    """issue 46 Why 6: a `.writable` link in the cache made the probe create its target
    outside the cache folder."""
    root = tmp_path / "cache"
    (root / "compiled").mkdir(parents=True)
    target = tmp_path / "outside" / "created"
    (tmp_path / "outside").mkdir()
    (root / "compiled" / ".writable").symlink_to(target)
    monkeypatch.setenv("NETSUSHISEN_CACHE", str(root))
    assert build._cache_root() == root / "compiled"
    assert not target.exists()
    assert sorted(p.name for p in (root / "compiled").iterdir()) == [".writable"]


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
