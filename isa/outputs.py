"""Every file a command writes: atomic, consistent, never through a link.

A command that fails half-way (a full disk, a read-only folder, Ctrl-C, a fault) must not leave a
truncated file where a good one was, nor a new PNG beside the old statistics. So every writer goes
through this module:

- each file is written to a temporary file in the same folder (`.NAME.XXXXXX.tmp`), flushed to
  disk (fsync) and renamed over the target — rename within a folder is atomic on POSIX, so a
  reader sees the old file or the new one, never a part;
- a failure removes the temporary and leaves any earlier file untouched, and is reported as one
  located line (`path: error: cannot write: No space left on device`);
- a command with several outputs (`render`'s image, ids and statistics) writes them all to
  temporaries first and renames them only when every one is complete (`write_all`): a failure
  leaves the earlier set whole;
- a symbolic link at a target path is refused (one line): writing through it would change a file
  elsewhere (`kernels export DIR --force` with `DIR/ic.s -> ~/.bashrc`), and replacing it would
  surprise whoever made it.

Files keep the permissions a plain `open(path, "w")` would give (0666 less the umask; an existing
file's mode is kept).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from netsushisen.isa.errors import Diagnostic, NetsushisenError

Writer = Callable[[Path], None]
"""Writes the whole file at the path it is given (a temporary beside the target)."""


def _fail(path: str | Path, message: str) -> NetsushisenError:
    return NetsushisenError(Diagnostic(message, file=str(path)))


def check_target(path: str | Path) -> Path:
    """The target as a Path, refused (one line) if it is a symbolic link (dangling or not) or
    something that is not a regular file (a folder, a device, a FIFO)."""
    p = Path(path)
    if p.is_symlink():
        raise _fail(p, "refusing to write through a symbolic link (remove the link or choose "
                       "another name)")
    if p.exists() and not p.is_file():
        raise _fail(p, "cannot write: not a regular file")
    return p


def _mode(target: Path) -> int:
    try:
        return target.stat().st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _temporary(target: Path) -> Path:
    # ends in .tmp, never the target's suffix: a reader globbing `*.json` must not see it
    # (writers that choose a format by the suffix are told the format: savefig(format=...))
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp",
                                dir=target.parent if str(target.parent) else ".")
    os.close(fd)
    return Path(name)


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _remove(path: Path | None) -> None:
    if path is not None:
        with contextlib.suppress(OSError):
            path.unlink()


def _oserror(path: str | Path, err: OSError) -> NetsushisenError:
    return _fail(path, f"cannot write: {err.strerror or err}")


def write_all(outputs: list[tuple[str | Path, Writer]]) -> None:
    """Write every (target, writer) to a temporary beside its target, then rename them all into
    place; any failure (including one that is not an OSError, and Ctrl-C) removes every
    temporary and leaves every target as it was. An OSError becomes one located line."""
    targets = [check_target(path) for path, _ in outputs]
    temps: list[Path] = []
    current: Path | None = None
    try:
        for target, (_, write) in zip(targets, outputs):
            current = target
            tmp = _temporary(target)
            temps.append(tmp)
            write(tmp)
            os.chmod(tmp, _mode(target))
            _fsync(tmp)
        for target, tmp in zip(targets, temps):
            current = target
            os.replace(tmp, target)
    except OSError as err:
        for tmp in temps:
            _remove(tmp)
        raise _oserror(current if current is not None else targets[0], err) from None
    except BaseException:
        for tmp in temps:
            _remove(tmp)
        raise


def write_file(path: str | Path, write: Writer) -> None:
    """One file, atomically (see `write_all`)."""
    write_all([(path, write)])


def write_text(path: str | Path, text: str, encoding: str = "utf-8") -> None:
    """`text` to the file `path`, atomically."""
    write_file(path, lambda p: p.write_text(text, encoding=encoding))


def write_bytes(path: str | Path, data: bytes) -> None:
    """`data` to the file `path`, atomically."""
    write_file(path, lambda p: p.write_bytes(data))


class Replacing:
    """An open file for writers that stream (a trace, a timeline, a CSV): it writes to a
    temporary beside `path`; `close()` (or the end of a `with` block) renames it over `path`,
    `discard()` (or a `with` block that raises) removes it, leaving `path` as it was."""

    def __init__(self, path: str | Path, mode: str = "w", **kwargs) -> None:
        self.target = check_target(path)
        try:
            self.tmp: Path | None = _temporary(self.target)
            self.file = open(self.tmp, mode, **kwargs)
        except OSError as err:
            raise _oserror(self.target, err) from None

    def __getattr__(self, name: str):
        return getattr(self.file, name)

    def write(self, text):
        return self.file.write(text)

    def close(self) -> None:
        """Complete the file: flush, fsync and rename into place (once)."""
        if self.tmp is None:
            return
        tmp, self.tmp = self.tmp, None
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            os.chmod(tmp, _mode(self.target))
            os.replace(tmp, self.target)
        except OSError as err:
            self.file.close()
            _remove(tmp)
            raise _oserror(self.target, err) from None

    def discard(self) -> None:
        """Drop what was written; the target stays as it was."""
        if self.tmp is not None:
            self.file.close()
            _remove(self.tmp)
            self.tmp = None

    def __enter__(self) -> "Replacing":
        return self

    def __exit__(self, kind, value, tb) -> None:
        if kind is None:
            self.close()
        else:
            self.discard()


def replacing(path: str | Path, mode: str = "w", **kwargs) -> Replacing:
    """`with replacing(path) as f:` — a streamed file, in place only if the block completes."""
    return Replacing(path, mode, **kwargs)
