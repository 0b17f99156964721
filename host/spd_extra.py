"""More SPD generators beyond the paper's four: shells, tree, lattice.

Same rules as `host.spd`: the C arithmetic is repeated operation for operation (see `spd_lib`) so
that the output matches the published `.nff` files, and records come out in the C program's order.
Sources: erich666/StandardProceduralDatabases SPD 3.14, `src/shells.c`, `src/tree.c`,
`src/lattice.c`.
"""

from __future__ import annotations

import math

from netsushisen.host.nff_builder import SceneBuilder
from netsushisen.host.scenes import Scene
from netsushisen.host.spd_lib import (
    BACKGROUND_UNC_SKY_BLUE, PI, X_AXIS, Z_AXIS, Matrix, identity_matrix, output_background,
    output_color, output_cylcone, output_light, output_polygon, output_sphere, output_viewpoint,
    rotate_matrix, transform_point,
)


def _c_div(a: int, b: int) -> int:
    """C integer division (truncates toward zero; Python's // floors)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def matrix_multiply(m1: Matrix, m2: Matrix) -> Matrix:
    """lib_matrix_multiply: four products summed left to right."""
    return [[m1[i][0] * m2[0][j] + m1[i][1] * m2[1][j] + m1[i][2] * m2[2][j] + m1[i][3] * m2[3][j]
             for j in range(4)] for i in range(4)]


# -- shells.c --------------------------------------------------------------------------------------

def shells(size: int = 5) -> Scene:
    """Pickover's sea shell: a logarithmic spiral of 180 * 2**size (+1) overlapping spheres."""
    fgamma, alpha, beta, a, k = 1.0, 0.0, -2.0, 0.15, 1.0  # the C defaults
    b = SceneBuilder()
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    output_viewpoint(b, (-6.0, -60.0, 35.0), (0.0, 8.0, -15.0), (0.0, 0.0, 1.0),
                     45.0, 1.0, 0.5, 512, 512)
    output_light(b, (-100.0, -100.0, 100.0, 1.0))
    output_color(b, (1.0, 0.8, 0.4), 0.0, 0.8, 0.2, 0.5, 10.0, 0.0, 1.0)
    steps = int(180.0 * math.pow(2.0, float(size)))
    for i in range(_c_div(-steps * 2, 3), _c_div(steps, 3) + 1):
        angle = 3.0 * 6.0 * PI * float(i) / float(steps)
        r = k * math.exp(a * angle)
        z = alpha * angle if alpha > 0.0 else beta * r
        output_sphere(b, (r * math.sin(angle), r * math.cos(angle), z, r / fgamma))
    return b.build("shells", source=f"spd:shells(size={size})")


# -- tree.c ----------------------------------------------------------------------------------------

_BR_ANGLE = (40.0, 25.0)
_BR_CONTR = (0.65, 0.70)
_BR_DIAMETER = 0.67
_DIV_ANGLE = 140.0
_WIDTH_HEIGHT_RATIO = 0.15


def tree(size: int = 11) -> Scene:
    """Aono & Kunii's binary tree: 2**(size+1)-1 cone branches, each capped by a sphere, on a
    green field; seven lights."""
    b = SceneBuilder()
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    output_viewpoint(b, (4.5, 0.4, 2.0), (0.0, 0.0, 1.5), (0.0, 0.0, 1.0),
                     45.0, 1.0, 1.0, 512, 512)
    for light in ((-5.0, 5.0, 50.0), (30.0, -30.0, 30.0), (-40.0, -30.0, 20.0),
                  (10.0, 30.0, 40.0), (-30.0, 40.0, 10.0), (50.0, 25.0, 20.0),
                  (-10.0, -60.0, 30.0)):
        output_light(b, (*light, 1.0))
    output_color(b, (0.2, 0.7, 0.2), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    output_polygon(b, [(50.0, 50.0, 0.0), (-50.0, 50.0, 0.0), (-50.0, -50.0, 0.0),
                       (50.0, -50.0, 0.0)])
    output_color(b, (0.55, 0.4, 0.2), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    rst = []
    for i in range(2):
        divergence = 90.0 if i == 0 else _DIV_ANGLE + 90.0
        tempr = matrix_multiply(rotate_matrix(X_AXIS, _BR_ANGLE[i] * PI / 180.0),
                                rotate_matrix(Z_AXIS, divergence * PI / 180.0))
        tempst = identity_matrix()
        tempst[0][0] = tempst[1][1] = tempst[2][2] = _BR_CONTR[i]
        tempst[3][2] = 1.0
        rst.append(matrix_multiply(tempr, tempst))
    _grow_tree(b, rst, identity_matrix(), 1.0, size)
    return b.build("tree", source=f"spd:tree(size={size})")


def _grow_tree(b: SceneBuilder, rst: list[Matrix], cur: Matrix, scale: float,
               depth: int) -> None:
    base = transform_point((0.0, 0.0, 0.0), cur)
    base_w = scale * _WIDTH_HEIGHT_RATIO
    apex = transform_point((0.0, 0.0, 1.0), cur)
    apex_w = base_w * _BR_DIAMETER
    output_cylcone(b, (*base, base_w), (*apex, apex_w))
    output_sphere(b, (*apex, apex_w))
    if depth > 0:
        for i in range(2):
            _grow_tree(b, rst, matrix_multiply(rst[i], cur), scale * _BR_DIAMETER, depth - 1)


# -- lattice.c -------------------------------------------------------------------------------------

def lattice(size: int = 12) -> Scene:
    """A cubic lattice of (size+1)**3 shiny spheres joined by 3*size*(size+1)**2 matte
    cylinders; six lights. Every primitive has its own `f` record in the C output."""
    radius1 = (1.0 / 4.0) / float(size)
    radius2 = (1.0 / 16.0) / float(size)
    inv_factor = 1.0 / float(size)
    delta = (radius1 * (1.0 - math.sqrt((1.0 / 16.0) / (1.0 / 4.0)))) * 0.99
    b = SceneBuilder()
    output_background(b, BACKGROUND_UNC_SKY_BLUE)
    mid = (float(size >> 1) + 0.5) * inv_factor
    output_viewpoint(b, (mid, 1.0, 1.0 - 1.0 / float(size << 1)),
                     (mid, -1.0, -1.0 - 1.0 / float(size << 1)), (0.2, 1.0, 0.0),
                     60.0, 1.0, 0.0, 512, 512)
    for light in ((2.0, 0.5, 0.5), (-1.0, 0.5, 0.5), (0.5, 2.0, 0.5), (0.5, -1.0, 0.5),
                  (0.5, 0.5, 2.0), (0.5, 0.5, -1.0)):
        output_light(b, (*light, 1.0))
    axis_colors = ((0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.1, 0.1, 0.9))
    for x in range(size + 1):
        x0 = float(x) / float(size)
        for y in range(size + 1):
            y0 = float(y) / float(size)
            for z in range(size + 1):
                z0 = float(z) / float(size)
                output_color(b, (0.9, 0.9, 0.9), 0.0, 0.5, 0.5, 0.5, 37.0, 0.0, 0.0)
                output_sphere(b, (x0, y0, z0, radius1))
                for axis, index in enumerate((x, y, z)):
                    if index == size:
                        continue
                    output_color(b, axis_colors[axis], 0.1, 0.99, 0.0, 0.0, 0.0, 0.0, 0.0)
                    c1, c2 = [x0, y0, z0, radius2], [x0, y0, z0, radius2]
                    c1[axis] = c1[axis] + delta
                    c2[axis] = c2[axis] + inv_factor - delta
                    output_cylcone(b, c1, c2)
    return b.build("lattice", source=f"spd:lattice(size={size})")
