"""A brute-force float64 oracle for the numerical catalog (docs/golden.md, "Judging against the oracle").

Independent of the golden model's formulas on purpose: no grid, every ray against every
primitive, textbook float64 intersection code (plane + 2-D winding number for polygons, the
quadratics for spheres, cylinders and cones), the same facing rules (opaque primitives count front
hits only, transmitting ones every hit). It intersects the *machine's* inputs — the scene's
coordinates rounded once to the precision under test, rays as that precision holds them — so
that what is left between a path and the oracle is the path's arithmetic.

The tolerance rule: a ray whose true answer lies within rounding of an edge, a silhouette or a
tangent may take either answer. "Within rounding" is made concrete by perturbation: the ray is
also cast with its origin moved by `tol` along two directions across it (four more rays); the
answers of all five are the allowed set. A path's answer must be in it. A ray exactly on a shared
edge therefore may hit either neighbour (the shifted rays find both) but never what lies behind
(no shifted ray reaches it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from netsushisen.host.golden import OFFSET_ULPS, SIZE_ULPS
from netsushisen.host.rays import dtype_of
from netsushisen.host.scenes import Kind, Scene
from netsushisen.host.shapes import polygon_normals64

TOL_ULPS = 8
"""The tolerance: TOL_ULPS x unit roundoff x the ray's length scale (origin magnitude + distance
to the far side of the scene + the largest primitive size)."""


@dataclass
class OracleScene:
    """The scene's geometry rounded once to a precision, then held in float64."""

    kind: np.ndarray
    local: np.ndarray
    two_sided: np.ndarray
    poly_v: list[np.ndarray]  # per polygon (n, 3)
    poly_n: np.ndarray  # (P, 3) float64 unit normals of the rounded vertices (0 if degenerate)
    sph: np.ndarray  # (S, 4) centre, radius
    cone: np.ndarray  # (C, 8) base, r0, apex, r1
    lo: np.ndarray  # scene box
    hi: np.ndarray
    size: float  # the largest primitive's bounding-box side

    @classmethod
    def of(cls, scene: Scene, precision: str) -> OracleScene:
        dt = dtype_of(precision)
        r = lambda a: np.asarray(a, np.float64).astype(dt).astype(np.float64)  # noqa: E731
        pg = scene.polygons
        v = r(pg.vertices.reshape(-1, 3))
        polys = [v[s:s + c] for s, c in zip(pg.start, pg.count)]
        rounded = replace(scene, polygons=replace(pg, vertices=v))
        normals = polygon_normals64(rounded) if len(polys) else np.zeros((0, 3))
        sp, cn = scene.spheres, scene.cones
        sph = np.column_stack([r(sp.center.reshape(-1, 3)), r(sp.radius)]) if len(sp) else np.zeros((0, 4))
        cone = (np.column_stack([r(cn.base.reshape(-1, 3)), r(cn.base_radius), r(cn.apex.reshape(-1, 3)),
                                 r(cn.apex_radius)]) if len(cn) else np.zeros((0, 8)))
        los, his = [], []
        for p in polys:
            los.append(p.min(axis=0))
            his.append(p.max(axis=0))
        for s in sph:
            los.append(s[:3] - abs(s[3]))
            his.append(s[:3] + abs(s[3]))
        for c in cone:
            rad = max(abs(c[3]), abs(c[7]))
            los.append(np.minimum(c[:3], c[4:7]) - rad)
            his.append(np.maximum(c[:3], c[4:7]) + rad)
        lo, hi = (np.min(los, axis=0), np.max(his, axis=0)) if los else (np.zeros(3), np.zeros(3))
        size = max((float(np.max(h - low)) for low, h in zip(los, his)), default=0.0)
        return cls(kind=scene.kind.copy(), local=scene.local_index.copy(),
                   two_sided=scene.materials.t[scene.material] > 0, poly_v=polys, poly_n=normals,
                   sph=sph, cone=cone, lo=lo, hi=hi, size=size)


def _pick(t0, ok0, t1, ok1, t_min):
    a = ok0 & (t0 > t_min)
    b = ok1 & (t1 > t_min)
    return np.where(a, t0, np.where(b, t1, np.inf))


def _polygon(v: np.ndarray, n: np.ndarray, two: bool, o, d, t_min):
    """Plane hit, then the winding number of the hit point in the projection that drops the
    normal's largest axis (a crossing count, exact enough in float64)."""
    if not np.any(n):
        return np.full(o.shape[0], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):  # a ray in the plane: 0/0, no hit
        den = d @ n
        t = ((v[0] - o) @ n) / den
        p = o + t[:, None] * d
    drop = int(np.argmax(np.abs(n)))
    a, b = [k for k in range(3) if k != drop]
    px, py = p[:, a], p[:, b]
    wind = np.zeros(len(o), np.int64)
    m = len(v)
    for i in range(m):
        x0, y0 = v[i, a], v[i, b]
        x1, y1 = v[(i + 1) % m, a], v[(i + 1) % m, b]
        with np.errstate(invalid="ignore"):
            side = (x1 - x0) * (py - y0) - (px - x0) * (y1 - y0)
        up = (y0 <= py) & (y1 > py) & (side > 0)
        down = (y0 > py) & (y1 <= py) & (side < 0)
        wind += up.astype(np.int64) - down.astype(np.int64)
    hit = (wind != 0) & np.isfinite(t) & (t > t_min)
    if not two:
        hit &= den < 0  # front side: the ray meets the face its normal points to
    return np.where(hit, t, np.inf)


def _sphere(s: np.ndarray, two: bool, o, d, t_min):
    oc = o - s[:3]
    b = np.einsum("ij,ij->i", oc, d)
    q = oc - b[:, None] * d
    disc = s[3] * s[3] - np.einsum("ij,ij->i", q, q)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(disc)
    real = disc >= 0
    return _pick(-b - h, real, -b + h, real & two, t_min)


def _cone(c: np.ndarray, two: bool, o, d, t_min):
    base, apex = c[:3], c[4:7]
    axis = apex - base
    length = float(np.sqrt(axis @ axis))
    if length == 0:
        return np.full(o.shape[0], np.inf)
    a = axis / length
    k = (c[7] - c[3]) / length
    w = o - base
    wa, da = w @ a, d @ a
    wp, dp = w - wa[:, None] * a, d - da[:, None] * a
    rw = c[3] + k * wa
    A = np.einsum("ij,ij->i", dp, dp) - (k * da) ** 2
    B = np.einsum("ij,ij->i", wp, dp) - rw * k * da
    C = np.einsum("ij,ij->i", wp, wp) - rw * rw
    disc = B * B - A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(disc)
        q = -(B + np.copysign(sq, B))
        r1, r2 = q / A, C / q
    t0, t1 = np.minimum(r1, r2), np.maximum(r1, r2)
    real = (disc >= 0) & (A != 0)
    z0, z1 = wa + t0 * da, wa + t1 * da
    ok0 = real & (z0 >= 0) & (z0 <= length) & (two | (A * t0 + B < 0))
    ok1 = real & (z1 >= 0) & (z1 <= length) & (two | (A * t1 + B < 0))
    return _pick(t0, ok0, t1, ok1, t_min)


def nearest(osc: OracleScene, o: np.ndarray, d: np.ndarray, t_min: float = 0.0,
            skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(hit primitive (n,) or -1, t (n,)) of rays o, d ((n, 3) float64) against every primitive.
    `skip` (n,) names a primitive per ray to ignore (-1: none)."""
    n = len(o)
    best_t = np.full(n, np.inf)
    best = np.full(n, -1, np.int64)
    for pid in range(len(osc.kind)):
        k, j, two = osc.kind[pid], osc.local[pid], bool(osc.two_sided[pid])
        if k == Kind.POLYGON:
            t = _polygon(osc.poly_v[j], osc.poly_n[j], two, o, d, t_min)
        elif k == Kind.SPHERE:
            t = _sphere(osc.sph[j], two, o, d, t_min)
        else:
            t = _cone(osc.cone[j], two, o, d, t_min)
        if skip is not None:
            t = np.where(skip == pid, np.inf, t)
        better = t < best_t
        best_t = np.where(better, t, best_t)
        best = np.where(better, pid, best)
    return best, best_t


def _across(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across each direction."""
    helper = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(d, e1)


def tolerance(osc: OracleScene, o: np.ndarray, precision: str) -> np.ndarray:
    """Per ray origin: TOL_ULPS x u x (|o|max + distance to the scene's far corner + size)."""
    u = float(np.finfo(dtype_of(precision)).eps) / 2.0
    far = np.max(np.abs(np.stack([osc.lo, osc.hi])[None] - o[:, None]), axis=1).max(axis=1) * np.sqrt(3)
    return TOL_ULPS * u * (np.abs(o).max(axis=1) + far + osc.size)


def allowed_hits(osc: OracleScene, o: np.ndarray, d: np.ndarray, precision: str,
                 t_min: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(exact answer (n,), allowed answers (n, 5), t of the exact answer (n,)): the exact ray's
    hit and the hits of the four rays shifted by the tolerance across it."""
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    tol = tolerance(osc, o, precision)
    e1, e2 = _across(d)
    exact, t = nearest(osc, o, d, t_min)
    sets = [exact]
    for e, s in ((e1, 1), (e1, -1), (e2, 1), (e2, -1)):
        sets.append(nearest(osc, o + (s * tol)[:, None] * e, d, t_min)[0])
    return exact, np.stack(sets, axis=1), t


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance (n,) from points p (n, k) to the segment a-b ((k,) each)."""
    ab = b - a
    den = float(ab @ ab)
    s = np.clip(((p - a) @ ab) / den, 0.0, 1.0) if den > 0 else np.zeros(len(p))
    return np.linalg.norm(p - (a + s[:, None] * ab), axis=1)


def distance_to(osc: OracleScene, p: np.ndarray, prim: np.ndarray) -> np.ndarray:
    """Distance (n,) from points p (n, 3) to the surface of primitive prim[i] (inf for -1): a
    polygon's plane distance inside it, else the nearest edge; a sphere's | |p - c| - r |; an open
    cone's or cylinder's distance in the meridian half-plane to its side segment. A ray whose
    exact hit point lies within rounding of another primitive (an edge or vertex it shares, a
    coplanar or coincident surface: a tie) may answer that one."""
    out = np.full(len(p), np.inf)
    for pid in np.unique(prim[prim >= 0]):
        sel = np.flatnonzero(prim == pid)
        q = p[sel]
        k, j = osc.kind[pid], osc.local[pid]
        if k == Kind.POLYGON:
            v, n = osc.poly_v[j], osc.poly_n[j]
            edges = np.min([_segment_distance(q, v[i], v[(i + 1) % len(v)]) for i in range(len(v))], axis=0)
            if np.any(n):
                plane = np.abs((q - v[0]) @ n)
                drop = int(np.argmax(np.abs(n)))
                a, b = [x for x in range(3) if x != drop]
                wind = np.zeros(len(q), np.int64)
                for i in range(len(v)):
                    x0, y0, x1, y1 = v[i, a], v[i, b], v[(i + 1) % len(v), a], v[(i + 1) % len(v), b]
                    side = (x1 - x0) * (q[:, b] - y0) - (q[:, a] - x0) * (y1 - y0)
                    wind += ((y0 <= q[:, b]) & (y1 > q[:, b]) & (side > 0)).astype(np.int64)
                    wind -= ((y0 > q[:, b]) & (y1 <= q[:, b]) & (side < 0)).astype(np.int64)
                edges = np.where(wind != 0, plane, edges)
            out[sel] = edges
        elif k == Kind.SPHERE:
            c = osc.sph[j]
            out[sel] = np.abs(np.linalg.norm(q - c[:3], axis=1) - abs(c[3]))
        else:
            c = osc.cone[j]
            axis = c[4:7] - c[:3]
            length = float(np.linalg.norm(axis))
            if length == 0:
                continue
            w = q - c[:3]
            z = w @ (axis / length)
            rho = np.sqrt(np.maximum((w * w).sum(axis=1) - z * z, 0.0))
            out[sel] = _segment_distance(np.column_stack([z, rho]), np.array([0.0, abs(c[3])]),
                                         np.array([length, abs(c[7])]))
    return out


def judge_hits(answer: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """Rays whose answer is not among the allowed ones (bool (n,))."""
    return ~np.any(allowed == np.asarray(answer)[:, None], axis=1)


def shadow_truth(osc: OracleScene, p: np.ndarray, prim: np.ndarray, lights: np.ndarray,
                 precision: str, t_eye: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For surface points `p` (n, 3) on primitives `prim` and one light per row (n, 3): (blocked,
    ambiguous). Blocked: some primitive's counting hit lies strictly between the point and the
    light, beyond the tolerance at both ends (the surface the point lies on is skipped near 0,
    not beyond). Ambiguous: the answer changes when the tolerance is applied either way (a hit
    within it of the point, of the light or of a silhouette: the origin is moved by it along
    +-e1, +-e2 across the ray, +-n along the normal and the diagonals of those). The tolerance here also covers
    twice the offset the machine moves a secondary ray's origin by (`t_eye`: the eye ray's t), a
    deliberate displacement off the surface."""
    to = lights - p
    dist = np.linalg.norm(to, axis=1)
    d = to / dist[:, None]
    u = float(np.finfo(dtype_of(precision)).eps) / 2.0
    delta = u * (OFFSET_ULPS * (np.abs(p).max(axis=1) + t_eye) + SIZE_ULPS * osc.size)
    tol = tolerance(osc, p, precision) + 2 * delta
    # the own surface counts only clearly away from the point (a cylinder's far wall, say)
    _, t_self_far = _self_hits(osc, p, d, prim, tol)
    other, t_other = nearest(osc, p, d, 0.0, skip=prim)
    t_hit = np.minimum(t_other, t_self_far)
    blocked = t_hit < dist - tol
    near_start = (t_other <= tol)
    near_light = np.abs(t_hit - dist) <= tol
    e1, e2 = _across(d)
    n = normals(osc, p, prim)
    amb = near_start | near_light
    shifts = [e1, -e1, e2, -e2, n, -n]
    shifts += [(a + b) / np.sqrt(2) for i, a in enumerate(shifts) for b in shifts[i + 2 - i % 2:]]
    for e, s in ((e, 1) for e in shifts):
        q = p + (s * tol)[:, None] * e
        _, to2 = nearest(osc, q, d, 0.0, skip=prim)
        _, ts2 = _self_hits(osc, q, d, prim, tol)  # a ray within rounding of tangent to its own surface
        amb |= (np.minimum(to2, ts2) < dist - tol) != blocked
    return blocked, amb


def _self_hits(osc: OracleScene, p, d, prim, tol):
    """The own primitive's hits beyond the tolerance from the point: (pid, t)."""
    t_far = np.full(len(p), np.inf)
    for pid in np.unique(prim):
        sel = np.flatnonzero(prim == pid)
        one = OracleScene(kind=osc.kind[[pid]], local=osc.local[[pid]], two_sided=osc.two_sided[[pid]],
                          poly_v=osc.poly_v, poly_n=osc.poly_n, sph=osc.sph, cone=osc.cone, lo=osc.lo,
                          hi=osc.hi, size=osc.size)
        # from a point on the surface the own roots near 0 are rounding; farther ones are real
        _, t_far[sel] = nearest(one, p[sel], d[sel], 8 * tol[sel])
    return prim, t_far


def normals(osc: OracleScene, p: np.ndarray, prim: np.ndarray) -> np.ndarray:
    """Unit surface normals (n, 3) at points `p` on primitives `prim` (outward / front side)."""
    out = np.zeros_like(p)
    for pid in np.unique(prim):
        sel = np.flatnonzero(prim == pid)
        k, j = osc.kind[pid], osc.local[pid]
        if k == Kind.POLYGON:
            out[sel] = osc.poly_n[j]
        elif k == Kind.SPHERE:
            v = p[sel] - osc.sph[j, :3]
            out[sel] = v / np.linalg.norm(v, axis=1, keepdims=True)
        else:
            c = osc.cone[j]
            axis = c[4:7] - c[:3]
            length = np.linalg.norm(axis)
            a = axis / length
            w = p[sel] - c[:3]
            radial = w - (w @ a)[:, None] * a
            u = radial / np.linalg.norm(radial, axis=1, keepdims=True)
            v = u - ((c[7] - c[3]) / length) * a
            out[sel] = v / np.linalg.norm(v, axis=1, keepdims=True)
    return out
