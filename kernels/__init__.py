"""The hand-written stage programs (`os.s`, `ic.s`, `sc.s`), their shared includes, and worked
examples. Python code reads their numbers from the includes, never types them again."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

KERNELS = Path(__file__).resolve().parent

KERNEL_SETS = {"classic": "the 1992-style kernels as first written: hand-packed bundles, one list "
                          "cell at a time (kernels/classic/)"}
"""Other bundled kernel sets, by name: `render --kernels classic` runs them (docs/kernels.md)."""


def kernel_folder(name_or_dir: str | Path | None) -> Path:
    """The folder a `--kernels` value means: none, the bundled kernels; the name of a bundled
    set (KERNEL_SETS) that is not also a folder here, that set; else the folder as given."""
    if name_or_dir is None or str(name_or_dir) == "":
        return KERNELS
    if str(name_or_dir) in KERNEL_SETS and not Path(name_or_dir).is_dir():
        return KERNELS / str(name_or_dir)
    return Path(name_or_dir)


@lru_cache(maxsize=1)
def protocol() -> dict[str, int]:
    """The message protocol's constants (tags, header words, ray record offsets) from
    `protocol.inc` (docs/kernels.md)."""
    from netsushisen.asm.assembler import read_constants
    return read_constants(KERNELS / "protocol.inc")
