"""The hand-written stage programs (`os.s`, `ic.s`, `sc.s`), their shared includes, and worked
examples. Python code reads their numbers from the includes, never types them again."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

KERNELS = Path(__file__).resolve().parent

KERNEL_SETS = {"classic": "the 1992-style kernels as first written: hand-packed bundles, one list "
                          "cell at a time, every traversal step afresh, one leaf per VISIT (kernels/classic/: "
                          "OS's and IC's, with their protocol; SC is today's)"}
"""Other bundled kernel sets, by name: `render --kernels classic` runs them (docs/kernels.md). A
set keeps only the stages and includes it changes; the rest are the bundled kernels'."""


def kernel_folder(name_or_dir: str | Path | None) -> Path:
    """The folder a `--kernels` value means: none, the bundled kernels; the name of a bundled
    set (KERNEL_SETS) that is not also a folder here, that set; else the folder as given."""
    if name_or_dir is None or str(name_or_dir) == "":
        return KERNELS
    if str(name_or_dir) in KERNEL_SETS and not Path(name_or_dir).is_dir():
        return KERNELS / str(name_or_dir)
    return Path(name_or_dir)


def kernel_source(folder: Path, stage: str) -> Path:
    """`stage`.s of a kernels folder; a bundled set without its own (KERNEL_SETS: it keeps only
    what it changes) uses the bundled kernels' one."""
    path = Path(folder) / f"{stage}.s"
    if not path.exists() and Path(folder).resolve().parent == KERNELS:
        return KERNELS / f"{stage}.s"
    return path


@lru_cache(maxsize=1)
def protocol() -> dict[str, int]:
    """The message protocol's constants (tags, header words, ray record offsets) from
    `protocol.inc` (docs/kernels.md)."""
    from netsushisen.asm.assembler import read_constants
    return read_constants(KERNELS / "protocol.inc")
