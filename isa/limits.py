"""The machine's limits, and the bound on any one input file: what every layer checks.

Integers, addresses and the pixel index are 32-bit two's complement words (isa/words.py:
`wrap32`), so a memory holds at most 2^31 words (addresses 0 … 2^31−1) and a frame at most
2^31 − 1 samples (the RAY_PIXEL / COL pixel index is `y·width + x` in one integer word): at most
MAX_SIDE = 46,340 samples on a side. Every configuration field that sizes memory or time has its
range here (`FIELD_LIMITS`), beside the configuration tree that `MachineConfig.validate` checks
with it (`field_problems`, `machine_problems`). `read_input` bounds every input file (a
configuration, a source, a scene, statistics) and lives here because the configuration loader,
the lowest layer that reads a file, needs it.

The host's limits (the memory a run takes on this machine, the scene and sweep sizes) are
netsushisen/limits.py's; it re-exports these names, so `limits.MAX_WORDS` reads either way.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from netsushisen.isa.errors import Diagnostic, NetsushisenError

if TYPE_CHECKING:
    from netsushisen.isa.config import MachineConfig

MAX_WORDS = 1 << 31
"""Words one memory can hold: addresses are 32-bit signed integer words (0 … 2^31 − 1)."""

MAX_SAMPLES = (1 << 31) - 1
"""Samples (eye rays) one frame can hold: the pixel index `y·width + x` is one integer word."""

MAX_SIDE = math.isqrt(MAX_SAMPLES)
"""Samples on a side of the (square) frame: 46,340 (46,340² < 2^31 ≤ 46,341²)."""

MiB = 1 << 20
GiB = 1 << 30

MAX_LATENCY = 4096
"""Cycles of any unit latency, memory access time (t_r, t_c, t_g), link latency or branch
penalty: the compiled engine's write-back ring has a slot (72 bytes) per cycle of the longest
latency in every processor (a latency of 10^9 asked for 48 GiB); the paper's slowest access,
t_g, is 8 cycles."""

MAX_CYCLES = (1 << 62) - 1
"""Cycles a run may be given (`max_cycles`, `ring.deadlock_cycles`): cycle counts are 64-bit
integers in both engines."""

MAX_FIFO_WORDS = 1 << 20
"""Words of one ring FIFO or link channel (`ring.fifo_depth`, `ring.link_buffer_words`): the
compiled engine allocates all 56 FIFOs of a PE at the deepest one's depth, 8 bytes a word (at
this limit 470 MB a PE); the paper's CMU buffers hold tens of words."""

MAX_GRID_RESOLUTION = 256
"""Voxels per axis of either grid level (`grid.top_resolution`, `grid.sub_resolution`): a
level has resolution³ cells (256³ = 16.8 M cells, two words each of OS memory, already 500×
the default OS memory), built on the host at tens of bytes a cell (100,000 asked for 914 TiB)."""

MAX_DEPTH = 64
"""Levels of the ray tree (`render.max_depth`): the golden model keeps every sample's path, one
word a level, and SC's kernel counts depth in a word; after a few dozen reflections a ray's
weight is far below fp32's resolution (the SPD conventions use 5)."""

FIELD_LIMITS: dict[str, tuple[float, float, str]] = {
    "max_cycles": (0, MAX_CYCLES, "cycles; 0: no limit, cycle counts are 64-bit"),
    "ring.deadlock_cycles": (1, MAX_CYCLES, "cycles; cycle counts are 64-bit"),
    "ring.fifo_depth": (1, MAX_FIFO_WORDS, "words; the compiled engine's FIFO buffers"),
    "ring.link_buffer_words": (1, MAX_FIFO_WORDS, "words; the compiled engine's FIFO buffers"),
    "ring.link_latency": (1, MAX_LATENCY, "cycles; the compiled engine's write-back ring"),
    "grid.top_resolution": (0, MAX_GRID_RESOLUTION,
                            "voxels a side; 0: automatic, resolution³ cells on the host"),
    "grid.sub_resolution": (0, MAX_GRID_RESOLUTION,
                            "voxels a side; 0: automatic, resolution³ cells on the host"),
    "grid.subdivide_threshold": (0, MAX_WORDS, "primitives"),
    "render.max_depth": (1, MAX_DEPTH, "levels; a word a level for every sample"),
    "render.min_weight": (0.0, 1.0, "as a ray's weight"),
    "render.epsilon": (0.0, 1.0, "scene units; unused, kept for older files"),
    **{f"{m}.{t}": (1, MAX_LATENCY, "cycles; the compiled engine's write-back ring")
       for m in ("ic_memory", "sc_memory") for t in ("t_r", "t_c", "t_g")},
    **{f"{m}.cache_ways": (1, 8, "ways per set; 1, 2, 4 or 8 (LRU over at most 8 tags)")
       for m in ("ic_memory", "sc_memory")},
    **{f"{c}.taken_branch_penalty": (0, MAX_LATENCY,
                                      "cycles; the compiled engine's write-back ring")
       for c in ("os", "ic", "sc")},
}
"""Every configuration field that sizes memory or time, with its allowed range (both ends
included), unit and reason; `{os,ic,sc}.latency.OP` share ring.link_latency's range."""


MAX_INPUT_BYTES = 256 * MiB
"""Bytes of one input file (scene, source, object, configuration, statistics, spec): the
project's largest inputs are a few MB; reading is bounded so `/dev/zero` or a runaway file
cannot fill memory."""

def read_input(path: str | Path, what: str = "input") -> bytes:
    """The bytes of an input file, refused (one located line) when it is not a regular file
    (`render /dev/zero`, a FIFO, a socket) or is larger than MAX_INPUT_BYTES. A missing file
    or a folder raises FileNotFoundError / IsADirectoryError, for the caller's own message."""
    import errno
    import os
    import stat

    p = Path(path)
    st = os.stat(p)
    if stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(p))
    if not stat.S_ISREG(st.st_mode):
        raise NetsushisenError(Diagnostic(f"this {what} is not a regular file (a device, pipe "
                                          "or socket)", file=str(p)))
    if st.st_size > MAX_INPUT_BYTES:
        raise NetsushisenError(Diagnostic(f"{what} of {size_text(st.st_size)}, more than "
                                          f"{size_text(MAX_INPUT_BYTES)} (limits.MAX_INPUT_BYTES)",
                                          file=str(p)))
    with open(p, "rb") as f:
        return f.read(MAX_INPUT_BYTES + 1)


def size_text(n: float) -> str:
    return f"{n / GiB:,.1f} GiB" if n >= GiB else f"{n / MiB:,.0f} MiB"




def _fmt(v: float) -> str:
    return f"{v:,}" if isinstance(v, int) else f"{v:g}"


def range_problem(path: str, value: float, low: float, high: float, what: str) -> str | None:
    """The one-line problem of a field outside low..high (NaN and infinities included)."""
    if isinstance(value, float) and not math.isfinite(value):
        return (f"{path} must be a finite number (allowed {_fmt(low)}..{_fmt(high)} {what}), "
                f"got {value}")
    if value < low:
        return f"{path} must be at least {_fmt(low)}, got {_fmt(value)} (allowed {_fmt(low)}.." \
               f"{_fmt(high)} {what})"
    if value > high:
        return f"{path} must be at most {_fmt(high)}, got {_fmt(value)} (allowed {_fmt(low)}.." \
               f"{_fmt(high)} {what})"
    return None


def field_problems(config: MachineConfig) -> list[str]:
    """Every field of FIELD_LIMITS (and every latency override) outside its range."""
    problems = []
    for path, (low, high, what) in FIELD_LIMITS.items():
        obj = config
        for part in path.split("."):
            obj = getattr(obj, part)
        problem = range_problem(path, obj, low, high, what)
        if problem:
            problems.append(problem)
    low, high, what = FIELD_LIMITS["ring.link_latency"]
    for stage in ("os", "ic", "sc"):
        for op, lat in getattr(config, stage).latency.items():
            if isinstance(lat, int):
                problem = range_problem(f"{stage}.latency.{op}", lat, low, high, what)
                if problem:
                    problems.append(problem)
    return problems


def machine_problems(config: MachineConfig) -> list[str]:
    """The configuration's fields that exceed what the machine's words can address."""
    problems = []
    for stage in ("os", "ic", "sc"):
        words = getattr(config, stage).local_words
        if words > MAX_WORDS:
            problems.append(f"{stage}.local_words {words:,} is more than a memory can address "
                            f"({MAX_WORDS:,} words: addresses are 32-bit signed integers)")
    for name in ("ic_memory", "sc_memory"):
        mem = getattr(config, name)
        for size in ("cache_bytes", "resident_bytes"):
            words = getattr(mem, size) // config.word_bytes
            if words > MAX_WORDS:
                problems.append(f"{name}.{size} {getattr(mem, size):,} is more than a memory can "
                                f"address ({MAX_WORDS:,} words of {config.word_bytes} bytes)")
    return problems
