"""The four databases laid out as the word images the emulated machine loads (docs/databases.md).

    voxel_data      OS local memory, from `os_base`: top header, top voxel words, sub-grids
    primitive_list  ICGM from word 1 (word 0 is the null cell): 2-word cells [P, shape pointer], one list per leaf
    shape_data      IC resident memory (priority <= M, in priority order) or ICGM after the lists
                    (priority > M, ascending id) — never both: resident data have no global copy
    luminance_data  SCGM: deduplicated material records; SC local memory from `sc_base`: the
                    scene block (lights, background, eps, counts)

`docs/databases.md` gives every word format and the IC access protocol; `host/records.py` holds
the offsets. `plan_layout` decides every address (cheap: no words are encoded), so
`database_bytes` and the pre-pass can ask for sizes without building images; `build_images`
encodes the words, the region maps the emulator counts with, and the assembler symbols the
kernels are built with.

The "primitive database" that `ic_memory.cache_share` / `resident_share` refer to (the paper's
Figures 4–5) is IC's data: primitive_list + shape_data, all records counted once.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from netsushisen.isa.errors import ConfigError, Diagnostic
from netsushisen.host.golden import Luminance, offset_scale, scene_epsilon
from netsushisen.host.grid import Grid, build_grid
from netsushisen.host.records import (CELL_WORDS, LIGHT_WORDS, MATERIAL_WORDS, SCENE_HEADER_WORDS,
                                      SUB_HEADER_WORDS, TOP_HEADER_WORDS, access_offsets, float_words,
                                      int_words, material_records, ranges, record_sizes,
                                      scene_block, shape_records, symbols)
from netsushisen.host.scenes import Kind, Scene
from netsushisen.host.shapes import ShapeData, build_shape_data
from netsushisen.host.traversal import OSGrid, _boundary
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.images import MemoryImage, Segment
from netsushisen.isa.regions import (GLOBAL, REGION_NAMES, RESIDENT, Region, cache_bytes,
                                     resident_words)
from netsushisen.isa.words import WordFormat, word_format

OS_BASE = 256
"""Default OS local address of the voxel data; words below it are the OS kernel's own data."""
SC_BASE = 256
"""Default SC local address of the scene block; words below it are the SC kernel's own data."""
LIST_BASE = 1
"""ICGM address of the first list cell: word 0 stays 0, so a cell or list pointer of 0 is null."""
IC_LISTS_BASE = 4096
"""With the lists in IC's local memory (`build_images(lists_local=True)`, the findings' reading
`--lists local`): the IC local address of ICGM word 0, so cell c is read at IC_LISTS_BASE + c;
words below it are IC's own data (slot table, fan buffers)."""
# GLOBAL, RESIDENT — the address spaces of a shape record / an IC access, ICGM through the cache
# (ldg) or resident (ldr) — live in isa/regions.py, shared with the machine's trace-driven model.
DATABASES = ("voxel_data", "primitive_list", "shape_data", "luminance_data")


@dataclass
class DatabaseLayout:
    """Every address of the four databases (no words): what images, sizes and the IC access
    stream are computed from."""

    scene: Scene
    grid: Grid
    shapes: ShapeData
    luminance: Luminance
    wf: WordFormat
    os_base: int
    sc_base: int
    priorities: np.ndarray  # (N,) int64 permutation of 1..N (1 = most referenced)
    resident_count: int  # M: primitives with priority <= M live in resident memory
    resident_capacity: int  # resident memory words (config, shares resolved)
    cache_bytes: int  # IC cache bytes (config, shares resolved)
    record_size: np.ndarray  # (N,) words
    record_space: np.ndarray  # (N,) int8 GLOBAL / RESIDENT
    record_address: np.ndarray  # (N,) int64 word address in that space
    shape_base: int  # ICGM address of the first non-resident record
    material_words: np.ndarray  # deduplicated material records (raw words)
    luminance_pointer: np.ndarray  # (N,) int64 SCGM address of each primitive's material record
    voxel_words: int  # header + top voxels + sub-grids
    scene_words: int  # SC scene block

    @property
    def n_primitives(self) -> int:
        return len(self.priorities)

    @property
    def list_words(self) -> int:
        """The null word + one cell per list entry."""
        return LIST_BASE + CELL_WORDS * len(self.grid.leaf_prims)

    @property
    def shape_words(self) -> int:
        return int(self.record_size.sum())

    @property
    def primitive_database_words(self) -> int:
        """IC's data (primitive_list + shape_data): what the cache and resident shares refer to."""
        return self.list_words + self.shape_words

    @property
    def resident_words(self) -> int:
        """Words of resident memory the M records use."""
        return int(self.record_size[self.record_space == RESIDENT].sum())

    @property
    def leaf_cell(self) -> np.ndarray:
        """(leaves,) ICGM address of each leaf's first cell (what a voxel word points to)."""
        return LIST_BASE + CELL_WORDS * self.grid.leaf_offsets[:-1]

    def primitive_of(self, space: int, address: int) -> int:
        """The primitive whose shape record starts at `address` of `space` (-1 if none): turns a
        record pointer a kernel forwards back into a primitive id."""
        ids = np.flatnonzero((self.record_space == space) & (self.record_address == address))
        return int(ids[0]) if len(ids) else -1

    def sizes(self) -> dict[str, int]:
        """Bytes of each database (shape_data counts every record once, wherever it lives)."""
        words = {"voxel_data": self.voxel_words, "primitive_list": self.list_words,
                 "shape_data": self.shape_words,
                 "luminance_data": len(self.material_words) + self.scene_words}
        return {k: v * self.wf.bytes for k, v in words.items()}


# ------------------------------------------------------------------------------------------------
# Capacities and the resident fill


def ic_capacities(config: MachineConfig, primitive_database_words: int) -> tuple[int, int]:
    """(resident words, cache bytes) of IC, the shares resolved against the primitive database
    with the emulator's own rounding (resident: whole words, cache: whole blocks)."""
    mc = config.ic_memory
    for name in ("resident_share", "cache_share"):
        v = getattr(mc, name)
        if v is not None and not 0.0 <= v <= 1.0:
            raise ConfigError(f"ic_memory.{name} = {v}: a share of the primitive database must "
                              "lie in 0..1 (resident data have no copy in global memory)")
    wb = config.word_bytes
    return (resident_words(mc, primitive_database_words, wb),
            cache_bytes(mc, primitive_database_words, wb))


def resident_fill(sizes_in_priority_order: np.ndarray, capacity_words: int) -> int:
    """M: records are copied in priority order until the next one does not fit (the paper's
    pre-pass; docs/databases.md)."""
    used = np.cumsum(np.asarray(sizes_in_priority_order, dtype=np.int64))
    return int(np.searchsorted(used, capacity_words, side="right"))


def identity_priorities(n: int) -> np.ndarray:
    """Priorities without a pre-pass: primitive id order (priority = id + 1)."""
    return np.arange(1, n + 1, dtype=np.int64)


def _check_priorities(priorities, n: int) -> np.ndarray:
    p = np.asarray(priorities, dtype=np.int64)
    if p.shape != (n,) or not np.array_equal(np.sort(p), np.arange(1, n + 1)):
        raise ValueError(f"priorities must be a permutation of 1..{n} (one per primitive)")
    return p


# ------------------------------------------------------------------------------------------------
# Layout


def plan_layout(scene: Scene, config: MachineConfig | None = None, priorities=None,
                grid: Grid | None = None, os_base: int = OS_BASE,
                sc_base: int = SC_BASE) -> DatabaseLayout:
    """Decide every address. Raises ConfigError when the voxel data or the scene block do not
    fit their local memories or a share is impossible."""
    config = config or MachineConfig()
    wf = word_format(config.precision)
    grid = grid if grid is not None else build_grid(scene, config)
    sd = build_shape_data(scene, config.precision)
    lum = Luminance.of(scene, wf.float_type)
    n = scene.n_primitives
    p = identity_priorities(n) if priorities is None else _check_priorities(priorities, n)
    size = record_sizes(sd)
    list_words = LIST_BASE + CELL_WORDS * len(grid.leaf_prims)
    capacity, cache = ic_capacities(config, list_words + int(size.sum()))
    order = np.argsort(p)  # primitive ids in priority order
    m = resident_fill(size[order], capacity)
    space = np.full(n, GLOBAL, np.int8)
    address = np.zeros(n, np.int64)
    res = order[:m]
    space[res] = RESIDENT
    address[res] = np.cumsum(size[res]) - size[res]
    rest = np.flatnonzero(space == GLOBAL)  # ascending id
    address[rest] = list_words + np.cumsum(size[rest]) - size[rest]
    mat_words, mat_index = material_records(lum, wf)
    lum_ptr = MATERIAL_WORDS * mat_index[scene.material] if n else np.zeros(0, np.int64)
    voxel_words = TOP_HEADER_WORDS + grid.words
    scene_words = SCENE_HEADER_WORDS + LIGHT_WORDS * len(lum.light_pos)
    problems = []
    if os_base < 0 or sc_base < 0:
        problems.append(f"local bases must not be negative (os_base {os_base}, sc_base {sc_base})")
    if os_base + voxel_words > config.os.local_words:
        problems.append(f"voxel data ({voxel_words} words: {TOP_HEADER_WORDS}-word header + "
                        f"{grid.words} grid words) at OS local address {os_base} do not fit "
                        f"os.local_words = {config.os.local_words}; raise os.local_words, pass a lower "
                        "os_base or choose smaller grid.top_resolution / grid.sub_resolution")
    if sc_base + scene_words > config.sc.local_words:
        problems.append(f"the SC scene block ({scene_words} words) at SC local address {sc_base} "
                        f"does not fit sc.local_words = {config.sc.local_words}")
    if problems:
        raise ConfigError([Diagnostic(p, file="config") for p in problems])
    return DatabaseLayout(scene=scene, grid=grid, shapes=sd, luminance=lum, wf=wf, os_base=os_base,
                          sc_base=sc_base, priorities=p, resident_count=m, resident_capacity=capacity,
                          cache_bytes=cache, record_size=size, record_space=space,
                          record_address=address, shape_base=list_words, material_words=mat_words,
                          luminance_pointer=np.asarray(lum_ptr, np.int64), voxel_words=voxel_words,
                          scene_words=scene_words)


def check_fixed_grid(config: MachineConfig, os_base: int = OS_BASE) -> None:
    """Before the grid is built: a fixed `grid.top_resolution` whose voxels alone cannot fit OS
    memory is refused from the configuration, at once (building a 256³ grid to find out took
    19-53 s); the same message `plan_layout` gives a built grid that does not fit."""
    from netsushisen.host.grid import WORDS_PER_VOXEL

    top = config.grid.top_resolution
    if top <= 0:
        return
    words = TOP_HEADER_WORDS + top ** 3 * WORDS_PER_VOXEL
    if os_base + words > config.os.local_words:
        raise ConfigError(Diagnostic(
            f"voxel data (at least {words:,} words: grid.top_resolution {top} is {top ** 3:,} "
            f"top voxels) at OS local address {os_base} do not fit os.local_words = "
            f"{config.os.local_words}; raise os.local_words or choose a smaller "
            "grid.top_resolution", file="config"))


def database_bytes(scene: Scene, config: MachineConfig | None = None,
                   grid: Grid | None = None) -> dict[str, int]:
    """Bytes of voxel_data, primitive_list, shape_data and luminance_data (`scene info`)."""
    return plan_layout(scene, config, grid=grid).sizes()


# ------------------------------------------------------------------------------------------------
# Images


@dataclass
class MachineImages:
    """Everything the machine loads for one scene, as raw words (uint32 fp32 / uint64 fp64).

    `config` is a copy of the build's config with IC's cache and resident sizes resolved to
    bytes (shares set to None): the emulator resolves shares against the ICGM image, which
    shrinks by the resident records, so run the emulator with this config."""

    layout: DatabaseLayout
    config: MachineConfig
    os_local: np.ndarray  # voxel data, placed at layout.os_base
    icgm: np.ndarray  # from address 0
    ic_resident: np.ndarray  # from address 0 (the M resident records)
    scgm: np.ndarray  # material records from address 0
    sc_local: np.ndarray  # scene block, placed at layout.sc_base
    sc_resident: np.ndarray  # empty: SC keeps nothing resident
    regions: dict[str, list[Region]]  # "<proc>.<local|resident|global>" -> ranges
    symbols: dict[str, int]
    ic_local: np.ndarray | None = None  # lists_local: ICGM's list words, placed at IC_LISTS_BASE

    def placements(self) -> dict[str, tuple[int, np.ndarray]]:
        """Memory key (emulator image names) -> (address, words)."""
        out = {"os.local": (self.layout.os_base, self.os_local), "icgm": (0, self.icgm),
               "ic.local": (IC_LISTS_BASE, self.ic_local if self.ic_local is not None
                            else self.icgm[:0]),
               "ic.resident": (0, self.ic_resident), "scgm": (0, self.scgm),
               "sc.local": (self.layout.sc_base, self.sc_local), "sc.resident": (0, self.sc_resident)}
        return {k: v for k, v in out.items() if len(v[1]) or k in ("icgm", "scgm")}

    def memory_image(self) -> MemoryImage:
        """The machine's `MemoryImage` (memories, global sizes, region maps; isa/images.py)."""
        img = MemoryImage(source=f"<images of {self.layout.scene.name}>")
        for key, (at, words) in self.placements().items():
            img.memories[key] = [Segment(at, [("w", words)])]
        img.sizes = {"icgm": len(self.icgm), "scgm": len(self.scgm)}
        img.regions = {k: list(v) for k, v in self.regions.items()}
        return img

    def save_npz(self, path) -> None:
        """Write the images in the emulator's .npz format (`netsushisen run --image FILE.npz`)."""
        arrays: dict[str, np.ndarray] = {}
        for key, (at, words) in self.placements().items():
            arrays[f"{key}@{at}" if at else key] = words
        arrays["sizes.icgm"] = np.array(len(self.icgm))
        arrays["sizes.scgm"] = np.array(len(self.scgm))
        for key, regs in self.regions.items():
            arrays[f"regions.{key}"] = np.array(
                [[r.start, r.end, REGION_NAMES.index(r.name), -1 if r.primitive is None else r.primitive]
                 for r in regs], dtype=np.int64).reshape(-1, 4)
        from netsushisen.isa.outputs import write_file

        def write(tmp: Path) -> None:
            with open(tmp, "wb") as f:  # a file, not a name: np.savez would add ".npz" to it
                np.savez(f, **arrays)
        write_file(path, write)

    def check_programs(self, programs: dict) -> None:
        """Kernel `.data` is loaded at local address 0 and image words overwrite it: a program
        whose data reach the voxel data (OS) or the scene block (SC) is a configuration error."""
        for stage, base in (("os", self.layout.os_base), ("sc", self.layout.sc_base)):
            prog = programs.get(stage)
            if prog is not None and len(prog.data) > base:
                raise ConfigError(f"the {stage.upper()} kernel has {len(prog.data)} data words but the "
                                  f"{'voxel data' if stage == 'os' else 'scene block'} start at local "
                                  f"address {base}: build the images with a larger {stage}_base")
        prog = programs.get("ic")
        if self.ic_local is not None and prog is not None and len(prog.data) > IC_LISTS_BASE:
            raise ConfigError(f"the IC kernel has {len(prog.data)} data words but the lists start "
                              f"at IC local address {IC_LISTS_BASE} (lists local)")

    def defines(self) -> list[str]:
        """The symbols as assembler arguments: ["-D", "NAME=VALUE", ...]."""
        out: list[str] = []
        for k, v in self.symbols.items():
            out += ["-D", f"{k}={v}"]
        return out


def build_images(scene: Scene, config: MachineConfig | None = None, priorities=None, grid: Grid | None = None,
                 os_base: int = OS_BASE, sc_base: int = SC_BASE,
                 lists_local: bool = False) -> MachineImages:
    """Lay out and encode the databases of `scene` for `config`. `priorities` (from the
    pre-pass, `host/prepass.py`) decide which records are resident; None = id order.
    `lists_local`: also place the list words (ICGM 0 .. list end, the same words at the same
    relative addresses) in IC's local memory from IC_LISTS_BASE, for the kernels assembled with
    LISTS_LOCAL = 1 (IC reads its cells there with `ld`, never through the cache: the findings'
    reading `--lists local`); ICGM keeps every address as it is."""
    config = config or MachineConfig()
    lay = plan_layout(scene, config, priorities, grid, os_base, sc_base)
    wf = lay.wf
    records, rec_off = shape_records(lay.shapes, lay.luminance_pointer, wf)
    res_ids = np.flatnonzero(lay.record_space == RESIDENT)
    res_ids = res_ids[np.argsort(lay.priorities[res_ids])]
    glob_ids = np.flatnonzero(lay.record_space == GLOBAL)
    icgm = np.concatenate([_list_words(lay), _gather(records, rec_off, glob_ids)])
    ic_resident = _gather(records, rec_off, res_ids)
    scene_words = scene_block(lay.luminance, len(lay.material_words) // MATERIAL_WORDS,
                              config.render.max_depth, scene_epsilon(lay.grid, config, wf.float_type),
                              config.render.min_weight, wf, offset_scale(wf.float_type))
    resolved = copy.deepcopy(config)
    resolved.ic_memory.resident_bytes = lay.resident_capacity * wf.bytes
    resolved.ic_memory.cache_bytes = lay.cache_bytes
    resolved.ic_memory.resident_share = resolved.ic_memory.cache_share = None
    regions, symbols, ic_local = region_maps(lay), kernel_symbols(lay, config), None
    if lists_local:
        if IC_LISTS_BASE + lay.list_words > config.ic.local_words:
            raise ConfigError(Diagnostic(
                f"the lists ({lay.list_words} words) at IC local address {IC_LISTS_BASE} do not "
                f"fit ic.local_words = {config.ic.local_words}; raise ic.local_words to at least "
                f"{IC_LISTS_BASE + lay.list_words} to hold them in IC's local memory", file="config"))
        ic_local = icgm[:lay.list_words].copy()
        regions["ic.local"] = [Region(IC_LISTS_BASE, IC_LISTS_BASE + lay.list_words,
                                      "primitive_list")]
        symbols.update(LISTS_LOCAL=1, IC_LISTS_BASE=IC_LISTS_BASE)
    return MachineImages(layout=lay, config=resolved, os_local=_voxel_words(lay), icgm=icgm,
                         ic_resident=ic_resident, scgm=lay.material_words.copy(), sc_local=scene_words,
                         sc_resident=np.zeros(0, wf.word_dtype), regions=regions,
                         symbols=symbols, ic_local=ic_local)


def _gather(records: np.ndarray, offsets: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """The records of `ids`, in that order, back to back."""
    return records[ranges(offsets[ids], offsets[ids + 1] - offsets[ids])]


def _list_words(lay: DatabaseLayout) -> np.ndarray:
    """ICGM words 0 .. list end: the null word, then per leaf (grid order) its cells
    [priority, shape pointer] in ascending primitive id; the leaf's last cell holds -priority."""
    g = lay.grid
    prim = g.leaf_prims.astype(np.int64)
    e = len(prim)
    last = np.zeros(e, bool)
    last[g.leaf_offsets[1:] - 1] = True
    priority = lay.priorities[prim].astype(np.int64)
    cells = np.column_stack([np.where(last, -priority, priority), lay.record_address[prim]])
    return np.concatenate([int_words([0] * LIST_BASE, lay.wf), int_words(cells, lay.wf)])


def _voxel_words(lay: DatabaseLayout) -> np.ndarray:
    """OS local words from os_base: top header, top voxels, then each sub-grid (header + voxels).
    Voxel word: 0 empty, > 0 ICGM address of the leaf's first cell, < 0 -(sub-grid header address)."""
    g, wf = lay.grid, lay.wf
    osg = OSGrid.of(g, wf.float_type)
    dt = wf.float_type
    hi = _boundary(osg.lo, osg.res, osg.cell, dt)  # traversal's far boundary, same operations
    header = np.concatenate([float_words(np.concatenate([osg.lo, osg.cell, osg.inv_cell]), wf),
                             int_words(g.res, wf), float_words(hi, wf), int_words([g.res[0] * g.res[1]], wf)])
    ntop = int(np.prod(g.res))
    n_sub = len(g.sub_res)
    sub_size = g.sub_res.prod(axis=1) if n_sub else np.zeros(0, np.int64)
    hdr_rel = TOP_HEADER_WORDS + ntop + SUB_HEADER_WORDS * np.arange(n_sub) + g.sub_offset
    if TOP_HEADER_WORDS + ntop + SUB_HEADER_WORDS * n_sub + int(sub_size.sum()) != lay.voxel_words:
        raise AssertionError("host/grid.py's voxel-data word count no longer matches this layout")
    cell_of = np.concatenate([lay.leaf_cell, [0]])  # index -1 (no leaf) reads the trailing 0
    sub_of = np.concatenate([-(lay.os_base + hdr_rel), [0]])  # index -1 (not divided) reads 0

    out = np.zeros(lay.voxel_words, dtype=wf.word_dtype)
    out[:TOP_HEADER_WORDS] = header
    out[TOP_HEADER_WORDS:TOP_HEADER_WORDS + ntop] = int_words(cell_of[g.top_leaf] + sub_of[g.top_sub], wf)
    if n_sub:
        floats = float_words(np.concatenate([osg.sub_lo, osg.sub_cell, osg.sub_inv_cell], axis=1), wf)
        hdr = np.concatenate([floats.reshape(n_sub, 9), int_words(g.sub_res, wf).reshape(n_sub, 3)], axis=1)
        out[(hdr_rel[:, None] + np.arange(SUB_HEADER_WORDS)).ravel()] = hdr.ravel()
        s_of = np.repeat(np.arange(n_sub), sub_size)
        rel = TOP_HEADER_WORDS + ntop + SUB_HEADER_WORDS * (s_of + 1) + np.arange(len(s_of))
        out[rel] = int_words(cell_of[g.sub_leaf], wf)
    return out


# ------------------------------------------------------------------------------------------------
# Region maps and symbols


def region_maps(lay: DatabaseLayout) -> dict[str, list[Region]]:
    """Named address ranges for the emulator's counters. Each shape record is two ranges: its
    kind word carries the primitive id (IC reads it once per intersection test, so the
    per-primitive count equals the golden reference count) and the rest is plain shape_data."""
    def records(space: int) -> list[Region]:
        ids = np.flatnonzero(lay.record_space == space)
        out = []
        for p, a, s in zip(ids.tolist(), lay.record_address[ids].tolist(), lay.record_size[ids].tolist()):
            out.append(Region(a, a + 1, "shape_data", p))
            out.append(Region(a + 1, a + s, "shape_data"))
        return out

    out = {"os.local": [Region(lay.os_base, lay.os_base + lay.voxel_words, "voxel_data")],
           "ic.global": [Region(0, lay.list_words, "primitive_list")] + records(GLOBAL),
           "ic.resident": records(RESIDENT),
           "sc.local": [Region(lay.sc_base, lay.sc_base + lay.scene_words, "luminance_data")]}
    if len(lay.material_words):
        out["sc.global"] = [Region(0, len(lay.material_words), "luminance_data")]
    return {k: v for k, v in out.items() if v}


def kernel_symbols(lay: DatabaseLayout, config: MachineConfig) -> dict[str, int]:
    """Assembler symbols (`-D NAME=VALUE`) the kernels are built with for this scene."""
    sc = lay.scene
    kinds = lay.shapes.kind
    deep = config.render.max_depth > 1
    poly = lay.shapes.poly_count
    out = symbols()
    out.update(
        VOXEL_BASE=lay.os_base, TOP_VOXELS=lay.os_base + TOP_HEADER_WORDS, SCENE_BASE=lay.sc_base,
        LIGHTS_BASE=lay.sc_base + SCENE_HEADER_WORDS, RESIDENT_M=lay.resident_count,
        N_PRIMITIVES=lay.n_primitives, NLIGHTS=len(lay.luminance.light_pos),
        NMATERIALS=len(lay.material_words) // MATERIAL_WORDS, MAX_DEPTH=config.render.max_depth,
        MAX_VERTICES=int(poly.max()) if len(poly) else 0,
        HAS_POLYGONS=int(np.any(kinds == Kind.POLYGON)), HAS_SPHERES=int(np.any(kinds == Kind.SPHERE)),
        HAS_CYLINDERS=int(np.any(kinds == Kind.CYLINDER)), HAS_CONES=int(np.any(kinds == Kind.CONE)),
        HAS_PATCHES=int(np.any(lay.shapes.poly_is_patch)), HAS_TWO_SIDED=int(np.any(lay.shapes.two_sided)),
        HAS_REFLECTION=int(sc.reflective and deep), HAS_REFRACTION=int(sc.transparent and deep),
        # OS: its local memory above the voxel data (slot table, ray queue) and whether the grid
        # has a second level at all
        OS_FREE_BASE=lay.os_base + lay.voxel_words, OS_LOCAL_WORDS=config.os.local_words,
        HAS_SUBGRIDS=int(len(lay.grid.sub_res) > 0),
    )
    return out


def access_tables(lay: DatabaseLayout) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per primitive, CSR word offsets IC reads for a test and for a hit (`host/ic_access.py`)."""
    return {"test": access_offsets(lay.shapes, "test"), "hit": access_offsets(lay.shapes, "hit")}
