"""The two-level uniform grid OS traverses (the paper's object-search structure).

Top level: a uniform grid over the scene bounds. A top voxel listing more than
`config.grid.subdivide_threshold` primitives gets its own uniform sub-grid. Every non-empty
*leaf* (an undivided top voxel or a sub-voxel) owns a primitive list in ascending primitive id.

Membership uses exact (or tight conservative) primitive-box overlap tests on boxes padded by
`pad` (below), so that rounding in traversal can never lose a hit:
polygon-box by the separating-axis theorem on the polygon's fan triangles (exact for convex
polygons, the union of the fan covers a concave polygon, so conservative there), sphere-box by the
closest-point distance (and a box strictly inside the sphere does not touch its surface),
cylinder/cone-box by minimising dist(axis point, box) - radius along the axis (a convex function;
the lateral surface lies in that union of balls, so conservative and tight) and dropping boxes
strictly inside the solid.

Conservative in the working precision at any magnitude (docs/golden.md, "Grid bounds and
membership at any scale"): the origin is rounded down and the cell sizes up to values the
precision holds exactly, so traversal reads exactly the grid built here; a voxel's box is taken
between its boundaries *as traversal computes them* (`lo + float(i)*cell` in the precision), and
every box grows by `pad = max(PAD x extent, PAD_ULPS x u x M)`, u the precision's unit roundoff and
M the largest coordinate magnitude of the scene and its eye: the crossings and hit points
traversal compares carry errors of a few u x M, so a face never lies within rounding of a
primitive it should list.

All geometry here is float64 host work on those exactly representable constants.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from netsushisen.host.rays import dtype_of, rowdot
from netsushisen.host.scenes import Kind, Scene
from netsushisen.isa.config import GridConfig, MachineConfig

WORDS_PER_VOXEL = 1  # OS voxel data: flag + list pointer (or sub-grid pointer) in one word
WORDS_PER_SUBGRID = 12  # sub-grid header: packed resolution, voxel pointer, origin, cell, 1/cell
TOP_DENSITY = 1.0  # top-level voxels per primitive, before the memory cap
SUB_DENSITY = 1.0  # sub-voxels per primitive listed in the subdivided voxel
MAX_TOP_PER_AXIS = 128
MAX_SUB_PER_AXIS = 16
PAD = 1e-5  # overlap boxes grow by at least PAD x the largest scene extent on every side
PAD_ULPS = 64  # ... and by at least PAD_ULPS x unit roundoff x the largest coordinate magnitude
MIN_CELL_PADS = 4
"""Automatic voxels (either level) are at least this many pads wide on every axis. A unit's
candidate range spans (size + 2 pad)/cell + 3 cells an axis; a scene far from the origin
(pad = 64u x M, e.g. tetra moved by 1e5 in fp32: pad 0.38 on an extent of 2) would otherwise
list every triangle in thousands of voxels it only touches through the pad — 5.6 GB of
candidates for an 8x8 image, growing with the translation. Voxels no finer than 4 pads keep
that at (size/cell + 3.5)^3 per unit and cost nothing at ordinary magnitudes (pad = 1e-5 x
extent, far below any cell)."""


@dataclass
class Grid:
    """Everything traversal needs. Voxel (ix, iy, iz) of a level has flat index
    (iz*ny + iy)*nx + ix; its box is [lo + i*cell, lo + (i+1)*cell] (float64 here; traversal
    rounds lo, cell and inv_cell to `precision`, where lo and cell are exact, and computes
    boundaries as lo + float(i)*cell in it: `boundaries` gives the same values)."""

    lo: np.ndarray  # (3,) float64 top-level origin
    res: np.ndarray  # (3,) int64 top-level voxels per axis
    cell: np.ndarray  # (3,) float64
    inv_cell: np.ndarray  # (3,) float64, 1/cell
    top_leaf: np.ndarray  # (nx*ny*nz,) int32 leaf id, -1 if empty or subdivided
    top_sub: np.ndarray  # (nx*ny*nz,) int32 sub-grid id, -1 if not subdivided
    sub_res: np.ndarray  # (S, 3) int64
    sub_lo: np.ndarray  # (S, 3) float64 (= the top voxel's lower corner)
    sub_cell: np.ndarray  # (S, 3) float64
    sub_inv_cell: np.ndarray  # (S, 3) float64
    sub_offset: np.ndarray  # (S,) int64 start of the sub-grid in sub_leaf
    sub_leaf: np.ndarray  # (sum of sub-grid voxels,) int32 leaf id or -1
    leaf_offsets: np.ndarray  # (leaves+1,) int64 CSR into leaf_prims
    leaf_prims: np.ndarray  # int32 primitive ids, ascending within a leaf
    words: int  # OS voxel data size by the sizing rule
    budget: int  # OS local memory words available
    pad: float
    precision: str = "fp32"
    primitive_size: float = 0.0  # the longest side of any primitive's bounding box


    @property
    def n_leaves(self) -> int:
        return len(self.leaf_offsets) - 1

    @property
    def hi(self) -> np.ndarray:
        return self.lo + self.res * self.cell

    def stats(self) -> dict[str, int]:
        return {"top_voxels": int(np.prod(self.res)), "subgrids": len(self.sub_res),
                "leaves": self.n_leaves, "list_entries": len(self.leaf_prims), "words": self.words}


# ------------------------------------------------------------------------------------------------
# Sizing


def axis_resolution(extent: np.ndarray, target: np.ndarray, cap: int) -> np.ndarray:
    """Per-axis voxel counts (K, 3) for boxes `extent` (K, 3) holding about `target` (K,) cubic
    voxels: the side s solving prod(max(1, E/s)) = target (bisection), then round(E/s) in [1, cap]."""
    e = np.maximum(np.asarray(extent, dtype=np.float64), 1e-300)
    lo = np.full(len(e), 1e-300)
    hi = e.max(axis=1) * 2.0
    t = np.maximum(np.asarray(target, dtype=np.float64), 1.0)
    for _ in range(80):
        mid = np.sqrt(lo * hi)
        with np.errstate(over="ignore"):
            cells = np.prod(np.maximum(1.0, e / mid[:, None]), axis=1)
        big = cells > t
        lo = np.where(big, mid, lo)
        hi = np.where(big, hi, mid)
    return np.clip(np.rint(e / hi[:, None]), 1, cap).astype(np.int64)


def choose_resolutions(extent: np.ndarray, n_prims: int, cfg: GridConfig, budget: int,
                       count_top: Callable[[np.ndarray], np.ndarray],
                       min_cell: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The sizing rule, in one place: (top resolution (3,), sub resolution (nx*ny*nz, 3), zero
    rows for undivided voxels).

    Top: about TOP_DENSITY voxels per primitive, at most half the OS budget, near-cubic voxels.
    A top voxel with more than `subdivide_threshold` primitives gets near-cubic sub-voxels, about
    SUB_DENSITY per listed primitive, 2..MAX_SUB_PER_AXIS per axis. OS voxel data then costs
    WORDS_PER_VOXEL per voxel of either level + WORDS_PER_SUBGRID per sub-grid; while that exceeds
    `budget` the sub-grids shrink (density halves), then the top level. Fixed resolutions from
    the config (non-zero) are used as given; automatic ones never make a voxel narrower than
    `min_cell` (MIN_CELL_PADS pads), so a sub-grid that would is not made.
    """
    def widest(e: np.ndarray) -> np.ndarray:  # most voxels an axis of extent e may take
        return np.maximum(np.floor(e / min_cell), 1).astype(np.int64) if min_cell > 0 \
            else np.full(np.shape(e), 1 << 30, np.int64)

    top_scale, sub_scale = 1.0, 1.0
    while True:
        if cfg.top_resolution > 0:
            top = np.full(3, cfg.top_resolution, dtype=np.int64)
        else:
            target = min(n_prims * TOP_DENSITY * top_scale, max(budget // (2 * WORDS_PER_VOXEL), 1))
            top = np.minimum(axis_resolution(extent[None], np.array([target]), MAX_TOP_PER_AXIS)[0],
                             widest(extent))
        counts = count_top(top)
        sub = np.zeros((len(counts), 3), dtype=np.int64)
        divided = counts > cfg.subdivide_threshold
        room = widest(extent / top)
        if cfg.sub_resolution == 0 and room.prod() < 2:
            divided[:] = False  # a sub-voxel would be narrower than min_cell on every axis
        if divided.any():
            if cfg.sub_resolution > 0:
                sub[divided] = cfg.sub_resolution
            else:
                cell = extent / top
                k = int(divided.sum())
                sub[divided] = np.clip(axis_resolution(np.tile(cell, (k, 1)),
                                                       counts[divided] * SUB_DENSITY * sub_scale,
                                                       MAX_SUB_PER_AXIS), 1, room)
                sub[divided] = np.where(sub[divided].prod(axis=1, keepdims=True) < 2,
                                        np.minimum(2, room), sub[divided])
        words = int(np.prod(top)) * WORDS_PER_VOXEL + int(divided.sum()) * WORDS_PER_SUBGRID \
            + int(sub[divided].prod(axis=1).sum()) * WORDS_PER_VOXEL
        fixed = cfg.top_resolution > 0 and cfg.sub_resolution > 0
        if words <= budget or fixed or (top_scale < 1e-6):
            return top, sub
        if cfg.sub_resolution == 0 and divided.any() and sub[divided].max() > 2:
            sub_scale /= 2.0
        else:
            top_scale /= 2.0


# ------------------------------------------------------------------------------------------------
# Overlap units: fan triangles of polygons, spheres, cylinders/cones


@dataclass
class _Units:
    prim: np.ndarray  # (U,) owner primitive id
    kind: np.ndarray  # (U,) 0 triangle, 1 sphere, 2 cone/cylinder
    geo: np.ndarray  # (U,) row in the kind's geometry
    lo: np.ndarray  # (U, 3) bounding box
    hi: np.ndarray
    tri: np.ndarray  # (T, 3, 3)
    sphere: np.ndarray  # (S, 4) centre, radius
    cone: np.ndarray  # (C, 8) base, r0, apex, r1


def _units(scene: Scene) -> _Units:
    pg, sp, cn = scene.polygons, scene.spheres, scene.cones
    kind, local = scene.kind, scene.local_index
    polys = np.flatnonzero(kind == Kind.POLYGON)
    nfan = np.maximum(pg.count[local[polys]] - 2, 0)
    t_prim = np.repeat(polys, nfan)
    j = np.arange(len(t_prim)) - np.repeat(np.cumsum(nfan) - nfan, nfan)
    s0 = pg.start[local[t_prim]]
    v = pg.vertices.reshape(-1, 3)
    tri = np.stack([v[s0], v[s0 + j + 1], v[s0 + j + 2]], axis=1) if len(t_prim) else np.zeros((0, 3, 3))
    sph = np.flatnonzero(kind == Kind.SPHERE)
    sgeo = np.column_stack([sp.center.reshape(-1, 3), sp.radius])[local[sph]] if len(sph) else np.zeros((0, 4))
    cones = np.flatnonzero((kind == Kind.CYLINDER) | (kind == Kind.CONE))
    cgeo = np.zeros((0, 8))
    if len(cones):
        cgeo = np.column_stack([cn.base.reshape(-1, 3), cn.base_radius, cn.apex.reshape(-1, 3),
                                cn.apex_radius])[local[cones]]
    # bounds
    tlo, thi = tri.min(axis=1), tri.max(axis=1)
    slo, shi = sgeo[:, :3] - sgeo[:, 3:4], sgeo[:, :3] + sgeo[:, 3:4]
    axis = cgeo[:, 4:7] - cgeo[:, :3]
    ln = np.sqrt((axis * axis).sum(axis=1, keepdims=True))
    a = np.divide(axis, ln, out=np.zeros_like(axis), where=ln > 0)
    disk = np.sqrt(np.maximum(1.0 - a * a, 0.0))  # half-extent of a unit disk across the axis
    r0, r1 = np.abs(cgeo[:, 3:4]), np.abs(cgeo[:, 7:8])
    clo = np.minimum(cgeo[:, :3] - r0 * disk, cgeo[:, 4:7] - r1 * disk)
    chi = np.maximum(cgeo[:, :3] + r0 * disk, cgeo[:, 4:7] + r1 * disk)
    return _Units(prim=np.concatenate([t_prim, sph, cones]).astype(np.int64),
                  kind=np.repeat([0, 1, 2], [len(t_prim), len(sph), len(cones)]),
                  geo=np.concatenate([np.arange(len(t_prim)), np.arange(len(sph)), np.arange(len(cones))]),
                  lo=np.concatenate([tlo, slo, clo]), hi=np.concatenate([thi, shi, chi]),
                  tri=tri, sphere=sgeo, cone=cgeo)


def triangle_box(tri: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Separating-axis test (K,) of triangles (K, 3, 3) against boxes: 3 box normals, the
    triangle normal and the 9 cross products of box axes with triangle edges."""
    c = (lo + hi) * 0.5
    h = (hi - lo) * 0.5
    v = tri - c[:, None, :]
    sep = (v.min(axis=1) > h).any(axis=1) | (v.max(axis=1) < -h).any(axis=1)
    edges = [v[:, 1] - v[:, 0], v[:, 2] - v[:, 1], v[:, 0] - v[:, 2]]
    n = np.cross(edges[0], edges[1])
    sep |= np.abs((n * v[:, 0]).sum(axis=1)) > (h * np.abs(n)).sum(axis=1)
    zero = np.zeros(len(v))
    for e in edges:
        for ax in (np.stack([zero, -e[:, 2], e[:, 1]], 1), np.stack([e[:, 2], zero, -e[:, 0]], 1),
                   np.stack([-e[:, 1], e[:, 0], zero], 1)):
            p = rowdot(ax[:, None, :], v)  # per vertex i of triangle k: ax[k] · v[k, i]
            r = (h * np.abs(ax)).sum(axis=1)
            sep |= (p.min(axis=1) > r) | (p.max(axis=1) < -r)
    return ~sep


def sphere_box(sph: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The sphere's surface meets the box: closest point within r, farthest corner not inside."""
    c, r = sph[:, :3], np.abs(sph[:, 3])
    near = np.maximum(np.maximum(lo - c, c - hi), 0.0)
    far = np.maximum(np.abs(lo - c), np.abs(hi - c))
    return ((near * near).sum(axis=1) <= r * r) & ((far * far).sum(axis=1) >= r * r)


def _box_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    q = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt((q * q).sum(axis=1))


def cone_box(cone: np.ndarray, lo: np.ndarray, hi: np.ndarray, iterations: int = 48) -> np.ndarray:
    """Open cylinder/cone surface meets the box (tight, conservative): min over s in [0, 1] of
    dist(B + s(A-B), box) - r(s) <= 0 (convex in s: ternary search), the box meets the slab
    between the end planes, and the box is not strictly inside the solid (all corners inside)."""
    b, r0, a, r1 = cone[:, :3], np.abs(cone[:, 3]), cone[:, 4:7], np.abs(cone[:, 7])
    axis = a - b
    g = lambda s: _box_distance(b + s[:, None] * axis, lo, hi) - (r0 + s * (r1 - r0))  # noqa: E731
    s_lo, s_hi = np.zeros(len(b)), np.ones(len(b))
    for _ in range(iterations):
        m1 = s_lo + (s_hi - s_lo) / 3.0
        m2 = s_hi - (s_hi - s_lo) / 3.0
        left = g(m1) < g(m2)
        s_hi = np.where(left, m2, s_hi)
        s_lo = np.where(left, s_lo, m1)
    length = np.sqrt((axis * axis).sum(axis=1))
    slack = (length + r0 + r1) * 1e-9 + (s_hi - s_lo) * (length + np.abs(r1 - r0))
    best = np.minimum(np.minimum(g(s_lo), g(s_hi)), g(np.zeros(len(b))))
    best = np.minimum(best, g(np.ones(len(b))))
    touches = best <= slack
    u = np.divide(axis, length[:, None], out=np.zeros_like(axis), where=length[:, None] > 0)
    # the lateral surface lies between the end planes: the box must meet that slab too
    zc = ((lo + hi) * 0.5 - b) * u
    zr = ((hi - lo) * 0.5 * np.abs(u)).sum(axis=1)
    zc = zc.sum(axis=1)
    touches &= (zc + zr >= -slack) & (zc - zr <= length + slack)
    inside = np.ones(len(b), dtype=bool)
    for corner in range(8):
        p = np.where([(corner >> k) & 1 for k in range(3)], hi, lo)
        w = p - b
        z = (w * u).sum(axis=1)
        rad2 = (w * w).sum(axis=1) - z * z
        rz = r0 + (r1 - r0) * np.divide(z, length, out=np.zeros_like(z), where=length > 0)
        inside &= (z > 0) & (z < length) & (rad2 < rz * rz)
    return touches & ~inside


def _overlap(units: _Units, u: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    out = np.zeros(len(u), dtype=bool)
    kind = units.kind[u]
    for k, test, geo in ((0, triangle_box, units.tri), (1, sphere_box, units.sphere), (2, cone_box, units.cone)):
        sel = np.flatnonzero(kind == k)
        if len(sel):
            out[sel] = test(geo[units.geo[u[sel]]], lo[sel], hi[sel])
    return out


def _expand(lo_idx: np.ndarray, hi_idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All integer cells of K index boxes: (owner row (M,), cell index (M, 3))."""
    from netsushisen.isa.limits import check_grid_candidates

    n = np.maximum(hi_idx - lo_idx + 1, 0)
    cnt = n.prod(axis=1)
    check_grid_candidates(int(cnt.sum()))
    rep = np.repeat(np.arange(len(cnt)), cnt)
    local = np.arange(len(rep)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    nx, ny = n[rep, 0], n[rep, 1]
    ijk = np.stack([local % nx, (local // nx) % ny, local // (nx * ny)], axis=1) + lo_idx[rep]
    return rep, ijk


def unit_roundoff(precision: str) -> float:
    """u = half the machine epsilon of `precision` (2^-24 for fp32, 2^-53 for fp64)."""
    return float(np.finfo(dtype_of(precision)).eps) / 2.0


def round_outward(x: np.ndarray, precision: str, up: bool) -> np.ndarray:
    """float64 values of `x` rounded to `precision` toward +inf (`up`) or -inf, as float64."""
    x = np.asarray(x, dtype=np.float64)
    dt = dtype_of(precision)
    v = x.astype(dt)
    wrong = v.astype(np.float64) < x if up else v.astype(np.float64) > x
    v = np.where(wrong, np.nextafter(v, dt(np.inf if up else -np.inf)), v)
    return v.astype(np.float64)


def boundaries(lo: np.ndarray, cell: np.ndarray, i: np.ndarray, precision: str) -> np.ndarray:
    """Boundary planes lo + float(i)*cell computed in `precision`, exactly as traversal computes
    them (lo and cell must be exact in it), returned as float64."""
    dt = dtype_of(precision)
    with np.errstate(over="ignore"):
        return (np.asarray(lo).astype(dt) + np.asarray(i).astype(dt) * np.asarray(cell).astype(dt)).astype(np.float64)


def _members(units: _Units, u: np.ndarray, origin: np.ndarray, cell: np.ndarray, res: np.ndarray,
             pad: float, precision: str) -> tuple[np.ndarray, np.ndarray]:
    """(unit, cell index) pairs of units `u` overlapping the padded cells of grids given per row
    (origin, cell, res: (K, 3) each). A cell's box runs between its boundaries as the precision
    computes them, grown by `pad`; the candidate index range is widened by one cell each way so
    that rounding of those boundaries cannot drop a cell before the exact test."""
    ilo = np.floor((units.lo[u] - pad - origin) / cell).astype(np.int64) - 1
    ihi = np.floor((units.hi[u] + pad - origin) / cell).astype(np.int64) + 1
    ilo = np.clip(ilo, 0, res - 1)
    ihi = np.clip(ihi, 0, res - 1)
    rep, ijk = _expand(ilo, ihi)
    box_lo = boundaries(origin[rep], cell[rep], ijk, precision) - pad
    box_hi = boundaries(origin[rep], cell[rep], ijk + 1, precision) + pad
    keep = _overlap(units, u[rep], box_lo, box_hi)
    return rep[keep], ijk[keep]


# ------------------------------------------------------------------------------------------------
# Build


def build_grid(scene: Scene, config: MachineConfig | None = None) -> Grid:
    """The two-level grid of `scene`, sized for `config.os.local_words`."""
    config = config or MachineConfig()
    cfg = config.grid
    units = _units(scene)
    if len(units.prim):
        slo, shi = units.lo.min(axis=0), units.hi.max(axis=0)
    else:
        slo, shi = np.zeros(3), np.ones(3)
    big = float(np.max(shi - slo))
    big = big if big > 0 else max(float(np.max(np.abs(slo))), 1.0)
    precision = config.precision
    magnitude = float(np.max(np.abs(np.concatenate([slo, shi, np.asarray(scene.camera.eye, np.float64)]))))
    pad = max(PAD * big, PAD_ULPS * unit_roundoff(precision) * magnitude)
    lo = round_outward(slo - 2 * pad, precision, up=False)
    extent = (shi + 2 * pad) - lo
    all_u = np.arange(len(units.prim))
    size = 0.0
    if len(units.prim):
        plo = np.full((scene.n_primitives, 3), np.inf)
        phi = np.full((scene.n_primitives, 3), -np.inf)
        np.minimum.at(plo, units.prim, units.lo)
        np.maximum.at(phi, units.prim, units.hi)
        size = float(np.max(phi - plo, initial=0.0, where=np.isfinite(phi - plo)))
    cache: dict[tuple[int, ...], tuple[np.ndarray, np.ndarray]] = {}

    def top_members(res: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = tuple(int(x) for x in res)
        if key not in cache:
            cell = round_outward(extent / res, precision, up=True)
            k = len(all_u)
            rep, ijk = _members(units, all_u, np.tile(lo, (k, 1)), np.tile(cell, (k, 1)),
                                np.tile(res, (k, 1)), pad, precision)
            flat = (ijk[:, 2] * res[1] + ijk[:, 1]) * res[0] + ijk[:, 0]
            cache.clear()
            cache[key] = (all_u[rep], flat)
        return cache[key]

    def count_top(res: np.ndarray) -> np.ndarray:
        u, flat = top_members(res)
        key = np.unique(flat * (scene.n_primitives + 1) + units.prim[u])
        return np.bincount(key // (scene.n_primitives + 1), minlength=int(np.prod(res)))

    top, sub_res_all = choose_resolutions(extent, scene.n_primitives, cfg, config.os.local_words, count_top,
                                          MIN_CELL_PADS * pad)
    cell = round_outward(extent / top, precision, up=True)
    u_top, flat_top = top_members(top)
    ntop = int(np.prod(top))
    divided = np.flatnonzero(sub_res_all.prod(axis=1) > 0)
    top_sub = np.full(ntop, -1, dtype=np.int32)
    top_sub[divided] = np.arange(len(divided), dtype=np.int32)
    sub_res = sub_res_all[divided]
    dix = np.stack([divided % top[0], (divided // top[0]) % top[1], divided // (top[0] * top[1])], axis=1)
    sub_lo = boundaries(lo, cell, dix, precision).reshape(-1, 3)  # the top voxel's corner, as OS has it
    sub_cell = round_outward(cell / sub_res, precision, up=True).reshape(-1, 3)
    sub_size = sub_res.prod(axis=1)
    sub_offset = np.concatenate([[0], np.cumsum(sub_size)[:-1]]).astype(np.int64)
    # sub-level membership of units listed in divided voxels
    in_sub = top_sub[flat_top] >= 0
    su, sflat_top = u_top[in_sub], flat_top[in_sub]
    sid = top_sub[sflat_top]
    rep, ijk = _members(units, su, sub_lo[sid], sub_cell[sid], sub_res[sid], pad, precision)
    s_of = sid[rep]
    sflat = (ijk[:, 2] * sub_res[s_of, 1] + ijk[:, 1]) * sub_res[s_of, 0] + ijk[:, 0]
    # leaves in (top voxel, sub voxel) order, primitives ascending
    n1 = scene.n_primitives + 1
    plain = ~in_sub
    top_key = np.concatenate([flat_top[plain], sflat_top[rep]]).astype(np.int64)
    sub_key = np.concatenate([np.zeros(int(plain.sum()), np.int64), sflat.astype(np.int64)])
    prim = np.concatenate([units.prim[u_top[plain]], units.prim[su[rep]]])
    maxsub = int(sub_size.max()) + 1 if len(sub_size) else 1
    key = np.unique((top_key * maxsub + sub_key) * n1 + prim)
    cellkey, prim = key // n1, (key % n1).astype(np.int32)
    new_leaf = np.concatenate([[True], cellkey[1:] != cellkey[:-1]]) if len(key) else np.zeros(0, bool)
    starts = np.flatnonzero(new_leaf)
    leaf_offsets = np.concatenate([starts, [len(key)]]).astype(np.int64)
    leaf_cell = cellkey[starts]
    ltop, lsub = leaf_cell // maxsub, leaf_cell % maxsub
    top_leaf = np.full(ntop, -1, dtype=np.int32)
    sub_leaf = np.full(int(sub_size.sum()), -1, dtype=np.int32)
    leaf_ids = np.arange(len(starts), dtype=np.int32)
    is_sub = top_sub[ltop] >= 0
    top_leaf[ltop[~is_sub]] = leaf_ids[~is_sub]
    sub_leaf[sub_offset[top_sub[ltop[is_sub]]] + lsub[is_sub]] = leaf_ids[is_sub]
    words = ntop * WORDS_PER_VOXEL + len(divided) * WORDS_PER_SUBGRID + int(sub_size.sum()) * WORDS_PER_VOXEL
    return Grid(lo=lo, res=top.astype(np.int64), cell=cell, inv_cell=1.0 / cell, top_leaf=top_leaf,
                top_sub=top_sub, sub_res=sub_res.astype(np.int64), sub_lo=sub_lo, sub_cell=sub_cell,
                sub_inv_cell=1.0 / sub_cell, sub_offset=sub_offset, sub_leaf=sub_leaf,
                leaf_offsets=leaf_offsets, leaf_prims=prim, words=words,
                budget=config.os.local_words, pad=pad, precision=precision, primitive_size=size)
