"""Primitive shape data (what IC reads from ICGM) and the ray-primitive intersection tests.

`build_shape_data` computes every per-primitive constant ONCE in float64 and rounds it to the
machine precision: this is exactly the shape record the IC kernel will load. The tests
(`intersect`) use only the ray and those record fields, one elementwise IEEE operation at a time,
in the order `docs/golden.md` lists, so an IC kernel can reproduce them bit for bit.

Vectorised over (ray, primitive) pairs: `intersect(shapes, rays, ray_index, prim)` gives, per
pair, the nearest acceptable t (or +inf) and, for polygons, the fan triangle and barycentrics SC
needs for patch normals.

Which hits count ("facing"): a primitive's candidate intersections are those of its surface with
the ray at t > the ray's t_min. An opaque primitive (material T = 0) is one-sided: only front-side
candidates count — polygons seen counter-clockwise (from the side their normal points to), spheres
/ cylinders / cones where the ray enters the solid (closed surfaces seen from outside; an open
cylinder's inner wall is a back face). A transmitting primitive (T > 0) is two-sided: every
candidate counts, so a refraction ray inside a glass sphere hits its far wall. The test returns the
smallest counting candidate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from netsushisen.host.rays import dot, dtype_of, normalize, rownorm
from netsushisen.host.scenes import Kind, Scene


@dataclass
class ShapeData:
    """Per-primitive shape records in the machine precision (float constants rounded from float64).

    Polygons: vertices, unit plane normal n = normalise((v1-v0) x (v2-v1)) and, for `pp` patches,
    the per-vertex shading normals. Spheres: centre, r, r^2. Cylinders and cones (one table,
    `Scene.cones` order): base point B, unit axis a, length L, base radius r0, r0^2 and slope
    k = (r_apex - r0) / L (0 for cylinders)."""

    dtype: type
    kind: np.ndarray  # (N,) int8 Kind
    local: np.ndarray  # (N,) int32 row in the kind's table
    two_sided: np.ndarray  # (N,) bool: material T > 0
    poly_start: np.ndarray  # (P,) int64
    poly_count: np.ndarray  # (P,) int64
    poly_vertices: np.ndarray  # (V, 3)
    poly_normal: np.ndarray  # (P, 3)
    poly_vertex_normals: np.ndarray  # (V, 3), NaN rows for plain `p` polygons
    poly_is_patch: np.ndarray  # (P,) bool
    sph_center: np.ndarray  # (S, 3)
    sph_radius: np.ndarray  # (S,)
    sph_r2: np.ndarray  # (S,)
    cone_base: np.ndarray  # (C, 3)
    cone_axis: np.ndarray  # (C, 3)
    cone_length: np.ndarray  # (C,)
    cone_r0: np.ndarray  # (C,)
    cone_r2: np.ndarray  # (C,)
    cone_slope: np.ndarray  # (C,)


def polygon_normals64(scene: Scene) -> np.ndarray:
    """Unit geometric normals in float64: (v1-v0) x (v2-v1) of the first corner (NFF promises it
    is convex), falling back to Newell's normal when that corner is degenerate."""
    pg = scene.polygons
    v = pg.vertices
    s = pg.start
    if len(s) == 0:
        return np.zeros((0, 3))
    n = np.cross(v[s + 1] - v[s], v[s + 2] - v[s + 1])
    ln = rownorm(n)
    bad = ln == 0
    if bad.any():  # Newell: sum over edges of (yi - yj)(zi + zj), ...
        owner = np.repeat(np.arange(len(s)), pg.count)
        nxt = np.arange(len(v)) + 1
        last = s + pg.count - 1
        nxt[last] = s
        a, b = v, v[nxt]
        terms = np.stack([(a[:, 1] - b[:, 1]) * (a[:, 2] + b[:, 2]),
                          (a[:, 2] - b[:, 2]) * (a[:, 0] + b[:, 0]),
                          (a[:, 0] - b[:, 0]) * (a[:, 1] + b[:, 1])], axis=1)
        newell = np.zeros((len(s), 3))
        np.add.at(newell, owner, terms)
        n[bad] = newell[bad]
        ln = rownorm(n)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = n / ln[:, None]
    out[ln == 0] = 0.0
    return out


def build_shape_data(scene: Scene, precision: str = "fp32") -> ShapeData:
    """The shape records of `scene`: float64 math, rounded once to `precision`."""
    dt = dtype_of(precision)
    pg, sp, cn = scene.polygons, scene.spheres, scene.cones
    axis = cn.apex - cn.base
    length = rownorm(axis) if len(cn) else np.zeros(0)
    ok = length > 0
    unit = np.tile([0.0, 0.0, 1.0], (len(cn), 1))
    unit[ok] = axis[ok] / length[ok, None]
    slope = np.zeros(len(cn))
    slope[ok] = (cn.apex_radius[ok] - cn.base_radius[ok]) / length[ok]
    r = lambda a: np.ascontiguousarray(np.asarray(a, dtype=np.float64).astype(dt))  # noqa: E731
    return ShapeData(
        dtype=dt, kind=scene.kind.astype(np.int8), local=scene.local_index.astype(np.int32),
        two_sided=scene.materials.t[scene.material] > 0,
        poly_start=pg.start.astype(np.int64), poly_count=pg.count.astype(np.int64),
        poly_vertices=r(pg.vertices.reshape(-1, 3)), poly_normal=r(polygon_normals64(scene).reshape(-1, 3)),
        poly_vertex_normals=r(pg.normals.reshape(-1, 3)), poly_is_patch=pg.is_patch.astype(bool),
        sph_center=r(sp.center.reshape(-1, 3)), sph_radius=r(sp.radius), sph_r2=r(sp.radius * sp.radius),
        cone_base=r(cn.base.reshape(-1, 3)), cone_axis=r(unit), cone_length=r(length),
        cone_r0=r(cn.base_radius), cone_r2=r(cn.base_radius * cn.base_radius), cone_slope=r(slope))


@dataclass
class ICRays:
    """Rays as IC holds them: origin, unit direction, t_min, and the per-ray constants of the
    watertight polygon test — the dominant axis kz of the direction, kx/ky the other two (swapped
    when d[kz] < 0 so the projection keeps polygon winding) and the shears sx = d[kx]/d[kz],
    sy = d[ky]/d[kz]."""

    o: np.ndarray  # (3, n)
    d: np.ndarray  # (3, n)
    t_min: np.ndarray  # (n,)
    k: np.ndarray  # (3, n) int8: kx, ky, kz
    sx: np.ndarray  # (n,)
    sy: np.ndarray  # (n,)


def ic_rays(o: np.ndarray, d: np.ndarray, t_min: np.ndarray) -> ICRays:
    """Per-ray setup of the polygon test (ties in |d| go to the lower axis: x, then y)."""
    a = np.abs(d)
    kz = np.where((a[0] >= a[1]) & (a[0] >= a[2]), 0, np.where(a[1] >= a[2], 1, 2)).astype(np.int8)
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    cols = np.arange(d.shape[1])
    dz = d[kz, cols]
    flip = dz < 0
    kx, ky = np.where(flip, ky, kx).astype(np.int8), np.where(flip, kx, ky).astype(np.int8)
    return ICRays(o=o, d=d, t_min=t_min, k=np.stack([kx, ky, kz]),
                  sx=d[kx, cols] / dz, sy=d[ky, cols] / dz)


@dataclass
class PairHits:
    """Per (ray, primitive) pair: t of the counting intersection (+inf: none) and, for polygons,
    the fan triangle (v0, v[fan+1], v[fan+2]) that holds the hit with barycentrics b1, b2 of its
    second and third vertex (SC interpolates `pp` normals with them)."""

    t: np.ndarray
    fan: np.ndarray
    b1: np.ndarray
    b2: np.ndarray


def intersect(sd: ShapeData, rays: ICRays, ray_index: np.ndarray, prim: np.ndarray) -> PairHits:
    """Test each ray `ray_index[i]` against primitive `prim[i]` (one IC reference per pair)."""
    dt = sd.dtype
    n = len(prim)
    hits = PairHits(t=np.full(n, np.inf, dtype=dt), fan=np.zeros(n, np.int32),
                    b1=np.zeros(n, dt), b2=np.zeros(n, dt))
    kind = sd.kind[prim]
    local = sd.local[prim]
    two = sd.two_sided[prim]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        for k in np.unique(kind):
            sel = np.flatnonzero(kind == k)
            r = ray_index[sel]
            o, d, tmin = rays.o[:, r], rays.d[:, r], rays.t_min[r]
            if k == Kind.POLYGON:
                counts = sd.poly_count[local[sel]]
                for nv in np.unique(counts):
                    sub = sel[counts == nv]
                    rs = ray_index[sub]
                    t, fan, b1, b2 = polygon_test(sd, int(nv), local[sub], two[sub], rays.o[:, rs],
                                                  rays.d[:, rs], rays.t_min[rs], rays.k[:, rs],
                                                  rays.sx[rs], rays.sy[rs])
                    hits.t[sub], hits.fan[sub], hits.b1[sub], hits.b2[sub] = t, fan, b1, b2
            elif k == Kind.SPHERE:
                hits.t[sel] = sphere_test(sd, local[sel], two[sel], o, d, tmin)
            elif k == Kind.CYLINDER:
                hits.t[sel] = cylinder_test(sd, local[sel], two[sel], o, d, tmin)
            else:
                hits.t[sel] = cone_test(sd, local[sel], two[sel], o, d, tmin)
    return hits


def _first_root(t0, ok0, t1, ok1, tmin, inf):
    """The smaller root if it counts, else the larger one if it counts, else +inf."""
    a = ok0 & (t0 > tmin)
    b = ok1 & (t1 > tmin)
    return np.where(a, t0, np.where(b, t1, inf))


def _perturbed_sign(f, dy, dx):
    """Sign of an edge value with exact zeros broken by a symbolic perturbation of the ray
    (origin moved by (eps, eps^2) in the projected plane): the first non-zero of f, dy, dx decides;
    all zero (a degenerate projected edge) counts as +1. Reversing the edge negates f, dy and dx
    exactly, so two polygons sharing an edge always get opposite signs."""
    s = np.where(f != 0, f, np.where(dy != 0, dy, dx))
    return np.where(s < 0, np.int8(-1), np.int8(1))


def polygon_test(sd: ShapeData, nv: int, poly, two, o, d, tmin, k, sx, sy):
    """Watertight test of polygons with `nv` vertices (any shape: a fan from vertex 0 with signed
    coverage, hit where the winding number is non-zero; front side = positive winding).

    Each vertex is moved to ray space (relative to the origin, axes permuted, sheared so the ray
    runs along the third axis): A = v - o, px = A[kx] - sx*A[kz], py = A[ky] - sy*A[kz]. The edge
    value of (a, b) is F = ay*bx - ax*by. Rounding is monotone, so the sign of F is that of the
    exact 2-D cross product of the rounded projected points: no cracks at shared edges or vertices.
    """
    dt = sd.dtype
    cols = np.arange(len(poly))
    vid = sd.poly_start[poly][:, None] + np.arange(nv)[None, :]
    V = sd.poly_vertices
    okx, oky, okz = o[k[0], cols], o[k[1], cols], o[k[2], cols]
    ax = V[vid, k[0][:, None]] - okx[:, None]
    ay = V[vid, k[1][:, None]] - oky[:, None]
    az = V[vid, k[2][:, None]] - okz[:, None]
    px = ax - sx[:, None] * az
    py = ay - sy[:, None] * az
    # diagonals/edges from vertex 0: F(A0, Ai), i = 1..nv-1; rim edges F(Ai, Ai+1), i = 1..nv-2
    e0 = py[:, :1] * px[:, 1:] - px[:, :1] * py[:, 1:]
    e1 = py[:, 1:-1] * px[:, 2:] - px[:, 1:-1] * py[:, 2:]
    s0 = _perturbed_sign(e0, py[:, 1:] - py[:, :1], px[:, :1] - px[:, 1:])
    s1 = _perturbed_sign(e1, py[:, 2:] - py[:, 1:-1], px[:, 1:-1] - px[:, 2:])
    # fan triangle j = (v0, v[j+1], v[j+2]): edges F(A0,Aj+1), F(Aj+1,Aj+2), F(Aj+2,A0) = -F(A0,Aj+2)
    a, b, c = s0[:, :-1], s1, -s0[:, 1:]
    cover = np.where((a == b) & (b == c), a, np.int8(0)).astype(np.int32)
    winding = cover.sum(axis=1)
    counts = (winding > 0) | (two & (winding != 0))
    # t from the plane through v0: (n . (v0 - o)) / (n . d), in x, y, z order
    n = sd.poly_normal[poly].T
    w = V[sd.poly_start[poly]].T - o
    t = dot(n, w) / dot(n, d)
    counts &= t > tmin
    t = np.where(counts, t, dt(np.inf))
    # barycentrics in the first fan triangle that covers the hit
    fan = np.argmax(cover != 0, axis=1).astype(np.int32)
    w0 = e1[cols, fan]
    w1 = -e0[cols, fan + 1]
    w2 = e0[cols, fan]
    s = w0 + w1 + w2
    return t, fan, w1 / s, w2 / s


def sphere_test(sd: ShapeData, sph, two, o, d, tmin):
    """oc = o - c; b = oc.d; q = oc - b*d (centre to the closest point of the line); disc = r^2 -
    q.q (no cancellation for far, tiny spheres); h = sqrt(disc); roots -b - h (entering, front)
    and -b + h (leaving, back)."""
    c = sd.sph_center[sph].T
    oc = o - c
    b = dot(oc, d)
    q = oc - b * d
    disc = sd.sph_r2[sph] - dot(q, q)
    h = np.sqrt(disc)
    real = disc >= 0
    nb = -b
    return _first_root(nb - h, real, nb + h, real & two, tmin, sd.dtype(np.inf))


def _axis_frame(sd: ShapeData, cone, o, d):
    """Ray relative to a cone/cylinder record: w = o - B; wa = w.a, da = d.a; the parts
    perpendicular to the axis wp = w - wa*a, dp = d - da*a."""
    a = sd.cone_axis[cone].T
    w = o - sd.cone_base[cone].T
    wa = dot(w, a)
    da = dot(d, a)
    return w - wa * a, d - da * a, wa, da


def cylinder_test(sd: ShapeData, cyl, two, o, d, tmin):
    """Open cylinder, solved like the sphere in the plane across the axis: A = dp.dp,
    s = (wp.dp)/A, q = wp - s*dp, disc = r^2 - q.q, h = sqrt(disc/A), roots -s -+ h; a root
    counts only where the axial coordinate wa + t*da lies in [0, L]."""
    wp, dp, wa, da = _axis_frame(sd, cyl, o, d)
    A = dot(dp, dp)
    s = dot(wp, dp) / A
    q = wp - s * dp
    disc = sd.cone_r2[cyl] - dot(q, q)
    h = np.sqrt(disc / A)
    real = (A > 0) & (disc >= 0)
    ns = -s
    t0, t1 = ns - h, ns + h
    L = sd.cone_length[cyl]
    z0, z1 = wa + t0 * da, wa + t1 * da
    in0 = real & (z0 >= 0) & (z0 <= L)
    in1 = real & (z1 >= 0) & (z1 <= L) & two
    return _first_root(t0, in0, t1, in1, tmin, sd.dtype(np.inf))


def cone_test(sd: ShapeData, cone, two, o, d, tmin):
    """Open truncated cone r(z) = r0 + k*z: with rw = r0 + k*wa and kd = k*da the quadratic is
    A t^2 + 2 B t + C with A = dp.dp - kd*kd, B = wp.dp - rw*kd, C = wp.wp - rw*rw. Roots by the
    cancellation-free pair q = -(B + sign(B) sqrt(B*B - A*C)), q/A and C/q, ordered by a compare.
    A root enters the solid (front) where the quadratic falls: A*t + B < 0."""
    dt = sd.dtype
    wp, dp, wa, da = _axis_frame(sd, cone, o, d)
    k = sd.cone_slope[cone]
    rw = sd.cone_r0[cone] + k * wa
    kd = k * da
    A = dot(dp, dp) - kd * kd
    B = dot(wp, dp) - rw * kd
    C = dot(wp, wp) - rw * rw
    disc = B * B - A * C
    sq = np.sqrt(disc)
    qq = np.where(B >= 0, -(B + sq), sq - B)
    ta, tb = qq / A, C / qq
    swap = tb < ta
    t0, t1 = np.where(swap, tb, ta), np.where(swap, ta, tb)
    real = disc >= 0
    L = sd.cone_length[cone]
    z0, z1 = wa + t0 * da, wa + t1 * da
    ok0 = real & (z0 >= 0) & (z0 <= L) & (two | (A * t0 + B < 0))
    ok1 = real & (z1 >= 0) & (z1 <= L) & (two | (A * t1 + B < 0))
    return _first_root(t0, ok0, t1, ok1, tmin, dt(np.inf))


def surface_normals(sd: ShapeData, prim: np.ndarray, p: np.ndarray, fan: np.ndarray,
                    b1: np.ndarray, b2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(geometric, shading) unit normals at hit points `p` (3, n), outward / front-side.

    Polygon: the record normal; `pp` patch shading normal: normalise(b0*n0 + b1*n1 + b2*n2) over
    the fan triangle's vertices with b0 = (1 - b1) - b2. Sphere: normalise(p - c). Cylinder:
    normalise(wp) with w = p - B. Cone: normalise(normalise(wp) - k*a).
    """
    dt = sd.dtype
    n = len(prim)
    ng = np.zeros((3, n), dt)
    ns = np.zeros((3, n), dt)
    kind = sd.kind[prim]
    local = sd.local[prim]
    with np.errstate(divide="ignore", invalid="ignore"):
        sel = np.flatnonzero(kind == Kind.POLYGON)
        if len(sel):
            poly = local[sel]
            ng[:, sel] = sd.poly_normal[poly].T
            ns[:, sel] = ng[:, sel]
            patch = sel[sd.poly_is_patch[poly]]
            if len(patch):
                pl = local[patch]
                v0 = sd.poly_start[pl]
                vi = v0 + fan[patch] + 1
                nn = sd.poly_vertex_normals
                c1, c2 = b1[patch], b2[patch]
                c0 = (dt(1) - c1) - c2
                ns[:, patch] = normalize(c0 * nn[v0].T + c1 * nn[vi].T + c2 * nn[vi + 1].T)
        sel = np.flatnonzero(kind == Kind.SPHERE)
        if len(sel):
            ng[:, sel] = normalize(p[:, sel] - sd.sph_center[local[sel]].T)
            ns[:, sel] = ng[:, sel]
        sel = np.flatnonzero((kind == Kind.CYLINDER) | (kind == Kind.CONE))
        if len(sel):
            c = local[sel]
            a = sd.cone_axis[c].T
            w = p[:, sel] - sd.cone_base[c].T
            u = normalize(w - dot(w, a) * a)
            cone = kind[sel] == Kind.CONE
            u[:, cone] = normalize(u[:, cone] - sd.cone_slope[c[cone]] * a[:, cone])
            ng[:, sel] = u
            ns[:, sel] = u
    return ng, ns
