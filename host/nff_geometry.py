"""Geometry checks of the NFF reader (host/nff.py): what a record may say and still be rendered.

Errors where the record cannot be rendered as written, warnings where it can but probably not
as meant:

* **Errors** (exit 1, the first one stops the read): a sphere radius that is not positive; a
  cone radius that is negative, or both zero; a coordinate or radius of magnitude beyond
  MAX_COORD (1e18: the machine computes in fp32, where the squares and dot products every
  intersection test takes overflow to infinity past about 1.8e19); a cone whose axis is lost
  beside its position in fp32 (it has no direction).
* **Warnings** (`file:line:col: warning: ...` on standard error, the scene is used): a polygon
  with zero area (collinear or repeated vertices: it is never hit; tessellators emit these at
  poles, so they are legal), and a polygon of more than three vertices that is not planar (it
  is rendered as the fan of triangles from its first vertex, which may not be the surface the
  file meant). At most MAX_WARNINGS per kind are shown, then how many more; every warning is
  also in the scene's notes (`scene info`).

`GeometryChecks` is a mixin of the reader's parser: it uses the parser's `error(message,
token)` and `locate(token)`, so every message is located at its record like the parser's own.
"""

from __future__ import annotations

import numpy as np

from netsushisen.isa.errors import Diagnostic
from netsushisen.host.rays import rowdot, rownorm
from netsushisen.host.scenes import Scene

MAX_COORD = 1e18
"""Largest magnitude of a coordinate or radius: its square (every intersection test takes
squares and dot products) must stay finite in fp32 (max 3.4e38)."""

FP32_EPS = 2.0 ** -23
"""fp32's relative spacing (the gap between 1 and the next fp32 number). An extent below half
the spacing at its position, |position| × FP32_EPS / 2, is lost beside it: position ± extent
rounds back to the position. Anything larger is still a (tiny) object that the robust tests
handle — the numerics catalog's far tiny sphere, r = 1e-3 at 1e4, is hit correctly in fp32."""

def fp32_half_spacing(x: float) -> float:
    """Half the gap between fp32 numbers at magnitude |x|: an extent below it, added to x,
    rounds back to x."""
    return float(np.spacing(np.float32(min(abs(x), MAX_COORD)))) / 2


MAX_WARNINGS = 5
"""Warnings shown per kind of problem; the rest are counted."""


class GeometryChecks:
    """Per-record geometry checks; errors raise at once, warnings are collected (`warn`) and
    become the scene's notes (`warning_lines`)."""

    def init_checks(self) -> None:
        self.warnings: dict[str, list[int]] = {}  # message kind -> token indices of its records
        self.messages: dict[str, str] = {}  # message kind -> message
        self.polygons: dict[int, list] = {}  # vertex count -> (record, keyword, xyz) to check

    def warn(self, kind: str, message: str, record: int) -> None:
        self.messages.setdefault(kind, message)
        self.warnings.setdefault(kind, []).append(record)

    def warning_lines(self) -> list[str]:
        """One located line per warning, MAX_WARNINGS per kind, then a count of the rest."""
        shown = sorted((record, kind) for kind, records in self.warnings.items()
                       for record in records[:MAX_WARNINGS])
        lines = []
        for record, kind in shown:  # in file order
            line, col, _ = self.locate(record)
            lines.append(Diagnostic(self.messages[kind], file=self.filename, line=line, col=col,
                                    severity="warning").format())
        for kind, records in self.warnings.items():
            if len(records) > MAX_WARNINGS:
                lines.append(Diagnostic(f"{len(records) - MAX_WARNINGS} more {kind}",
                                        file=self.filename, severity="warning").format())
        return lines

    def check_magnitude(self, values: list[float], record: int, what: str) -> None:
        big = next((v for v in values if abs(v) > MAX_COORD), None)
        if big is not None:
            raise self.error(f"{what}: {big:g} is too large (at most {MAX_COORD:g}: the machine "
                             "computes in fp32, where its square overflows)", record)

    def check_polygon(self, xyz: list[float], record: int, what: str) -> None:
        """Magnitudes now; area and planarity at the end, all polygons of a vertex count at
        once (`check_polygons`: per-record numpy calls would double a large file's read)."""
        self.check_magnitude(xyz, record, what)
        self.polygons.setdefault(len(xyz) // 3, []).append((record, what, xyz))

    def check_polygons(self) -> None:
        found = []
        for n, polys in self.polygons.items():
            v = np.array([xyz for _, _, xyz in polys], dtype=np.float64).reshape(len(polys), n, 3)
            edges = v[:, 1:] - v[:, :1]
            area = np.cross(edges[:, :-1], edges[:, 1:]).sum(axis=1) * 0.5
            size = rownorm(edges).max(axis=1)
            norm = rownorm(area)
            flat = (norm <= 1e-12 * size * size) | (size == 0.0)
            off = np.zeros(len(polys))
            if n > 3:
                unit = area / np.where(flat, 1.0, norm)[:, None]
                off = np.abs(rowdot(edges, unit[:, None, :])).max(axis=1)
            bent = ~flat & (off > 1e-4 * size)
            for i in np.flatnonzero(flat | bent):
                found.append((polys[i][0], polys[i][1], bool(flat[i]), float(off[i]),
                              float(size[i])))
        for record, what, zero, off, size in sorted(found):  # in file order
            if zero:
                self.warn("zero-area polygons", f"{what} has zero area (collinear "
                          "or repeated vertices): it is never hit", record)
            else:
                self.warn("non-planar polygons", f"{what} is not planar (a vertex "
                          f"lies {off:.3g} off its plane, {off / size:.1%} of its size): it is "
                          "rendered as the fan of triangles from its first vertex", record)

    def check_round(self, centre: list[float], radius: float, record: int, what: str) -> None:
        """A sphere's or cone end's radius against fp32's resolution at its position: a warning,
        not an error — fp64 still renders it, and `netsushisen numerics` exists to show such a
        scene's fp32 failures."""
        scale = max(abs(c) for c in centre)
        if 0.0 < radius < fp32_half_spacing(scale):
            self.warn("lost in fp32", f"{what}: radius {radius:g} is lost beside its position "
                      f"{scale:g} in fp32 (centre ± radius rounds back to the centre): in fp32 "
                      "the object vanishes; fp64 keeps it", record)


def scene_warnings(scene: Scene) -> list[str]:
    """The located warnings the reader left in a scene's notes (`file:line:col: warning: ...`),
    for a command to print on standard error."""
    return [note for note in scene.notes if ": warning: " in note]
