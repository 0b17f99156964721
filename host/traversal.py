"""Object search (OS) + intersection calls (IC) as a wavefront: 3-D DDA over the two-level grid.

Every active ray advances one *leaf* voxel per iteration (an undivided top voxel, or a voxel of
the sub-grid of a divided one); a non-empty leaf sends the ray with its primitive list to IC, which
tests every listed primitive in list order (each test = one reference, no mailboxing).

Surface rays (eye, reflection, refraction) take the nearest counting hit with t <= the leaf's
t_exit (t > t_min is part of every test); no hit: on to the next leaf. The lower end of the leaf's
range is deliberately not checked: a hit before t_enter could only be one an earlier leaf's list
missed by rounding, and accepting it avoids a crack. Shadow rays stop at the first primitive in
list order whose hit has t < t_max (the light's distance): IC's early exit, so the references of a
leaf end there; otherwise they stop after the leaf whose t_exit >= t_max.

Robustness: a direction component steps only where 1/d is finite and non-zero (so +-0.0 and
subnormal components never step and never make 0*inf), voxel boundaries are recomputed from the
integer index as lo + i*cell (no accumulated increments), ties in the next boundary go to the
lower axis (x, then y, then z), one axis steps per iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from netsushisen.host.grid import Grid
from netsushisen.host.shapes import ICRays, ShapeData, intersect


@dataclass
class OSGrid:
    """The grid constants OS holds, float values rounded once from the float64 grid."""

    lo: np.ndarray  # (3,) dtype
    cell: np.ndarray
    inv_cell: np.ndarray
    res: np.ndarray  # (3,) int64
    sub_lo: np.ndarray  # (S, 3) dtype
    sub_cell: np.ndarray
    sub_inv_cell: np.ndarray
    sub_res: np.ndarray  # (S, 3) int64
    grid: Grid

    @classmethod
    def of(cls, grid: Grid, dtype: type) -> OSGrid:
        r = lambda a: np.asarray(a, dtype=np.float64).astype(dtype)  # noqa: E731
        return cls(lo=r(grid.lo), cell=r(grid.cell), inv_cell=r(grid.inv_cell), res=grid.res,
                   sub_lo=r(grid.sub_lo).reshape(-1, 3), sub_cell=r(grid.sub_cell).reshape(-1, 3),
                   sub_inv_cell=r(grid.sub_inv_cell).reshape(-1, 3), sub_res=grid.sub_res.reshape(-1, 3),
                   grid=grid)


@dataclass
class TraceResult:
    """Per ray: hit primitive (-1 none) / occluded flag, t and polygon barycentric data; and the
    references in the order IC made them (ray index, primitive), chronological per ray."""

    prim: np.ndarray  # (n,) int32
    t: np.ndarray  # (n,) dtype
    fan: np.ndarray
    b1: np.ndarray
    b2: np.ndarray
    occluded: np.ndarray  # (n,) bool (shadow rays)
    ref_ray: np.ndarray  # (R,) int64
    ref_prim: np.ndarray  # (R,) int32
    ref_counts: np.ndarray  # (N,) int64
    ref_leaf: np.ndarray | None = None  # (R,) int32 leaf (grid list) of each kept reference
    visits: np.ndarray | None = None  # (V, 3) int64 rows (ray, top voxel, sub voxel or -1), if kept


def _boundary(lo, i, cell, dt):
    """lo + float(i)*cell: the boundary plane with integer index i."""
    return lo + i.astype(dt) * cell


def _next_crossing(lo, cell, idx, o, inv, pos, neg, dt):
    """t of the next boundary on each axis (+inf where the ray does not step) and the argmin axis.

    pos/neg: (3, m) stepping masks; idx: (3, m) voxel index; lo/cell: (3, m) or (3, 1)."""
    up = _boundary(lo, idx + 1, cell, dt)
    down = _boundary(lo, idx, cell, dt)
    inf = dt(np.inf)
    with np.errstate(invalid="ignore", over="ignore"):  # the unused branch may be 0*inf
        t = np.where(pos, (up - o) * inv, np.where(neg, (down - o) * inv, inf))
    tx, ty, tz = t
    axis = np.where((tx <= ty) & (tx <= tz), 0, np.where(ty <= tz, 1, 2))
    return np.minimum(np.minimum(tx, ty), tz), axis


def _start_index(p, lo, inv_cell, res, dt):
    """Voxel holding point p: floor((p - lo) * inv_cell), clamped to [0, res-1] (as floats)."""
    f = np.floor((p - lo) * inv_cell)
    f = np.minimum(np.maximum(f, dt(0)), (res - 1).astype(dt))
    return f.astype(np.int64)


def trace(osg: OSGrid, sd: ShapeData, rays: ICRays, t_max: np.ndarray | None = None,
          ray_ids: np.ndarray | None = None, keep_refs: bool = False,
          keep_visits: bool = False) -> TraceResult:
    """Trace surface rays (`t_max` None) or shadow rays (hit if t < t_max) through the grid.

    `ray_ids` renames rays in the kept references; `keep_visits` records every leaf visited
    (empty ones too) for tests."""
    dt = sd.dtype
    grid = osg.grid
    shadow = t_max is not None
    n = rays.o.shape[1]
    o, d = rays.o, rays.d
    inf = dt(np.inf)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = dt(1) / d
        pos = (inv > 0) & (inv < inf)
        neg = (inv < 0) & (inv > -inf)
        g_lo = osg.lo[:, None]
        g_hi = _boundary(osg.lo, osg.res, osg.cell, dt)[:, None]
        inside = (o >= g_lo) & (o <= g_hi)
        ta, tb = (g_lo - o) * inv, (g_hi - o) * inv
        t_lo = np.where(pos, ta, np.where(neg, tb, np.where(inside, -inf, inf)))
        t_hi = np.where(pos, tb, np.where(neg, ta, np.where(inside, inf, -inf)))
    t_enter = np.maximum(np.maximum(np.maximum(t_lo[0], t_lo[1]), t_lo[2]), rays.t_min)
    t_far = np.minimum(np.minimum(t_hi[0], t_hi[1]), t_hi[2])
    alive = t_enter <= t_far
    if shadow:
        alive &= t_enter < t_max
    ti = np.zeros((3, n), np.int64)
    first = np.flatnonzero(alive)
    p = o[:, first] + t_enter[first] * d[:, first]
    ti[:, first] = _start_index(p, g_lo, osg.inv_cell[:, None], osg.res[:, None], dt)
    in_sub = np.zeros(n, bool)
    sg = np.zeros(n, np.int64)
    si = np.zeros((3, n), np.int64)
    t_top_exit = np.zeros(n, dt)
    top_axis = np.zeros(n, np.int64)
    step = np.where(pos, 1, np.where(neg, -1, 0))
    res = TraceResult(prim=np.full(n, -1, np.int32), t=np.full(n, inf, dt), fan=np.zeros(n, np.int32),
                      b1=np.zeros(n, dt), b2=np.zeros(n, dt), occluded=np.zeros(n, bool),
                      ref_ray=np.zeros(0, np.int64), ref_prim=np.zeros(0, np.int32),
                      ref_counts=np.zeros(len(sd.kind), np.int64))
    refs_r: list[np.ndarray] = []
    refs_p: list[np.ndarray] = []
    refs_l: list[np.ndarray] = []
    visits: list[np.ndarray] = []
    nx, ny = osg.res[0], osg.res[1]
    while True:
        act = np.flatnonzero(alive)
        if len(act) == 0:
            break
        # top level: rays not inside a sub-grid find their top voxel's exit and contents
        top = act[~in_sub[act]]
        if len(top):
            t_exit, axis = _next_crossing(g_lo, osg.cell[:, None], ti[:, top], o[:, top], inv[:, top],
                                          pos[:, top], neg[:, top], dt)
            t_top_exit[top], top_axis[top] = t_exit, axis
            flat = (ti[2, top] * ny + ti[1, top]) * nx + ti[0, top]
            sub = grid.top_sub[flat]
            enter = top[sub >= 0]
            if len(enter):
                s = sub[sub >= 0].astype(np.int64)
                in_sub[enter], sg[enter] = True, s
                pe = o[:, enter] + t_enter[enter] * d[:, enter]
                si[:, enter] = _start_index(pe, osg.sub_lo[s].T, osg.sub_inv_cell[s].T, osg.sub_res[s].T, dt)
        leaf = np.full(len(act), -1, np.int64)
        t_cur = t_top_exit[act].copy()
        sub_end = np.zeros(len(act), bool)
        sub_axis = np.zeros(len(act), np.int64)
        at_top = ~in_sub[act]
        if at_top.any():
            a = act[at_top]
            leaf[at_top] = grid.top_leaf[(ti[2, a] * ny + ti[1, a]) * nx + ti[0, a]]
        if (~at_top).any():
            w = np.flatnonzero(~at_top)
            a = act[w]
            s = sg[a]
            tn, ax = _next_crossing(osg.sub_lo[s].T, osg.sub_cell[s].T, si[:, a], o[:, a], inv[:, a],
                                    pos[:, a], neg[:, a], dt)
            t_cur[w] = np.minimum(tn, t_top_exit[a])
            sub_end[w] = tn >= t_top_exit[a]
            sub_axis[w] = ax
            r = osg.sub_res[s]
            leaf[w] = grid.sub_leaf[grid.sub_offset[s] + (si[2, a] * r[:, 1] + si[1, a]) * r[:, 0] + si[0, a]]
        if keep_visits:
            vsub = np.full(len(act), -1, np.int64)
            if (~at_top).any():
                w = np.flatnonzero(~at_top)
                a = act[w]
                r = osg.sub_res[sg[a]]
                vsub[w] = (si[2, a] * r[:, 1] + si[1, a]) * r[:, 0] + si[0, a]
            visits.append(np.stack([act, (ti[2, act] * ny + ti[1, act]) * nx + ti[0, act], vsub], axis=1))
        # IC: test every listed primitive of non-empty leaves
        busy = np.flatnonzero(leaf >= 0)
        if len(busy):
            rays_b = act[busy]
            lf = leaf[busy]
            start = grid.leaf_offsets[lf]
            length = grid.leaf_offsets[lf + 1] - start
            seg = np.cumsum(length) - length
            pr = np.repeat(rays_b, length)
            within = np.arange(int(length.sum())) - np.repeat(seg, length)
            prim = grid.leaf_prims[np.repeat(start, length) + within]
            pl = np.repeat(lf, length)
            h = intersect(sd, rays, pr, prim)
            if shadow:
                occl = h.t < t_max[pr]
                before = np.cumsum(occl) - occl
                before = before - np.repeat(before[seg], length)
                tested = before == 0
                pr, prim, pl = pr[tested], prim[tested], pl[tested]
                hit_any = np.logical_or.reduceat(occl, seg)
                res.occluded[rays_b[hit_any]] = True
                alive[rays_b[hit_any]] = False
            else:
                ok = h.t <= np.repeat(t_cur[busy], length)
                tt = np.where(ok, h.t, inf)
                best = np.minimum.reduceat(tt, seg)
                win = np.flatnonzero((tt == np.repeat(best, length)) & ok)
                ray_of_win = pr[win]
                first = np.concatenate([[True], ray_of_win[1:] != ray_of_win[:-1]]) if len(win) else win
                win = win[first.astype(bool)]
                wr = pr[win]
                res.prim[wr], res.t[wr] = prim[win], h.t[win]
                res.fan[wr], res.b1[wr], res.b2[wr] = h.fan[win], h.b1[win], h.b2[win]
                alive[wr] = False
            res.ref_counts += np.bincount(prim, minlength=len(res.ref_counts))
            if keep_refs:
                refs_r.append(pr if ray_ids is None else ray_ids[pr])
                refs_p.append(prim)
                refs_l.append(pl)
        # advance every ray still alive by one leaf
        if shadow:
            done = t_cur >= t_max[act]
            alive[act[done]] = False
        live = alive[act]
        in_s = ~at_top & live
        w = np.flatnonzero(in_s)
        if len(w):
            a = act[w]
            ax = sub_axis[w]
            nxt = si[ax, a] + step[ax, a]
            out = sub_end[w] | (nxt < 0) | (nxt >= osg.sub_res[sg[a], ax])
            stay = ~out
            si[ax[stay], a[stay]] = nxt[stay]
            in_sub[a[out]] = False
        move = act[live & ~in_sub[act]]
        if len(move):
            ax = top_axis[move]
            nxt = ti[ax, move] + step[ax, move]
            out = (nxt < 0) | (nxt >= osg.res[ax])
            ti[ax, move] = nxt
            t_enter[move] = t_top_exit[move]
            alive[move[out]] = False
    if keep_visits:
        res.visits = np.concatenate(visits) if visits else np.zeros((0, 3), np.int64)
    if keep_refs and refs_r:
        res.ref_ray = np.concatenate(refs_r).astype(np.int64)
        res.ref_prim = np.concatenate(refs_p).astype(np.int32)
        res.ref_leaf = np.concatenate(refs_l).astype(np.int32)
    return res
