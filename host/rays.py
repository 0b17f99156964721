"""Rays as the machine sees them: structure-of-arrays vectors in the machine's precision.

Every float value the golden model computes lives in an array of the precision's dtype
(`np.float32` for fp32, `np.float64` for fp64), and every arithmetic step is one elementwise IEEE
operation in a fixed order, so that a hand-written kernel doing the same operations in the same
order gets the same bits. The helpers here (`dot`, `cross`, `normalize`) fix that order once for
the whole golden model; `docs/golden.md` spells it out for the kernel writers.

A 3-vector field over n rays is an array of shape (3, n): row 0 is x, row 1 y, row 2 z.

`primary_rays` is the one function that turns an NFF camera into eye rays; the emulator's host/DIS
uses it too, so the machine and the golden model start from identical rays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from netsushisen.host.scenes import Camera

PRECISIONS: dict[str, type] = {"fp32": np.float32, "fp64": np.float64, "fp16": np.float16}
"""fp32 and fp64 are the machine's formats; fp16 is for the golden model only, in accuracy
studies (`netsushisen accuracy`: what a narrower format would cost in image error). The
machine's configuration accepts fp32 and fp64 alone."""


def dtype_of(precision: str) -> type:
    """The numpy scalar type of a precision name (`fp32`, `fp64`; `fp16` for the golden model)."""
    try:
        return PRECISIONS[precision]
    except KeyError:
        names = ", ".join(PRECISIONS)
        raise ValueError(f"precision must be one of {names}, got {precision!r}") from None


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(ax*bx + ay*by) + az*bz — always this order (no reduction, no FMA)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def rowdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products of vectors along the last axis ((N, 3) rows, or one (3,) vector) in `dot`'s
    order, ((a0 b0 + a1 b1) + a2 b2). numpy's `@`, `einsum` and 1-D `linalg.norm` go through BLAS or SIMD loops whose
    summation order and FMA use depend on the CPU and the library build, so host arithmetic that
    must give the same bits everywhere uses this instead."""
    total = a[..., 0] * b[..., 0]
    for i in range(1, a.shape[-1]):  # 2-vectors too (the oracle's (z, ρ) planes)
        total = total + a[..., i] * b[..., i]
    return total


def rownorm(a: np.ndarray) -> np.ndarray:
    """Euclidean lengths of vectors along the last axis: sqrt(rowdot(a, a))."""
    return np.sqrt(rowdot(a, a))


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(ay*bz - az*by, az*bx - ax*bz, ax*by - ay*bx)."""
    return np.stack([a[1] * b[2] - a[2] * b[1],
                     a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def normalize(v: np.ndarray) -> np.ndarray:
    """v / sqrt(dot(v, v)): one sqrt, then three divisions (not a reciprocal multiply)."""
    length = np.sqrt(dot(v, v))
    with np.errstate(divide="ignore", invalid="ignore"):
        return v / length


def axpy(a: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """y + a*x per component: one multiply, then one add (a point along a ray, o + t*d)."""
    return y + a * x


@dataclass
class PrimaryRays:
    """Eye rays of one image. `direction[:, s]` is sample s, samples in row-major order of a
    `shape` = (rows, cols) grid, row 0 at the top. All eye rays share `origin` (the eye) and start
    at `t_min` (the NFF hither distance, measured along each unit direction)."""

    origin: np.ndarray  # (3,) dtype
    direction: np.ndarray  # (3, rows*cols) dtype, unit length (rounded from float64)
    t_min: np.floating
    shape: tuple[int, int]
    corners: bool  # True: (N+1)^2 pixel-corner rays (SPD); False: N^2 pixel centres


def camera_basis(camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, right, up) unit vectors in float64 for NFF's left-handed coordinates.

    Left-handed means right = up x forward and the true up = forward x right (with the usual
    arithmetic cross product); `camera.up` need be neither unit nor perpendicular to the view.
    """
    eye = np.asarray(camera.eye, dtype=np.float64)
    forward = np.asarray(camera.at, dtype=np.float64) - eye
    forward = forward / math.sqrt(float(dot(forward, forward)))  # not `@`: BLAS's order
    right = np.cross(np.asarray(camera.up, dtype=np.float64), forward)
    right = right / math.sqrt(float(dot(right, right)))  # varies with the CPU
    up = np.cross(forward, right)
    return forward, right, up


def screen_coordinates(samples: int, angle_degrees: float) -> np.ndarray:
    """Float64 offsets on the image plane at distance 1 of `samples` evenly spaced rays per axis.

    NFF's `angle` is the full field of view measured between the outermost ray rows/columns, so
    the first and last sample sit at -tan(angle/2) and +tan(angle/2).
    """
    half = math.tan(math.radians(angle_degrees) / 2.0)
    if samples == 1:
        return np.zeros(1)
    j = np.arange(samples, dtype=np.float64)
    return (2.0 * j - (samples - 1)) / (samples - 1) * half


def primary_rays(camera: Camera, res: int, corners: bool = False, precision: str = "fp32",
                 jitter: int | None = None) -> PrimaryRays:
    """Eye rays for an res x res image: pixel centres (res^2 rays) or, with `corners`, the SPD
    pixel corners ((res+1)^2 rays). `jitter`: a seed; each sample moves by a uniform offset
    within its pixel (the sampling spread of `paper --draws`; None: the exact centres).

    The host computes each direction entirely in float64 (forward + sx*right + sy*up, normalised)
    and rounds it once to the precision, so the result is deterministic and identical for the
    golden model and the emulated machine's DIS.
    """
    if res < 1:
        raise ValueError(f"resolution must be at least 1, got {res}")
    dtype = dtype_of(precision)
    forward, right, up = camera_basis(camera)
    m = res + 1 if corners else res
    s = screen_coordinates(m, camera.angle)
    sx = s[None, :]  # column j: left (-) to right (+)
    sy = -s[:, None]  # row 0 at the top: +tan(angle/2)
    if jitter is not None and m > 1:  # `paper --draws`: each sample moved within its pixel
        step = float(s[1] - s[0])
        rng = np.random.default_rng(jitter)
        sx = sx + (rng.random((m, m)) - 0.5) * step
        sy = sy + (rng.random((m, m)) - 0.5) * step
    d = (forward[:, None, None] + sx[None] * right[:, None, None] + sy[None] * up[:, None, None])
    d = d.reshape(3, m * m)
    d = d / np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    return PrimaryRays(origin=np.asarray(camera.eye, dtype=np.float64).astype(dtype),
                       direction=np.ascontiguousarray(d.astype(dtype)),
                       t_min=dtype(max(float(camera.hither), 0.0)),
                       shape=(m, m), corners=corners)
