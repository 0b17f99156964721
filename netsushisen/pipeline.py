"""Render a scene on the emulated machine: the whole pipeline, host to frame buffer.

    scene ─► grid ─► pre-pass (priorities, M) ─► memory images + kernel symbols
          ─► kernels assembled for this scene's needs ─► engine (config, programs, image) ─► run
          ─► frame buffer, hit ids, ray counts, statistics

It sits above both sides and joins them: the host's side is the golden model's (same grid, same
eye rays, same records; host/), the machine's side is the three hand-written kernels
(docs/kernels.md) run by any engine of the machine. It reaches the machine only through the
engine interface (emulator/engine.py): `make_engine`, `run`, and then `frame`, `ids`,
`statistics()` and `memory()` (SC's ray counters). `generic=True` assembles every feature
(`HAS_* = 1`) instead of only what the scene calls for; the two must give identical images.
"""

from __future__ import annotations

from netsushisen.host.scale import check_scale

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from netsushisen.asm.assembler import assemble_file
from netsushisen.asm.objects import Program
from netsushisen.emulator.engine import EXIT_CODES, Engine, RunResult, default_engine, make_engine
from netsushisen.isa.errors import ConfigError, Diagnostic
from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import MachineImages, build_images, check_fixed_grid
from netsushisen.host.golden import to_u8
from netsushisen.host.grid import build_grid
from netsushisen.host.prepass import PrepassResult, run_prepass
from netsushisen.host.rays import dtype_of, primary_rays
from netsushisen.host.scenes import Scene
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.images import MemoryImage, Segment
from netsushisen.isa.processors import STAGES
from netsushisen.isa.words import WordFormat, word_format
from netsushisen.kernels import KERNELS, kernel_folder, kernel_source, protocol

RAY_COUNTERS = ("eye_hits", "reflection", "refraction", "shadow")
"""SC's ray counters, at data labels `count_<name>` of kernels/sc.s."""

DEFAULT_SLOTS = 8
"""Rays OS keeps in flight (`-D SLOTS`)."""


@dataclass
class RenderSetup:
    """Everything a run needs, built once: a run, a debugger or a benchmark builds its machine
    from it."""

    scene: Scene
    config: MachineConfig
    res: int
    corners: bool
    generic: bool
    images: MachineImages
    prepass: PrepassResult
    programs: dict[str, Program]
    defines: dict[str, int | float]
    host_words: np.ndarray

    @property
    def side(self) -> int:
        """Samples per axis: the frame COL fills (res, or res + 1 SPD corners)."""
        return self.res + 1 if self.corners else self.res

    def memory_image(self) -> MemoryImage:
        """The databases, the eye-ray stream DIS hands out and the frame COL fills."""
        image = self.images.memory_image()
        image.host = [Segment(0, [("w", self.host_words)])]
        image.frame = (self.side, self.side)
        return image

    def engine(self, name: str | None = None) -> Engine:
        """A fresh engine `name` (default: `default_engine()`) loaded with this setup."""
        return make_engine(name or default_engine(), self.images.config, self.programs, self.memory_image())

    def machine(self):
        """A fresh reference `Machine`, for the debugger: it steps the reference engine's
        machine directly (debugger/__init__.py says why); everything else takes `engine()`."""
        from netsushisen.emulator.machine import Machine

        return Machine(self.images.config, self.programs, self.memory_image())


@dataclass
class RenderResult:
    setup: RenderSetup
    engine: Engine
    run: RunResult
    image: np.ndarray  # (res, res, 3) in the machine's precision
    image_u8: np.ndarray
    hit_ids: np.ndarray  # (side, side) int32, -1 background
    rays: dict[str, int]
    visible_primitives: int
    stats: dict = field(default_factory=dict)

    @property
    def exit_code(self) -> int:
        return EXIT_CODES.get(self.run.status, 1)


def schedule_key(config: MachineConfig) -> str:
    """What of a configuration the assembler's scheduler reads (latencies, memory times,
    branch penalties): kernels assembled for equal keys are equal."""
    return repr((config.os, config.ic, config.sc, config.ic_memory, config.sc_memory))


def kernel_defines(images: MachineImages, generic: bool = False, slots: int = DEFAULT_SLOTS,
                   extra: dict[str, int | float] | None = None) -> dict[str, int | float]:
    """The `-D` symbols of a scene's kernels: its databases, its needs (`HAS_*`, all 1 when
    generic) and the pipeline's knobs."""
    defines: dict[str, int | float] = dict(images.symbols)
    if generic:
        for k in defines:
            if k.startswith("HAS_"):
                defines[k] = 1
    defines["SLOTS"] = slots
    defines["MAX_DEPTH"] = images.config.render.max_depth
    defines.update(extra or {})
    return defines


def assemble_kernels(defines: dict[str, int | float], kernel_dir: str | Path | None = None,
                     overrides: dict[str, str | Path] | None = None,
                     config: MachineConfig | None = None) -> dict[str, Program]:
    """os.s, ic.s and sc.s from `kernel_dir` (default: the bundled kernels; a bundled set's
    name, e.g. "classic", that set), or the files `overrides` names per stage — sources, or
    object files (`asm --scene SCENE -o`, loaded as they are) — their `.sched` regions
    scheduled for `config` (the run's machine; default the default one); an error in any is
    the assembler's located error."""
    from netsushisen.options import load_program

    folder = kernel_folder(kernel_dir)
    programs = {}
    for stage in STAGES:
        path = Path((overrides or {}).get(stage) or kernel_source(folder, stage))
        if path.suffix != ".s" and (overrides or {}).get(stage):
            programs[stage] = load_program(str(path), stage, defines)
            continue
        programs[stage] = assemble_file(path, proc=stage, defines=defines, include_dirs=[KERNELS],
                                        config=config)
    return programs


_BUNDLED: dict = {}
_BUNDLED_MAX = 64


def _bundled_kernels(key: tuple, defines, kernel_dir, overrides, config) -> dict[str, Program]:
    """`assemble_kernels`, kept per process for the bundled kernels (no `overrides`, the bundled
    folder or a bundled set), which cannot change while it runs: a program depends only on the
    symbols and the scheduler's view of the configuration (`key`), and assembling the three
    kernels takes longer than many small renders (the test suite renders hundreds). Programs are
    never modified after assembly, so one object serves every render."""
    folder = kernel_folder(kernel_dir).resolve()
    if overrides or not (folder == KERNELS.resolve() or folder.parent == KERNELS.resolve()):
        return assemble_kernels(defines, kernel_dir, overrides, config)
    programs = _BUNDLED.get(key)
    if programs is None:
        programs = assemble_kernels(defines, kernel_dir, overrides, config)
        if len(_BUNDLED) >= _BUNDLED_MAX:
            _BUNDLED.pop(next(iter(_BUNDLED)))
        _BUNDLED[key] = programs
    return programs


def eye_ray_messages(scene: Scene, res: int, corners: bool, wf: WordFormat) -> np.ndarray:
    """The host stream: one RAY message (header + 13-word ray record) per eye sample, in sample
    order, with the golden model's eye rays (host/rays.py)."""
    p = protocol()
    eye = primary_rays(scene.camera, res, corners, wf.precision)
    n = eye.direction.shape[1]
    ft = wf.float_type
    floats = np.zeros((n, p["RAY_WORDS"]), ft)
    floats[:, p["RAY_OX"]:p["RAY_OZ"] + 1] = np.asarray(eye.origin, ft)[None, :]
    floats[:, p["RAY_DX"]:p["RAY_DZ"] + 1] = eye.direction.T
    floats[:, p["RAY_TMIN"]] = eye.t_min
    floats[:, p["RAY_TMAX"]] = np.inf
    floats[:, p["RAY_WR"]:p["RAY_WB"] + 1] = 1
    words = np.empty((n, 1 + p["RAY_WORDS"]), wf.word_dtype)
    words[:, 1:] = floats.view(wf.word_dtype)
    words[:, 0] = wf.from_int(p["HDR_RAY_TO_OS"])
    words[:, 1 + p["RAY_PIXEL"]] = [wf.from_int(i) for i in range(n)]
    words[:, 1 + p["RAY_INFO"]] = wf.from_int(p["KIND_EYE"] + (1 << p["INFO_DEPTH_SHIFT"]))
    return words.ravel()


def longest_message() -> tuple[str, int]:
    """The protocol's longest ring message (HIT): its name and its words, header included."""
    p = protocol()
    name, length = max(((k[4:], v) for k, v in p.items() if k.startswith("LEN_")), key=lambda kv: kv[1])
    return name, 1 + length


def check_fifo_depth(config: MachineConfig) -> None:
    """The kernels need FIFOs that hold the longest message: OS sends a message only when it fits
    its send FIFO whole (docs/kernels.md "Deadlock freedom"), and the other stages' messages must
    stream through."""
    name, need = longest_message()
    if config.ring.fifo_depth < need:
        raise ConfigError(Diagnostic(
            f"ring.fifo_depth must be at least {need} to run the kernels (the longest ring "
            f"message, {name}, is {need} words with its header; OS sends a message only once it "
            f"fits its send FIFO whole), got {config.ring.fifo_depth}", file="config"))


class HostMemo:
    """Host work kept between `prepare` calls of one process (a sweep's worker runs many points
    of a scene): the scene, its grid and the assembled kernels, each under the inputs it is a
    function of — the scene's name, and the grid's settings (`grid`, OS's local words, the
    precision) or the kernels' folder and defines. Images and the pre-pass depend on the memory
    configuration a sweep varies, so they are built per point."""

    def __init__(self) -> None:
        self.items: dict[tuple, object] = {}

    def get(self, key: tuple, build):
        if key not in self.items:
            self.items[key] = build()
        return self.items[key]


@dataclass
class KernelInputs:
    """What a scene's kernels are assembled for: the scene, the pre-pass that ranked its
    records, the databases laid out in the machine's memories, and the `-D` symbols that follow
    from them (`kernel_defines`)."""

    scene: Scene
    prepass: PrepassResult
    images: MachineImages
    defines: dict[str, int | float]


def kernel_inputs(scene: Scene | str, config: MachineConfig, res: int = 32,
                  corners: bool = False, generic: bool = False, slots: int = DEFAULT_SLOTS,
                  defines: dict[str, int | float] | None = None,
                  memo: HostMemo | None = None, lists_local: bool = False) -> KernelInputs:
    """The host work the kernels' symbols depend on — grid, pre-pass (at `res`: it picks the
    resident records), databases — and the symbols. The one place they are computed: `render`
    (through `prepare`) and `asm --scene` / `kernels export --scene` call it, so an assembled
    kernel is the one the render runs. `defines` adds or overrides symbols; `memo` keeps the
    scene and grid for later calls (only for a scene given by name). `lists_local`: the list
    cells in IC's local memory too, IC assembled to read them there (`build_images`)."""
    name = scene if isinstance(scene, str) else None

    def cached(key: tuple, build):
        return build() if memo is None or name is None else memo.get((name, *key), build)

    if isinstance(scene, str):
        scene = cached(("scene",), lambda: load_scene(name))
    config.validate()
    check_fifo_depth(config)
    check_fixed_grid(config)
    grid = cached(("grid", repr(config.grid), config.os.local_words, config.precision),
                  lambda: build_grid(scene, config))
    prepass = run_prepass(scene, config, res=res, corners=corners, grid=grid)
    images = build_images(scene, config, priorities=prepass.priorities, grid=grid,
                          lists_local=lists_local)
    return KernelInputs(scene, prepass, images, kernel_defines(images, generic, slots, defines))


def prepare(scene: Scene | str, config: MachineConfig, res: int = 32, corners: bool = False,
            generic: bool = False, slots: int = DEFAULT_SLOTS, kernel_dir: str | Path | None = None,
            kernels: dict[str, str | Path] | None = None,
            defines: dict[str, int | float] | None = None,
            memo: HostMemo | None = None, lists_local: bool = False) -> RenderSetup:
    """Host work before a run: grid, pre-pass, images, kernels, eye rays. `defines` adds (or
    overrides) kernel symbols, e.g. {"SERIAL_TREES": 1} for the serial mode. `memo` keeps the
    scene, grid and kernels for later calls (only for a scene given by name). `lists_local`:
    IC reads the list cells from its local memory (`kernel_inputs`)."""
    name = scene if isinstance(scene, str) else None
    inputs = kernel_inputs(scene, config, res, corners, generic, slots, defines, memo, lists_local)
    scene, prepass, images, defines = inputs.scene, inputs.prepass, inputs.images, inputs.defines
    check_scale(scene, config.precision)
    key = ("kernels", str(kernel_dir), repr(kernels), tuple(sorted(defines.items())),
           schedule_key(config))
    programs = (memo.get((name, *key), lambda: assemble_kernels(defines, kernel_dir, kernels, config))
                if memo is not None and name is not None
                else _bundled_kernels(key, defines, kernel_dir, kernels, config))
    images.check_programs(programs)
    wf = word_format(config.precision)
    return RenderSetup(scene, config, res, corners, generic, images, prepass, programs, defines,
                       eye_ray_messages(scene, res, corners, wf))


def finish(setup: RenderSetup, engine: Engine, run: RunResult) -> RenderResult:
    """Read the results out of an engine that has run (whatever its end: nothing computed is
    lost), through the engine interface only."""
    dt = dtype_of(setup.config.precision)
    frame = np.asarray(engine.frame).astype(dt)
    if setup.corners:
        c = frame
        image = (((c[:-1, :-1] + c[:-1, 1:]) + c[1:, :-1]) + c[1:, 1:]) * dt(0.25)
    else:
        image = frame
    wf = word_format(setup.config.precision)
    sc = setup.programs["sc"]
    rays = {"eye": int(setup.side * setup.side)}
    for name in RAY_COUNTERS:
        label = f"count_{name}"
        section, addr = sc.labels.get(label, ("", -1))
        if section != "data":
            rays[name] = 0
            continue
        rays[name] = sum(wf.to_int(engine.memory(f"pe{pe}.sc", "local")[addr])
                         for pe in range(setup.images.config.pes))
    ids = np.array(engine.ids, copy=True)
    visible = int(len(np.unique(ids[ids >= 0])))
    u8 = to_u8(image)
    result = RenderResult(setup, engine, run, image, u8, ids, rays, visible)
    s = engine.statistics()
    s["render"] = {"scene": setup.scene.name, "resolution": setup.res, "corners": setup.corners,
                   "generic": setup.generic, "slots": setup.defines.get("SLOTS"),
                   "prepass": setup.prepass.summary() | {"seconds": None}}
    s["rays"] = {k: rays[k] for k in ("eye", *RAY_COUNTERS)}
    s["visible_primitives"] = visible
    s["image_sha256"] = hashlib.sha256(u8.tobytes()).hexdigest()
    result.stats = s
    return result


def render(scene: Scene | str, config: MachineConfig, res: int = 32, corners: bool = False,
           generic: bool = False, slots: int = DEFAULT_SLOTS, kernel_dir: str | Path | None = None,
           kernels: dict[str, str | Path] | None = None, progress=None,
           defines: dict[str, int | float] | None = None,
           engine: str | None = None, record_loads: bool = False,
           lists_local: bool = False) -> RenderResult:
    """Render on the emulated machine with engine `engine` (default: `default_engine()`). `progress(cycle)` is called now and
    then if given; `defines` adds kernel symbols (see `prepare`). `record_loads`: record every
    IC's resident and global loads (`Engine.record_loads`; read `result.engine.recorder`).
    `lists_local`: IC reads the list cells from its local memory (`prepare`); recorded loads
    then include IC's local ones."""
    setup = prepare(scene, config, res, corners, generic, slots, kernel_dir, kernels, defines,
                    lists_local=lists_local)
    eng = setup.engine(engine)
    if record_loads:
        eng.record_loads(local=lists_local)
    return finish(setup, eng, eng.run(progress=progress))
