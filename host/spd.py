"""SPD generators (Eric Haines's Standard Procedural Databases) ported to Python: the four scenes of
the Netsushisen paper's Table 1 — tetra, balls, mount, rings — and the `GENERATORS` registry
(which also lists shells, tree and lattice from `spd_extra`).

Each generator returns a `Scene` built through the same `SceneBuilder` as the NFF reader, emitting
records in the C program's order, so `format_nff(generate(name))` is the NFF text the C generator
writes with `-c` (true curved surfaces) and NFF output. The arithmetic follows the C sources
operation for operation (see `spd_lib`), which is what makes the shared files reproducible to the
last printed digit rather than merely close.

Sources: erich666/StandardProceduralDatabases, SPD 3.14 plus the 2021 balls.c change (commit
5c860e209aec43392e44a2defb272b287a6e85a5): `tetra.c`, `balls.c`, `mount.c`, `rings.c`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from netsushisen.isa.errors import SceneError
from netsushisen.host.nff_builder import SceneBuilder
from netsushisen.host.scenes import Scene
from netsushisen.host.spd_extra import lattice, shells, tree
from netsushisen.host.spd_lib import (
    BACKGROUND_UNC_SKY_BLUE, PI, X_AXIS, Y_AXIS, Z_AXIS, axis_rotate_matrix, cross, dot,
    gauss_rand, identity_matrix, normalize, output_background, output_color, output_cylcone,
    output_light, output_polygon, output_sphere, output_viewpoint, rotate_matrix,
    transform_coord, transform_point, transform_vector,
)


@dataclass(frozen=True)
class Generator:
    """A built-in scene: its C default size factor and the sizes this port accepts."""

    name: str
    function: Callable[[int], Scene]
    default_size: int
    max_size: int
    summary: str


# -- tetra.c ---------------------------------------------------------------------------------------

def tetra(size: int = 6) -> Scene:
    """Sierpinski tetrahedron of 4**size triangles; one light (Glassner / Kay-Kajiya view)."""
    b = SceneBuilder()
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    output_viewpoint(b, (1.022846, -3.177154, -2.174512), (-0.004103, -0.004103, 0.216539),
                     (-0.816497, -0.816497, 0.816497), 45.0, 1.0, 1.0, 512, 512)
    output_light(b, (2.0, -18.0, -5.0, 1.0))
    output_color(b, (1.0, 0.2, 0.2), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    _create_tetra(b, size, (0.0, 0.0, 0.0, 1.0))
    return b.build("tetra", source=f"spd:tetra(size={size})")


def _create_tetra(b: SceneBuilder, depth: int, center: tuple[float, ...]) -> None:
    dirs = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1) if x * y * z == 1]
    cx, cy, cz, cw = center
    if depth <= 1:
        pts = [(cx + float(x) * cw, cy + float(y) * cw, cz + float(z) * cw) for x, y, z in dirs]
        for face in range(4):
            order = [(face + v) % 4 for v in range(3)]
            if face % 2 == 1:
                order[0], order[2] = order[2], order[0]
            output_polygon(b, [pts[i] for i in order])
    else:
        for x, y, z in dirs:
            _create_tetra(b, depth - 1, (cx + float(x) * cw / 2.0, cy + float(y) * cw / 2.0,
                                         cz + float(z) * cw / 2.0, cw / 2.0))


# -- balls.c ---------------------------------------------------------------------------------------

def balls(size: int = 4) -> Scene:
    """Sphereflake: each sphere sprouts 9 spheres of 1/3 its radius, `size` levels deep, over a
    floor square; three lights. Includes the 2021 tolerance for directions near +-Z."""
    b = SceneBuilder()
    radius = 1.0
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    output_viewpoint(b, (2.1, 1.3, 1.7), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
                     45.0, 1.0, 0.01, 512, 512)
    for light in ((4.0, 3.0, 2.0), (1.0, -4.0, 4.0), (-3.0, 1.0, 5.0)):
        output_light(b, (*light, 1.0))
    output_color(b, (1.0, 0.75, 0.33), 0.2, 0.8, 0.0, 0.0, 0.0, 0.0, 1.0)
    bx, by, bz = 12.0 * radius, 12.0 * radius, -radius / 2.0
    output_polygon(b, [(bx, by, bz), (-bx, by, bz), (-bx, -by, bz), (bx, -by, bz)])
    output_color(b, (1.0, 0.9, 0.7), 0.0, 0.5, 0.5, 0.5, 37.0, 0.0, 1.0)
    objset = _balls_objset()
    _balls_object(b, objset, size, [0.0, 0.0, 0.0, radius / 2.0], [0.0, 0.0, 1.0, 1.0 / 3.0])
    return b.build("balls", source=f"spd:balls(size={size})")


def _balls_objset() -> list[list[float]]:
    """create_objset: the 9 unit directions (3 trios) along which child spheres grow."""
    dist = 1.0 / math.sqrt(2.0)
    trio = [[dist, dist, 0.0, 0.0], [dist, 0.0, -dist, 0.0], [0.0, dist, -dist, 0.0]]
    axis = normalize([1.0, -1.0, 0.0])
    mx = axis_rotate_matrix(axis, math.asin(2.0 / math.sqrt(6.0)))
    trio = [transform_coord(t, mx) for t in trio]
    objset = []
    for num_set in range(3):
        mx = rotate_matrix(Z_AXIS, num_set * 2.0 * PI / 3.0)
        objset += [transform_coord(t, mx) for t in trio]
    return objset


def _balls_object(b: SceneBuilder, objset: list[list[float]], depth: int,
                  center: list[float], direction: list[float]) -> None:
    output_sphere(b, center)
    if depth <= 0:
        return
    depth -= 1
    if direction[2] >= 0.9999:  # 2021: (almost) +Z, no rotation needed
        mx = identity_matrix()
    elif direction[2] <= -0.9999:  # 2021: (almost) -Z, rotate 180 degrees
        mx = rotate_matrix(Y_AXIS, PI)
    else:
        z_axis = [0.0, 0.0, 1.0]
        axis = normalize(cross(z_axis, direction))
        mx = axis_rotate_matrix(axis, math.acos(dot(z_axis, direction)))
    scale = center[3] * (1.0 + direction[3])
    for k in range(9):
        child = transform_coord(objset[k], mx)
        child[0] = child[0] * scale + center[0]
        child[1] = child[1] * scale + center[1]
        child[2] = child[2] * scale + center[2]
        child[3] = center[3] * direction[3]
        child_dir = [(child[0] - center[0]) / scale, (child[1] - center[1]) / scale,
                     (child[2] - center[2]) / scale, direction[3]]
        _balls_object(b, objset, depth, child, child_dir)


# -- mount.c ---------------------------------------------------------------------------------------

_FRACTAL_DIMENSION = 2.2
_MOUNTAIN_NO = 21
_X_CORNER, _Y_CORNER, _WIDTH = -1.0, -1.0, 2.0
_ULONG = (1 << 64) - 1


def hash_rand(a: int, b: int, c: int) -> int:
    """mount.c's original (non-JENKINS) hash: `((A<<(23-C)) + (B<<(15-C)) + (A<<(7-C))) & 0xffff`
    in 64-bit unsigned long. Defined in C only for C <= 7 (no negative shift counts)."""
    return (((a << (23 - c)) + (b << (15 - c)) + (a << (7 - c))) & _ULONG) & 0xFFFF


def mount(size: int = 6) -> Scene:
    """Fractal mountain (Carpenter's midpoint method, 2 * 4**size triangles) with four glass
    spheres in front; one light. Uses the original, 'faulty' hash as the SPD asks."""
    b = SceneBuilder()
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    output_viewpoint(b, (-1.6, 1.6, 1.7), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
                     45.0, 1.0, 0.01, 512, 512)
    output_light(b, (-100.0, -100.0, 100.0, 1.0))
    output_color(b, (1.0, 1.0, 1.0), 0.0, 0.1, 0.1, 0.4, 6.7, 0.9, 1.5)
    _mount_spheres(b, [-0.8, 0.8, 1.00, 0.17])
    output_color(b, (0.5, 0.45, 0.35), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    num_pts = 1 << size
    ratio = 2.0 / math.exp(math.log(2.0) / (_FRACTAL_DIMENSION - 1.0))
    roughness = math.sqrt(ratio * ratio - 1.0)
    _Mountain(b, size, roughness).grow(float(num_pts), num_pts, 0, 0, 0.0, 0.0, 0.0, 0.0)
    return b.build("mount", source=f"spd:mount(size={size})")


def _mount_spheres(b: SceneBuilder, center: list[float]) -> None:
    """create_spheres: a pyramid of four crystal spheres."""
    axis = normalize([1.0, 1.0, 0.0])
    angle = math.acos(-1.0 / 3.0)
    pt = [0.0, 0.0, center[3] * math.sqrt(3.0 / 2.0)]
    output_sphere(b, [center[0] + pt[0], center[1] + pt[1], center[2] + pt[2], center[3]])
    new_pt = transform_vector(pt, axis_rotate_matrix(axis, angle))
    for i in range(3):
        s = transform_vector(new_pt, rotate_matrix(Z_AXIS, float(i) * 2.0 * PI / 3.0))
        output_sphere(b, [s[0] + center[0], s[1] + center[1], s[2] + center[2], center[3]])


class _Mountain:
    def __init__(self, b: SceneBuilder, size: int, roughness: float):
        self.b, self.size, self.roughness = b, size, roughness
        self._gauss: dict[int, float] = {}

    def rand(self, a: int, bb: int) -> float:
        iz = _MOUNTAIN_NO + hash_rand(a, bb, self.size)
        value = self._gauss.get(iz)
        if value is None:
            value = self._gauss[iz] = gauss_rand(iz)
        return value

    def grow(self, fnum_pts: float, width: int, ll_x: int, ll_y: int,
             ll_fz: float, lr_fz: float, ur_fz: float, ul_fz: float) -> None:
        """grow_mountain: split the square into four until width 1, then emit two triangles."""
        if width == 1:
            l_fx = _X_CORNER + float(ll_x) * _WIDTH / fnum_pts
            r_fx = _X_CORNER + float(ll_x + 1) * _WIDTH / fnum_pts
            l_fy = _Y_CORNER + float(ll_y) * _WIDTH / fnum_pts
            u_fy = _Y_CORNER + float(ll_y + 1) * _WIDTH / fnum_pts
            corners = ((l_fx, l_fy, ll_fz), (r_fx, l_fy, lr_fz), (r_fx, u_fy, ur_fz),
                       (l_fx, u_fy, ul_fz))
            self.b.add_polygon([*corners[0], *corners[1], *corners[2]])
            self.b.add_polygon([*corners[2], *corners[3], *corners[0]])
            return
        half = width >> 1
        hside_length = float(half) * _WIDTH / fnum_pts
        rise = hside_length * self.roughness
        lower = (ll_fz + lr_fz) / 2.0 + rise * self.rand(ll_x + half, ll_y)
        right = (lr_fz + ur_fz) / 2.0 + rise * self.rand(ll_x + width, ll_y + half)
        upper = (ur_fz + ul_fz) / 2.0 + rise * self.rand(ll_x + half, ll_y + width)
        left = (ul_fz + ll_fz) / 2.0 + rise * self.rand(ll_x, ll_y + half)
        middle = (ll_fz + lr_fz + ur_fz + ul_fz) / 4.0 + \
            1.4142136 * rise * self.rand(ll_x + half, ll_y + half)
        self.grow(fnum_pts, half, ll_x, ll_y, ll_fz, lower, middle, left)
        self.grow(fnum_pts, half, ll_x + half, ll_y, lower, lr_fz, right, middle)
        self.grow(fnum_pts, half, ll_x + half, ll_y + half, middle, right, ur_fz, upper)
        self.grow(fnum_pts, half, ll_x, ll_y + half, left, middle, upper, ul_fz)


# -- rings.c ---------------------------------------------------------------------------------------

def rings(size: int = 7) -> Scene:
    """A pyramid of 1 + 4 + ... + size**2 objects, each 6 pentagonal rings (5 spheres + 5
    cylinders) on the edge midpoints of a dodecahedron, before a white wall; three lights."""
    b = SceneBuilder()
    radius = 0.07412
    spread = 1 / math.sin(PI / 8.0)
    spread_out = 1  # SPREAD_OUT, an int in C
    if spread_out <= spread:
        y_diff, xz_diff = spread / spread_out, 1.0
    else:
        y_diff, xz_diff = 1.0, spread_out / spread
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    frm = (-1.0, -spread, 0.5)
    output_viewpoint(b, frm, (frm[0], frm[1] + 1.0, frm[2]), (0.0, 0.0, 1.0),
                     45.0, 1.0, 1.0, 512, 512)
    for light in ((3.0, -spread, 3.0), (-4.0, -spread, 1.0), (2.0, -spread, -4.0)):
        output_light(b, (*light, 1.0))
    output_color(b, (1.0, 1.0, 1.0), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    wy = y_diff * float(size + 1)
    wx = wz = 1.01 * (wy - frm[1]) * math.tan(PI / 8.0)
    output_polygon(b, [(wx + frm[0], wy, wz + frm[2]), (-wx + frm[0], wy, wz + frm[2]),
                       (-wx + frm[0], wy, -wz + frm[2]), (wx + frm[0], wy, -wz + frm[2])])
    ring_color = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0),
                  (0.0, 1.0, 1.0), (1.0, 0.0, 1.0), (1.0, 1.0, 0.0))
    dodec = _create_dodec(radius)
    for depth in range(size):
        oy = y_diff * float(depth + 1)
        for objz in range(depth + 1):
            oz = xz_diff * float(2 * objz - depth)
            for objx in range(depth + 1):
                ox = xz_diff * float(2 * objx - depth)
                for elem in range(30):
                    d = dodec[elem]
                    base = (d[0] + ox, d[1] + oy, d[2] + oz, radius)
                    if elem % 5 == 0:
                        prev = elem + 4
                        output_color(b, ring_color[elem // 5], 0.0, 0.5, 0.2, 0.3, 37.0,
                                     0.0, 0.0)
                    else:
                        prev = elem - 1
                    a = dodec[prev]
                    output_cylcone(b, base, (a[0] + ox, a[1] + oy, a[2] + oz, radius))
                    output_sphere(b, base)
    return b.build("rings", source=f"spd:rings(size={size})")


def _create_dodec(minor_radius: float) -> list[list[float]]:
    """create_dodec: 30 points, 6 pentagons of 5, scaled to fit a unit sphere with the tubes."""
    scale = 1.0 / (1.0 + minor_radius)
    vertex = [[scale * math.cos(float(i) * 2.0 * PI / 5.0),
               scale * math.sin(float(i) * 2.0 * PI / 5.0), 0.0] for i in range(5)]
    x_rotation = 2.0 * math.acos(math.cos(PI / 3.0) / math.sin(PI / 5.0))
    x_matrix = rotate_matrix(X_AXIS, x_rotation)
    for pentagon in range(1, 6):
        z_rotation = PI * (2.0 * float(pentagon - 1) + 1.0) / 5.0
        z_matrix = rotate_matrix(Z_AXIS, z_rotation)
        for i in range(5):
            vertex.append(transform_point(transform_point(vertex[i], x_matrix), z_matrix))
    return vertex


# -- registry --------------------------------------------------------------------------------------

GENERATORS: dict[str, Generator] = {
    g.name: g for g in (
        Generator("tetra", tetra, 6, 10, "Sierpinski tetrahedron, 4**SF triangles"),
        Generator("balls", balls, 4, 6, "sphereflake, sum(9**k) spheres + floor"),
        Generator("mount", mount, 6, 7, "fractal mountain, 2*4**SF triangles + 4 spheres"),
        Generator("rings", rings, 7, 30, "pyramid of dodecahedral ring objects + wall"),
        # not in the paper's Table 1; shared/spd holds their files at these default sizes
        Generator("shells", shells, 5, 12, "Pickover sea shell, 180*2**SF+1 spheres"),
        Generator("tree", tree, 11, 16, "Aono-Kunii tree, 2**(SF+1)-1 cones + spheres"),
        Generator("lattice", lattice, 12, 40, "cubic lattice of spheres and cylinders"),
    )
}
PAPER_SCENES: tuple[str, ...] = ("tetra", "balls", "mount", "rings")  # Table 1 of the paper


def generate(name: str, size: int | None = None) -> Scene:
    """Run the built-in generator `name` at size factor `size` (its SPD default if None)."""
    gen = GENERATORS.get(name)
    if gen is None:
        raise SceneError(f"unknown SPD generator '{name}' (built-in: {', '.join(GENERATORS)})")
    if size is None:
        size = gen.default_size
    if not 1 <= size <= gen.max_size:
        why = " (the original hash shifts by 7-SF bits)" if name == "mount" else ""
        raise SceneError(f"size factor for '{name}' must be between 1 and {gen.max_size}"
                         f"{why}, got {size}")
    return gen.function(size)
