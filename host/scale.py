"""Whether a scene's scale lets the intersection tests work in a precision.

The tests form squares of the scene's lengths (r², |q|² of a sphere test, |e|² of a polygon edge,
the cone's radii): when the smallest such length ℓ has ℓ² below the precision's smallest normal
number divided by its epsilon, the square is subnormal or zero and carries fewer bits than the
arithmetic needs (a mixed scene scaled by 1e-30 makes r² and |q|² underflow to 0 in fp32, so every
ray is a tangent hit). Such a scene is refused with a located message on the golden model and on
the machine alike (both call `check_scale`), never rendered wrong: fp32 needs ℓ ≥ 3.2·10⁻¹⁶,
fp64 ℓ ≥ 1.5·10⁻¹⁴⁶. The largest coordinates are the NFF reader's guard (|x| ≤ 10¹⁸).
"""

from __future__ import annotations

import numpy as np

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.host.rays import rownorm
from netsushisen.host.scenes import Scene

_DTYPES = {"fp32": np.float32, "fp64": np.float64, "fp16": np.float16}


def smallest_length(scene: Scene) -> float:
    """The smallest non-zero length the intersection tests square: sphere and cone radii,
    polygon edges, the eye's distance to the look-at point."""
    parts = [np.abs(np.asarray(scene.spheres.radius, np.float64)),
             np.abs(np.asarray(scene.cones.base_radius, np.float64)),
             np.abs(np.asarray(scene.cones.apex_radius, np.float64))]
    pg = scene.polygons
    for s, c in zip(np.asarray(pg.start), np.asarray(pg.count)):
        v = np.asarray(pg.vertices[s:s + c], np.float64)
        parts.append(rownorm(np.roll(v, -1, axis=0) - v))
    cam = scene.camera
    view = np.asarray(cam.eye, np.float64) - np.asarray(cam.at, np.float64)
    parts.append(np.atleast_1d(rownorm(view)))
    values = np.concatenate([p.ravel() for p in parts]) if parts else np.zeros(0)
    values = values[values > 0]
    return float(values.min()) if values.size else 1.0


def minimum_length(precision: str) -> float:
    """ℓ with ℓ² = the precision's smallest normal / its epsilon."""
    info = np.finfo(_DTYPES.get(precision, np.float64))
    return float(np.sqrt(float(info.tiny) / float(info.eps)))


def check_scale(scene: Scene, precision: str) -> None:
    """Refuse (NetsushisenError, located at the scene's file) a scene too small for `precision`."""
    if precision not in ("fp32", "fp64"):  # fp16 is the accuracy study's emulation: judged there
        return
    length, need = smallest_length(scene), minimum_length(precision)
    if length < need:
        raise NetsushisenError(Diagnostic(
            f"scene {scene.name!r}: its smallest length {length:.3g} is below {need:.2g}, the least "
            f"whose square {precision} holds as a normal number; the intersection tests would "
            "underflow and render it wrong (scale the scene up)", file=scene.source or None))
