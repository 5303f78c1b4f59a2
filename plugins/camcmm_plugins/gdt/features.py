"""Features of a measured cloud: which points belong to a feature, and the element
associated with them (ISO 14405-1, ISO 5459, ISO 1101).

Public functions
----------------
surface_distance(points, type, params) -> (N,)
    Signed distance (mm) of points from a nominal or associated element: + outside the
    material (for an ``internal`` feature — a hole, a bore — that is towards the axis or
    centre), on the normal's side of a plane; a line's and a point's distance is ≥ 0.
select(points, spec, cad=None, warnings=None) -> (n,) indices
    The points within ``spec.band`` of the nominal surface and inside the feature's
    extent: ``spec.box`` if given, and a cylinder's or line's ``length`` from its
    ``point`` along its axis. Without either a plane, a cone or a cylinder/line without a
    length is unlimited; :func:`extent_note` says so (appended to ``warnings``).
associate(points, indices, spec, association=None) -> Associated
    The element associated with the feature's points by one of
    :data:`.model.ASSOCIATIONS` (default ``spec.association``).
resolve_face(spec, cad) -> FeatureSpec
    A ``face`` feature as the analytic feature its CAD face is (plane, cylinder, ...).

Associations
------------
* ``ls`` (least squares, Gaussian) — the fitting plugin (``fit.<element>`` by id). Its
  covariance is carried in the global parameters of :class:`.model.Associated`
  (``covariance_names`` such as ``point_x ... axis_z, diameter``; singular, since a
  direction has two degrees of freedom): ``s² (JᵀJ)⁻¹`` with ``s² = Σr²/(n − p)`` from the
  Jacobian of :func:`surface_distance` in a local parametrisation (shifts and tilts
  normal to the axis about the reported point), mapped to the global names. The plugin's
  own covariance is over its internal local parameters in a basis it does not report,
  so it is recomputed here (the two agree; tests/gdt/test_features.py checks them).
* ``minzone`` (Chebyshev) — the fitting plugin for plane, sphere, cone and torus. For a
  circle (in its plane), a cylinder and a line (the thinnest cylinder about a line:
  straightness in space) the fitting plugin has none, and plugins may not import each
  other, so they are computed here by sequential linear programming (:func:`_slp`).
* ``mincircumscribed`` / ``maxinscribed`` (ISO 12181-2, ISO 12180-2, ISO 14405-1 GN/GX)
  for circle, cylinder and sphere — also by :func:`_slp`; refused when the points leave
  more than half the circumference (a hemisphere) open, where the criterion has no
  meaning (a 30° arc's circumscribed circle is the one on its chord).
* ``tangent`` — the ISO 5459 default for datums: for a plane the outer tangent plane
  (minimax constrained outside the material: all points on the material side, the
  largest distance minimal). For every orientation the best such plane touches the
  highest point and its largest distance is the points' extent along the normal, so it
  is the minimum-zone orientation shifted to the zone's outer face. A shaft (cylinder,
  circle, sphere) takes the minimum circumscribed element, a hole (``internal: true``)
  the maximum inscribed one; other types fall back to least squares with a warning.

Parameters (mm, unit directions, degrees): plane ``point``/``normal`` (normal as the
nominal's, away from the material); line ``point``/``direction``/``length`` (``point``
the foot at the start of its points' extent); point ``point``; circle ``centre``/
``normal``/``diameter``; cylinder ``point``/``axis``/``diameter``/``length`` (``point`` the
foot of the axis at the start of the points' extent along the nominal axis' direction,
``length`` that extent); sphere ``centre``/``diameter``; cone ``apex``/``axis``/``angle``
(axis from the apex into the cone, full apex angle); torus ``centre``/``axis``/
``major_diameter``/``minor_diameter``. Closed elements carry ``internal``. A circle's
residuals are its points' radial deviations in its plane (ISO 12181 roundness); every
other element's are :func:`surface_distance`.

References: ISO 14405-1:2016, ISO 5459:2011 §6 (datum association), ISO 12181-2:2011
(roundness), ISO 12180-2:2011 (cylindricity), ISO 12780-2 (straightness); G. T. Anthony
et al., Precision Engineering 19 (1996) 28-36 (Chebyshev elements); A. B. Forbes, NPL
DITC 140/89 (least-squares elements).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.optimize import linprog

from camcmm.api import CamcmmError, GeometryError, InputError, ParameterError, PointCloud, default_host

from .model import ASSOCIATIONS, Associated, FeatureSpec

#: Parameter names of each element type, in the order of the covariance's global names.
NAMES: dict[str, tuple[str, ...]] = {
    "plane": ("point", "normal"),
    "line": ("point", "direction"),
    "point": ("point",),
    "circle": ("centre", "normal", "diameter"),
    "cylinder": ("point", "axis", "diameter"),
    "sphere": ("centre", "diameter"),
    "cone": ("apex", "axis", "angle"),
    "torus": ("centre", "axis", "major_diameter", "minor_diameter"),
}
#: Elements with an inside and an outside (``internal`` flips the sign of distances).
CLOSED = ("circle", "cylinder", "sphere", "cone", "torus")
#: Elements min circumscribed / max inscribed apply to.
ROUND = ("circle", "cylinder", "sphere")
_VECTORS = ("point", "centre", "apex", "normal", "axis", "direction")
_DIRECTIONS = ("normal", "axis", "direction")


def _unit(v: Any) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _complement(n: np.ndarray) -> np.ndarray:
    """(2, 3) orthonormal rows b1, b2 perpendicular to the unit vector n."""
    a = np.zeros(3)
    a[int(np.argmin(np.abs(n)))] = 1.0
    b1 = np.cross(n, a)
    b1 /= np.linalg.norm(b1)
    return np.vstack([b1, np.cross(n, b1)])


def _axial(points: np.ndarray, p: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heights along the unit axis a above p and distances from the axis, of points (N, 3)."""
    w = points - p
    h = w @ a
    rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", w, w) - h * h, 0.0))
    # the subtraction above loses digits for points near the axis: recompute those exactly
    near = rho < 1e-4 * (np.abs(h) + 1e-300)
    if near.any():
        rho[near] = np.linalg.norm(w[near] - h[near, None] * a, axis=1)
    return h, rho


def surface_distance(points: Any, type: str, params: dict[str, Any]) -> np.ndarray:  # noqa: A002 - the plan's word
    """Signed distance (N,) in mm of points (N, 3) from the element ``type`` with
    ``params`` (the names of :data:`NAMES`, as a FeatureSpec's nominal or an Associated's
    params; ``internal`` true flips the sign of a closed element).

    plane (x − point)·normal; line and point the (unsigned) distance; circle the distance
    from the circle curve, sqrt(h² + (ρ − r)²), signed as ρ − r; cylinder ρ − r; sphere
    |x − centre| − r; cone ρ cos ψ − z sin ψ (z along the axis from the apex, ψ the half
    angle; a point whose foot would lie beyond the apex: its distance from the apex);
    torus sqrt((ρ − R)² + z²) − r. ρ is the distance from the axis (circle: in its plane).
    """
    x = np.asarray(points, dtype=float)
    if type == "plane":
        d = (x - params["point"]) @ _unit(params["normal"])
    elif type == "line":
        return _axial(x, np.asarray(params["point"], float), _unit(params["direction"]))[1]
    elif type == "point":
        return np.linalg.norm(x - params["point"], axis=1)
    elif type == "circle":
        h, rho = _axial(x, np.asarray(params["centre"], float), _unit(params["normal"]))
        e = rho - 0.5 * params["diameter"]
        d = np.where(e >= 0, 1.0, -1.0) * np.hypot(e, h)
    elif type == "cylinder":
        d = _axial(x, np.asarray(params["point"], float), _unit(params["axis"]))[1] - 0.5 * params["diameter"]
    elif type == "sphere":
        d = np.linalg.norm(x - params["centre"], axis=1) - 0.5 * params["diameter"]
    elif type == "cone":
        z, rho = _axial(x, np.asarray(params["apex"], float), _unit(params["axis"]))
        psi = np.radians(0.5 * params["angle"])
        c, s = np.cos(psi), np.sin(psi)
        d = np.where(z * c + rho * s >= 0, rho * c - z * s, np.hypot(z, rho))
    elif type == "torus":
        z, rho = _axial(x, np.asarray(params["centre"], float), _unit(params["axis"]))
        d = np.hypot(rho - 0.5 * params["major_diameter"], z) - 0.5 * params["minor_diameter"]
    else:
        raise ParameterError(f"no distance for a {type!r}; use one of {', '.join(NAMES)}")
    return -d if params.get("internal") and type in CLOSED else d


# -- selection ------------------------------------------------------------------------------


def extent_note(spec: FeatureSpec) -> str | None:
    """A warning for a feature whose extent is unlimited (no box, no length): every
    point of the cloud near its infinite nominal surface belongs to it."""
    if spec.box is not None:
        return None
    if spec.type in ("plane", "cone") or (spec.type in ("cylinder", "line") and "length" not in spec.nominal):
        what = "length or box" if spec.type in ("cylinder", "line") else "box"
        return (
            f"feature {spec.id}: no {what}, so its extent is unlimited — every point within "
            f"{spec.band:g} mm of the infinite {spec.type} belongs to it"
        )
    return None


def select(points: Any, spec: FeatureSpec, cad: Any = None, warnings: list[str] | None = None) -> np.ndarray:
    """Indices (n,) of the points (N, 3) mm that belong to feature ``spec``: within
    ``spec.band`` of its nominal surface (|distance| ≤ band) and inside its extent (the
    box, corners included; a cylinder's or line's ``length`` along its axis from its
    ``point``). A ``face`` feature takes the points whose nearest CAD face is its face
    (``cad.distance``). An unlimited extent adds :func:`extent_note` to ``warnings``."""
    x = np.asarray(points, dtype=float)
    if spec.type == "face":
        if cad is None:
            raise InputError(f"features.{spec.id}: a CAD face (cad: {spec.nominal.get('cad')}) needs a STEP nominal")
        _cad_face(spec, cad)
        d, _, face = cad.distance(x)
        inside = (np.asarray(face) == spec.nominal["cad"]) & (np.abs(d) <= spec.band)
    else:
        inside = np.abs(surface_distance(x, spec.type, spec.nominal)) <= spec.band
        if spec.type in ("cylinder", "line") and "length" in spec.nominal:
            axis = spec.nominal["axis" if spec.type == "cylinder" else "direction"]
            t = (x - spec.nominal["point"]) @ axis
            inside &= (t >= 0) & (t <= spec.nominal["length"])
    if spec.box is not None:
        inside &= np.all((x >= spec.box[0]) & (x <= spec.box[1]), axis=1)
    note = extent_note(spec) if spec.type != "face" else None
    if note and warnings is not None:
        warnings.append(note)
    return np.flatnonzero(inside)


def _cad_face(spec: FeatureSpec, cad: Any) -> Any:
    """The CAD face a ``face`` feature names (1-based), or a one-line refusal."""
    n_faces = len(cad.faces)
    if not 1 <= spec.nominal["cad"] <= n_faces:
        raise InputError(f"features.{spec.id}.cad: face {spec.nominal['cad']} does not exist (the CAD has {n_faces})")
    return cad.faces[spec.nominal["cad"] - 1]


def resolve_face(spec: FeatureSpec, cad: Any) -> FeatureSpec:
    """A ``face`` feature as the analytic feature of its CAD face: type and nominal from
    ``cad.faces[cad - 1]``, ``internal`` when the plan says so or the face's outward
    normal points towards its axis or centre (``sense`` −1: a bore), the box (when the
    plan gives none) the face's bounds widened by the band; band and association kept.
    A free-form face (bspline, other) is returned unchanged: it has a surface profile,
    no element."""
    if spec.type != "face":
        return spec
    face = _cad_face(spec, cad)
    if face.type not in NAMES:
        return spec
    nominal = {k: (np.asarray(v, dtype=float) if k in _VECTORS else v) for k, v in face.params.items()}
    nominal["internal"] = bool(spec.nominal.get("internal", False)) or getattr(face, "sense", 1) < 0
    if face.type == "cylinder" and "length" not in nominal:
        _cylinder_extent(nominal, cad, int(spec.nominal["cad"]))
    box = spec.box
    if box is None:
        bounds = np.asarray(face.bounds, dtype=float)
        box = np.array([bounds[0] - spec.band, bounds[1] + spec.band])
    return replace(spec, type=face.type, nominal=nominal, box=box)


def _cylinder_extent(nominal: dict[str, Any], cad: Any, index: int) -> None:
    """A CAD cylinder's ``point`` moved to the start of the face along its axis and its
    ``length`` set, as a plan's cylinder states them: a position's axis ends are then the
    face's ends, not the extent of whichever points were measured. The extent is that of
    the face's tessellation vertices, which BRepMesh places on the face's boundary edges
    (exact for a cylinder cut square to its axis; for an oblique cut the vertices between
    the edge's extremes are at most one deflection short)."""
    mesh = getattr(cad, "mesh", None)
    tri_face = getattr(cad, "triangle_face", None)
    if mesh is None or tri_face is None:
        return
    faces = np.asarray(mesh.faces)[np.asarray(tri_face) == index]
    if len(faces) == 0:
        return
    v = np.asarray(mesh.vertices, dtype=float)[np.unique(faces)]
    p, a = np.asarray(nominal["point"], dtype=float), np.asarray(nominal["axis"], dtype=float)
    t = (v - p) @ a
    nominal["point"] = p + t.min() * a
    nominal["length"] = float(t.max() - t.min())


# -- association ----------------------------------------------------------------------------


def associate(points: Any, indices: Any, spec: FeatureSpec, association: str | None = None) -> Associated:
    """The element associated with the points ``points[indices]`` of feature ``spec``
    by ``association`` (default ``spec.association``; see the module docstring).

    Raises GeometryError (one line naming the feature) when the points do not determine
    the element, ParameterError for an association the type has none of."""
    how = association or spec.association
    if how not in ASSOCIATIONS:
        raise ParameterError(f"features.{spec.id}: unknown association {how!r}; use one of {', '.join(ASSOCIATIONS)}")
    if spec.type not in NAMES:
        raise InputError(f"features.{spec.id}: a {spec.type} feature cannot be associated (a CAD face: resolve it)")
    idx = np.asarray(indices, dtype=np.int64).reshape(-1)
    cloud = np.asarray(points, dtype=float)
    if len(idx) == 0:
        raise GeometryError(f"features.{spec.id}: no points belong to it")
    if idx.min() < 0 or idx.max() >= len(cloud):
        raise InputError(f"features.{spec.id}: point index {int(idx.max())} is outside the {len(cloud)} points")
    x = cloud[idx]
    if not np.isfinite(x).all():
        raise InputError(f"features.{spec.id}: its points have NaN or Inf coordinates")
    internal = bool(spec.nominal.get("internal", False))
    warnings: list[str] = []
    if how == "tangent":
        if spec.type in ROUND:
            how = "maxinscribed" if internal else "mincircumscribed"
        elif spec.type != "plane":
            warnings.append(
                f"feature {spec.id}: no tangent (ISO 5459) association for a {spec.type}; least squares used"
            )
            how = "ls"
    if how in ("mincircumscribed", "maxinscribed") and spec.type not in ROUND:
        raise ParameterError(
            f"features.{spec.id}: association {how} is for a circle, cylinder or sphere, not a {spec.type}"
        )
    if spec.type == "point" and how != "ls":
        warnings.append(f"feature {spec.id}: a point is associated by its centroid (least squares), not {how}")
        how = "ls"
    try:
        params, cov, names, more = _associate(x, spec, how)
    except CamcmmError as exc:
        msg = str(exc)
        raise type(exc)(msg if msg.startswith(f"features.{spec.id}") else f"features.{spec.id}: {msg}") from None
    warnings += more
    if spec.type in CLOSED:
        params["internal"] = internal
    _extent(x, spec, params)
    if spec.type == "circle":
        res = _axial(x, params["centre"], params["normal"])[1] - 0.5 * params["diameter"]
        residuals = -res if internal else res
    else:
        residuals = surface_distance(x, spec.type, params)
    return Associated(
        id=spec.id,
        type=spec.type,
        association=how,
        indices=idx,
        params=params,
        residuals=residuals,
        form=_form(residuals),
        covariance=cov,
        covariance_names=names,
        warnings=warnings,
    )


def _form(r: np.ndarray) -> dict[str, float]:
    if len(r) == 0:
        return {k: float("nan") for k in ("range", "max", "min", "std", "rms")}
    return {
        "range": float(r.max() - r.min()),
        "max": float(r.max()),
        "min": float(r.min()),
        "std": float(r.std(ddof=1)) if len(r) > 1 else float("nan"),
        "rms": float(np.sqrt(np.mean(r * r))),
    }


def _extent(x: np.ndarray, spec: FeatureSpec, params: dict[str, Any]) -> None:
    """Orient directions as the nominal's and move a cylinder's or line's ``point`` to
    the foot at the start of its points' extent, with ``length`` that extent."""
    for name in _DIRECTIONS:
        if name in params and name in spec.nominal and params[name] @ spec.nominal[name] < 0:
            if spec.type == "cone":
                continue  # a cone's axis points from the apex into the cone, whatever the plan says
            params[name] = -params[name]
    if spec.type in ("cylinder", "line"):
        a = params["axis" if spec.type == "cylinder" else "direction"]
        t = (x - params["point"]) @ a
        params["point"] = params["point"] + t.min() * a
        params["length"] = float(t.max() - t.min())


def fit_plugin(element: str, x: np.ndarray, method: str = "ls") -> tuple[dict[str, Any], list[str]]:
    """The fitting plugin ``fit.<element>`` on points (n, 3): its outputs and warnings."""
    params: dict[str, Any] = {"outliers": "none"}
    if element in ("plane", "sphere", "cone", "torus"):
        params["method"] = method
    run = default_host().run(f"fit.{element}", {"cloud": PointCloud(x)}, params)
    return run.outputs, list(run.warnings)


def _associate(
    x: np.ndarray, spec: FeatureSpec, how: str
) -> tuple[dict[str, Any], np.ndarray | None, tuple[str, ...], list[str]]:
    t = spec.type
    if how == "ls" or (how == "minzone" and t in ("plane", "sphere", "cone", "torus")):
        if t == "point":
            params: dict[str, Any] = {"point": x.mean(axis=0)}
            notes: list[str] = []
        else:
            out, notes = fit_plugin(t, x, how)
            params = _from_plugin(t, out)
        if how == "ls":
            _extent(x, spec, params)  # the covariance is of the reported point
            cov, names = ls_covariance(x, t, params)
            return params, cov, names, notes
        return params, None, (), notes
    if how == "tangent":  # a plane: the minimum-zone orientation, on the zone's outer face
        out, notes = fit_plugin("plane", x, "minzone")
        params = _from_plugin("plane", out)
        if params["normal"] @ spec.nominal["normal"] < 0:
            params["normal"] = -params["normal"]
        params["point"] = params["point"] + float(np.max((x - params["point"]) @ params["normal"])) * params["normal"]
        return params, None, (), notes
    # minzone (circle, cylinder, line), mincircumscribed, maxinscribed: by SLP from least squares
    start_type = "cylinder" if t == "line" else t
    if t == "line":
        out, notes = fit_plugin("line", x)
        start = {"point": np.asarray(out["point"], float), "axis": _unit(out["direction"]), "diameter": 0.0}
    else:
        out, notes = fit_plugin(t, x)
        start = _from_plugin(t, out)
    criterion = "mincircumscribed" if t == "line" else how
    params = _radial_association(x, start_type, start, criterion, spec.id)
    if t == "line":
        params = {"point": params["point"], "direction": params["axis"], "zone": params["diameter"]}
    return params, None, (), notes


def _from_plugin(t: str, out: dict[str, Any]) -> dict[str, Any]:
    """The fitting plugin's outputs in this module's names (diameters, ``centre``)."""
    v = {k: (np.asarray(out[k], dtype=float) if k in _VECTORS or k == "center" else out[k]) for k in out}
    if t == "plane":
        return {"point": v["point"], "normal": _unit(v["normal"])}
    if t == "line":
        return {"point": v["point"], "direction": _unit(v["direction"])}
    if t == "circle":
        return {"centre": v["center"], "normal": _unit(v["normal"]), "diameter": 2.0 * float(v["radius"])}
    if t == "cylinder":
        return {"point": v["point"], "axis": _unit(v["axis"]), "diameter": 2.0 * float(v["radius"])}
    if t == "sphere":
        return {"centre": v["center"], "diameter": 2.0 * float(v["radius"])}
    if t == "cone":
        return {"apex": v["apex"], "axis": _unit(v["axis"]), "angle": float(v["angle"])}
    if t == "torus":
        return {
            "centre": v["center"],
            "axis": _unit(v["axis"]),
            "major_diameter": 2.0 * float(v["major_radius"]),
            "minor_diameter": 2.0 * float(v["minor_radius"]),
        }
    raise ParameterError(f"no fit for a {t}")


# -- least-squares covariance in the global names -------------------------------------------


def _local_map(t: str, params: dict[str, Any], scale: float) -> tuple[list[tuple[str, np.ndarray | float]], np.ndarray]:
    """The local parameters of element ``t`` at ``params``: a list of (name, change per
    unit of the local parameter) — a vector for vector parameters, a float for scalars —
    and the finite-difference step of each (mm or rad; degrees for a cone angle)."""
    moves: list[tuple[str, np.ndarray | float]] = []
    dirs = {
        "plane": "normal",
        "line": "direction",
        "circle": "normal",
        "cylinder": "axis",
        "cone": "axis",
        "torus": "axis",
    }
    d = dirs.get(t)
    b = _complement(_unit(params[d])) if d else np.eye(3)[:2]
    if t == "plane":
        moves.append(("point", params["normal"]))
    elif t in ("line", "cylinder"):
        moves += [("point", b[0]), ("point", b[1])]
    else:
        pt = {"point": "point", "circle": "centre", "sphere": "centre", "cone": "apex", "torus": "centre"}[t]
        moves += [(pt, e) for e in np.eye(3)]
    if d:
        moves += [(d, b[0]), (d, b[1])]
    for name in NAMES[t]:
        if name not in _VECTORS:
            moves.append((name, 1.0))
    steps = np.array([_step(name, dv, scale) for name, dv in moves])
    return moves, steps


def _components(y: np.ndarray, t: str, params: dict[str, Any]) -> tuple[np.ndarray, int]:
    """The residual components of a least-squares element and how many of them are
    independent: the signed distances (n), but for a circle in space its points' heights
    above its plane and radial deviations in it (2n: the distance sqrt(h² + e²) has no
    derivative in h at h = 0; the fitting plugin's circle uses the same two), for a line
    the vector from the line (3n numbers, 2n independent) and for a point the vector from
    it (3n): an unsigned distance is no Gauss-Markov residual (its linearisation is wrong
    where the residuals are not small against their spread)."""
    if t == "circle":
        h, rho = _axial(y, np.asarray(params["centre"], float), _unit(params["normal"]))
        return np.concatenate([h, rho - 0.5 * params["diameter"]]), 2 * len(y)
    if t == "line":
        d = _unit(params["direction"])
        w = y - params["point"]
        return (w - np.outer(w @ d, d)).ravel(), 2 * len(y)
    if t == "point":
        return (y - params["point"]).ravel(), 3 * len(y)
    return surface_distance(y, t, params), len(y)


def _step(name: str, dv: Any, scale: float) -> float:
    """Central-difference step of a local parameter: 1e-6 of the points' spread for
    lengths, 1e-6 rad for a tilt, 1e-4° for a cone's angle."""
    if name in _DIRECTIONS:
        return 1e-6
    return 1e-4 if name == "angle" else 1e-6 * scale


def ls_covariance(x: np.ndarray, t: str, params: dict[str, Any]) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """Covariance ``s² (JᵀJ)⁻¹`` of a least-squares element over its global parameter
    names (``point_x`` ... ``diameter``; mm, unit-vector components, degrees for a cone's
    angle), ``s² = Σr²/(n − p)``. J is the Jacobian of :func:`surface_distance` in a local
    parametrisation (central differences on points centred on their centroid, accurate
    to ~1e-10 relative — ample for an uncertainty; circles, lines and points use their
    residuals' components, :func:`_components`). None without degrees of freedom.

    A cylinder's or line's ``point`` moves only across its axis here: its place along
    the axis is the start of the points' extent, not a fitted quantity. Checked by
    simulation (400 noisy 200° arcs of a cylinder, σ = 10 µm): the spread of point
    across the axis, of the axis' tilt and of the diameter within 5 % of these figures
    (the statistical scatter of 400 samples' standard deviations is 3.5 %)."""
    centre = x.mean(axis=0)
    y = x - centre
    scale = float(np.sqrt(np.mean(np.einsum("ij,ij->i", y, y)))) or 1.0
    p0 = {k: (np.asarray(v, float) - centre if k in ("point", "centre", "apex") else v) for k, v in params.items()}
    p0 = {k: v for k, v in p0.items() if k in NAMES[t]}
    moves, steps = _local_map(t, p0, scale)
    names = tuple(f"{n}_{c}" if n in _VECTORS else n for n in NAMES[t] for c in ("xyz" if n in _VECTORS else "_"))
    k = len(moves)
    if len(x) <= k:
        return None, names

    def moved(j: int, h: float) -> dict[str, Any]:
        p = dict(p0)
        name, dv = moves[j]
        p[name] = p[name] + h * dv
        return p

    r, m = _components(y, t, p0)
    jac = np.empty((len(r), k))
    for j in range(k):
        h = steps[j]
        jac[:, j] = (_components(y, t, moved(j, h))[0] - _components(y, t, moved(j, -h))[0]) / (2 * h)
    if m <= k:
        return None, names
    s2 = float(r @ r) / (m - k)
    norm = np.linalg.norm(jac, axis=0)
    if not np.all(norm > 0):
        return None, names
    jn = jac / norm
    u, sv, vt = np.linalg.svd(jn, full_matrices=False)
    if sv[-1] <= 1e-12 * sv[0]:
        return None, names
    cov_local = (vt.T / sv**2) @ vt / np.outer(norm, norm) * s2
    # global = Σ_j (change per local parameter j) δ_j
    offsets = {}
    pos = 0
    for n in NAMES[t]:
        offsets[n] = pos
        pos += 3 if n in _VECTORS else 1
    to_global = np.zeros((pos, k))
    for j, (name, dv) in enumerate(moves):
        o = offsets[name]
        if name in _VECTORS:
            to_global[o : o + 3, j] = dv
        else:
            to_global[o, j] = dv
    return to_global @ cov_local @ to_global.T, names


# -- minimum zone, min circumscribed, max inscribed by sequential LP ------------------------

_LP_OPTS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
_ACTIVE = 60  # points per side in the first active set
_GROW = 30  # violators added per side and round


def _radial_association(x: np.ndarray, t: str, start: dict[str, Any], criterion: str, fid: str) -> dict[str, Any]:
    """Circle (in the plane of its least-squares fit), cylinder or sphere associated by
    ``criterion`` (minzone, mincircumscribed, maxinscribed) from the LS ``start``:
    :func:`_slp` on the distances ρ of the points from the centre / axis, in coordinates
    centred on the points and scaled by their spread."""
    origin = x.mean(axis=0)
    y = x - origin
    scale = float(np.sqrt(np.mean(np.einsum("ij,ij->i", y, y))))
    if not scale > 0:
        raise GeometryError("all points coincide")
    y /= scale
    if t == "circle":
        n = start["normal"]
        b = _complement(n)
        q = y @ b.T  # in-plane coordinates
        c0 = ((start["centre"] - origin) / scale) @ b.T
        if criterion != "minzone":
            _check_coverage(np.arctan2(q[:, 1] - c0[1], q[:, 0] - c0[0]), criterion)
        c, lo, hi = _slp(q, c0, _centre_model, criterion)
        plane_h = float(np.mean(y @ n))  # the circle's plane through the points' mean height
        centre = origin + scale * (c @ b + plane_h * n)
        return {"centre": centre, "normal": n, "diameter": scale * _diameter(criterion, lo, hi)}
    if t == "sphere":
        c0 = (start["centre"] - origin) / scale
        if criterion != "minzone":
            _check_hemisphere(y - c0, criterion)
        c, lo, hi = _slp(y, c0, _centre_model, criterion)
        return {"centre": origin + scale * c, "diameter": scale * _diameter(criterion, lo, hi)}
    # cylinder: state [p (3), a (3)]
    a = _unit(start["axis"])
    p = (start["point"] - origin) / scale
    p = p - (p @ a) * a  # the foot of the centroid
    if criterion != "minzone" and start.get("diameter", 0) > 0:
        b = _complement(a)
        w = y - p
        _check_coverage(np.arctan2(w @ b[1], w @ b[0]), criterion)
    state, lo, hi = _slp(y, np.concatenate([p, a]), _axis_model, criterion)
    return {"point": origin + scale * state[:3], "axis": state[3:], "diameter": scale * _diameter(criterion, lo, hi)}


def _diameter(criterion: str, lo: float, hi: float) -> float:
    return 2.0 * {"minzone": 0.5 * (lo + hi), "mincircumscribed": hi, "maxinscribed": lo}[criterion]


def _check_coverage(angles: np.ndarray, criterion: str) -> None:
    a = np.sort(np.mod(angles, 2 * np.pi))
    gap = float(np.max(np.diff(np.concatenate([a, [a[0] + 2 * np.pi]])))) if len(a) else 2 * np.pi
    if gap >= np.pi:
        raise GeometryError(
            f"{criterion} needs points around more than half the circumference (they leave "
            f"{np.degrees(gap):.0f}° open); use ls or minzone"
        )


def _check_hemisphere(u: np.ndarray, criterion: str) -> None:
    """Refuse when all directions u (n, 3) lie in one open hemisphere (max t: u·v ≥ t)."""
    n = len(u)
    res = linprog(
        np.array([0, 0, 0, -1.0]),
        A_ub=np.hstack([-u, np.ones((n, 1))]),
        b_ub=np.zeros(n),
        bounds=[(-1, 1)] * 3 + [(None, 1)],
        method="highs",
    )
    if res.status == 0 and -res.fun > 1e-9 * float(np.abs(u).max()):
        raise GeometryError(
            f"{criterion} needs points all around the sphere (they lie on one side of it); use ls or minzone"
        )


def _centre_model(y: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, Callable]:
    """Distances ρ (n,) of points y (n, d) from the centre c, their Jacobian (n, d) with
    respect to a shift of c, and the update."""
    w = y - c
    rho = np.linalg.norm(w, axis=1)
    jac = -w / np.where(rho > 0, rho, 1.0)[:, None]
    return rho, jac, lambda delta: c + delta


def _axis_model(y: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, np.ndarray, Callable]:
    """Distances ρ (n,) of points y (n, 3) from the axis (p, a), their Jacobian (n, 4)
    with respect to two shifts and two tilts (about p) towards b1, b2 ⊥ a, and the
    update (the axis point moved back to the foot of the centroid, so that tilts and
    shifts stay uncorrelated)."""
    p, a = state[:3], state[3:]
    b = _complement(a)
    w = y - p
    h = w @ a
    wp = w - h[:, None] * a
    rho = np.linalg.norm(wp, axis=1)
    u = wp / np.where(rho > 0, rho, 1.0)[:, None]
    ub = u @ b.T
    jac = np.column_stack([-ub, -h[:, None] * ub])

    def update(delta: np.ndarray) -> np.ndarray:
        p2 = p + delta[0] * b[0] + delta[1] * b[1]
        a2 = _unit(a + delta[2] * b[0] + delta[3] * b[1])
        m = y.mean(axis=0)
        p2 = p2 + ((m - p2) @ a2) * a2
        return np.concatenate([p2, a2])

    return rho, jac, update


def _objective(rho: np.ndarray, criterion: str) -> float:
    if criterion == "minzone":
        return float(rho.max() - rho.min())
    if criterion == "mincircumscribed":
        return float(rho.max())
    return -float(rho.min())


def _slp(
    y: np.ndarray, state: np.ndarray, model: Callable, criterion: str, max_iter: int = 200
) -> tuple[np.ndarray, float, float]:
    """Sequential linear programming for a Chebyshev-type association of the distances
    ρ(state) of points from a centre or an axis (normalised units):

    * minzone: min (u − l) s.t. l ≤ ρ_i + J_i δ ≤ u,
    * mincircumscribed: min u s.t. ρ_i + J_i δ ≤ u,
    * maxinscribed: max l s.t. ρ_i + J_i δ ≥ l,

    each LP with a trust region |δ| ≤ box (HiGHS, on an active set of the extreme
    points grown by the violators), its vertex polished by solving its active
    constraints as equations. A step is kept when the true objective does not grow
    (the box then widens), else the box shrinks; converged when the step or the gain
    vanishes (quadratic near a vertex solution: the linearisation error is O(δ²)).
    Returns the final state and min ρ, max ρ there.
    """
    rho, jac, update = model(y, state)
    f = _objective(rho, criterion)
    box = 0.1
    start_rho = float(np.median(rho)) + 1.0
    for _ in range(max_iter):
        delta = _lp_step(rho, jac, criterion, box)
        new = update(delta)
        rho2, jac2, update2 = model(y, new)
        f2 = _objective(rho2, criterion)
        big = float(np.abs(delta).max())
        if f2 <= f + 1e-15 * max(abs(f), 1.0):
            small = big <= 1e-14 or f - f2 <= 1e-16 * max(abs(f), 1.0)
            state, rho, jac, update, f = new, rho2, jac2, update2, f2
            if small:
                break
            box = max(box, 4 * big)
        else:
            box = 0.25 * big
            if box <= 1e-15:
                break
        if rho.min() > 100 * start_rho:
            raise GeometryError(f"{criterion}: the element grows without bound (the points do not enclose it)")
    else:
        raise GeometryError(f"{criterion} did not converge in {max_iter} iterations")
    return state, float(rho.min()), float(rho.max())


def _lp_step(rho: np.ndarray, jac: np.ndarray, criterion: str, box: float) -> np.ndarray:
    """The LP of :func:`_slp` on all points, solved on a growing active set."""
    n, k = jac.shape
    upper = criterion in ("minzone", "mincircumscribed")
    lower = criterion in ("minzone", "maxinscribed")
    if n <= 4 * _ACTIVE:
        act = np.arange(n)
    else:
        order = np.argsort(rho)
        parts = ([order[-_ACTIVE:]] if upper else []) + ([order[:_ACTIVE]] if lower else [])
        act = np.unique(np.concatenate(parts))
    for _ in range(500):
        sol = _lp(rho[act], jac[act], upper, lower, box)
        delta = sol[:k]
        pred = rho + jac @ delta
        tol = 1e-12 * max(1.0, float(np.abs(sol[k:]).max()))
        add = []
        if upper:
            hi = np.flatnonzero(pred > sol[-1] + tol)
            hi = hi[~np.isin(hi, act)]
            add.append(hi[np.argsort(-pred[hi])[:_GROW]])
        if lower:
            lo = np.flatnonzero(pred < sol[k] - tol)
            lo = lo[~np.isin(lo, act)]
            add.append(lo[np.argsort(pred[lo])[:_GROW]])
        new = np.concatenate(add)
        if len(new) == 0:
            return delta
        act = np.union1d(act, new)
    raise GeometryError("the active set of the linear programme did not settle")


def _lp(rho: np.ndarray, jac: np.ndarray, upper: bool, lower: bool, box: float) -> np.ndarray:
    """One LP over variables (δ (k), [l], [u]); returns them, the vertex polished."""
    m, k = jac.shape
    rows, rhs = [], []
    nv = k + int(lower) + int(upper)
    cost = np.zeros(nv)
    if lower:  # l − J δ ≤ ρ
        a = np.zeros((m, nv))
        a[:, :k] = -jac
        a[:, k] = 1.0
        rows.append(a)
        rhs.append(rho)
        cost[k] -= 1.0
    if upper:  # J δ − u ≤ −ρ
        a = np.zeros((m, nv))
        a[:, :k] = jac
        a[:, -1] = -1.0
        rows.append(a)
        rhs.append(-rho)
        cost[-1] += 1.0
    aub, bub = np.vstack(rows), np.concatenate(rhs)
    bounds = [(-box, box)] * k + [(None, None)] * (nv - k)
    res = linprog(cost, A_ub=aub, b_ub=bub, bounds=bounds, method="highs", options=_LP_OPTS)
    if res.status != 0:
        raise GeometryError(f"the linear programme failed ({res.message})")
    sol = res.x
    # polish: the constraints active at the vertex, as equations, solved directly (HiGHS
    # stops at its feasibility tolerance; the exact vertex makes the SLP converge to
    # machine precision)
    scale = max(1.0, float(np.abs(sol[k:]).max()))
    slack = bub - aub @ sol
    act = np.flatnonzero(slack <= 1e-8 * scale)
    on_box = np.any(np.abs(np.abs(sol[:k]) - box) <= 1e-12 * box)
    if len(act) >= nv and not on_box:
        polished, *_ = np.linalg.lstsq(aub[act], bub[act], rcond=None)
        if np.all(aub @ polished <= bub + 1e-9 * scale) and abs(cost @ polished - cost @ sol) <= 1e-6 * scale:
            sol = polished
    return sol
