"""The tessellation of a CAD shape: one triangle mesh over all faces, each triangle
knowing its face and each vertex its (u, v) on that face's surface.

``BRepMesh_IncrementalMesh`` meshes every face so that no facet lies farther than the
linear ``deflection`` (mm) from its surface, and the faces' boundary nodes are shared
(the edges are discretised once), so the welded mesh is closed where the B-rep is. A
reversed face's triangles are turned over so that every triangle's normal points out of
the material, like the face's.

Measured on NIST CTC 01 (800 × 450 × 150 mm, 117 faces) at 0.01 mm: 11 176 triangles in
0.13 s, facet distance to the exact surface 0.64 µm mean, 5.65 µm max.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError

#: Angular deflection of the tessellation, rad: keeps small radii from being meshed by
#: a few long facets whose chord is within the linear deflection only by their length.
ANGULAR = 0.2


def default_deflection(bounds: np.ndarray) -> float:
    """10 µm, or 1e-3 of the bounding-box diagonal for parts below 10 mm (mm). The
    distances are exact whatever the deflection (camcmm.cad.distance); it sets the cost
    (the mesh query, the preparation) and how often a point near an edge is left to
    OpenCascade."""
    diag = float(np.linalg.norm(bounds[1] - bounds[0]))
    return float(min(0.01, max(1e-3 * diag, 1e-5)))


def tessellate(
    shape: Any, faces: list[Any], deflection: float, name: str = "CAD"
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(vertices (V, 3) mm, triangles (M, 3), triangle_face (M,) 1-based face index,
    uv (V, 2))`` of ``shape`` meshed at ``deflection``. ``faces`` are the TopoDS_Faces in
    index order. Vertices of different faces are not merged (their (u, v) differ)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopLoc import TopLoc_Location

    BRepMesh_IncrementalMesh(shape, float(deflection), False, ANGULAR, True)
    verts, uvs, tris, owner = [], [], [], []
    base = 0
    for k, face in enumerate(faces, start=1):
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(face, loc)
        if tri is None:
            continue  # a face the mesher could not triangulate: distances fall back on OpenCascade
        trsf = loc.Transformation()
        nn = tri.NbNodes()
        v = np.empty((nn, 3))
        uv = np.zeros((nn, 2))
        has_uv = tri.HasUVNodes()
        for j in range(1, nn + 1):
            p = tri.Node(j).Transformed(trsf)
            v[j - 1] = (p.X(), p.Y(), p.Z())
            if has_uv:
                q = tri.UVNode(j)
                uv[j - 1] = (q.X(), q.Y())
        t = np.array([tri.Triangle(j).Get() for j in range(1, tri.NbTriangles() + 1)], dtype=np.int64) - 1
        if t.size == 0:
            continue
        if face.Orientation() == TopAbs_REVERSED:
            t = t[:, ::-1]
        verts.append(v)
        uvs.append(uv)
        tris.append(t + base)
        owner.append(np.full(len(t), k, dtype=np.int64))
        base += nn
    if not tris:
        raise InputError(f"{name}: OpenCascade could not tessellate any face")
    return np.vstack(verts), np.vstack(tris), np.concatenate(owner), np.vstack(uvs)
