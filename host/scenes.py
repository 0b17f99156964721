"""The scene model: what the host knows about a scene, as numpy arrays.

A `Scene` is produced by the NFF reader (`host.nff`) or an SPD generator (`host.spd`) and consumed
by the grid builder, the database layout, the golden renderer and the reports. Primitive ids are
0-based in file order everywhere in the project; every per-primitive array is indexed by that id,
and each kind's own arrays are reached through `local_index`.

Kinds (the paper's Table 1 columns): polygons (NFF `p`, and `pp` patches, which are polygons with
per-vertex shading normals), spheres (`s`), cylinders and cones (both NFF `c`: equal radii make a
cylinder, different radii a cone).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np


class Kind(IntEnum):
    POLYGON = 0
    SPHERE = 1
    CYLINDER = 2
    CONE = 3


@dataclass(frozen=True)
class Camera:
    """NFF `v` block. `angle` is the full field of view in degrees; `up` need not be unit or
    perpendicular to the view direction. `resolution` is (nx, ny) as written in the file."""

    eye: np.ndarray  # (3,) float64
    at: np.ndarray  # (3,)
    up: np.ndarray  # (3,)
    angle: float
    hither: float
    resolution: tuple[int, int]


@dataclass
class Materials:
    """NFF `f` records, one row per distinct material: `R G B Kd Ks Shine T ior`."""

    color: np.ndarray  # (M, 3) float64
    kd: np.ndarray  # (M,)
    ks: np.ndarray  # (M,)  Ks > 0: hits spawn reflection rays
    shine: np.ndarray  # (M,)  Phong exponent
    t: np.ndarray  # (M,)  T > 0: hits spawn refraction rays; the surface is two-sided
    ior: np.ndarray  # (M,)

    def __len__(self) -> int:
        return len(self.kd)


@dataclass
class Polygons:
    """Planar polygons (any vertex count, concave allowed), counter-clockwise seen from the front.
    Polygon j's vertices are `vertices[start[j] : start[j] + count[j]]`. `normals` holds the `pp`
    per-vertex shading normals (rows of NaN for plain `p` polygons); `is_patch[j]` says which."""

    start: np.ndarray  # (P,) int64
    count: np.ndarray  # (P,) int64
    vertices: np.ndarray  # (V, 3) float64
    normals: np.ndarray  # (V, 3) float64
    is_patch: np.ndarray  # (P,) bool

    def __len__(self) -> int:
        return len(self.start)


@dataclass
class Spheres:
    center: np.ndarray  # (S, 3)
    radius: np.ndarray  # (S,)

    def __len__(self) -> int:
        return len(self.radius)


@dataclass
class Cones:
    """Open cones and cylinders (no end caps) from `base` (radius `base_radius`) to `apex`
    (radius `apex_radius`). Cylinders and cones share this layout; `Scene.kind` tells them apart."""

    base: np.ndarray  # (C, 3)
    base_radius: np.ndarray  # (C,)
    apex: np.ndarray  # (C, 3)
    apex_radius: np.ndarray  # (C,)

    def __len__(self) -> int:
        return len(self.base_radius)


@dataclass
class Scene:
    name: str
    background: np.ndarray  # (3,)
    camera: Camera
    light_position: np.ndarray  # (L, 3)
    light_color: np.ndarray  # (L, 3); NFF leaves intensity to the renderer; absent colour = 1 1 1
    materials: Materials
    kind: np.ndarray  # (N,) int8, a `Kind` per primitive id
    material: np.ndarray  # (N,) int32, row of `materials`
    local_index: np.ndarray  # (N,) int32, row in polygons / spheres / cones
    polygons: Polygons
    spheres: Spheres
    cones: Cones  # cylinders and cones, in file order; `local_index` of both kinds points here
    source: str = ""  # file path or "spd:<name>(size=<sf>)"
    notes: list[str] = field(default_factory=list)

    @property
    def n_primitives(self) -> int:
        return len(self.kind)

    def count(self, kind: Kind) -> int:
        return int(np.count_nonzero(self.kind == kind))

    @property
    def reflective(self) -> bool:
        """Some primitive has Ks > 0 (Table 1's 'reflective' column)."""
        return bool(np.any(self.materials.ks[self.material] > 0))

    @property
    def transparent(self) -> bool:
        """Some primitive has T > 0 (Table 1's 'transparent' column)."""
        return bool(np.any(self.materials.t[self.material] > 0))
