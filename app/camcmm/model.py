"""The data model: point clouds, meshes, height maps, images, cameras, artefacts.

Numpy arrays are the common currency. Lengths are in millimetres (mm) everywhere in the
model; readers convert files known to be in other units and record the original unit
in ``source_unit``. Conversions to pyvista and Open3D import those libraries lazily, so
this module stays importable without them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import InputError


def _finite_xyz(array: Any, what: str, name: str) -> np.ndarray:
    """Return ``array`` as a C-contiguous (N, 3) float64 array or raise InputError."""
    a = np.ascontiguousarray(array, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"{name}: {what} must have shape (N, 3), got {a.shape}")
    if np.isfinite(a).all():  # one flat pass; the per-row check below costs 40x more
        return a
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{name}: {int(bad.sum())} of {len(a)} {what} have NaN or Inf coordinates (first at index {first})"
        )
    return a


def _per_item(array: Any, n: int, what: str, name: str, dtype=None) -> np.ndarray:
    a = np.asarray(array) if dtype is None else np.asarray(array, dtype=dtype)
    if a.shape[0] != n:
        raise InputError(f"{name}: {what} has {a.shape[0]} rows for {n} items")
    return a


@dataclass(eq=False)
class PointCloud:
    """A measured point cloud.

    Attributes
    ----------
    points : (N, 3) float64, mm
    colors : (N, 3) uint8 or None
    normals : (N, 3) float64 unit vectors or None
    fields : dict name -> (N,) array, per-point scalar fields (e.g. ``deviation``)
    field_units : dict name -> unit string (e.g. ``{"deviation": "mm"}``)
    name : a human-readable name, usually the file name
    source_unit : the length unit of the file it was read from (``"mm"`` if created here)
    """

    points: np.ndarray
    colors: np.ndarray | None = None
    normals: np.ndarray | None = None
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    field_units: dict[str, str] = field(default_factory=dict)
    name: str = "cloud"
    source_unit: str = "mm"

    def __post_init__(self) -> None:
        self.points = _finite_xyz(self.points, "points", self.name)
        n = len(self.points)
        if self.colors is not None:
            c = np.asarray(self.colors)
            if c.dtype.kind == "f":  # 0..1 floats, as Open3D keeps them
                c = np.clip(np.round(c * 255.0), 0, 255)
            self.colors = _per_item(c, n, "colors", self.name, np.uint8)
        if self.normals is not None:
            self.normals = _per_item(self.normals, n, "normals", self.name, np.float64)
        self.fields = {k: _per_item(v, n, f"field {k!r}", self.name) for k, v in self.fields.items()}

    @property
    def n_points(self) -> int:
        return len(self.points)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) array: minimum and maximum corner in mm."""
        if self.n_points == 0:
            return np.zeros((2, 3))
        return np.vstack([self.points.min(axis=0), self.points.max(axis=0)])

    def subset(self, index: np.ndarray | slice) -> PointCloud:
        """A new cloud with the points selected by a boolean mask, index array or slice."""
        return PointCloud(
            self.points[index],
            None if self.colors is None else self.colors[index],
            None if self.normals is None else self.normals[index],
            {k: v[index] for k, v in self.fields.items()},
            dict(self.field_units),
            self.name,
            self.source_unit,
        )

    def to_open3d(self):
        import open3d as o3d

        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(self.points))
        if self.colors is not None:
            pc.colors = o3d.utility.Vector3dVector(self.colors / 255.0)
        if self.normals is not None:
            pc.normals = o3d.utility.Vector3dVector(self.normals)
        return pc

    @classmethod
    def from_open3d(cls, pc, name: str = "cloud") -> PointCloud:
        return cls(
            np.asarray(pc.points),
            np.asarray(pc.colors) if pc.has_colors() else None,
            np.asarray(pc.normals) if pc.has_normals() else None,
            name=name,
        )

    def to_pyvista(self):
        import pyvista as pv

        poly = pv.PolyData(self.points)
        if self.colors is not None:
            poly.point_data["RGB"] = self.colors
        if self.normals is not None:
            poly.point_data["Normals"] = self.normals
        for k, v in self.fields.items():
            poly.point_data[k] = v
        return poly


@dataclass(eq=False)
class TriangleMesh:
    """A triangle mesh (CAD nominal or reconstructed surface).

    vertices : (V, 3) float64, mm; faces : (F, 3) int64 vertex indices;
    fields : per-vertex scalar fields with ``field_units``.
    """

    vertices: np.ndarray
    faces: np.ndarray
    vertex_normals: np.ndarray | None = None
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    field_units: dict[str, str] = field(default_factory=dict)
    name: str = "mesh"
    source_unit: str = "mm"

    def __post_init__(self) -> None:
        self.vertices = _finite_xyz(self.vertices, "vertices", self.name)
        f = np.ascontiguousarray(self.faces, dtype=np.int64)
        if f.size == 0:
            raise InputError(f"{self.name}: mesh has no faces")
        if f.ndim != 2 or f.shape[1] != 3:
            raise InputError(f"{self.name}: faces must be triangles with shape (F, 3), got {f.shape}")
        if f.min() < 0 or f.max() >= len(self.vertices):
            raise InputError(
                f"{self.name}: face indices run {f.min()}..{f.max()} but there are {len(self.vertices)} vertices"
            )
        self.faces = f
        n = len(self.vertices)
        if self.vertex_normals is not None:
            self.vertex_normals = _per_item(self.vertex_normals, n, "normals", self.name, np.float64)
        self.fields = {k: _per_item(v, n, f"field {k!r}", self.name) for k, v in self.fields.items()}

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def bounds(self) -> np.ndarray:
        return np.vstack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def area(self) -> float:
        """Total surface area in mm²."""
        v = self.vertices[self.faces]
        return float(0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum())

    def to_open3d(self):
        import open3d as o3d

        m = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(self.vertices), o3d.utility.Vector3iVector(self.faces.astype(np.int32))
        )
        if self.vertex_normals is not None:
            m.vertex_normals = o3d.utility.Vector3dVector(self.vertex_normals)
        return m

    @classmethod
    def from_open3d(cls, m, name: str = "mesh") -> TriangleMesh:
        return cls(
            np.asarray(m.vertices),
            np.asarray(m.triangles),
            np.asarray(m.vertex_normals) if m.has_vertex_normals() else None,
            name=name,
        )

    def to_pyvista(self):
        import pyvista as pv

        cells = np.hstack([np.full((self.n_faces, 1), 3, dtype=np.int64), self.faces]).ravel()
        poly = pv.PolyData(self.vertices, cells)
        for k, v in self.fields.items():
            poly.point_data[k] = v
        return poly


def _step(value: Any, what: str, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: {what} {value!r} is not a number") from None
    if not (np.isfinite(v) and v > 0):
        raise InputError(f"{name}: {what} = {v:.6g} mm must be positive and finite")
    return v


@dataclass(eq=False)
class HeightMap:
    """A surface-topography height map on a regular grid (an interferometer's or a
    confocal microscope's measurement; thesis ch. 6.1).

    Attributes
    ----------
    heights : (ny, nx) float64, mm; NaN where the instrument found no valid point
    dx, dy : lateral steps in mm, x along columns (j), y along rows (i)
    intensity : (ny, nx) float64 or None, the instrument's intensity/quality channel
        (arbitrary units), when the file has one
    origin : (x0, y0) mm, the position of ``heights[0, 0]``
    name : a human-readable name, usually the file name
    source_unit : the height unit stated by the file it was read from (``"mm"`` if made here)
    meta : the instrument metadata kept from the file (free-form, JSON-able values)

    Construction refuses non-2-D or empty grids, infinite heights, steps that are not
    positive finite numbers and an intensity of another shape, with an InputError naming
    the map.
    """

    heights: np.ndarray
    dx: float
    dy: float
    intensity: np.ndarray | None = None
    origin: tuple[float, float] = (0.0, 0.0)
    name: str = "heightmap"
    source_unit: str = "mm"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        try:
            h = np.ascontiguousarray(self.heights, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"{self.name}: heights are not numbers") from None
        if h.ndim != 2 or min(h.shape) < 1:
            raise InputError(f"{self.name}: heights must be a non-empty (ny, nx) grid, got shape {h.shape}")
        inf = np.isinf(h)
        if inf.any():
            i, j = np.argwhere(inf)[0]
            raise InputError(
                f"{self.name}: {int(inf.sum())} heights are infinite (first at row {i}, column {j}); "
                "invalid points must be NaN"
            )
        self.heights = h
        self.dx = _step(self.dx, "lateral step dx", self.name)
        self.dy = _step(self.dy, "lateral step dy", self.name)
        if self.intensity is not None:
            try:
                a = np.ascontiguousarray(self.intensity, dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError(f"{self.name}: intensity is not numbers") from None
            if a.shape != h.shape:
                raise InputError(f"{self.name}: intensity has shape {a.shape}, heights {h.shape}")
            self.intensity = a
        try:
            o = np.asarray(self.origin, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise InputError(f"{self.name}: origin {self.origin!r} is not two numbers") from None
        if o.size != 2 or not np.all(np.isfinite(o)):
            raise InputError(f"{self.name}: origin must be two finite numbers (x0, y0) mm, got {o.tolist()}")
        self.origin = (float(o[0]), float(o[1]))
        self.meta = dict(self.meta or {})

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): rows, columns."""
        return int(self.heights.shape[0]), int(self.heights.shape[1])

    @property
    def valid(self) -> np.ndarray:
        """(ny, nx) bool: True where the height is a number."""
        return ~np.isnan(self.heights)

    @property
    def n_valid(self) -> int:
        return int(np.count_nonzero(self.valid))

    @property
    def size_mm(self) -> tuple[float, float]:
        """(width, height) in mm as instruments state it: nx dx by ny dy (each point
        stands for one dx by dy cell)."""
        ny, nx = self.shape
        return nx * self.dx, ny * self.dy

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        """(nx,) x and (ny,) y coordinates of the columns and rows, mm."""
        ny, nx = self.shape
        return self.origin[0] + np.arange(nx) * self.dx, self.origin[1] + np.arange(ny) * self.dy

    def points(self) -> np.ndarray:
        """(N, 3) float64 mm of the valid cells, row by row: x = x0 + j dx,
        y = y0 + i dy, z = height."""
        i, j = np.nonzero(self.valid)
        return np.column_stack([self.origin[0] + j * self.dx, self.origin[1] + i * self.dy, self.heights[i, j]])

    def to_pyvista(self):
        """A pyvista StructuredGrid of the surface, point data ``height`` (mm, NaN where
        invalid) and ``intensity`` when there is one; invalid points keep z = 0 and are
        blanked (ghost cells), so plots hide them."""
        import pyvista as pv

        x, y = self.xy()
        # (nx, ny) arrays: pyvista ravels them in Fortran order, x fastest, which is
        # numpy's C order of the (ny, nx) grids below
        xx, yy = np.meshgrid(x, y, indexing="ij")
        z = np.where(self.valid, self.heights, 0.0).T
        grid = pv.StructuredGrid(xx, yy, z)
        grid.point_data["height"] = self.heights.ravel()
        if self.intensity is not None:
            grid.point_data["intensity"] = self.intensity.ravel()
        if not self.valid.all():
            grid = grid.extract_points(self.valid.ravel(), adjacent_cells=False)
        return grid


@dataclass(eq=False)
class Image:
    """A camera image: ``data`` is (H, W) or (H, W, C), any dtype; metadata is free-form
    (exposure in ms, time stamp, temperature in °C, camera id ...)."""

    data: np.ndarray
    name: str = "image"
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels, as OpenCV orders it."""
        return int(self.data.shape[1]), int(self.data.shape[0])


#: OpenCV's distortion models: none, k1 k2 p1 p2 [k3 [k4 k5 k6 [s1..s4 [tau_x tau_y]]]]
DIST_COUNTS = (0, 4, 5, 8, 12, 14)
#: |R R^T - I| and |det R - 1| allowed: a rotation written with 6 decimals (as MATLAB's
#: calibration toolboxes print it) is off by up to ~3e-6; a non-rotation is off by far more.
ROTATION_TOL = 1e-5
#: the largest image side a camera model may declare (px); OpenCV's maps and the image
#: readers' limits are far below what a garbled file could ask for.
MAX_IMAGE_SIDE = 65536


def _num(v: float) -> str:
    return f"{v:.6g}"


def camera_problem(
    camera_matrix: Any,
    dist_coeffs: Any = (),
    rotation: Any = None,
    translation: Any = None,
    image_size: Any = (0, 0),
    pixel_pitch: Any = None,
) -> str | None:
    """The first reason (one line, no culprit prefix) why these cannot describe a camera,
    or None: positive finite focal lengths (px), a finite principal point inside or near
    the image when its size is known, K's last row (0, 0, 1), finite distortion with an
    OpenCV coefficient count, a rotation (orthonormal, det +1 within ``ROTATION_TOL``), a
    finite translation (mm), whole positive image sides (or (0, 0): unknown) and a positive
    pixel pitch (mm) when given. Native code (OpenCV's undistortion maps) crashes on some
    of these, so every reader checks them before anything computes."""
    try:
        K = np.asarray(camera_matrix, dtype=np.float64)
    except (TypeError, ValueError):
        return "camera_matrix is not a matrix of numbers"
    if K.size != 9:
        return f"camera_matrix must be 3 x 3 (9 numbers), got {K.size} numbers"
    K = K.reshape(3, 3)
    for what, v in (("fx", K[0, 0]), ("fy", K[1, 1])):
        if not (np.isfinite(v) and v > 0):
            return f"focal length {what} = {_num(v)} px must be positive and finite"
    for what, v in (("cx", K[0, 2]), ("cy", K[1, 2]), ("skew", K[0, 1])):
        if not np.isfinite(v):
            return (
                f"principal point {what} = {_num(v)} px must be finite"
                if what != "skew"
                else f"skew = {_num(v)} must be finite"
            )
    if not np.allclose(K[2], (0.0, 0.0, 1.0), rtol=0, atol=1e-9) or abs(K[1, 0]) > 1e-9:
        return f"camera_matrix last row must be (0, 0, 1) and K[1,0] = 0, got {K[2].tolist()} and {_num(K[1, 0])}"
    try:
        d = np.asarray(dist_coeffs if dist_coeffs is not None else (), dtype=np.float64).ravel()
    except (TypeError, ValueError):
        return "distortion coefficients are not numbers"
    if d.size not in DIST_COUNTS:
        return f"{d.size} distortion coefficients; OpenCV's models have {', '.join(str(n) for n in DIST_COUNTS[1:])}"
    if not np.all(np.isfinite(d)):
        i = int(np.flatnonzero(~np.isfinite(d))[0])
        return f"distortion coefficient {i + 1} = {_num(d[i])} must be finite"
    try:
        size = [float(v) for v in (image_size if image_size is not None else (0, 0))]
    except (TypeError, ValueError):
        return f"image size {image_size!r} is not two numbers"
    if len(size) != 2:
        return f"image size must be (width, height), got {len(size)} numbers"
    w, h = size
    if (w, h) != (0.0, 0.0):
        for what, v in (("width", w), ("height", h)):
            if not (np.isfinite(v) and v == int(v) and 0 < v <= MAX_IMAGE_SIDE):
                return f"image {what} = {_num(v)} px must be a whole number from 1 to {MAX_IMAGE_SIDE}"
        for what, v, n in (("cx", K[0, 2], w), ("cy", K[1, 2], h)):
            if not -n <= v <= 2 * n:  # more than an image away from it: a garbled value
                return f"principal point {what} = {_num(v)} px lies far outside the {int(w)} x {int(h)} px image"
    if rotation is not None:
        try:
            R = np.asarray(rotation, dtype=np.float64)
        except (TypeError, ValueError):
            return "rotation is not a matrix of numbers"
        if R.size != 9:
            return f"rotation must be 3 x 3 (9 numbers), got {R.size} numbers"
        R = R.reshape(3, 3)
        if not np.all(np.isfinite(R)):
            return "rotation has NaN or infinite entries"
        off = float(np.abs(R @ R.T - np.eye(3)).max())
        det = float(np.linalg.det(R))
        if off > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
            kind = "a reflection" if det < 0 else "not a rotation"
            return f"rotation is {kind} (max |R R^T - I| = {off:.2g}, det R = {det:.6g}; need det +1)"
    if translation is not None:
        try:
            t = np.asarray(translation, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            return "translation is not numbers"
        if t.size != 3:
            return f"translation must have 3 numbers (mm), got {t.size}"
        if not np.all(np.isfinite(t)):
            return f"translation {t.tolist()} mm must be finite"
    if pixel_pitch is not None:
        try:
            pp = float(pixel_pitch)
        except (TypeError, ValueError):
            return f"pixel pitch {pixel_pitch!r} is not a number"
        if not (np.isfinite(pp) and pp > 0):
            return f"pixel pitch = {_num(pp)} mm must be positive and finite"
    return None


@dataclass(eq=False)
class CameraModel:
    """A pinhole camera with lens distortion (thesis ch. 2.3, eqs. 2.1-2.6).

    camera_matrix : (3, 3) K in pixels; dist_coeffs : OpenCV order
    (k1, k2, p1, p2, k3[, k4, k5, k6, s1, s2, s3, s4]); rotation (3, 3) and translation
    (3,) in mm map world to camera coordinates, x_cam = R x_world + t;
    image_size : (width, height) px, (0, 0) when unknown; pixel_pitch in mm when known.
    Construction refuses values no camera has (see :func:`camera_problem`) with an
    InputError naming the camera.
    """

    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray = field(default_factory=lambda: np.zeros(5))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    image_size: tuple[int, int] = (0, 0)
    pixel_pitch: float | None = None
    name: str = "camera"

    def __post_init__(self) -> None:
        if self.dist_coeffs is None:
            self.dist_coeffs = np.zeros(5)
        if self.rotation is None:
            self.rotation = np.eye(3)
        if self.translation is None:
            self.translation = np.zeros(3)
        why = camera_problem(
            self.camera_matrix, self.dist_coeffs, self.rotation, self.translation, self.image_size, self.pixel_pitch
        )
        if why is not None:
            raise InputError(f"camera {self.name!r}: {why}")
        self.camera_matrix = np.asarray(self.camera_matrix, dtype=np.float64).reshape(3, 3)
        self.dist_coeffs = np.asarray(self.dist_coeffs, dtype=np.float64).ravel()
        self.rotation = np.asarray(self.rotation, dtype=np.float64).reshape(3, 3)
        self.translation = np.asarray(self.translation, dtype=np.float64).reshape(3)
        self.image_size = (int(self.image_size[0]), int(self.image_size[1]))

    def check(self) -> CameraModel:
        """The camera itself, after checking it again (for a model whose arrays were
        changed after it was made); InputError naming the camera otherwise."""
        why = camera_problem(
            self.camera_matrix, self.dist_coeffs, self.rotation, self.translation, self.image_size, self.pixel_pitch
        )
        if why is not None:
            raise InputError(f"camera {self.name!r}: {why}")
        return self

    @property
    def projection_matrix(self) -> np.ndarray:
        """(3, 4) P = K [R | t] (thesis eq. 2.1), distortion not included."""
        return self.camera_matrix @ np.hstack([self.rotation, self.translation[:, None]])

    @property
    def centre(self) -> np.ndarray:
        """(3,) the projection centre in world coordinates, mm (C = -R^T t)."""
        return -self.rotation.T @ self.translation


@dataclass(frozen=True)
class Certificate:
    """A calibrated value: ``value`` ± ``expanded_uncertainty`` (coverage factor ``k``)."""

    value: float
    expanded_uncertainty: float
    k: float = 2.0
    unit: str = "mm"

    def __post_init__(self) -> None:
        if not np.isfinite(self.value):
            raise InputError(f"certificate value {self.value!r} is not a finite number")
        if not (self.expanded_uncertainty >= 0):
            raise InputError(f"certificate uncertainty {self.expanded_uncertainty!r} must be >= 0")
        if not (self.k > 0):
            raise InputError(f"certificate coverage factor k={self.k!r} must be > 0")

    @property
    def standard_uncertainty(self) -> float:
        return self.expanded_uncertainty / self.k


@dataclass
class Artefact:
    """A calibrated artefact: sphere, ball bar, ball plate, flat, gauge block ...

    ``nominal`` holds the design dimensions in mm (e.g. ``{"diameter": 20.0}``);
    ``certificates`` the calibrated ones (e.g. ``{"diameter": Certificate(...)}``).
    """

    id: str
    kind: str
    name: str = ""
    nominal: dict[str, Any] = field(default_factory=dict)
    certificates: dict[str, Certificate] = field(default_factory=dict)
    notes: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": self.kind,
            "name": self.name,
            "nominal": self.nominal,
            "certificates": {
                k: {"value": c.value, "uncertainty": c.expanded_uncertainty, "k": c.k, "unit": c.unit}
                for k, c in self.certificates.items()
            },
            "notes": self.notes,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Artefact:
        certs = {
            k: Certificate(
                float(c["value"]), float(c.get("uncertainty", 0.0)), float(c.get("k", 2.0)), c.get("unit", "mm")
            )
            for k, c in (d.get("certificates") or {}).items()
        }
        return cls(d["id"], d["kind"], d.get("name", ""), dict(d.get("nominal") or {}), certs, d.get("notes", ""))
