"""`SceneBuilder`: the sink for NFF records (`b v l f p pp s c`) that turns them into a `Scene`.

The NFF reader (`host.nff`) and the SPD generators (`host.spd`) both build scenes through it, so a
generated scene and the same scene read back from its `.nff` text are assembled by the same code
and can be compared array for array.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from netsushisen.host.scenes import Camera, Cones, Kind, Materials, Polygons, Scene, Spheres

_NAN3 = [math.nan] * 3


class SceneBuilder:
    """Collects NFF records in file order and turns them into a `Scene`.

    The NFF reader and the SPD generators both write through this class, so a generated scene and
    the same scene read back from its `.nff` text are assembled by the same code. Geometry is kept
    in flat Python lists while records arrive (cheap appends) and converted to numpy once, in
    `build`. Identical `f` records share one `Materials` row.
    """

    def __init__(self) -> None:
        self.background: tuple[float, float, float] | None = None
        self.camera: Camera | None = None
        self._light_pos: list[float] = []
        self._light_col: list[float] = []
        self._material_row: dict[tuple[float, ...], int] = {}
        self._materials: list[tuple[float, ...]] = []
        self.current_material = -1
        self._kind: list[int] = []
        self._material: list[int] = []
        self._local: list[int] = []
        self._poly_count: list[int] = []
        self._poly_patch: list[bool] = []
        self._vertices: list[float] = []
        self._normals: list[float] = []
        self._spheres: list[float] = []
        self._cones: list[float] = []
        self._n_spheres = 0
        self._n_cones = 0

    # -- global records -------------------------------------------------------------------------
    def set_background(self, r: float, g: float, b: float) -> None:
        self.background = (r, g, b)

    def set_camera(self, eye: Sequence[float], at: Sequence[float], up: Sequence[float],
                   angle: float, hither: float, resolution: tuple[int, int]) -> None:
        self.camera = Camera(eye=np.array(eye[:3], dtype=np.float64),
                             at=np.array(at[:3], dtype=np.float64),
                             up=np.array(up[:3], dtype=np.float64),
                             angle=float(angle), hither=float(hither),
                             resolution=(int(resolution[0]), int(resolution[1])))

    def add_light(self, x: float, y: float, z: float,
                  color: Sequence[float] | None = None) -> None:
        self._light_pos += (x, y, z)
        self._light_col += (1.0, 1.0, 1.0) if color is None else tuple(color[:3])

    def set_material(self, r: float, g: float, b: float, kd: float, ks: float, shine: float,
                     t: float, ior: float) -> int:
        """Make `R G B Kd Ks Shine T ior` current for the following objects; returns its row."""
        key = (r, g, b, kd, ks, shine, t, ior)
        row = self._material_row.get(key)
        if row is None:
            row = self._material_row[key] = len(self._materials)
            self._materials.append(key)
        self.current_material = row
        return row

    # -- objects --------------------------------------------------------------------------------
    def _primitive(self, kind: int, local: int) -> None:
        if self.current_material < 0:
            raise ValueError("object before any material")
        self._kind.append(kind)
        self._material.append(self.current_material)
        self._local.append(local)

    def add_polygon(self, xyz: Sequence[float]) -> None:
        """A `p` polygon from its vertices as a flat `x y z x y z ...` sequence."""
        n = len(xyz) // 3
        self._primitive(Kind.POLYGON, len(self._poly_count))
        self._poly_count.append(n)
        self._poly_patch.append(False)
        self._vertices += xyz
        self._normals += _NAN3 * n

    def add_patch(self, xyzn: Sequence[float]) -> None:
        """A `pp` patch from a flat `x y z nx ny nz ...` sequence (six numbers per vertex)."""
        n = len(xyzn) // 6
        self._primitive(Kind.POLYGON, len(self._poly_count))
        self._poly_count.append(n)
        self._poly_patch.append(True)
        verts, norms = self._vertices, self._normals
        for i in range(0, 6 * n, 6):
            verts += xyzn[i:i + 3]
            norms += xyzn[i + 3:i + 6]

    def add_sphere(self, x: float, y: float, z: float, r: float) -> None:
        self._primitive(Kind.SPHERE, self._n_spheres)
        self._n_spheres += 1
        self._spheres += (x, y, z, r)

    def add_cone(self, bx: float, by: float, bz: float, br: float,
                 ax: float, ay: float, az: float, ar: float) -> None:
        """An open cone from base (radius br) to apex (radius ar); equal radii: a cylinder."""
        self._primitive(Kind.CYLINDER if br == ar else Kind.CONE, self._n_cones)
        self._n_cones += 1
        self._cones += (bx, by, bz, br, ax, ay, az, ar)

    # -- result ---------------------------------------------------------------------------------
    def build(self, name: str, source: str = "", notes: list[str] | None = None) -> Scene:
        if self.camera is None:
            raise ValueError("scene has no camera")
        notes = list(notes or [])
        background = self.background
        if background is None:
            background = (0.0, 0.0, 0.0)
            notes.append("no 'b' record: black background")
        count = np.array(self._poly_count, dtype=np.int64)
        start = np.zeros(len(count), dtype=np.int64)
        if len(count):
            np.cumsum(count[:-1], out=start[1:])
        mats = np.array(self._materials, dtype=np.float64).reshape(-1, 8)
        spheres = np.array(self._spheres, dtype=np.float64).reshape(-1, 4)
        cones = np.array(self._cones, dtype=np.float64).reshape(-1, 8)
        return Scene(
            name=name,
            background=np.array(background, dtype=np.float64),
            camera=self.camera,
            light_position=np.array(self._light_pos, dtype=np.float64).reshape(-1, 3),
            light_color=np.array(self._light_col, dtype=np.float64).reshape(-1, 3),
            materials=Materials(color=mats[:, 0:3].copy(), kd=mats[:, 3].copy(),
                                ks=mats[:, 4].copy(), shine=mats[:, 5].copy(),
                                t=mats[:, 6].copy(), ior=mats[:, 7].copy()),
            kind=np.array(self._kind, dtype=np.int8),
            material=np.array(self._material, dtype=np.int32),
            local_index=np.array(self._local, dtype=np.int32),
            polygons=Polygons(start=start, count=count,
                              vertices=np.array(self._vertices, dtype=np.float64).reshape(-1, 3),
                              normals=np.array(self._normals, dtype=np.float64).reshape(-1, 3),
                              is_patch=np.array(self._poly_patch, dtype=bool)),
            spheres=Spheres(center=spheres[:, 0:3].copy(), radius=spheres[:, 3].copy()),
            cones=Cones(base=cones[:, 0:3].copy(), base_radius=cones[:, 3].copy(),
                        apex=cones[:, 4:7].copy(), apex_radius=cones[:, 7].copy()),
            source=source,
            notes=notes,
        )
