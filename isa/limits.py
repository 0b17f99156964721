"""The machine's limits, and the bound on any one input file: what every layer checks.

Integers, addresses and the pixel index are 32-bit two's complement words (isa/words.py:
`wrap32`), so a memory holds at most 2^31 words (addresses 0 … 2^31−1) and a frame at most
2^31 − 1 samples (the RAY_PIXEL / COL pixel index is `y·width + x` in one integer word): at most
MAX_SIDE = 46,340 samples on a side. Every configuration field that sizes memory or time has its
range here (`FIELD_LIMITS`), beside the configuration tree that `MachineConfig.validate` checks
with it (`field_problems`, `machine_problems`). `read_input` bounds every input file (a
configuration, a source, a scene, statistics) and lives here because the configuration loader,
the lowest layer that reads a file, needs it.

Below them, this host's limits (issue 30; they were netsushisen/limits.py's until issue 45 moved
them here, so the assembler, the host and the reports, which check inputs against them, import
nothing above their layer): the sizes of an assembly's expansion, a scene and a sweep, and the
memory a run will take (`check_host`): estimated from the configuration, the image size and the
engine, against the memory this process may use (`available_bytes`: the smallest of
/proc/meminfo's MemAvailable, the cgroup's memory.max headroom and RLIMIT_AS). The estimate is
a model with measured constants, meant to refuse the impossible (`render --pes 100000`,
`render --res 8192`) and to announce the large, not to account for every byte. A run whose
estimate passes LARGE_BYTES, or that traces more than LARGE_RAYS eye rays, prints one line with
its size when it starts (`Footprint.note`). Every command that builds a machine or an image
(render, golden, run, paper, accuracy, sweep, debug) goes through these checks via
netsushisen/options.py before its first allocation: a run that cannot fit says so in one line,
at once, naming the limit, rather than being killed after a minute of silence (exit 137).
"""

from __future__ import annotations

import math
import resource
import sys
from dataclasses import dataclass
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


# ---------------------------------------------------------------------------------------------
# This host's limits

BASE_BYTES = 192 * MiB
"""The process before any image or machine: Python, numpy, numba and the compiled engine
loaded (measured: `render tetra --res 4` peaks at 171 MB)."""

RENDER_BYTES_PER_RAY = 1024
"""Host memory per eye ray of a machine render: the host stream (14 words a ray), the frame and
id buffers, the pre-pass and the images written (measured: tetra 64² → 256², 0.81 KiB a ray)."""

GOLDEN_BYTES_PER_RAY = 3 * 1024
"""Host memory per eye ray of the golden model (vectorised over every ray of a generation;
measured: tetra 512² 0.42 KiB, balls 512² 2.7 KiB a ray, reflections included)."""

PE_BYTES = {"reference": 1 * MiB, "compiled": 8 * MiB, "tandem": 9 * MiB}
"""Per-PE overhead beyond its memories and FIFOs, by engine (measured with the bundled kernels,
1 → 64 PEs: the reference engine's objects about 0.9 MiB a PE; the compiled engine's decoded
bundle and per-PC stall tables about 7.9 MiB a PE; tandem holds both)."""

FIFOS_PER_PE = 56
"""FIFOs and link channels of one PE's ring with the buffer pool on (11 without): the compiled
engine allocates each at the deepest one's capacity."""

LARGE_BYTES = 1 * GiB
LARGE_RAYS = 1 << 18
"""A run past either of these prints its size when it starts (unless quiet)."""


MAX_EXPANDED_LINES = 1 << 20
"""Statements one assembly may produce through macros and `.rept` together (1,048,576): more
than any processor's program memory holds many times over; counted across every level, so
nested `.rept`s (each within its own 65,536) or a macro invoking the previous one twice, 40
deep, stop here at once instead of running for hours."""

MAX_EXPANDED_CHARS = 64 << 20
"""Characters of source one assembly may produce through macro substitution (64 MiB): a macro
argument that doubles at each level of nesting reaches it after about 26 levels."""

MAX_STATEMENT_CHARS = 1 << 16
"""Characters of one statement after substitution (65,536)."""

MAX_CONSTANT_BITS = 1024
"""Bits of an integer in a constant expression (`.equ`, `-D`, operands): the machine's words
are 32 or 64 bits; the margin lets intermediate results overflow and be masked, not grow
without end."""

MAX_EXPRESSION_DEPTH = 256
"""Levels of one expression's tree (operators and parentheses): `1+1+…+1` with 200,000 terms is
200,000 levels deep, and the assembler walks an expression recursively."""


MAX_PRIMITIVES = 1 << 18
"""Primitives of one scene (262,144): the host builds the grid, the databases and the
pre-pass at hundreds of bytes a primitive and more where primitives overlap many voxels (1 M
spheres, or 20,000 coincident ones, ran the host out of memory); the SPD scenes at size 4
have under 10,000."""


MAX_GRID_CANDIDATES = 1 << 26
"""(primitive, voxel) pairs the grid builder tests at once (67,108,864), and no more than the
host's memory holds at GRID_BYTES_PER_CANDIDATE: primitives that overlap many voxels each —
20,000 coincident spheres asked for 300 M pairs — are refused; tetra:8 (65,536 triangles)
needs 2.4 M, the accuracy study's bfloat16-rounded balls 25 M."""

GRID_BYTES_PER_CANDIDATE = 200
"""Host bytes a candidate pair takes while the grid builder tests it (its owner, cell index,
cell box and the temporaries of their computation)."""


def check_grid_candidates(total: int) -> None:
    """One line when the grid builder would test more pairs than MAX_GRID_CANDIDATES or than
    the memory available holds."""
    available = available_bytes()
    need = total * GRID_BYTES_PER_CANDIDATE
    if total > MAX_GRID_CANDIDATES or (available is not None and need > available):
        raise NetsushisenError(
            f"the grid would test {total:,} (primitive, voxel) pairs, about {size_text(need)} "
            f"(limits.MAX_GRID_CANDIDATES {MAX_GRID_CANDIDATES:,} and the memory available: "
            "primitives that overlap many voxels each, e.g. coincident or very large ones)")

MAX_SWEEP_POINTS = 100_000
"""Points of one sweep (scenes × the product of the axes) and values of one range: a point is
a render of seconds to minutes, so 100,000 is already months of one core (9 axes of 10
values asked for 10^9 points)."""


def check_primitives(n: int, where: str) -> None:
    """One line when a scene has more primitives than MAX_PRIMITIVES."""
    if n > MAX_PRIMITIVES:
        raise NetsushisenError(Diagnostic(f"{n:,} primitives, more than {MAX_PRIMITIVES:,} "
                                          "(limits.MAX_PRIMITIVES: the host's grid and databases)",
                                          file=where))


def check_words(words: int, what: str) -> None:
    """One-line error if a memory of `words` words cannot exist on the machine."""
    if not 0 <= words <= MAX_WORDS:
        raise NetsushisenError(f"{what}: {words:,} words; a memory holds 0 to {MAX_WORDS:,} "
                               "words (addresses are 32-bit signed integers)")


def check_frame(width: int, height: int, what: str) -> None:
    """One-line error if a width×height frame is negative or has more samples than a pixel
    index can number."""
    if width < 0 or height < 0:
        raise NetsushisenError(f"{what}: a {width}×{height} frame (width and height must not be "
                               "negative)")
    if width * height > MAX_SAMPLES:
        raise NetsushisenError(f"{what}: {width:,}×{height:,} samples exceed the machine's frame "
                               f"({MAX_SAMPLES:,} samples, {MAX_SIDE:,} on a side: the pixel index "
                               "is one 32-bit integer word)")


# ---------------------------------------------------------------------------------------------
# Host memory


def _meminfo_available() -> int | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _cgroup_headroom() -> int | None:
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit == "max":
            return None
        used = int(Path("/sys/fs/cgroup/memory.current").read_text().strip())
        return max(int(limit) - used, 0)
    except (OSError, ValueError):
        return None


def available_bytes() -> int | None:
    """Memory this process may still take (None: unknown, no host check): the smallest of the
    kernel's MemAvailable, the cgroup's headroom and the address-space limit (ulimit -v)."""
    candidates = [_meminfo_available(), _cgroup_headroom()]
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        candidates.append(soft)
    known = [c for c in candidates if c is not None]
    return min(known) if known else None


@dataclass(frozen=True)
class Footprint:
    """The estimated host memory of one run and what it is made of."""

    what: str  # e.g. "render tetra 256×256 on 4 PEs (compiled engine)"
    bytes: int
    eye_rays: int = 0

    @property
    def large(self) -> bool:
        return self.bytes >= LARGE_BYTES or self.eye_rays >= LARGE_RAYS

    def note(self, available: int | None = None) -> str:
        """The line a large run prints when it starts."""
        rays = f"{self.eye_rays:,} eye rays, " if self.eye_rays else ""
        have = f" of {size_text(available)} available" if available else ""
        return f"{self.what}: {rays}about {size_text(self.bytes)} of host memory{have}"


def machine_bytes(config: MachineConfig, engine: str) -> int:
    """Host memory of the machine's PEs: memories, FIFOs and per-PE engine state."""
    word = 8 if config.precision == "fp64" else 4
    per_pe = PE_BYTES.get(engine, PE_BYTES["tandem"])
    per_pe += word * sum(getattr(config, s).local_words for s in ("os", "ic", "sc"))
    for name in ("ic_memory", "sc_memory"):
        mem = getattr(config, name)
        per_pe += mem.resident_bytes + 16 * (mem.cache_bytes // max(mem.block_bytes, 1))
    if engine != "reference":  # the compiled engine's copies of memories and FIFO buffers
        deepest = max(config.ring.fifo_depth, config.ring.link_buffer_words)
        per_pe += 8 * deepest * (FIFOS_PER_PE if config.ring.buffer_pool else 11)
        per_pe += 8 * sum(getattr(config, s).local_words for s in ("os", "ic", "sc"))
    return config.pes * per_pe


def render_footprint(what: str, config: MachineConfig | None, width: int, engine: str | None,
                     golden: bool = False, height: int | None = None,
                     per_ray: bool = False, extra_bytes: int = 0) -> Footprint:
    """A machine render (config and engine given) and/or the golden model (`golden`) of
    width×height (default square) eye rays; `per_ray`: only a machine render's host side per
    ray (the least any use of the image costs); `extra_bytes`: anything else the run holds (a
    memory image's global memories)."""
    rays = width * (width if height is None else height)
    total = BASE_BYTES + extra_bytes + rays * (GOLDEN_BYTES_PER_RAY if golden else 0)
    if per_ray or (config is not None and engine is not None):
        total += rays * RENDER_BYTES_PER_RAY
    if config is not None and engine is not None:
        total += machine_bytes(config, engine)
    return Footprint(what, total, rays)


NUMERICS_BYTES_PER_RAY = 8 * 1024
"""Host memory per eye ray of `numerics SCENE` (measured: balls:1 128² → 256², 7.4 KiB a ray):
golden fp32 and fp64 one after the other with every shadow ray of an eye hit kept, both results
held while they are compared, and the oracle run on the differing rays only (a few float64
vectors of them per primitive) — proportional to the pixels. The grid, which grew with a
scene's distance from the origin, is bounded apart (host/grid.py MIN_CELL_PADS, and
MAX_GRID_CANDIDATES)."""


def numerics_footprint(what: str, res: int) -> Footprint:
    """`numerics SCENE` at res×res: BASE_BYTES + NUMERICS_BYTES_PER_RAY a pixel."""
    return Footprint(what, BASE_BYTES + res * res * NUMERICS_BYTES_PER_RAY, res * res)


def check_host(footprint: Footprint, quiet: bool = False, announce=None) -> Footprint:
    """Refuse a run whose estimate exceeds the memory available (one line naming both), and
    announce a large one (`announce(line)`, default: print to standard error) unless quiet."""
    available = available_bytes()
    if available is not None and footprint.bytes > available:
        raise NetsushisenError(f"{footprint.what} needs about {size_text(footprint.bytes)} of "
                               f"host memory, more than the {size_text(available)} available; "
                               "use a smaller --res or --pes (or smaller memories / FIFOs)")
    if footprint.large and not quiet:
        if announce is None:
            def announce(line: str) -> None:
                print(f"netsushisen: {line}", file=sys.stderr)
        announce(footprint.note(available))
    return footprint
