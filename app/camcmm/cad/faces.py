"""The faces of a CAD B-rep: each face's analytic type and parameters, its outward normal
side, bounds and area.

OpenCascade describes an elementary face by a surface placed by a ``gp_Ax3`` (which may be
left-handed) and an orientation flag (``TopAbs_REVERSED`` turns the face's normal over
against its surface's ``dS/du × dS/dv``). Rather than untangle the two conventions per
type, the outward side is measured: the normal OpenCascade computes at a point of the
face (``BRepLProp_SLProps``, turned over for a reversed face, so it points out of the
material of a solid) is compared with the direction away from the axis or centre (the
plane's axis direction for a plane). ``sense`` is the sign of that comparison: +1 for a
boss or a ball (material on the axis side), -1 for a bore or a spherical cavity; for a
plane the stored normal is the outward one and ``sense`` is +1.

Parameters carry the names of the GD&T plan's feature types (plugins/camcmm_plugins/gdt
model.FEATURE_TYPES): plane ``point``/``normal`` (outward), cylinder ``point``/``axis``/
``diameter``, cone ``apex``/``axis``/``angle`` (full apex angle in degrees, the axis
pointing from the apex into the cone), sphere ``centre``/``diameter``, torus ``centre``/
``axis``/``major_diameter``/``minor_diameter``; lengths in mm. The ``point`` of a plane and
of a cylinder is the foot of the face's centre of area on the plane or the axis.

OCP (cadquery-ocp-novtk) is imported by the functions, never at module import.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Face types of :class:`CadFace`; the first five have closed-form projections.
ANALYTIC = ("plane", "cylinder", "cone", "sphere", "torus")
TYPES = (*ANALYTIC, "bspline", "other")


@dataclass(eq=False)
class CadFace:
    """One face of a CAD model.

    index : 1-based, the order in which OpenCascade's ``TopExp::MapShapes`` (the first
        visit of ``TopExp_Explorer``) meets the faces
    type : one of :data:`TYPES`
    params : the type's parameters (see the module docstring), mm and degrees; empty for
        ``bspline`` and ``other``
    bounds : (2, 3) mm, the face's bounding box (min, max corner)
    area : mm²
    sense : +1 when the outward normal points away from the axis or centre (boss, ball;
        always +1 for a plane), -1 when it points towards it (bore, cavity)
    """

    index: int
    type: str
    params: dict[str, Any]
    bounds: np.ndarray
    area: float
    sense: int = 1
    surface: str = ""  # OpenCascade's own name of the surface type (GeomAbs_...)
    face: Any = field(default=None, repr=False)  # the TopoDS_Face

    def to_json(self) -> dict[str, Any]:
        """JSON-able summary (vectors as lists)."""
        p = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.params.items()}
        return {
            "index": self.index,
            "type": self.type,
            "params": p,
            "bounds": self.bounds.tolist(),
            "area": self.area,
            "sense": self.sense,
        }


def _xyz(p: Any) -> np.ndarray:
    return np.array([p.X(), p.Y(), p.Z()], dtype=float)


def outward_normal(face: Any, u: float, v: float) -> np.ndarray | None:
    """The unit normal of ``face`` at (u, v) turned out of the material (the face's
    orientation respected); None where the surface has no normal (a pole, an apex)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepLProp import BRepLProp_SLProps
    from OCP.TopAbs import TopAbs_REVERSED

    props = BRepLProp_SLProps(BRepAdaptor_Surface(face), u, v, 1, 1e-9)
    if not props.IsNormalDefined():
        return None
    n = _xyz(props.Normal())
    return -n if face.Orientation() == TopAbs_REVERSED else n


def _centre_of_area(face: Any) -> tuple[np.ndarray, float]:
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    g = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, g)
    return _xyz(g.CentreOfMass()), float(g.Mass())


def _bounds(face: Any) -> np.ndarray:
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.AddOptimal_s(face, box, False, False)
    return np.vstack([_xyz(box.CornerMin()), _xyz(box.CornerMax())])


def _mid_uv(face: Any) -> tuple[float, float]:
    """A (u, v) inside the face: the middle of its parameter box, else a node of its
    triangulation (a face may not cover the middle of its box: an annulus)."""
    from OCP.BRepClass import BRepClass_FaceClassifier
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_Pnt2d
    from OCP.TopAbs import TopAbs_IN

    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    for fu, fv in ((0.5, 0.5), (0.31, 0.47), (0.73, 0.29), (0.11, 0.83), (0.9, 0.9), (0.05, 0.05)):
        u, v = u0 + fu * (u1 - u0), v0 + fv * (v1 - v0)
        if BRepClass_FaceClassifier(face, gp_Pnt2d(u, v), 1e-7).State() == TopAbs_IN:
            return u, v
    return 0.5 * (u0 + u1), 0.5 * (v0 + v1)


def _away(kind: str, q: np.ndarray, g: dict[str, Any]) -> np.ndarray:
    """Unit direction away from the axis / centre / tube centre at a surface point ``q``."""
    if kind == "sphere":
        d = q - g["centre"]
    else:
        a = np.asarray(g["axis"])
        o = np.asarray(g["centre"] if kind == "torus" else g["apex"] if kind == "cone" else g["point"])
        w = q - o
        r = w - (w @ a) * a
        if kind == "torus":
            r = r / max(np.linalg.norm(r), 1e-300)
            d = q - (o + float(g["major_radius"]) * r)
        elif kind == "cone":
            e = r / max(np.linalg.norm(r), 1e-300)
            alpha = float(g["half_angle"])
            d = -np.sin(alpha) * a + np.cos(alpha) * e
        else:
            d = r
    return d / max(float(np.linalg.norm(d)), 1e-300)


def describe(face: Any, index: int) -> tuple[CadFace, dict[str, Any]]:
    """The :class:`CadFace` of an OCP ``TopoDS_Face`` and the geometry its projection uses
    (``kind`` and, in mm and radians: plane ``point``/``normal`` (outward); cylinder
    ``point``/``axis``/``radius``; cone ``apex``/``axis``/``half_angle``; sphere
    ``centre``/``radius``; torus ``centre``/``axis``/``major_radius``/``minor_radius``;
    with ``sense``)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import (
        GeomAbs_BSplineSurface,
        GeomAbs_Cone,
        GeomAbs_Cylinder,
        GeomAbs_Plane,
        GeomAbs_Sphere,
        GeomAbs_Torus,
    )

    ad = BRepAdaptor_Surface(face)
    st = ad.GetType()
    centre, area = _centre_of_area(face)
    u, v = _mid_uv(face)
    q = _xyz(ad.Value(u, v))
    n_out = outward_normal(face, u, v)
    g: dict[str, Any]
    if st == GeomAbs_Plane:
        pos = ad.Plane().Position()
        n = _xyz(pos.Direction())
        if n_out is not None and n @ n_out < 0:
            n = -n
        foot = centre - ((centre - _xyz(pos.Location())) @ n) * n
        g = {"kind": "plane", "point": foot, "normal": n}
        params = {"point": foot, "normal": n}
    elif st == GeomAbs_Cylinder:
        cyl = ad.Cylinder()
        a = _xyz(cyl.Axis().Direction())
        o = _xyz(cyl.Location())
        o = o + ((centre - o) @ a) * a
        g = {"kind": "cylinder", "point": o, "axis": a, "radius": cyl.Radius()}
        params = {"point": o, "axis": a, "diameter": 2 * cyl.Radius()}
    elif st == GeomAbs_Cone:
        cone = ad.Cone()
        alpha = cone.SemiAngle()
        a = _xyz(cone.Axis().Direction()) * (1.0 if alpha > 0 else -1.0)  # from the apex into the cone
        apex = _xyz(cone.Apex())
        g = {"kind": "cone", "apex": apex, "axis": a, "half_angle": abs(alpha)}
        params = {"apex": apex, "axis": a, "angle": float(np.degrees(2 * abs(alpha)))}
    elif st == GeomAbs_Sphere:
        sph = ad.Sphere()
        c = _xyz(sph.Location())
        g = {"kind": "sphere", "centre": c, "radius": sph.Radius()}
        params = {"centre": c, "diameter": 2 * sph.Radius()}
    elif st == GeomAbs_Torus:
        tor = ad.Torus()
        c = _xyz(tor.Location())
        a = _xyz(tor.Axis().Direction())
        g = {"kind": "torus", "centre": c, "axis": a}
        g.update(major_radius=tor.MajorRadius(), minor_radius=tor.MinorRadius())
        params = {
            "centre": c,
            "axis": a,
            "major_diameter": 2 * tor.MajorRadius(),
            "minor_diameter": 2 * tor.MinorRadius(),
        }
    else:
        kind = "bspline" if st == GeomAbs_BSplineSurface else "other"
        g = {"kind": kind}
        params = {}
    sense = 1
    if g["kind"] in ("cylinder", "cone", "sphere", "torus") and n_out is not None:
        sense = 1 if _away(g["kind"], q, g) @ n_out >= 0 else -1
    g["sense"] = sense
    name = str(st).rsplit(".", 1)[-1]
    return CadFace(index, g["kind"], params, _bounds(face), area, sense, name, face), g
