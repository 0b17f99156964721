"""Numerical stability: the hard-case catalog, its three paths, and the stability report.

The catalog is a list of small scenes, one per hard case (docs/golden.md, "The numerical
catalog"). Each is rendered on a *path* — golden fp32, golden fp64, or the emulated machine — and
judged against the brute-force float64 oracle (`host/oracle.py`) with its tolerance rule: every
eye ray's hit must be one the oracle allows; every shadow ray of an eye ray's hit, judged from
the path's own hit point, must be blocked by an occluder above the offset's error bound (else
*wrongly lit*) and unblocked when the oracle says it is unambiguously free (*wrongly blocked*); the
translated cases must give exactly the hit ids of their untranslated scene; the machine must give
golden fp32's hit ids and 8-bit image bit for bit. `scene_report` does the same for any scene:
fp32 against fp64, and the scene translated by powers of ten until it breaks.
"""

from __future__ import annotations

from netsushisen.isa.errors import NetsushisenError

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from netsushisen.host.golden import render as golden_render
from netsushisen.host.grid import boundaries, build_grid
from netsushisen.host.nff import parse_nff
from netsushisen.host.oracle import (OracleScene, allowed_hits, contact_truth, distance_to, judge_hits,
                                     tolerance)
from netsushisen.host.rays import dot, normalize, primary_rays, rownorm
from netsushisen.host.scenes import Scene
from netsushisen.isa.config import load_config

GOLDEN32, GOLDEN64 = "golden-fp32", "golden-fp64"
TRANSLATIONS = (1e3, 1e4, 1e5, 1e6)

_HEAD = "b 0.1 0.2 0.3\nv\nfrom {eye}\nat {at}\nup {up}\nangle {angle}\nhither 0\nresolution 8 8\n"


def _view(eye: str, at: str, angle: float, up: str = "0 1 0", lights: str = "l 0 5 -5\n") -> str:
    return _HEAD.format(eye=eye, at=at, up=up, angle=angle) + lights


MATTE = "f 0.8 0.8 0.8 0.8 0 1 0 0\n"
GLASS = "f 0.9 0.9 1 0.2 0.3 20 0.7 1.5\n"
MIRROR = "f 1 1 1 0.5 0.5 20 0 1\n"
WALL = "p 4\n-9 -9 6\n-9 9 6\n9 9 6\n9 -9 6\n"  # faces the eyes at z < 6

MIXED = _view("0.5 3 -8", "0 1 0", 45, lights="l -3 6 -5\nl 4 5 -3\n") + MATTE + (
    "p 4\n-4 0 -4\n-4 0 4\n4 0 4\n4 0 -4\np 4\n-4 0 3\n4 0 3\n4 4 3\n-4 4 3\n") + GLASS + (
    "s -2 1 0 1\nc 0 0 -1 0.75 0 2 -1 0.75\nc 2 0 0 1 2 2 0 0.25\n") + \
    "f 1 0.5 0.2 0.8 0.2 10 0 0\ns 1 0.5 -2.5 0.5\n"
"""Floor, wall, glass sphere, cylinder and cone, an opaque sphere, two lights: all coordinates
exact in fp32 at every translation by 1e3..1e6 (halves and quarters), so eye rays are
bit-identical across translations."""

CONTACT_GAPS = {1e4: 2 * 2.0 ** -10, 1e5: 3 * 2.0 ** -7, 1e6: 3 * 2.0 ** -4}
"""Per translation, the contact gap of the plate above the floor: whole units in the last place of
fp32 at the floor's height, above the offset's bound at that height and at most the old blanket
offset 4u x (max|P| + t) + 64u x S (which starts the shadow ray on or above the plate)."""


def contact_scene(gap: float) -> str:
    """A floor, and a 7 x 2 plate `gap` above it (a face down, for the shadow rays, and a face up
    at the same height, for the eye); the light `3 x gap` high and 15 units to the side, so the
    shadow falls beyond the plate on floor the eye sees. Its colour keeps the lit floor near 0.5
    at that low angle. Every coordinate is a multiple of `gap` or of 1/2: exact in fp32 after the
    translation. At so low a light an origin raised by h moves the shadow by h / tan(angle), so
    only the part of the shadow every origin within the offset's bound sees is judged."""
    g = repr(gap)
    light = f"l -14 {repr(3 * gap)} 0 {2.5 / gap:g} {2.5 / gap:g} {2.5 / gap:g}\n"
    return (_view("2.5 4 -4", "2 0 0", 35, lights=light) + MATTE + "p 4\n-8 0 -4\n-8 0 4\n8 0 4\n8 0 -4\n"
            f"p 4\n-6 {g} -1\n1 {g} -1\n1 {g} 1\n-6 {g} 1\np 4\n-6 {g} -1\n-6 {g} 1\n1 {g} 1\n1 {g} -1\n")


OCTAHEDRON = "".join(f"p 3\n{a}\n{b}\n{c}\n" for a, b, c in [
    ("1 0 0", "0 1 0", "0 0 -1"), ("0 1 0", "-1 0 0", "0 0 -1"), ("-1 0 0", "0 -1 0", "0 0 -1"),
    ("0 -1 0", "1 0 0", "0 0 -1"), ("0 1 0", "1 0 0", "0 0 1"), ("-1 0 0", "0 1 0", "0 0 1"),
    ("0 -1 0", "-1 0 0", "0 0 1"), ("1 0 0", "0 -1 0", "0 0 1")])
FAN = "".join(f"p 3\n0 0 0\n{a}\n{b}\n" for a, b in [
    ("2 2 0", "2 0 0"), ("0 2 0", "2 2 0"), ("-2 2 0", "0 2 0"), ("-2 0 0", "-2 2 0"),
    ("-2 -2 0", "-2 0 0"), ("0 -2 0", "-2 -2 0"), ("2 -2 0", "0 -2 0"), ("2 0 0", "2 -2 0")])


@dataclass
class Case:
    """One catalog entry: a scene (NFF text), its resolution, configuration overrides, and
    which judgements apply."""

    name: str
    what: str
    nff: str
    res: int = 9
    sets: tuple[str, ...] = ()
    shadows: bool = True  # judge the eye hits' shadow rays
    translate: float = 0.0  # translated copy of `nff` by this much (compared with the untranslated)
    compare_fp64: bool = False  # also: fp32 and fp64 differ only where the oracle allows both
    tir: bool = False  # judge refraction spawning against Snell's law in float64
    place_eye: Callable[[Scene], Scene] | None = None  # moves the eye after the grid is known
    spec: str = ""  # a built-in scene instead of `nff`

    def scene(self) -> Scene:
        if self.spec:
            from netsushisen.host.catalog import load_scene  # noqa: PLC0415 (SPD generators are heavy)
            return load_scene(self.spec)
        text = translate_nff(self.nff, self.translate) if self.translate else self.nff
        sc = parse_nff(text, filename=f"{self.name}.nff")
        return self.place_eye(sc) if self.place_eye else sc


def translate_nff(text: str, by: float) -> str:
    """The scene moved by (by, by, by): eye, at, lights, vertices, centres, cone ends."""
    out = []
    vertex_lines = 0
    for line in text.splitlines():
        f = line.split()
        shift = lambda xs: " ".join(repr(float(x) + by) for x in xs)  # noqa: E731
        if vertex_lines:
            out.append(shift(f[:3]) + ("" if len(f) <= 3 else " " + " ".join(f[3:])))
            vertex_lines -= 1
        elif f and f[0] in ("from", "at", "l"):
            out.append(f"{f[0]} {shift(f[1:4])}" + "".join(" " + x for x in f[4:]))
        elif f and f[0] == "s":
            out.append(f"s {shift(f[1:4])} {f[4]}")
        elif f and f[0] == "c":
            out.append(f"c {shift(f[1:4])} {f[4]} {shift(f[5:8])} {f[8]}")
        elif f and f[0] in ("p", "pp"):
            out.append(line)
            vertex_lines = int(f[1])
        else:
            out.append(line)
    return "\n".join(out) + "\n"


def _eye_on_grid_face(sc: Scene) -> Scene:
    """Put the eye exactly on an interior voxel boundary of the fp32 grid (x and y)."""
    g = build_grid(sc, load_config(None, []))
    i = np.maximum(g.res // 2, 1)
    b = boundaries(g.lo, g.cell, i, "fp32")
    cam = replace(sc.camera, eye=np.array([b[0], b[1], sc.camera.eye[2]]), at=np.array([b[0], b[1], 0.0]))
    return replace(sc, camera=cam)


CATALOG: list[Case] = [
    Case("far_tiny_sphere", "r = 1e-3 at distance 1e4",
         _view("0 0 0", "0 0 1", 0.00002, lights="l 0 1 0\n") + MATTE + "s 0 0 10000 0.001\n", res=7),
    Case("grazing_sphere", "rays tangent to a sphere (disc = 0)",
         _view("0 0 -5", "0 0 0", 30) + MATTE + "s 1 0 0 1\n" + WALL),
    Case("grazing_cylinder", "rays tangent to an open cylinder",
         _view("0 0 -5", "0 0 0", 30) + GLASS + "c 1 -2 0 1 1 2 0 1\n" + MATTE + WALL),
    Case("grazing_cone", "rays tangent to an open cone",
         _view("0 0 -5", "0 0 0", 30) + GLASS + "c 1 -2 0 1.5 1 2 0 0.5\n" + MATTE + WALL),
    Case("shared_edge_fan", "8 triangles fanned around a vertex: rays on the spokes and the vertex",
         _view("0 0 -5", "0 0 0", 45) + MATTE + FAN + WALL),
    Case("closed_mesh", "an octahedron seen vertex-on: rays along its edges and through its vertex",
         _view("0 0 -5", "0 0 0", 30) + MATTE + OCTAHEDRON + WALL),
    Case("tiny_triangle_far", "a 1e-3 triangle 1e4 from the origin",
         _view("0 0 0", "0 0 1", 0.00001, lights="l 0 1 0\n") + MATTE +
         "p 3\n-0.0005 -0.0005 10000\n0.0005 -0.0005 10000\n0 0.0005 10000\n", res=7),
    Case("ray_in_polygon_plane", "eye rays in a polygon's plane (edge-on)",
         _view("0 0 -5", "0 0 0", 40) + MATTE + "p 4\n-2 0 -2\n-2 0 2\n2 0 2\n2 0 -2\n" + WALL),
    Case("degenerate_polygons", "zero area, repeated and collinear vertices",
         _view("0 0 -5", "0 0 0", 50) + MATTE + "p 3\n-2 -2 0\n-1 -1 0\n0 0 0\n"
         "p 4\n0 0 0\n2 0 0\n2 0 0\n2 2 0\np 5\n-2 0 0\n-2 1 0\n-2 2 0\n-1 2 0\n-1 0 0\n"
         "p 3\n1 -1 0\n1 -1 0\n1 -1 0\n" + WALL),
    Case("axis_parallel", "axis-parallel eye rays and -0.0 direction components through voxel faces",
         _view("0 0 10", "-0 -0 0", 40, lights="l 0 0 10\n") + MATTE +  # at -0: -0.0 components
         "".join(f"s {x} {y} 0 0.5\n" for y in (-2, 0, 2) for x in (-2, 0, 2)) +
         "p 4\n-3 -3 -3\n3 -3 -3\n3 3 -3\n-3 3 -3\n"),
    Case("origin_on_grid_face", "eye exactly on a voxel boundary of the grid",
         _view("0 0 -3", "0 0 0", 60) + MATTE +
         "".join(f"s {x} {y} 1 0.4\n" for y in (-2, 0, 2) for x in (-2, 0, 2)) + WALL.replace("6", "4"),
         place_eye=_eye_on_grid_face),
    Case("spanning_object", "a long cylinder through many voxels, hit beyond the current one",
         _view("0 3 -8", "0 0 0", 50) + MATTE + "c -4 -1 -3 0.3 4 1 3 0.3\n" +
         "".join(f"s {x} {y} 2 0.2\n" for y in (-2, 0, 2) for x in (-3, -1, 1, 3)) + WALL),
    Case("self_intersection", "secondary rays leaving their own surface (shadow rays judged)", MIXED, res=16),
    Case("total_internal_reflection", "eye inside glass (index 1.5), incidence across the critical angle",
         _view("0 0.6666666666666666 0", "1 0.6666666666666666 0", 60, up="0 0 1", lights="l 0 0 5\n") +
         GLASS + "s 0 0 0 1\n", res=9, sets=("render.max_depth=2",), shadows=False, tir=True),
    *[Case(f"translated_{t:.0e}".replace("+0", ""), f"the mixed scene moved by {t:g} on every axis",
           MIXED, res=16, translate=t) for t in TRANSLATIONS],
    *[Case(f"contact_shadow_{t:.0e}".replace("+0", ""),
           f"a plate {CONTACT_GAPS[t] / float(np.spacing(np.float32(t))):g} fp32 ulps above a floor moved by "
           f"{t:g}: its low-angle shadow",
           contact_scene(CONTACT_GAPS[t]), res=16, translate=t) for t in CONTACT_GAPS],
    Case("fp32_vs_fp64_balls", "an ordinary scene: SPD balls, size 1", "", res=12, compare_fp64=True,
         shadows=False, spec="balls:1"),
    Case("fp32_vs_fp64_tetra", "an ordinary scene: SPD tetra, size 2", "", res=12, compare_fp64=True,
         shadows=False, spec="tetra:2"),
]
"""The catalog, one small scene per hard case."""


# ------------------------------------------------------------------------------------------------
# Paths


@dataclass
class PathResult:
    path: str
    hit_ids: np.ndarray  # (rows*cols,) int32
    image_u8: np.ndarray
    rays: dict[str, int]
    shadows: dict[str, np.ndarray] | None = None  # golden paths: shadow rays of eye hits


def run_path(scene: Scene, path: str, res: int, sets: tuple[str, ...] = ()) -> PathResult:
    """Render `scene` on a path: golden-fp32, golden-fp64 or emulator-<engine> (fp32)."""
    if path.startswith("golden-"):
        precision = path.split("-", 1)[1]
        config = load_config(None, [f"precision={precision}", *sets])
        r = golden_render(scene, config, res=res, keep_shadows=True)
        return PathResult(path, r.hit_ids.ravel(), r.image_u8, dict(r.rays), r.shadows)
    from netsushisen.pipeline import render  # noqa: PLC0415 (the machine side is heavy to import)
    engine = path.split("-", 1)[1]
    m = render(scene, load_config(None, list(sets)), res=res, engine=engine)
    if m.run.status != "finished":
        raise RuntimeError(f"the machine stopped: {m.run.status} {m.run.error or ''}".strip())
    return PathResult(path, m.hit_ids.ravel(), m.image_u8, dict(m.rays))


# ------------------------------------------------------------------------------------------------
# Judging


@dataclass
class Verdict:
    """One row of the catalog table: a case on a path."""

    case: str
    path: str
    rays: int = 0  # eye rays judged
    wrong_hits: int = 0  # eye rays whose hit the oracle does not allow
    shadow_rays: int = 0  # unambiguous shadow rays judged
    wrongly_blocked: int = 0
    wrongly_lit: int = 0
    notes: list[str] = field(default_factory=list)  # anything else that failed

    @property
    def stable(self) -> bool:
        return not (self.wrong_hits or self.wrongly_blocked or self.wrongly_lit or self.notes)

    def reason(self) -> str:
        parts = []
        if self.wrong_hits:
            parts.append(f"{self.wrong_hits} eye rays hit what the oracle does not allow")
        if self.wrongly_blocked:
            parts.append(f"{self.wrongly_blocked} shadow rays wrongly blocked")
        if self.wrongly_lit:
            parts.append(f"{self.wrongly_lit} shadow rays wrongly unblocked")
        return "; ".join(parts + self.notes)


def eye_oracle(scene: Scene, res: int, precision: str):
    """The oracle's eye-ray answers for the rays `precision` holds: (exact, allowed, t, o, d)."""
    pr = primary_rays(scene.camera, res, False, precision)
    n = pr.direction.shape[1]
    o = np.repeat(pr.origin.astype(np.float64)[None], n, axis=0)
    d = pr.direction.T.astype(np.float64)
    osc = OracleScene.of(scene, precision)
    exact, allowed, t = allowed_hits(osc, o, d, precision)
    return osc, exact, allowed, t, o, d / rownorm(d)[:, None]


def judge(scene: Scene, result: PathResult, res: int, precision: str, shadows: bool = True,
          verdict: Verdict | None = None) -> Verdict:
    """Hits against the oracle; with `shadows`, the eye hits' shadow rays (golden paths), each
    from the path's own hit point against the offset's bound (`oracle.contact_truth`)."""
    v = verdict or Verdict(scene.name, result.path)
    osc, exact, allowed, t, o, d = eye_oracle(scene, res, precision)
    v.rays = len(exact)
    v.wrong_hits = int(judge_hits(result.hit_ids, allowed).sum())
    if shadows and result.shadows is not None and len(result.shadows["sample"]):
        sh = result.shadows  # judged from the path's own hit points (docs/golden.md)
        f64 = lambda a: np.asarray(a, np.float64)  # noqa: E731
        lights = f64(f64(scene.light_position).reshape(-1, 3).astype(sh["point"].dtype))  # as the path holds them
        blocked, amb = contact_truth(osc, f64(sh["point"].T), sh["prim"], f64(sh["normal"].T), f64(sh["t"]),
                                     lights[sh["light"]], precision)
        path_blocked = sh["blocked"]
        v.shadow_rays = int((~amb).sum())
        v.wrongly_blocked = int((path_blocked & ~blocked & ~amb).sum())
        v.wrongly_lit = int((~path_blocked & blocked & ~amb).sum())
    return v


def _snell_bounds(scene: Scene, result: PathResult, res: int, precision: str) -> tuple[int, int]:
    """How many depth-2 refraction rays the eye hits must spawn: (sure, sure + ambiguous), by
    Snell's law in float64 on the oracle's hit points (ambiguous: within 1e-3 of the critical
    angle's k = 0 in fp32, 1e-9 in fp64)."""
    osc, exact, _, t, o, d = eye_oracle(scene, res, precision)
    hit = np.flatnonzero(exact >= 0)
    sure = amb = 0
    for i in hit:
        prim = int(exact[i])
        if not osc.two_sided[prim]:
            continue
        c = osc.sph[osc.local[prim]]
        p = o[i] + t[i] * d[i]
        n = normalize(p - c[:3])  # explicit order: `@` and 1-D norms go through BLAS, whose
        cosi = -float(dot(d[i], n))  # kernels (FMA or not) vary with the CPU
        inside = cosi < 0
        ior = float(scene.materials.ior[scene.material[prim]])
        eta = ior if inside else 1 / ior
        k = 1 - eta * eta * (1 - cosi * cosi)
        if abs(k) <= (1e-3 if precision == "fp32" else 1e-9):
            amb += 1
        elif k >= 0:
            sure += 1
    return sure, sure + amb


def judge_case(case: Case, path: str, reference: PathResult | None = None,
               untranslated: PathResult | None = None) -> Verdict:
    """The whole verdict of one case on one path. `reference`: golden fp32's result (the machine
    must equal it); `untranslated`: the path's result on the untranslated scene (same `res`)."""
    scene = case.scene()
    precision = "fp64" if path == GOLDEN64 else "fp32"
    result = run_path(scene, path, case.res, case.sets)
    v = Verdict(case.name, path)
    judge(scene, result, case.res, precision, case.shadows, v)
    if reference is not None:
        if not np.array_equal(result.hit_ids, reference.hit_ids):
            v.notes.append(f"{int((result.hit_ids != reference.hit_ids).sum())} hit ids differ from golden fp32")
        if not np.array_equal(result.image_u8, reference.image_u8):
            v.notes.append("8-bit image differs from golden fp32")
        if result.rays != reference.rays:
            v.notes.append("ray counts differ from golden fp32")
    if untranslated is not None and not np.array_equal(result.hit_ids, untranslated.hit_ids):
        n = int((result.hit_ids != untranslated.hit_ids).sum())
        v.notes.append(f"{n} hit ids differ from the untranslated scene")
    if case.compare_fp64 and path == GOLDEN32:
        other = run_path(scene, GOLDEN64, case.res, case.sets)
        _, exact, allowed, *_ = eye_oracle(scene, case.res, "fp32")
        differ = result.hit_ids != other.hit_ids
        both = ~judge_hits(result.hit_ids, allowed) & ~judge_hits(other.hit_ids, allowed)
        if np.any(differ & ~both):
            n = int((differ & ~both).sum())
            v.notes.append(f"{n} pixels differ from fp64 where the oracle allows one answer")
    if case.tir:
        lo, hi = _snell_bounds(scene, result, case.res, precision)
        if not lo <= result.rays["refraction"] <= hi:
            v.notes.append(f"{result.rays['refraction']} refraction rays, Snell's law says {lo}..{hi}")
    return v


def run_catalog(paths: list[str], cases: list[Case] | None = None, res: int | None = None,
                progress: Callable[[Verdict], None] | None = None) -> list[Verdict]:
    """Every case on every path (the machine is compared with golden fp32, translated cases with
    their untranslated scene on the same path). `res` caps each case's resolution (the machine
    on the reference engine is slow); `progress` sees each verdict as it is made."""
    out = []
    for case in cases or CATALOG:
        for v in case_verdicts(case, paths, res):
            out.append(v)
            if progress:
                progress(v)
    return out


def case_verdicts(case: Case, paths: list[str], res: int | None = None) -> list[Verdict]:
    """One case on every path (one run of `run_catalog`; independent of the other cases)."""
    if res is not None and res < case.res:
        case = replace(case, res=res)
    ref = None
    base = {}
    if case.translate:  # the machine is compared with golden fp32's untranslated ids (it must
        # equal golden fp32 anyway): one machine render per case, not two
        plain = Case(case.name, case.what, case.nff, case.res, case.sets)
        golden_paths = {p if p.startswith("golden-") else GOLDEN32 for p in paths}
        runs = {p: run_path(plain.scene(), p, case.res, case.sets) for p in golden_paths}
        base = {p: runs[p if p.startswith("golden-") else GOLDEN32] for p in paths}
    if any(not p.startswith("golden-") for p in paths):
        ref = run_path(case.scene(), GOLDEN32, case.res, case.sets)
    return [judge_case(case, path, None if path.startswith("golden-") else ref, base.get(path))
            for path in paths]


# ------------------------------------------------------------------------------------------------
# A stability report for any scene

COLOUR_TOLERANCE = 1
"""8-bit levels a pixel may differ by between fp32 and fp64 when every ray behind it agrees: the
same colour computed in two precisions can round to neighbouring levels (floor(v·255 + 0.5)
near a half-level), never two apart — fp32's error over the few dozen operations of shading
(~1e-6 relative) is far below a level (1/255). A larger difference means a ray behind the pixel
(a shadow, reflection or refraction ray) took another answer."""
MAX_TRANSLATION_EXP = 7

def translate_scene(scene: Scene, by: float) -> Scene:
    """`scene` moved by (by, by, by) (float64; the precision rounds the moved coordinates), then
    written and read back through the NFF reader, so a moved scene passes the same checks (its
    diagnostics, not a crash deeper down) as one read from a file."""
    if by == 0:
        return scene
    from netsushisen.host.nff import format_nff, parse_nff

    cam = replace(scene.camera, eye=scene.camera.eye + by, at=scene.camera.at + by)
    pg, sp, cn = scene.polygons, scene.spheres, scene.cones
    moved = replace(scene, camera=cam, light_position=np.asarray(scene.light_position) + by,
                    polygons=replace(pg, vertices=pg.vertices + by),
                    spheres=replace(sp, center=sp.center + by),
                    cones=replace(cn, base=cn.base + by, apex=cn.apex + by))
    checked = parse_nff(format_nff(moved, exact=True), f"{scene.source or scene.name} moved by {by:g}")
    return replace(checked, name=scene.name, source=scene.source)


@dataclass
class ScenePair:
    """fp32 against fp64 on one scene, judged as the catalog judges: a difference the oracle
    explains (a ray within rounding of an edge, a vertex or a tie; a shadow ray within rounding
    of an occluder's edge, the surface or the light) may go either way; any other counts."""

    hit_differs: np.ndarray  # (rows, cols) bool: the eye ray hits another primitive
    colour_differs: np.ndarray  # (rows, cols) bool: same hit, colour apart by > COLOUR_TOLERANCE
    explained: np.ndarray  # (rows, cols) bool: the pixel's differing rays are within rounding
    shadow_rays: int  # shadow rays of eye hits present on both paths
    blocked_only_fp32: int  # of those: fp32 blocks, fp64 does not
    shadow_differs: int = 0  # of those: blocked in one precision only
    shadow_beyond: int = 0  # of those: not within rounding (the oracle is not ambiguous)
    max_levels: int = 0  # the largest 8-bit difference of a pixel with the same hit

    @property
    def pixels(self) -> int:
        return self.hit_differs.size

    @property
    def hit_beyond(self) -> np.ndarray:
        return self.hit_differs & ~self.explained

    @property
    def colour_beyond(self) -> np.ndarray:
        return self.colour_differs & ~self.explained

    def stable(self) -> bool:
        return not self.reasons()

    def reasons(self) -> list[str]:
        out = []
        if self.hit_beyond.any():
            n = int(self.hit_beyond.sum())
            out.append(f"{n} of {self.pixels} pixels hit another primitive in fp32 than in fp64, "
                       "not within rounding of an edge, vertex or tie")
        if self.shadow_beyond:
            out.append(f"{self.shadow_beyond} of {self.shadow_rays} shadow rays of eye hits blocked "
                       "in one precision only, not within rounding of an occluder, the surface or the light")
        if self.colour_beyond.any():
            n = int(self.colour_beyond.sum())
            out.append(f"{n} of {self.pixels} pixels differ in colour by more than {COLOUR_TOLERANCE} "
                       f"level (up to {self.max_levels}) with the same eye hit: secondary or shadow rays "
                       "took other answers")
        return out


def compare_precisions(scene: Scene, res: int, sets: tuple[str, ...] = ()) -> ScenePair:
    """Golden fp32 against golden fp64, judged by the oracle (`host/oracle.py`, in fp32: the
    scene and rays as fp32 holds them) on the rays that differ only, so its cost and memory grow
    with the differing pixels: eye hits that differ (allowed: each answer among the oracle's
    shifted rays' or passing within its tolerance of the exact hit point — an edge, a vertex, a
    tie), shadow rays of eye hits matched by
    (pixel, light) whose blocking differs (allowed: the oracle calls them ambiguous), and the
    8-bit colour of pixels with the same hit (beyond COLOUR_TOLERANCE counts unless one of the
    pixel's shadow rays is allowed to differ)."""
    a = run_path(scene, GOLDEN32, res, sets)
    b = run_path(scene, GOLDEN64, res, sets)
    shape = (int(np.sqrt(a.hit_ids.size)),) * 2
    hit = a.hit_ids != b.hit_ids
    levels = np.abs(a.image_u8.astype(np.int16) - b.image_u8.astype(np.int16)).max(axis=2).ravel()
    colour = (levels > COLOUR_TOLERANCE) & ~hit
    explained = np.zeros(hit.size, bool)
    n_l = max(len(scene.light_position), 1)
    key = lambda s: s["sample"] * n_l + s["light"]  # noqa: E731
    common, ia, ib = np.intersect1d(key(a.shadows), key(b.shadows), return_indices=True)
    only = a.shadows["blocked"][ia] & ~b.shadows["blocked"][ib]
    flips = np.flatnonzero(a.shadows["blocked"][ia] != b.shadows["blocked"][ib])
    flips = flips[~hit[a.shadows["sample"][ia[flips]]]]  # an eye hit that differs is judged above
    beyond = 0
    need = np.union1d(np.flatnonzero(hit), a.shadows["sample"][ia[flips]])
    if len(need):
        pr = primary_rays(scene.camera, res, False, "fp32")
        o = np.repeat(pr.origin.astype(np.float64)[None], len(need), axis=0)
        d = pr.direction.T.astype(np.float64)[need]
        d /= rownorm(d)[:, None]
        osc = OracleScene.of(scene, "fp32")
        exact, allowed, t = allowed_hits(osc, o, d, "fp32")
        tol = tolerance(osc, o, "fp32")
        ok = np.ones(len(need), bool)
        p = o + np.where(np.isfinite(t), t, 0.0)[:, None] * d  # the exact hit point
        for r in (a, b):
            ans = r.hit_ids[need]
            near = np.isfinite(t) & (distance_to(osc, p, ans) <= tol)  # an edge, vertex or tie
            ok &= ~judge_hits(ans, allowed) | near
        explained[need] = ok & hit[need]
        if len(flips):  # judged from fp32's own hit points against its offset's bound
            k = ia[flips]
            s = a.shadows["sample"][k]
            sh = a.shadows
            f64 = lambda x: np.asarray(x, np.float64)  # noqa: E731
            lights = f64(f64(scene.light_position).reshape(-1, 3).astype(sh["point"].dtype))
            _, amb = contact_truth(osc, f64(sh["point"][:, k].T), sh["prim"][k], f64(sh["normal"][:, k].T),
                                   f64(sh["t"][k]), lights[sh["light"][k]], "fp32")
            beyond = int((~amb).sum())
            explained[s[amb]] = True
    same = ~hit
    return ScenePair(hit.reshape(shape), colour.reshape(shape), explained.reshape(shape), len(common),
                     int(only.sum()), len(flips), beyond,
                     int(levels[same].max(initial=0)))


def difference_map(pair: ScenePair) -> np.ndarray:
    """RGB map: white where the hit differs beyond rounding, grey where it differs within
    rounding (an edge, vertex or tie), red where only the colour differs beyond the tolerance
    (dark red: explained by a shadow ray within rounding), black elsewhere."""
    img = np.zeros((*pair.hit_differs.shape, 3), np.uint8)
    img[pair.colour_differs] = (128, 0, 0)
    img[pair.colour_beyond] = (255, 0, 0)
    img[pair.hit_differs] = (128, 128, 128)
    img[pair.hit_beyond] = (255, 255, 255)
    return img


@dataclass
class SceneReport:
    scene: str
    res: int
    pair: ScenePair | None = None  # None until fp32 and fp64 are compared
    translations: list[tuple[float, bool, list[str]]] = field(default_factory=list)  # (by, stable, reasons)

    @property
    def largest_stable_translation(self) -> float | None:
        """The largest power of ten the scene survives with every smaller one (None: not even 1)."""
        best = None
        for by, ok, _ in self.translations:
            if not ok:
                break
            best = by
        return best

    def stable(self) -> bool:
        return bool(self.pair.stable())

    def reasons(self) -> list[str]:
        return self.pair.reasons()


def scene_report(scene: Scene, res: int, sets: tuple[str, ...] = (),
                 progress: Callable[[str], None] | None = None, report: SceneReport | None = None) -> SceneReport:
    """fp32 against fp64, then the scene moved by 1, 10, 100, ... until fp32 breaks (against fp64
    at the same place, judged as `compare_precisions` judges) or 10^MAX_TRANSLATION_EXP. Fills `report` as it
    goes (an interrupted run keeps what was measured)."""
    rep = report if report is not None else SceneReport(scene.name, res)
    rep.pair = compare_precisions(scene, res, sets)
    for k in range(MAX_TRANSLATION_EXP + 1):
        by = 10.0 ** k
        if progress:
            progress(f"translated by {by:g}")
        try:
            p = compare_precisions(translate_scene(scene, by), res, sets)
        except NetsushisenError as e:  # the moved scene fails the reader's (or the scale) checks
            rep.translations.append((by, False, [f"the moved scene is refused: {e.diagnostics[0].message}"]))
            break
        rep.translations.append((by, p.stable(), p.reasons()))
        if not p.stable():
            break
    return rep


# ------------------------------------------------------------------------------------------------
# The same runs on the cluster layer (netsushisen/cluster.py): one task per case, one per
# translation; results in input order


def catalog_on_cluster(paths: list[str], res: int | None = None, scheduler: str | None = None,
                       workers: int | None = None, progress: Callable[[Verdict], None] | None = None,
                       cases: list[Case] | None = None) -> tuple[list[Verdict], bool]:
    """`run_catalog` with each case one task: (verdicts in catalog order, interrupted).
    `progress` sees each verdict in catalog order, as soon as every case before it is done."""
    from netsushisen.cluster import Task, run_tasks  # noqa: PLC0415
    cases = list(cases or CATALOG)
    got: dict[int, list[Verdict]] = {}
    shown = [0]

    def done(i: int, verdicts: list[Verdict]) -> None:
        got[i] = verdicts
        while shown[0] in got:
            for v in got[shown[0]]:
                if progress:
                    progress(v)
            shown[0] += 1

    outcome = run_tasks([Task(case_verdicts, (c, paths, res), f"case-{c.name}") for c in cases], done,
                        scheduler=scheduler, workers=workers, title="numerics")
    return [v for i in range(shown[0]) for v in got[i]], outcome.interrupted


def translation_check(scene: Scene, by: float, res: int, sets: tuple[str, ...] = ()
                      ) -> tuple[float, bool, list[str], ScenePair]:
    """fp32 against fp64 on `scene` moved by `by` (0: where it is): (by, stable, reasons, pair)."""
    try:
        p = compare_precisions(translate_scene(scene, by), res, sets)
    except NetsushisenError as e:  # the moved scene fails the reader's (or the scale) checks
        if by == 0:
            raise
        return by, False, [f"the moved scene is refused: {e.diagnostics[0].message}"], None
    return by, p.stable(), p.reasons(), p


def scene_report_on_cluster(scene: Scene, res: int, sets: tuple[str, ...] = (),
                            scheduler: str | None = None, workers: int | None = None,
                            report: SceneReport | None = None) -> tuple[SceneReport, bool]:
    """`scene_report` with the comparison in place and every translation one task, all at once:
    the report keeps the translations up to the first that breaks, as `scene_report` does.
    (report, interrupted); an interrupted report keeps the translations measured in order."""
    from netsushisen.cluster import Task, run_tasks  # noqa: PLC0415
    rep = report if report is not None else SceneReport(scene.name, res)
    moves = [0.0] + [10.0 ** k for k in range(MAX_TRANSLATION_EXP + 1)]
    got: dict[int, tuple] = {}
    outcome = run_tasks([Task(translation_check, (scene, by, res, sets), f"translate-{by:g}") for by in moves],
                        lambda i, r: got.__setitem__(i, r), scheduler=scheduler, workers=workers,
                        title="numerics")
    if 0 in got:
        rep.pair = got[0][3]
    for i in range(1, len(moves)):
        if i not in got:
            break
        by, ok, reasons, _ = got[i]
        rep.translations.append((by, ok, reasons))
        if not ok:
            break
    return rep, outcome.interrupted
