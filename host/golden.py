"""The golden model: a vectorised Whitted ray tracer, the oracle the emulated machine must match.

Same grid (`host.grid`), same intersection formulas (`host.shapes`), same traversal
(`host.traversal`), same epsilons and ray-tree rules the OS / IC / SC kernels implement, in
float32 (fp32, the machine's) or float64 (fp64). It runs as a wavefront: all rays of one depth
are traced together, their hits shaded together, their shadow rays traced together.

Ray-tree rules (the SPD rendering conventions; docs/golden.md): eye ray depth 1, at most
`config.render.max_depth`; a hit on Ks > 0 spawns a reflection ray, on T > 0 a refraction ray
(none on total internal reflection; the reflection ray is still spawned if Ks > 0); one shadow
ray per light the shading normal faces (n.l > 0); each ray carries an RGB weight and its eye
sample ("pixel"); a shadow ray carries the contribution it would add and adds it to its pixel
only if nothing occludes it; a ray that leaves the scene adds weight x background. Lights are
positional with intensity light_colour / sqrt(#lights) (NFF gives none). There is no ambient term.
`docs/golden.md` lists every operation in order.
"""

from __future__ import annotations

from netsushisen.host.scale import check_scale

import time
from dataclasses import dataclass, field, replace

import numpy as np

from netsushisen.host.grid import Grid, build_grid
from netsushisen.host.rays import PrimaryRays, dot, dtype_of, normalize, primary_rays
from netsushisen.host.scenes import Scene
from netsushisen.host.shapes import ShapeData, build_shape_data, ic_rays, surface_normals
from netsushisen.host.traversal import OSGrid, trace
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.libm import machine_pow_array

EYE, REFLECTION, REFRACTION, SHADOW = 0, 1, 2, 3
KIND_NAMES = ("eye", "reflection", "refraction", "shadow")


@dataclass
class Luminance:
    """SC's per-material luminance data in the precision (float64 products rounded once):
    kdc = Kd * colour, Ks, Phong exponent, T, ior and 1/ior; lights and background."""

    kdc: np.ndarray  # (M, 3)
    ks: np.ndarray
    shine: np.ndarray
    t: np.ndarray
    ior: np.ndarray
    inv_ior: np.ndarray
    light_pos: np.ndarray  # (L, 3)
    light_int: np.ndarray  # (L, 3) colour / sqrt(L)
    background: np.ndarray  # (3,)

    @classmethod
    def of(cls, scene: Scene, dt: type) -> Luminance:
        m = scene.materials
        r = lambda a: np.asarray(a, dtype=np.float64).astype(dt)  # noqa: E731
        nl = max(len(scene.light_position), 1)
        with np.errstate(divide="ignore"):
            inv_ior = np.where(m.ior != 0, 1.0 / np.where(m.ior != 0, m.ior, 1.0), 1.0)
        return cls(kdc=r(m.kd[:, None] * m.color), ks=r(m.ks), shine=r(m.shine), t=r(m.t),
                   ior=r(m.ior), inv_ior=r(inv_ior), light_pos=r(scene.light_position).reshape(-1, 3),
                   light_int=r(np.asarray(scene.light_color).reshape(-1, 3) / np.sqrt(nl)),
                   background=r(scene.background))


@dataclass
class RayBatch:
    """Rays of one wavefront: geometry, weight, eye sample, depth, kind, and for the IC trace a
    global id and the tree path (column 0 = eye sample, column j = child slot at tree level j+1,
    -1 = none; slots: shadow ray of light l = l, reflection = #lights, refraction = #lights+1)."""

    o: np.ndarray
    d: np.ndarray
    t_min: np.ndarray
    weight: np.ndarray  # (3, n)
    sample: np.ndarray  # (n,) int64
    depth: int
    kind: np.ndarray  # (n,) int8
    gid: np.ndarray  # (n,) int64
    path: np.ndarray  # (n, max_depth + 2) int32

    def __len__(self) -> int:
        return len(self.sample)


@dataclass
class GoldenResult:
    image: np.ndarray  # (res, res, 3) precision dtype
    image_u8: np.ndarray  # (res, res, 3) uint8
    hit_ids: np.ndarray  # (rows, cols) int32 eye-sample hit primitive, -1 background
    rays: dict[str, int]
    visible_primitives: int
    references: np.ndarray  # (N,) int64, all ray kinds
    seconds: float
    precision: str
    corners: bool
    grid: Grid
    trace_ray_offsets: np.ndarray | None = None  # (R+1,) int64 CSR into trace_prims
    trace_prims: np.ndarray | None = None  # int32 primitive ids in test order
    trace_kind: np.ndarray | None = None  # (R,) int8 EYE/REFLECTION/REFRACTION/SHADOW
    trace_depth: np.ndarray | None = None  # (R,) int8
    trace_pixel: np.ndarray | None = None  # (R,) int32 eye sample index
    trace_leaves: np.ndarray | None = None  # aligned with trace_prims: int32 grid leaf (list) tested
    trace_hit: np.ndarray | None = None  # (R,) int32 surface ray's hit primitive (-1 miss; shadow -1)
    trace_hit_fan: np.ndarray | None = None  # (R,) int32 fan triangle of a polygon hit (0 otherwise)
    stats: dict[str, float] = field(default_factory=dict)
    shadows: dict[str, np.ndarray] | None = None  # keep_shadows: the shadow rays of eye-ray hits

    @property
    def total_references(self) -> int:
        return int(self.references.sum())


def to_u8(image: np.ndarray) -> np.ndarray:
    """floor(clamp(v, 0, 1) * 255 + 0.5) per channel."""
    v = np.minimum(np.maximum(image, 0), 1)
    return np.floor(v * 255 + 0.5).astype(np.uint8)


class _Recorder:
    """Collects rays and references so the IC trace can be put in depth-first order at the end."""

    def __init__(self, n_prims: int, keep: bool):
        self.keep = keep
        self.next_gid = 0
        self.refs = np.zeros(n_prims, np.int64)
        self.kind: list[np.ndarray] = []
        self.depth: list[np.ndarray] = []
        self.pixel: list[np.ndarray] = []
        self.path: list[np.ndarray] = []
        self.ref_ray: list[np.ndarray] = []
        self.ref_prim: list[np.ndarray] = []
        self.ref_leaf: list[np.ndarray] = []
        self.hit: list[np.ndarray] = []
        self.hit_fan: list[np.ndarray] = []
        self.shadows: list[dict] | None = None

    def new_ids(self, n: int) -> np.ndarray:
        ids = np.arange(self.next_gid, self.next_gid + n, dtype=np.int64)
        self.next_gid += n
        return ids

    def add(self, batch: RayBatch, kind_depth: np.ndarray, result) -> None:
        self.refs += result.ref_counts
        if self.keep:
            self.kind.append(batch.kind)
            self.depth.append(kind_depth.astype(np.int8))
            self.pixel.append(batch.sample.astype(np.int32))
            self.path.append(batch.path)
            self.ref_ray.append(result.ref_ray)
            self.ref_prim.append(result.ref_prim)
            self.ref_leaf.append(result.ref_leaf if result.ref_leaf is not None else np.zeros(0, np.int32))
            self.hit.append(result.prim)
            self.hit_fan.append(np.where(result.prim >= 0, result.fan, 0))

    def finish(self, out: GoldenResult) -> None:
        if not self.keep:
            return
        path = np.concatenate(self.path)
        order = np.lexsort(path.T[::-1])  # eye sample first, then child slots level by level
        rank = np.empty(len(order), np.int64)
        rank[order] = np.arange(len(order))
        ref_ray = np.concatenate(self.ref_ray) if self.ref_ray else np.zeros(0, np.int64)
        ref_prim = np.concatenate(self.ref_prim) if self.ref_prim else np.zeros(0, np.int32)
        r = rank[ref_ray]
        sort = np.argsort(r, kind="stable")
        out.trace_prims = ref_prim[sort].astype(np.int32)
        ref_leaf = np.concatenate(self.ref_leaf) if self.ref_leaf else np.zeros(0, np.int32)
        out.trace_leaves = ref_leaf[sort].astype(np.int32)
        out.trace_ray_offsets = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=len(order)))]).astype(np.int64)
        out.trace_kind = np.concatenate(self.kind)[order].astype(np.int8)
        out.trace_depth = np.concatenate(self.depth)[order]
        out.trace_pixel = np.concatenate(self.pixel)[order]
        out.trace_hit = np.concatenate(self.hit)[order].astype(np.int32)
        out.trace_hit_fan = np.concatenate(self.hit_fan)[order].astype(np.int32)


OFFSET_ULPS = 2.125
"""Secondary-ray origins move delta = (sum_a |P_a Ng_a| + t) x OFFSET_ULPS x unit roundoff + SIZE_ULPS
x unit roundoff x the largest primitive size along the geometric normal: 2u covers the rounding
of P and of P + delta*Ng along the normal, u/8 the few roundings of delta itself
(docs/golden.md, "Secondary-ray origins")."""
SIZE_ULPS = 64


def offset_scale(dt: type):
    """k_rel = OFFSET_ULPS x the precision's unit roundoff (SC's scene block SCN_EPS_REL; exact)."""
    return dt(OFFSET_ULPS * float(np.finfo(dt).eps) / 2.0)


def scene_epsilon(grid: Grid, config: MachineConfig, dt: type):
    """k_abs of the secondary-ray offset (SC's scene block SCN_EPS): SIZE_ULPS x u x the largest
    primitive's own size (the longest side of its bounding box), rounded once to the precision.
    The intersection tests' error grows with the primitive's size and the hit point's magnitude,
    not with the scene's extent; `config` is unused (render.epsilon no longer applies)."""
    return dt(SIZE_ULPS * float(np.finfo(dt).eps) / 2.0 * grid.primitive_size)


def offset_delta(p: np.ndarray, t: np.ndarray, ng: np.ndarray, k_rel, k_abs) -> np.ndarray:
    """SC's offset length: delta = (((|Px*Ngx| + |Py*Ngy|) + |Pz*Ngz|) + t)*k_rel + k_abs, one IEEE
    operation at a time in this order (a per-hit bound on P's rounding along the normal, pbrt-v4's
    dot(|n|, pError); docs/golden.md, "Secondary-ray origins")."""
    a = np.abs(p * ng)
    return (((a[0] + a[1]) + a[2]) + t) * k_rel + k_abs


def offset_vectors(p: np.ndarray, t: np.ndarray, ng: np.ndarray, inside: np.ndarray, k_rel, k_abs):
    """SC's secondary-ray origins: (front, back) = P +- delta*Nf with Nf the geometric normal
    facing the incoming ray and delta = `offset_delta`. Shadow and reflection rays leave from the
    front, refraction rays from the back; all with t_min = 0."""
    delta = offset_delta(p, t, ng, k_rel, k_abs)
    delta = np.where(inside, -delta, delta)
    off = delta * ng
    return p + off, p - off


def _shadow_table(parts: list[dict], dt: type) -> dict[str, np.ndarray]:
    """The kept shadow rays of eye hits as one table: sample, light, hit primitive, origin (3, n),
    the hit point P before the offset (3, n), the geometric normal facing the eye ray (3, n), the
    eye ray's t, blocked."""
    empty = {"sample": np.zeros(0, np.int64), "light": np.zeros(0, np.int64), "prim": np.zeros(0, np.int32),
             "origin": np.zeros((3, 0), dt), "point": np.zeros((3, 0), dt), "normal": np.zeros((3, 0), dt),
             "t": np.zeros(0, dt), "blocked": np.zeros(0, bool)}
    if not parts:
        return empty
    return {k: np.concatenate([x[k] for x in parts], axis=-1) for k in empty}


def _child_path(path: np.ndarray, level: int, slot: int) -> np.ndarray:
    out = path.copy()
    out[:, level] = slot
    return out


def _accumulate(acc: np.ndarray, sample: np.ndarray, value: np.ndarray) -> None:
    for c in range(3):
        np.add.at(acc[c], sample, value[c])


def render(scene: Scene, config: MachineConfig | None = None, res: int = 64, corners: bool = False,
           precision: str | None = None, keep_trace: bool = False, grid: Grid | None = None,
           keep_shadows: bool = False, jitter: int | None = None) -> GoldenResult:
    """Render `scene` at res x res (pixel centres, or SPD corners with `corners`). `keep_shadows`
    keeps every shadow ray of an eye ray's hit (sample, light, hit primitive, origin, hit point,
    facing normal, eye t, blocked) for the numerics checks. `jitter`: a seed moving each eye
    ray within its pixel (`host.rays.primary_rays`)."""
    start = time.perf_counter()
    config = config or MachineConfig()
    precision = precision or config.precision
    check_scale(scene, precision)
    dt = dtype_of(precision)
    if grid is None:  # conservative in the precision it is traversed in
        grid = build_grid(scene, config if config.precision == precision else replace(config, precision=precision))
    osg = OSGrid.of(grid, dt)
    sd = build_shape_data(scene, precision)
    lum = Luminance.of(scene, dt)
    eps, k_rel = scene_epsilon(grid, config, dt), offset_scale(dt)
    max_depth = config.render.max_depth
    min_weight = dt(config.render.min_weight)
    eye: PrimaryRays = primary_rays(scene.camera, res, corners, precision, jitter)
    ns = eye.direction.shape[1]
    acc = np.zeros((3, ns), dt)
    rec = _Recorder(scene.n_primitives, keep_trace)
    rec.shadows = [] if keep_shadows else None
    counts = {"eye": ns, "eye_hits": 0, "reflection": 0, "refraction": 0, "shadow": 0}
    path = np.full((ns, max_depth + 2), -1, np.int32)
    path[:, 0] = np.arange(ns)
    batch = RayBatch(o=np.repeat(eye.origin[:, None], ns, axis=1), d=eye.direction,
                     t_min=np.full(ns, eye.t_min, dt), weight=np.ones((3, ns), dt),
                     sample=np.arange(ns, dtype=np.int64), depth=1, kind=np.zeros(ns, np.int8),
                     gid=rec.new_ids(ns), path=path)
    hit_ids = np.full(ns, -1, np.int32)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        while len(batch):
            tr = trace(osg, sd, ic_rays(batch.o, batch.d, batch.t_min), ray_ids=batch.gid, keep_refs=keep_trace)
            rec.add(batch, np.full(len(batch), batch.depth), tr)
            if batch.depth == 1:
                hit_ids[:] = tr.prim
                counts["eye_hits"] = int(np.count_nonzero(tr.prim >= 0))
            miss = tr.prim < 0
            _accumulate(acc, batch.sample[miss], batch.weight[:, miss] * lum.background[:, None])
            h = np.flatnonzero(~miss)
            batch = _shade(batch, h, tr, sd, lum, scene, osg, rec, acc, counts, eps, k_rel, max_depth,
                           min_weight, keep_trace)
    if corners:
        m = res + 1
        c = acc.reshape(3, m, m)
        img = (((c[:, :-1, :-1] + c[:, :-1, 1:]) + c[:, 1:, :-1]) + c[:, 1:, 1:]) * dt(0.25)
    else:
        img = acc.reshape(3, res, res)
    image = np.ascontiguousarray(np.moveaxis(img, 0, 2))
    out = GoldenResult(image=image, image_u8=to_u8(image), hit_ids=hit_ids.reshape(eye.shape), rays=counts,
                       visible_primitives=int(len(np.unique(hit_ids[hit_ids >= 0]))),
                       references=rec.refs, seconds=0.0, precision=precision, corners=corners, grid=grid)
    rec.finish(out)
    if keep_shadows:
        out.shadows = _shadow_table(rec.shadows, dt)
    out.seconds = time.perf_counter() - start
    total = sum(v for k, v in counts.items() if k != "eye_hits")
    out.stats = {"rays_total": total, "rays_per_second": total / max(out.seconds, 1e-9)}
    return out


def _shade(batch: RayBatch, h: np.ndarray, tr, sd: ShapeData, lum: Luminance, scene: Scene,
           osg: OSGrid, rec: _Recorder, acc: np.ndarray, counts: dict[str, int], eps, k_rel, max_depth: int,
           min_weight, keep_trace: bool) -> RayBatch:
    """SC for the hits `h` of `batch`: shadow rays (traced here), then the next depth's rays."""
    dt = sd.dtype
    d = batch.d[:, h]
    t = tr.t[h]
    prim = tr.prim[h]
    w = batch.weight[:, h]
    sample = batch.sample[h]
    path = batch.path[h]
    level = batch.depth  # tree level of this batch's rays; children write path column `level`
    p = batch.o[:, h] + t * d
    ng, nsh = surface_normals(sd, prim, p, tr.fan[h], tr.b1[h], tr.b2[h])
    inside = dot(d, ng) > 0
    nsh = np.where(inside, -nsh, nsh)
    point = p
    p, p_back = offset_vectors(p, t, ng, inside, k_rel, eps)  # front: shadow, reflection; back: refraction
    zero = np.zeros(len(h), dt)
    mat = scene.material[prim]
    cosi = -dot(d, nsh)
    refl = normalize(d + (cosi + cosi) * nsh)
    ks, shine = lum.ks[mat], lum.shine[mat]
    kdc = lum.kdc[mat].T
    # shadow rays, light by light
    parts: list[tuple] = []
    for li in range(len(lum.light_pos)):
        lv = lum.light_pos[li][:, None] - p
        dist = np.sqrt(dot(lv, lv))
        ld = lv / dist
        ndl = dot(nsh, ld)
        face = np.flatnonzero(ndl > 0)
        spec = machine_pow_array(np.maximum(dot(refl[:, face], ld[:, face]), dt(0)), shine[face])  # as fpow
        contrib = ((kdc[:, face] * ndl[face] + ks[face] * spec) * lum.light_int[li][:, None]) * w[:, face]
        parts.append((face, li, ld[:, face], dist[face], contrib))
    if parts and sum(len(x[0]) for x in parts):
        face = np.concatenate([x[0] for x in parts])
        sl = np.concatenate([np.full(len(x[0]), x[1]) for x in parts])
        ld = np.concatenate([x[2] for x in parts], axis=1)
        dist = np.concatenate([x[3] for x in parts])
        contrib = np.concatenate([x[4] for x in parts], axis=1)
        n = len(face)
        spath = path[face].copy()
        spath[np.arange(n), level] = sl
        sb = RayBatch(o=p[:, face], d=ld, t_min=zero[face], weight=contrib, sample=sample[face],
                      depth=batch.depth, kind=np.full(n, SHADOW, np.int8), gid=rec.new_ids(n), path=spath)
        st = trace(osg, sd, ic_rays(sb.o, sb.d, sb.t_min), t_max=dist, ray_ids=sb.gid, keep_refs=keep_trace)
        rec.add(sb, np.full(n, batch.depth), st)
        counts["shadow"] += n
        lit = ~st.occluded
        if rec.shadows is not None and batch.depth == 1:
            nf = np.where(inside, -ng, ng)
            rec.shadows.append({"sample": sb.sample, "light": sl, "prim": prim[face], "origin": sb.o,
                                "point": point[:, face], "normal": nf[:, face], "t": t[face],
                                "blocked": st.occluded})
        _accumulate(acc, sb.sample[lit], contrib[:, lit])
    if batch.depth >= max_depth:
        return _empty(batch, dt)
    # reflection rays
    new: list[RayBatch] = []
    rw = w * ks
    r_sel = np.flatnonzero((ks > 0) & ((min_weight <= 0) | (rw.max(axis=0) >= min_weight)))
    n_l = len(lum.light_pos)
    if len(r_sel):
        new.append(RayBatch(o=p[:, r_sel], d=refl[:, r_sel], t_min=zero[r_sel],
                            weight=rw[:, r_sel], sample=sample[r_sel], depth=batch.depth + 1,
                            kind=np.full(len(r_sel), REFLECTION, np.int8), gid=np.zeros(0, np.int64),
                            path=_child_path(path[r_sel], level, n_l)))
        counts["reflection"] += len(r_sel)
    # refraction rays (Snell; none on total internal reflection)
    tt = lum.t[mat]
    eta = np.where(inside, lum.ior[mat], lum.inv_ior[mat])
    k = dt(1) - (eta * eta) * (dt(1) - cosi * cosi)
    tw = w * tt
    t_sel = np.flatnonzero((tt > 0) & (k >= 0) & ((min_weight <= 0) | (tw.max(axis=0) >= min_weight)))
    if len(t_sel):
        e, c, kk = eta[t_sel], cosi[t_sel], k[t_sel]
        tdir = normalize(e * d[:, t_sel] + (e * c - np.sqrt(kk)) * nsh[:, t_sel])
        new.append(RayBatch(o=p_back[:, t_sel], d=tdir, t_min=zero[t_sel], weight=tw[:, t_sel],
                            sample=sample[t_sel], depth=batch.depth + 1,
                            kind=np.full(len(t_sel), REFRACTION, np.int8), gid=np.zeros(0, np.int64),
                            path=_child_path(path[t_sel], level, n_l + 1)))
        counts["refraction"] += len(t_sel)
    if not new:
        return _empty(batch, dt)
    out = RayBatch(o=np.concatenate([b.o for b in new], axis=1), d=np.concatenate([b.d for b in new], axis=1),
                   t_min=np.concatenate([b.t_min for b in new]),
                   weight=np.concatenate([b.weight for b in new], axis=1),
                   sample=np.concatenate([b.sample for b in new]), depth=batch.depth + 1,
                   kind=np.concatenate([b.kind for b in new]), gid=np.zeros(0, np.int64),
                   path=np.concatenate([b.path for b in new]))
    out.gid = rec.new_ids(len(out))
    return out


def _empty(batch: RayBatch, dt: type) -> RayBatch:
    return RayBatch(o=np.zeros((3, 0), dt), d=np.zeros((3, 0), dt), t_min=np.zeros(0, dt),
                    weight=np.zeros((3, 0), dt), sample=np.zeros(0, np.int64), depth=batch.depth + 1,
                    kind=np.zeros(0, np.int8), gid=np.zeros(0, np.int64),
                    path=np.zeros((0, batch.path.shape[1]), np.int32))
