"""Atomic, consistent outputs that never follow a link (issue 30, items 3 and 5;
isa/outputs.py): a failed write leaves the earlier file whole and no temporary behind,
a command's several outputs are never a mixed set, and a symbolic link at a target is refused
with one line while its target stays untouched."""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from netsushisen.isa import outputs
from netsushisen.cli import main
from netsushisen.isa.errors import NetsushisenError


def _full_disk(monkeypatch, after: int = 0) -> None:
    """os.fsync fails with ENOSPC (as a full disk does when the data reach it) from the
    `after`-th call on."""
    real = os.fsync
    calls = []

    def fsync(fd):
        calls.append(fd)
        if len(calls) > after:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)
    monkeypatch.setattr(outputs.os, "fsync", fsync)


def test_a_failed_write_keeps_the_earlier_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "x.json"
    target.write_text("old\n")
    _full_disk(monkeypatch)
    with pytest.raises(NetsushisenError) as err:
        outputs.write_text(target, "new\n" * 1000)
    assert err.value.format() == f"{target}: error: cannot write: No space left on device"
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json"]


def test_a_writer_that_raises_midway_keeps_the_earlier_file(tmp_path):
    target = tmp_path / "x.txt"
    target.write_text("old\n")

    def half(p: Path) -> None:
        p.write_text("half")
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        outputs.write_file(target, half)
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["x.txt"]


def test_several_outputs_are_one_set(tmp_path, monkeypatch):
    a, b = tmp_path / "a.png", tmp_path / "b.json"
    a.write_text("old a")
    b.write_text("old b")
    _full_disk(monkeypatch, after=1)  # the first file completes, the second fails
    with pytest.raises(NetsushisenError):
        outputs.write_all([(a, lambda p: p.write_text("new a")), (b, lambda p: p.write_text("new b"))])
    assert (a.read_text(), b.read_text()) == ("old a", "old b")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.json"]
    monkeypatch.undo()
    outputs.write_all([(a, lambda p: p.write_text("new a")), (b, lambda p: p.write_text("new b"))])
    assert (a.read_text(), b.read_text()) == ("new a", "new b")


def test_new_files_get_the_umask_mode_and_existing_ones_keep_theirs(tmp_path):
    old = os.umask(0o022)
    try:
        outputs.write_text(tmp_path / "new.txt", "x")
        kept = tmp_path / "kept.txt"
        kept.write_text("y")
        kept.chmod(0o640)
        outputs.write_text(kept, "z")
    finally:
        os.umask(old)
    assert (tmp_path / "new.txt").stat().st_mode & 0o777 == 0o644
    assert kept.stat().st_mode & 0o777 == 0o640


def test_a_streamed_file_is_in_place_only_when_complete(tmp_path):
    target = tmp_path / "trace.log"
    target.write_text("old\n")
    with pytest.raises(ValueError):
        with outputs.replacing(target) as f:
            f.write("partial\n")
            raise ValueError
    assert target.read_text() == "old\n"
    f = outputs.replacing(target)
    f.write("new\n")
    assert target.read_text() == "old\n"
    f.close()
    assert target.read_text() == "new\n"
    assert [p.name for p in tmp_path.iterdir()] == ["trace.log"]


@pytest.mark.parametrize("dangling", [False, True])
def test_a_link_at_the_target_is_refused(tmp_path, dangling):
    elsewhere = tmp_path / "elsewhere.txt"
    if not dangling:
        elsewhere.write_text("precious\n")
    link = tmp_path / "out.txt"
    link.symlink_to(elsewhere)
    with pytest.raises(NetsushisenError, match="refusing to write through a symbolic link"):
        outputs.write_text(link, "x")
    assert link.is_symlink()
    assert (elsewhere.read_text() == "precious\n") if not dangling else not elsewhere.exists()


def test_render_on_a_full_disk_keeps_the_earlier_set(tmp_path, monkeypatch, capsys):
    png, ids, js = tmp_path / "t.png", tmp_path / "t.npy", tmp_path / "t.json"
    argv = ["golden", "tetra", "--res", "4", "-o", str(png), "--ids", str(ids), "--json", str(js)]
    assert main(argv) == 0
    before = {p: p.read_bytes() for p in (png, ids, js)}
    json.loads(js.read_text())
    _full_disk(monkeypatch, after=2)  # image and ids complete, the statistics fail
    assert main(argv[:3] + ["2"] + argv[4:]) == 1
    err = capsys.readouterr().err.strip()
    assert err == f"{js}: error: cannot write: No space left on device"
    assert {p: p.read_bytes() for p in (png, ids, js)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.json", "t.npy", "t.png"]


def test_kernels_export_does_not_write_through_a_link(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    out = tmp_path / "k"
    assert main(["kernels", "export", str(out)]) == 0
    (out / "ic.s").unlink()
    (out / "ic.s").symlink_to(victim)
    capsys.readouterr()
    assert main(["kernels", "export", str(out), "--force"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "symbolic link" in err[0] and "ic.s" in err[0]
    assert victim.read_text() == "precious\n"


def test_the_default_output_name_skips_a_dangling_link(tmp_path, monkeypatch):
    from netsushisen.options import fresh_output

    monkeypatch.chdir(tmp_path)
    Path("tetra.png").symlink_to(tmp_path / "nowhere.png")
    assert fresh_output("tetra") == "tetra-1.png"


@pytest.mark.parametrize("argv", [["isa", "-o", "{d}/isa.md"], ["disasm", "{o}", "-o", "{d}/x.s"],
                                  ["asm", "{s}", "--proc", "os", "-o", "{d}/x.o"],
                                  ["asm", "{s}", "--proc", "os", "--listing", "{d}/x.lst"],
                                  ["run", "--os", "{o}", "--json", "{d}/x.json"]])
def test_an_unwritable_folder_is_one_line(tmp_path, argv, capsys, monkeypatch):
    """A folder the user may not write (injected: the tests may run as root, who may)."""
    src = tmp_path / "os.s"
    src.write_text("start: addi r1, r0, 1\n    halt\n")
    obj = tmp_path / "os.o"
    assert main(["asm", str(src), "--proc", "os", "-o", str(obj)]) == 0
    ro = tmp_path / "ro"
    ro.mkdir()
    real = outputs.tempfile.mkstemp

    def mkstemp(*a, dir=None, **k):
        if Path(dir) == ro:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))
        return real(*a, dir=dir, **k)
    monkeypatch.setattr(outputs.tempfile, "mkstemp", mkstemp)
    capsys.readouterr()
    main([a.format(d=ro, o=obj, s=src) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(str(ro)) and err[0].endswith(
        "cannot write: Permission denied"), err
    assert list(ro.iterdir()) == []


def _tiny_tmpfs(tmp_path: Path) -> Path | None:
    """A 64 KiB tmpfs (root only, as in CI); None where it cannot be mounted."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return None
    mnt = tmp_path / "full"
    mnt.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)],
                          capture_output=True)
    return mnt if done.returncode == 0 else None


def test_a_really_full_filesystem_keeps_the_earlier_file(tmp_path):
    mnt = _tiny_tmpfs(tmp_path)
    if mnt is None:
        pytest.skip("needs root to mount a tiny tmpfs (the injected-error tests above cover it)")
    try:
        target = mnt / "x.json"
        target.write_text("old\n")
        with pytest.raises(NetsushisenError, match="No space left on device"):
            outputs.write_text(target, "y" * (1 << 20))
        assert target.read_text() == "old\n"
        assert [p.name for p in mnt.iterdir()] == ["x.json"]
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
