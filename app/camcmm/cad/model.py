"""A CAD model as a nominal: its faces, its tessellation, and exact distances to it.

    cad = read_cad("part.step")
    cad.faces[11].type, cad.faces[11].params       # face 12 (1-based index 12)
    d, closest, face = cad.distance(points)          # mm, + outside the material
    cloud = cad.sample(12, 1000, seed=0)             # points on the exact surface of face 12

Lengths in mm whatever the file's unit (``source_unit`` records it). A CadModel pickles
as its file's bytes (worker processes read it again), and its content hash is the file's
SHA-256 (``content_hash``), so a run records the same input hash for the file and for the
object read from it.
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..model import PointCloud, TriangleMesh
from .faces import ANALYTIC, CadFace

#: Most faces a model may have (a tessellated STL saved as STEP has one face per
#: triangle; such a file is a mesh and belongs in an STL).
MAX_FACES = 20_000


class CadModel:
    """A STEP/IGES model read by :func:`camcmm.cad.read_cad`.

    faces : list of :class:`CadFace` (``faces[i].index == i + 1``)
    mesh : :class:`~camcmm.model.TriangleMesh`, the tessellation (outward-wound triangles)
    triangle_face : (M,) int64, the 1-based face index of each triangle of ``mesh``
    deflection : the tessellation's linear deflection, mm
    name, source_unit, format ('STEP' or 'IGES'), sha256 (of the file's bytes)
    """

    def __init__(self, path: str | Path, deflection: float | None = None, name: str | None = None):
        from .distance import FaceGeometry
        from .faces import describe
        from .read import read_shape
        from .tessellate import default_deflection, tessellate

        p = Path(path)
        self._bytes = p.read_bytes() if p.is_file() else b""
        self.sha256 = hashlib.sha256(self._bytes).hexdigest()
        self.name = name or p.name
        self.suffix = p.suffix.lower()
        self.shape, self.format, self.source_unit = read_shape(p)
        from OCP.OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
        from OCP.TopAbs import TopAbs_FACE
        from OCP.TopExp import TopExp
        from OCP.TopoDS import TopoDS

        fmap = ShapeMap()
        TopExp.MapShapes_s(self.shape, TopAbs_FACE, fmap)
        n = fmap.Extent()
        if n == 0:
            raise InputError(f"{self.name}: the {self.format} file holds no face (no surface to compare with)")
        if n > MAX_FACES:
            raise InputError(
                f"{self.name}: {n} faces, more than {MAX_FACES}; a model of that many faces is a mesh: "
                "compare with it as STL"
            )
        topo = [TopoDS.Face(fmap.FindKey(i)) for i in range(1, n + 1)]
        described = [describe(f, i) for i, f in enumerate(topo, start=1)]
        self.faces: list[CadFace] = [d[0] for d in described]
        lo = np.min([f.bounds[0] for f in self.faces], axis=0)
        hi = np.max([f.bounds[1] for f in self.faces], axis=0)
        self.bounds = np.vstack([lo, hi])
        self.deflection = float(deflection) if deflection else default_deflection(self.bounds)
        self._deflection_given = deflection
        V, T, tf, uv = tessellate(self.shape, topo, self.deflection, self.name)
        self.mesh = TriangleMesh(V, T, name=f"{self.name} (tessellation)", source_unit=self.source_unit)
        self.triangle_face = tf
        self.uv = uv
        self._geometry = FaceGeometry([d[1] for d in described])
        self._topo = [None, *topo]
        self._distance: Any = None

    # ------------------------------------------------------------------ pickling, hashing
    def __getstate__(self) -> dict[str, Any]:
        return {"bytes": self._bytes, "name": self.name, "suffix": self.suffix, "deflection": self._deflection_given}

    def __setstate__(self, state: dict[str, Any]) -> None:
        with tempfile.TemporaryDirectory(prefix="camcmm-cad-") as tmp:
            path = Path(tmp) / ("model" + state["suffix"])
            path.write_bytes(state["bytes"])
            self.__init__(path, state["deflection"], state["name"])  # type: ignore[misc]

    def content_hash(self) -> str:
        """SHA-256 of the file's bytes (what a run records as this input's hash)."""
        return self.sha256

    # ------------------------------------------------------------------ queries
    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def face(self, index: int) -> CadFace:
        """Face ``index`` (1-based); InputError naming the model when there is none."""
        try:
            i = int(index)
        except (TypeError, ValueError):
            raise InputError(f"{self.name}: face {index!r} is not a face number") from None
        if not 1 <= i <= len(self.faces):
            raise InputError(f"{self.name}: no face {i}; faces are numbered 1 to {len(self.faces)}")
        return self.faces[i - 1]

    @property
    def distance_engine(self) -> Any:
        """The prepared :class:`~camcmm.cad.distance.CadDistance` (built on first use)."""
        if self._distance is None:
            from ..meshdistance import MeshDistance
            from .distance import CadDistance

            md = MeshDistance(self.mesh)
            tri_uv = self.uv[self.mesh.faces].mean(axis=1)  # the seeds of free-form feet
            self._distance = CadDistance(md, self.triangle_face, self._geometry, self._topo, self.deflection, tri_uv)
        return self._distance

    def distance(self, points: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Signed distances (N,) mm to the exact surface (+ outside the material), the
        closest points (N, 3) and the 1-based index (N,) of the face each lies on."""
        p = np.asarray(points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3:
            raise InputError(f"{self.name}: points must have shape (N, 3), got {p.shape}")
        if len(p) == 0:
            return np.zeros(0), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        d, q, f, _, _ = self.distance_engine(p)
        return d, q, f

    def closest(self, points: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`distance`, plus the outward unit normals (N, 3) at the closest points
        and ``rim`` (N,): True where a closest point lies on the boundary of an open shell
        (for the alignment, which must not pair points with the edge of a partial nominal)."""
        p = np.asarray(points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3:
            raise InputError(f"{self.name}: points must have shape (N, 3), got {p.shape}")
        return self.distance_engine(p)

    def sample(self, face: int | None = None, n: int = 1000, seed: int = 0) -> PointCloud:
        """``n`` points on the exact surface of face ``face`` (1-based; None: the whole
        model), uniform by area: triangles of the tessellation drawn by area, a uniform
        point in each, moved onto the surface (the closed-form foot point for analytic
        faces, the surface at the interpolated (u, v) otherwise). The density is uniform
        to the chord's relative error (≤ deflection / radius). Normals are the outward
        ones; the field ``face`` holds each point's face index."""
        n = int(n)
        if n < 1:
            raise InputError(f"{self.name}: sample needs at least one point, got {n}")
        rng = np.random.default_rng(seed)
        sel = (
            np.arange(len(self.triangle_face))
            if face is None
            else np.flatnonzero(self.triangle_face == self.face(face).index)
        )
        if sel.size == 0:
            raise InputError(f"{self.name}: face {face} has no triangles to sample")
        V, T = self.mesh.vertices, self.mesh.faces[sel]
        tri = V[T]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        pick = rng.choice(sel.size, size=n, p=area / area.sum())
        r1, r2 = rng.random(n), rng.random(n)
        s = np.sqrt(r1)
        bary = np.column_stack([1 - s, s * (1 - r2), s * r2])
        pts = np.einsum("ij,ijk->ik", bary, tri[pick])
        fidx = self.triangle_face[sel[pick]]
        q, nrm, ok = self._geometry.project(pts, fidx, 1e-9 * float(np.linalg.norm(self.bounds[1] - self.bounds[0])))
        other = np.flatnonzero(~ok)
        if other.size:  # no closed form: the surface at the interpolated (u, v)
            from OCP.BRepAdaptor import BRepAdaptor_Surface

            from .faces import outward_normal

            uv = np.einsum("ij,ijk->ik", bary[other], self.uv[T[pick[other]]])
            for j, (u, v) in zip(other, uv):
                f = self._topo[fidx[j]]
                pt = BRepAdaptor_Surface(f).Value(float(u), float(v))
                q[j] = (pt.X(), pt.Y(), pt.Z())
                nn = outward_normal(f, float(u), float(v))
                nrm[j] = nn if nn is not None else 0.0
        return PointCloud(
            q, normals=nrm, fields={"face": fidx.astype(np.int64)}, name=f"{self.name} samples", source_unit="mm"
        )

    def summary(self) -> dict[str, Any]:
        """JSON-able description: format, unit, faces by type, bounds, tessellation."""
        counts: dict[str, int] = {}
        for f in self.faces:
            counts[f.type] = counts.get(f.type, 0) + 1
        return {
            "kind": "cad",
            "format": self.format,
            "name": self.name,
            "source_unit": self.source_unit,
            "n_faces": len(self.faces),
            "face_types": counts,
            "analytic_share": sum(counts.get(t, 0) for t in ANALYTIC) / max(len(self.faces), 1),
            "bounds": self.bounds.tolist(),
            "deflection": self.deflection,
            "n_triangles": int(len(self.triangle_face)),
            "sha256": self.sha256,
        }


def read_cad(path: str | Path, deflection: float | None = None) -> CadModel:
    """Read a STEP (.step, .stp) or IGES (.iges, .igs) file as a :class:`CadModel` in mm.

    ``deflection`` (mm) is the tessellation's linear deflection (default 10 µm, finer for
    parts under 100 mm); the distances do not depend on it (they are exact), only their
    cost and the alignment's mesh. Refusals are one-line InputErrors naming the file."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p.name}: file not found ({p})")
    if not p.is_file():
        raise InputError(f"{p.name}: not a file ({p})")
    if p.stat().st_size == 0:
        raise InputError(f"{p.name}: the file is empty (0 bytes)")
    if deflection is not None and not (np.isfinite(deflection) and deflection > 0):
        raise InputError(f"{p.name}: deflection = {deflection} mm must be positive and finite")
    try:
        return CadModel(p, deflection)
    except InputError:
        raise
    except MemoryError:
        raise InputError(f"{p.name}: not enough memory to read the CAD file") from None
    except Exception as exc:  # OpenCascade's own failure, reworded to name the file
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise InputError(f"{p.name}: cannot read the CAD file ({reason})") from exc
