"""Word formats of the database records: shape records (IC), material records and the scene
block (SC), and the two grid headers (OS). `docs/databases.md` is the prose version of this file.

Every record is a run of machine words (`isa/words.py`): integers are 32-bit, floats are of the
machine's precision, addresses count words. The offsets below are the single source of truth: the
image builder (`host/databases.py`) writes them, the assembler symbols the kernels are built with
are generated from them (`symbols()`), and the IC access protocol (`host/ic_access.py`) reads its
per-kind word lists from the `test` / `hit` flags of `SHAPE_FORMATS`.

The shape-record fields are taken from `ShapeData` (`host/shapes.py`) and the material fields from
the golden model's `Luminance` (`host/golden.py`): nothing is recomputed here, values are only
placed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from netsushisen.host.grid import WORDS_PER_SUBGRID
from netsushisen.host.scenes import Kind
from netsushisen.host.shapes import ShapeData
from netsushisen.isa.images import encode
from netsushisen.isa.words import WordFormat

# ------------------------------------------------------------------------------------------------
# OS voxel data headers (OS local memory)

TOP_HEADER = {"VD_LO": 0, "VD_CELL": 3, "VD_INV_CELL": 6, "VD_RES": 9, "VD_HI": 12, "VD_NXY": 15}
"""Top grid header: lo, cell, inv_cell (3 floats each), res nx ny nz (3 ints), hi = the far
boundary lo + float(res)*cell exactly as traversal computes it (3 floats), nx*ny (int)."""
TOP_HEADER_WORDS = 16
SUB_HEADER = {"SG_LO": 0, "SG_CELL": 3, "SG_INV_CELL": 6, "SG_RES": 9}
"""Sub-grid header: sub_lo, sub_cell, sub_inv_cell (3 floats each), sub_res mx my mz (3 ints);
its sub-voxel words follow the header directly."""
SUB_HEADER_WORDS = 12
assert SUB_HEADER_WORDS == WORDS_PER_SUBGRID, "host/grid.py sizes sub-grids with another header"

# ------------------------------------------------------------------------------------------------
# Primitive list cells (ICGM)

CELL = {"CELL_PRIORITY": 0, "CELL_SHAPE": 1}
CELL_WORDS = 2
"""A cell is [priority, shape pointer]; the last cell of a leaf's list holds -P (priorities are
>= 1, so the sign ends the list). A leaf's cells are consecutive: the linked list's `next` is
implicit (cell + CELL_WORDS), which keeps the lists a third smaller than a stored pointer."""

# ------------------------------------------------------------------------------------------------
# Shape records (ICGM, or IC resident memory when priority <= M)

REC_KIND = 0  # kind/flags word
REC_LUMINANCE = 1  # SCGM address of the material record (the primitive's link to SC)
REC_PRIMITIVE = 2  # primitive id (IC sends it with a hit; SC reports eye-ray hits to COL)
KIND_MASK = 0x3  # bits 0..1: Kind (0 polygon, 1 sphere, 2 cylinder, 3 cone)
FLAG_TWO_SIDED = 1 << 2  # material T > 0: every root counts
FLAG_PATCH = 1 << 3  # `pp` polygon: per-vertex normals follow the vertices
COUNT_SHIFT = 8  # bits 8..31: vertex count of a polygon (0 for other kinds)


@dataclass(frozen=True)
class Field:
    """One field of a shape record, `width` words (per vertex for `per_vertex` fields, which
    come last). `test`: IC reads it for every intersection test; `hit`: IC reads it for the
    winning primitive of a surface ray, to compute the normals and fill the HIT message."""

    name: str
    width: int
    test: bool
    hit: bool
    per_vertex: bool = False


_HEAD = (Field("kind", 1, True, False), Field("luminance", 1, False, True), Field("primitive", 1, False, True))
SHAPE_FORMATS: dict[Kind, tuple[Field, ...]] = {
    # vertex_normals exist only in patches; a hit reads those of v0, v(j+1), v(j+2) (fan j)
    Kind.POLYGON: _HEAD + (Field("normal", 3, True, True), Field("vertices", 3, True, False, True),
                           Field("vertex_normals", 3, False, True, True)),
    Kind.SPHERE: _HEAD + (Field("center", 3, True, True), Field("r2", 1, True, False),
                          Field("radius", 1, False, False)),
    Kind.CYLINDER: _HEAD + (Field("base", 3, True, True), Field("axis", 3, True, True),
                            Field("length", 1, True, False), Field("r2", 1, True, False),
                            Field("r0", 1, False, False)),
    Kind.CONE: _HEAD + (Field("base", 3, True, True), Field("axis", 3, True, True),
                        Field("length", 1, True, False), Field("r0", 1, True, False),
                        Field("slope", 1, True, True), Field("r2", 1, False, False)),
}
_PREFIX = {Kind.POLYGON: "POLY", Kind.SPHERE: "SPH", Kind.CYLINDER: "CYL", Kind.CONE: "CONE"}


def field_offsets(kind: Kind) -> dict[str, int]:
    """Word offset of every field of a record kind (per-vertex fields: of vertex 0's first word;
    vertex normals start 3n words after the vertices)."""
    out, at = {}, 0
    for f in SHAPE_FORMATS[kind]:
        out[f.name] = at
        if not f.per_vertex:
            at += f.width
        elif f.name == "vertices":
            at = -1  # later per-vertex offsets depend on n
    return out


POLY_HEADER_WORDS = field_offsets(Kind.POLYGON)["vertices"]  # kind, luminance, id, normal
FIXED_WORDS = {k: sum(f.width for f in SHAPE_FORMATS[k]) for k in (Kind.SPHERE, Kind.CYLINDER, Kind.CONE)}
RECORD_SYMBOLS = {
    "REC_KIND": REC_KIND, "REC_LUMINANCE": REC_LUMINANCE, "REC_PRIMITIVE": REC_PRIMITIVE,
    "KIND_MASK": KIND_MASK, "FLAG_TWO_SIDED": FLAG_TWO_SIDED, "FLAG_PATCH": FLAG_PATCH,
    "COUNT_SHIFT": COUNT_SHIFT, "SPHERE_WORDS": FIXED_WORDS[Kind.SPHERE],
    "CYLINDER_WORDS": FIXED_WORDS[Kind.CYLINDER], "CONE_WORDS": FIXED_WORDS[Kind.CONE],
}
for _kind, _prefix in _PREFIX.items():
    RECORD_SYMBOLS[f"KIND_{_kind.name}"] = int(_kind)
    for _name, _offset in field_offsets(_kind).items():
        if _name not in ("kind", "luminance", "primitive", "vertex_normals"):
            RECORD_SYMBOLS[f"{_prefix}_{_name.upper()}"] = _offset

# ------------------------------------------------------------------------------------------------
# SC: material records (SCGM) and the scene block (SC local memory)

MATERIAL = {"MAT_KDC": 0, "MAT_KS": 3, "MAT_SHINE": 4, "MAT_T": 5, "MAT_IOR": 6, "MAT_INV_IOR": 7}
MATERIAL_WORDS = 8
SCENE = {"SCN_NLIGHTS": 0, "SCN_NMATERIALS": 1, "SCN_MAX_DEPTH": 2, "SCN_EPS": 3,
         "SCN_MIN_WEIGHT": 4, "SCN_BACKGROUND": 5, "SCN_EPS_REL": 8, "SCN_LIGHTS": 9}
SCENE_HEADER_WORDS = 9
LIGHT = {"LIGHT_POS": 0, "LIGHT_INT": 3}
LIGHT_WORDS = 6


def symbols() -> dict[str, int]:
    """Every fixed offset and size above as an assembler symbol (`-D NAME=VALUE`)."""
    out: dict[str, int] = {}
    for table in (TOP_HEADER, SUB_HEADER, CELL, RECORD_SYMBOLS, MATERIAL, SCENE, LIGHT):
        out.update(table)
    out.update(TOP_HEADER_WORDS=TOP_HEADER_WORDS, SUB_HEADER_WORDS=SUB_HEADER_WORDS,
               CELL_WORDS=CELL_WORDS, MATERIAL_WORDS=MATERIAL_WORDS,
               SCENE_HEADER_WORDS=SCENE_HEADER_WORDS, LIGHT_WORDS=LIGHT_WORDS)
    return out


# ------------------------------------------------------------------------------------------------
# Word helpers (the emulator's encoder: one definition of how a value becomes a word)


def float_words(values, wf: WordFormat) -> np.ndarray:
    """Raw words of values already rounded to the precision (host constants are never re-rounded)."""
    return encode("f", np.asarray(values, dtype=wf.float_type).ravel(), wf)


def int_words(values, wf: WordFormat) -> np.ndarray:
    return encode("i", np.asarray(values, dtype=np.int64).ravel(), wf)


# ------------------------------------------------------------------------------------------------
# Shape records


def _poly_counts(sd: ShapeData) -> tuple[np.ndarray, np.ndarray]:
    """Per primitive: vertex count (0 unless polygon) and patch flag."""
    n = len(sd.kind)
    count = np.zeros(n, np.int64)
    patch = np.zeros(n, bool)
    poly = np.flatnonzero(sd.kind == Kind.POLYGON)
    count[poly] = sd.poly_count[sd.local[poly]]
    patch[poly] = sd.poly_is_patch[sd.local[poly]]
    return count, patch


def record_sizes(sd: ShapeData) -> np.ndarray:
    """Words of each primitive's shape record (N,): polygons 5 + 3n (+ 3n for patches)."""
    count, patch = _poly_counts(sd)
    size = np.zeros(len(sd.kind), np.int64)
    for kind, words in FIXED_WORDS.items():
        size[sd.kind == kind] = words
    poly = sd.kind == Kind.POLYGON
    size[poly] = POLY_HEADER_WORDS + 3 * count[poly] * (1 + patch[poly])
    return size


def kind_words(sd: ShapeData) -> np.ndarray:
    """The kind/flags word value of every primitive (N,) int64."""
    count, patch = _poly_counts(sd)
    return (sd.kind.astype(np.int64) | np.where(sd.two_sided, FLAG_TWO_SIDED, 0)
            | np.where(patch, FLAG_PATCH, 0) | (count << COUNT_SHIFT))


def ranges(starts, lengths) -> np.ndarray:
    """Concatenated index ranges [starts[i], starts[i] + lengths[i]): how a run of records,
    vertices or cells is gathered or scattered in one numpy operation."""
    starts = np.asarray(starts, np.int64)
    lengths = np.asarray(lengths, np.int64)
    within = np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)
    return np.repeat(starts, lengths) + within


def shape_records(sd: ShapeData, luminance_pointer: np.ndarray,
                  wf: WordFormat) -> tuple[np.ndarray, np.ndarray]:
    """All shape records in primitive-id order as one raw-word array, and their offsets (N+1,).

    The image builder slices records out of this (resident ones in priority order, the others in
    id order), so a record's words are the same wherever it lives."""
    size = record_sizes(sd)
    offsets = np.concatenate([[0], np.cumsum(size)]).astype(np.int64)
    start = offsets[:-1]
    out = np.zeros(int(offsets[-1]), dtype=wf.word_dtype)
    out[start + REC_KIND] = int_words(kind_words(sd), wf)
    out[start + REC_LUMINANCE] = int_words(luminance_pointer, wf)
    out[start + REC_PRIMITIVE] = int_words(np.arange(len(sd.kind)), wf)
    loc = sd.local
    for kind in (Kind.SPHERE, Kind.CYLINDER, Kind.CONE):
        ids = np.flatnonzero(sd.kind == kind)
        if not len(ids):
            continue
        values = _fixed_fields(sd, kind, loc[ids])
        at = field_offsets(kind)
        for f in SHAPE_FORMATS[kind][len(_HEAD):]:
            v = float_words(values[f.name], wf)
            out[ranges(start[ids] + at[f.name], np.full(len(ids), f.width))] = v
    poly = np.flatnonzero(sd.kind == Kind.POLYGON)
    if len(poly):
        lp = loc[poly]
        normal_at = field_offsets(Kind.POLYGON)["normal"]
        out[ranges(start[poly] + normal_at, np.full(len(poly), 3))] = float_words(sd.poly_normal[lp], wf)
        count = sd.poly_count[lp]
        vertices = sd.poly_vertices[ranges(sd.poly_start[lp], count)]
        out[ranges(start[poly] + POLY_HEADER_WORDS, 3 * count)] = float_words(vertices, wf)
        patch = sd.poly_is_patch[lp]
        if patch.any():
            pc = count[patch]
            normals = sd.poly_vertex_normals[ranges(sd.poly_start[lp[patch]], pc)]
            out[ranges(start[poly[patch]] + POLY_HEADER_WORDS + 3 * pc, 3 * pc)] = float_words(normals, wf)
    return out, offsets


def _fixed_fields(sd: ShapeData, kind: Kind, local: np.ndarray) -> dict[str, np.ndarray]:
    """The ShapeData arrays behind each field name of a fixed-size record kind."""
    if kind == Kind.SPHERE:
        return {"center": sd.sph_center[local], "r2": sd.sph_r2[local], "radius": sd.sph_radius[local]}
    out = {"base": sd.cone_base[local], "axis": sd.cone_axis[local], "length": sd.cone_length[local],
           "r2": sd.cone_r2[local], "r0": sd.cone_r0[local]}
    if kind == Kind.CONE:
        out["slope"] = sd.cone_slope[local]
    return out


def access_offsets(sd: ShapeData, which: str) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets (N+1,), word offsets within the record) of the words IC reads per primitive:
    `which` = "test" (every intersection test) or "hit" (the winner of a surface ray), in
    ascending address order (docs/databases.md, IC access protocol)."""
    count, patch = _poly_counts(sd)
    n = len(sd.kind)
    per_prim: list[np.ndarray] = [np.zeros(0, np.int64)] * n
    cache: dict[tuple[int, int, bool], np.ndarray] = {}
    for p in range(n):
        key = (int(sd.kind[p]), int(count[p]), bool(patch[p]))
        if key not in cache:
            cache[key] = _field_words(Kind(key[0]), key[1], key[2], which)
        per_prim[p] = cache[key]
    lengths = np.array([len(a) for a in per_prim], np.int64)
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    words = np.concatenate(per_prim) if n else np.zeros(0, np.int64)
    return offsets, words.astype(np.int64)


def _field_words(kind: Kind, nv: int, patch: bool, which: str) -> np.ndarray:
    """Offsets of the `which` words of one record shape; the fan-dependent vertex normals of a
    patch hit are left to `patch_hit_offsets`."""
    words: list[int] = []
    offsets = field_offsets(kind)
    for f in SHAPE_FORMATS[kind]:
        if not getattr(f, which) or f.name == "vertex_normals":
            continue
        width = f.width * nv if f.per_vertex else f.width
        words.extend(range(offsets[f.name], offsets[f.name] + width))
    return np.array(sorted(words), np.int64)


def patch_hit_offsets(nv: np.ndarray, fan: np.ndarray) -> np.ndarray:
    """(k, 9) offsets of the vertex normals a patch hit reads: those of v0, v(j+1), v(j+2) of
    fan triangle j (the ones the shading normal interpolates), ascending."""
    first = POLY_HEADER_WORDS + 3 * np.asarray(nv, np.int64)
    corner = np.stack([np.zeros_like(fan), fan + 1, fan + 2], axis=1).astype(np.int64)
    return (first[:, None, None] + 3 * corner[:, :, None] + np.arange(3)).reshape(len(first), 9)


# ------------------------------------------------------------------------------------------------
# Material records and the scene block


def material_records(lum, wf: WordFormat) -> tuple[np.ndarray, np.ndarray]:
    """Deduplicated material records (raw words, MATERIAL_WORDS each) and, per scene material
    row, the index of its record. Rows whose eight words are equal share one record (first
    occurrence order), so the luminance pointer of two such primitives is the same."""
    rows = np.column_stack([lum.kdc, lum.ks, lum.shine, lum.t, lum.ior, lum.inv_ior]).astype(wf.float_type)
    words = float_words(rows, wf).reshape(len(rows), MATERIAL_WORDS)
    if not len(rows):
        return words.ravel(), np.zeros(0, np.int64)
    _, first, inverse = np.unique(words, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # unique rows in first-occurrence order
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    return words[np.sort(first)].ravel(), rank[inverse.ravel()]


def scene_block(lum, n_materials: int, max_depth: int, eps, min_weight, wf: WordFormat,
                eps_rel=0.0) -> np.ndarray:
    """SC's scene constants: counts, max depth, eps (k_abs of the secondary-ray offset), min
    weight, background, eps_rel (its k_rel), then per light its position and intensity
    (colour / sqrt(#lights), from the golden model)."""
    dt = wf.float_type
    head = np.concatenate([int_words([len(lum.light_pos), n_materials, max_depth], wf),
                           float_words([dt(eps), dt(min_weight)], wf), float_words(lum.background, wf),
                           float_words([dt(eps_rel)], wf)])
    lights = np.column_stack([lum.light_pos.reshape(-1, 3), lum.light_int.reshape(-1, 3)])
    return np.concatenate([head, float_words(lights, wf)])
