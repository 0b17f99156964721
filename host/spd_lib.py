"""The parts of Eric Haines's SPD library (`libvec.c`, `libpr1.c`, `libpr2.c`) the generators use,
ported to Python so that the generators reproduce the published `.nff` files.

Why scalar Python and not numpy: the shared files were printed with `%g` from C doubles, so the
generators must repeat the C arithmetic operation for operation — same association order, same
signed zeros (`-0.0 + 0.0` is `+0.0`, which `%g` prints as `0`, not `-0`), no fused multiply-adds
and no reordered sums (numpy's matmul may do either). Python floats are C doubles and `math` calls
the platform libm, so each expression below is written exactly as the C one, term by term.

Matrices are 4x4 nested lists in the SPD's row-vector convention (`v' = v * M`).
Source: erich666/StandardProceduralDatabases (SPD 3.14, CC0), files named in each docstring.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from netsushisen.host.nff_builder import SceneBuilder

PI = 3.141592653589793  # def.h
X_AXIS, Y_AXIS, Z_AXIS = 0, 1, 2  # libvec.h

Matrix = list[list[float]]


# -- libvec.c --------------------------------------------------------------------------------------

def normalize(v: Sequence[float]) -> list[float]:
    """lib_normalize_vector: divide by the length unless it is zero (returns a new list)."""
    divisor = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    out = list(v)
    if divisor > 0.0:
        out[0] = v[0] / divisor
        out[1] = v[1] / divisor
        out[2] = v[2] / divisor
    return out


def cross(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """def.h CROSS(r, a, b)."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a: Sequence[float], b: Sequence[float]) -> float:
    """def.h DOT_PRODUCT."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def zero_matrix() -> Matrix:
    return [[0.0] * 4 for _ in range(4)]


def identity_matrix() -> Matrix:
    mx = zero_matrix()
    for i in range(4):
        mx[i][i] = 1.0
    return mx


def rotate_matrix(axis: int, angle: float) -> Matrix:
    """lib_create_rotate_matrix: rotation about a coordinate axis, angle in radians."""
    mx = zero_matrix()
    cosine, sine = math.cos(angle), math.sin(angle)
    if axis == X_AXIS:
        mx[0][0] = 1.0
        mx[1][1] = cosine
        mx[2][2] = cosine
        mx[1][2] = sine
        mx[2][1] = -sine
    elif axis == Y_AXIS:
        mx[1][1] = 1.0
        mx[0][0] = cosine
        mx[2][2] = cosine
        mx[2][0] = sine
        mx[0][2] = -sine
    else:
        mx[2][2] = 1.0
        mx[0][0] = cosine
        mx[1][1] = cosine
        mx[0][1] = sine
        mx[1][0] = -sine
    mx[3][3] = 1.0
    return mx


def axis_rotate_matrix(axis: Sequence[float], angle: float) -> Matrix:
    """lib_create_axis_rotate_matrix: rotation about a unit axis (direction cosines)."""
    cosine, sine = math.cos(angle), math.sin(angle)
    omc = 1.0 - cosine
    x, y, z = axis[0], axis[1], axis[2]
    return [
        [x * x + (1.0 - x * x) * cosine, x * y * omc + z * sine, x * z * omc - y * sine, 0.0],
        [x * y * omc - z * sine, y * y + (1.0 - y * y) * cosine, y * z * omc + x * sine, 0.0],
        [x * z * omc + y * sine, y * z * omc - x * sine, z * z + (1.0 - z * z) * cosine, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]


def transform_vector(v: Sequence[float], mx: Matrix) -> list[float]:
    """lib_transform_vector: 3-vector times the upper 3x3."""
    return [v[0] * mx[0][0] + v[1] * mx[1][0] + v[2] * mx[2][0],
            v[0] * mx[0][1] + v[1] * mx[1][1] + v[2] * mx[2][1],
            v[0] * mx[0][2] + v[1] * mx[1][2] + v[2] * mx[2][2]]


def transform_point(v: Sequence[float], mx: Matrix) -> list[float]:
    """lib_transform_point: 3-point times the matrix, with the translation row."""
    return [v[0] * mx[0][0] + v[1] * mx[1][0] + v[2] * mx[2][0] + mx[3][0],
            v[0] * mx[0][1] + v[1] * mx[1][1] + v[2] * mx[2][1] + mx[3][1],
            v[0] * mx[0][2] + v[1] * mx[1][2] + v[2] * mx[2][2] + mx[3][2]]


def transform_coord(v: Sequence[float], mx: Matrix) -> list[float]:
    """lib_transform_coord: homogeneous 4-vector times the matrix (all four terms, in order)."""
    return [v[0] * mx[0][j] + v[1] * mx[1][j] + v[2] * mx[2][j] + v[3] * mx[3][j]
            for j in range(4)]


# Numerical Recipes GASDEV constants of libvec.c. RM1 is the macro `1.0/M1` without parentheses,
# so `ix1 * 2.0 * RM1` expands to `ix1 * 2.0 * 1.0 / M1`: kept literally below.
_M1, _IA1, _IC1 = 134456, 8121, 28411


def gauss_rand(iseed: int) -> float:
    """lib_gauss_rand: a deterministic gaussian deviate from an integer seed (polar method)."""
    ix2 = iseed
    while True:
        ix1 = (_IC1 + ix2 * _IA1) % _M1
        ix2 = (_IC1 + ix1 * _IA1) % _M1
        v1 = ix1 * 2.0 * 1.0 / _M1 - 1.0
        v2 = ix2 * 2.0 * 1.0 / _M1 - 1.0
        r = v1 * v1 + v2 * v2
        if r < 1.0:
            break
    fac = math.sqrt(-2.0 * math.log(r) / r)
    return v1 * fac


# -- libpr1.c / libpr2.c: output routines, NFF branch, writing into a SceneBuilder -----------------

def phong_pow(ang: float) -> float:
    """lib_output_color's Phong exponent from the highlight half-angle `ang` in degrees."""
    ang_radians = PI * ang / 180.0
    if ang_radians <= 0.0:
        return 100000.0
    if ang_radians >= PI / 2.0:
        return 1.0
    return math.log(0.5) / math.log(math.cos(ang_radians))


def output_background(b: SceneBuilder, color: Sequence[float]) -> None:
    b.set_background(color[0], color[1], color[2])


def output_viewpoint(b: SceneBuilder, frm: Sequence[float], at: Sequence[float],
                     up: Sequence[float], fov: float, aspect: float, hither: float,
                     resx: int, resy: int) -> None:
    """lib_output_viewpoint: NFF has no aspect ratio (it is 1 for every SPD scene)."""
    b.set_camera(frm, at, up, fov, hither, (resx, resy))


def output_light(b: SceneBuilder, center: Sequence[float]) -> None:
    """lib_output_light: NFF gets the position only (W is an intensity other formats use)."""
    b.add_light(center[0], center[1], center[2])


def output_color(b: SceneBuilder, color: Sequence[float], ka: float, kd: float, ks: float,
                 ks_spec: float, ang: float, kt: float, ior: float) -> None:
    """lib_output_color: NFF keeps `R G B Kd Ks phong_pow(ang) T ior` (not ka, not ks_spec)."""
    b.set_material(color[0], color[1], color[2], kd, ks, phong_pow(ang), kt, ior)


def output_polygon(b: SceneBuilder, verts: Sequence[Sequence[float]]) -> None:
    flat: list[float] = []
    for v in verts:
        flat += (v[0], v[1], v[2])
    b.add_polygon(flat)


def output_sphere(b: SceneBuilder, center: Sequence[float]) -> None:
    """lib_output_sphere with OUTPUT_CURVES: centre x y z, radius in W."""
    b.add_sphere(center[0], center[1], center[2], center[3])


def output_cylcone(b: SceneBuilder, base: Sequence[float], apex: Sequence[float]) -> None:
    """lib_output_cylcone with OUTPUT_CURVES: radii in W."""
    b.add_cone(base[0], base[1], base[2], base[3], apex[0], apex[1], apex[2], apex[3])


BACKGROUND_UNC_SKY_BLUE = (0.078, 0.361, 0.753)  # the common SPD background
