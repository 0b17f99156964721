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

Shadow rays are judged from the path's own hit point (`contact_truth`): an occluder higher above
it along the normal than the secondary-ray offset's error bound (`offset_bound`) must block,
whatever the point's magnitude — so a contact gap of a few units in the last place at 1e6 is
judged, and an offset larger than the bound shows as light leaking under it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from netsushisen.host.golden import OFFSET_ULPS, SIZE_ULPS
from netsushisen.host.rays import dot, dtype_of, rowdot, rownorm
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
        den = rowdot(d, n)
        t = rowdot(v[0] - o, n) / den
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
    b = rowdot(oc, d)
    q = oc - b[:, None] * d
    disc = s[3] * s[3] - rowdot(q, q)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(disc)
    real = disc >= 0
    return _pick(-b - h, real, -b + h, real & two, t_min)


def _cone(c: np.ndarray, two: bool, o, d, t_min):
    base, apex = c[:3], c[4:7]
    axis = apex - base
    length = float(rownorm(axis))
    if length == 0:
        return np.full(o.shape[0], np.inf)
    a = axis / length
    k = (c[7] - c[3]) / length
    w = o - base
    wa, da = rowdot(w, a), rowdot(d, a)
    wp, dp = w - wa[:, None] * a, d - da[:, None] * a
    rw = c[3] + k * wa
    A = rowdot(dp, dp) - (k * da) ** 2
    B = rowdot(wp, dp) - rw * k * da
    C = rowdot(wp, wp) - rw * rw
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


def nearest(osc: OracleScene, o: np.ndarray, d: np.ndarray, t_min: float | np.ndarray = 0.0,
            skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(hit primitive (n,) or -1, t (n,)) of rays o, d ((n, 3) float64) against every primitive;
    `t_min` is one number or one per ray. `skip` (n,) names a primitive per ray to ignore (-1: none)."""
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
    e1 /= rownorm(e1)[:, None]
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
    d = d / rownorm(d)[:, None]
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
    den = float(rowdot(ab, ab))
    s = np.clip(rowdot(p - a, ab) / den, 0.0, 1.0) if den > 0 else np.zeros(len(p))
    return rownorm(p - (a + s[:, None] * ab))


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
                plane = np.abs(rowdot(q - v[0], n))
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
            out[sel] = np.abs(rownorm(q - c[:3]) - abs(c[3]))
        else:
            c = osc.cone[j]
            axis = c[4:7] - c[:3]
            length = float(rownorm(axis))
            if length == 0:
                continue
            w = q - c[:3]
            z = rowdot(w, axis / length)
            rho = np.sqrt(np.maximum((w * w).sum(axis=1) - z * z, 0.0))
            out[sel] = _segment_distance(np.column_stack([z, rho]), np.array([0.0, abs(c[3])]),
                                         np.array([length, abs(c[7])]))
    return out


def judge_hits(answer: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """Rays whose answer is not among the allowed ones (bool (n,))."""
    return ~np.any(allowed == np.asarray(answer)[:, None], axis=1)


HEIGHTS = 8
"""`contact_truth` casts the shadow ray from this many origins up the offset's slab."""


def offset_bound(point: np.ndarray, normal: np.ndarray, t_eye: np.ndarray, size: float,
                 precision: str) -> np.ndarray:
    """How far along its normal (n,) a secondary ray's origin may legitimately sit above its hit
    point `point` (n, 3): the error bound the offset covers, evaluated in float64 —
    (sum_a |P_a Nf_a| + t) x OFFSET_ULPS x u + SIZE_ULPS x u x size — plus the rounding of the
    origin P + delta*Nf itself (half a unit in the last place of each coordinate, weighted by
    |Nf_a|) and a relative 8u for the few roundings of delta (docs/golden.md, "Secondary-ray
    origins"). Computed from the bound, not from the path's offset: a path whose offset exceeds
    it skips occluders it must see."""
    dt = dtype_of(precision)
    u = float(np.finfo(dt).eps) / 2.0
    a = np.abs(normal)
    delta = (np.sum(np.abs(point) * a, axis=1) + t_eye) * (OFFSET_ULPS * u) + SIZE_ULPS * u * size
    moved = np.abs(point) + delta[:, None] * a
    half_ulp = np.spacing(moved.astype(dt)).astype(np.float64) / 2
    return delta * (1 + 8 * u) + np.sum(half_ulp * a, axis=1)


def contact_truth(osc: OracleScene, point: np.ndarray, prim: np.ndarray, normal: np.ndarray,
                  t_eye: np.ndarray, lights: np.ndarray, precision: str) -> tuple[np.ndarray, np.ndarray]:
    """A shadow ray judged from the path's own hit point `point` (n, 3: the path's P before the
    offset, in float64) on primitive `prim` (n,), with its geometric normal facing the eye ray
    `normal` (n, 3), the eye ray's t and one light per row: (blocked, ambiguous).

    Blocked: the segment from P to the light crosses a counting hit higher above P along the
    normal than `offset_bound` lets the origin sit, short of the light by more than the shadow
    test's own rounding tol = TOL_ULPS x u x (distance + size) — which scales with the
    distances the test subtracts, not with |P|. A contact gap above the bound must therefore
    block. Ambiguous (either answer allowed): another primitive's counting hit lies within that
    height (the origin may sit below or above it); the answer changes with the height threshold
    moved by tol either way, or from an origin up the slab the bound allows
    (P + k/HEIGHTS x bound x Nf: at a low light a raised origin moves the shadow's edge by
    h / tan(angle)), or from the origin moved by bound + tol across the ray along the surface
    (silhouettes); the hit is within tol of the light; the light lies on or below the tangent
    plane."""
    u = float(np.finfo(dtype_of(precision)).eps) / 2.0
    to = lights - point
    dist = rownorm(to)
    d = to / dist[:, None]
    up = rowdot(d, normal)
    bound = offset_bound(point, normal, t_eye, osc.size, precision)
    tol = TOL_ULPS * u * (dist + osc.size)
    rising = up > 0
    slope = np.where(rising, up, 1.0)

    def blocked_above(o, height):  # the first counting hit above `height` (t_min: per ray)
        _, t = nearest(osc, o, d, height / slope)
        return t < dist - tol, t

    blocked, t_hit = blocked_above(point, bound + tol)
    lower, _ = blocked_above(point, np.maximum(bound - tol, 0.0))
    _, t_other = nearest(osc, point, d, 0.0, skip=prim)
    amb = ~rising | (lower != blocked) | (np.abs(t_hit - dist) <= tol) | (t_other * slope <= bound + tol)
    for k in range(1, HEIGHTS + 1):  # origins up the slab the bound allows (a silhouette in it)
        h = bound * (k / HEIGHTS)
        amb |= blocked_above(point + h[:, None] * normal, bound + tol - h)[0] != blocked
    side = np.cross(d, normal)  # across the ray and along the surface: the height stays
    norm = rownorm(side)[:, None]
    side = np.where(norm > 1e-6, side / np.maximum(norm, 1e-300), _across(d)[0])
    for s in (1, -1):
        amb |= blocked_above(point + (s * (bound + tol))[:, None] * side, bound + tol)[0] != blocked
    return blocked, amb

