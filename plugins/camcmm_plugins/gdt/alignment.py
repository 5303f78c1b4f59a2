"""Aligning a measured cloud to the plan's coordinates (``camcmm gdt evaluate --align``).

:func:`align` returns the rigid transform T (4×4, measured -> plan coordinates) and an
``info`` dict (``method``, ``transform``, ``rms`` mm, ``iterations``, ``converged``,
``free``: the degrees of freedom the method left undetermined, held where the start put
them, ``start``: the coarse start when one was needed, ``n_points``, ``features``). The
methods:

* ``best-fit``: with a nominal (mesh, reference cloud or CAD model) the cloud is aligned
  to it by ``inspect.align`` (robust point-to-plane ICP). Without one, to the nominal
  surfaces of the plan's features: iterated point-to-surface least squares (Gauss-Newton
  on the six rigid parameters) over the points within each feature's band and extent
  (:func:`.features.select`, re-selected at every iteration). "Best fit restricted to
  regions": the plan's ``alignment: {features: [A, H1], boxes: [[[x0,y0,z0],[x1,y1,z1]], ...]}``
  limits the fit to those features and to the points in those boxes (plan coordinates).
* ``datums``: the datum reference frame (ISO 5459) of the plan's datums
  (``alignment: {datums: [A, B, C]}``, by default the longest datum list a characteristic
  names) from :func:`.datums.datum_frame` becomes the part's coordinates; the datum
  features' points are re-selected in the new pose and the frame built again until the
  transform settles (1e-9 mm). The degrees of freedom the datums leave free keep the
  best fit's values (the iteration starts from a best fit).
* ``3-2-1``: classical alignment on least-squares elements: a primary plane fixes three
  degrees of freedom (its normal, its offset), a secondary plane, line or axis two (its
  direction about the primary normal, its offset across), a tertiary plane, point,
  sphere, circle or axis one (the offset along the remaining direction); or, plane-hole-
  slot, a secondary hole (a point, sphere, circle, or an axis along the primary normal)
  two (its position in the plane) and a tertiary hole one (the turn towards it):
  ``alignment: {features: [A, B, C]}`` or ``[A, H1, H2]`` (default: the first three
  single-feature datums).
* ``rps``: reference point system. The plan names reference points, each on a feature and
  fixing given plan directions::

      rps:
        R1: {feature: H1, fixes: [x, y]}             # bore: its axis point at the nominal point
        R2: {feature: H2, fixes: [y]}
        R3: {feature: A, fixes: [z], at: [10, 10, 0]}  # a plane: the surface point at `at`
        R4: {feature: A, fixes: [z], at: [70, 10, 0]}
        R5: {feature: A, fixes: [z], at: [40, 50, 0]}
        R6: {feature: C, fixes: [x], at: [0, 30, 15]}   # (x is fixed by R1 too: least squares)

  The measured reference point of a plane is where the line through ``at`` along its
  nominal normal meets the associated plane; of a cylinder or cone the point of its axis
  nearest ``at`` (default the nominal ``point``/``apex``); of a sphere or circle its
  centre; of a point feature the point. The transform minimises the sum of squared
  differences measured − nominal along each fixed direction (exact with six independent
  fixes; more are a least-squares fit; fewer leave degrees of freedom free, reported).
* ``none``: the cloud is in plan coordinates already.

A part delivered in a scanner's frame (rotated, far from the plan) first gets a coarse
start (``start: auto`` when fewer than half of the plan's features find enough points
within their bands as the cloud lies; ``coarse`` always; ``none`` never): the cloud's
principal axes onto those of points sampled on the nominal surfaces of the plan's
features (within their boxes and extents; or of the nominal geometry when given), each of
the four sign choices refined by ``inspect.align`` ICP and then by best fits in bands
narrowing from 8 mm, the one with most points within the bands kept (FPFH + RANSAC
registration when none holds half the points); the fine method starts from there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from camcmm.api import CadModel, GeometryError, InputError, PointCloud, get_algorithm

from .model import ALIGNMENTS, FeatureSpec, Plan

#: Least points a feature needs to take part in an alignment.
MIN_POINTS = 3
#: Feature types whose nominal surfaces the point-to-surface best fit uses.
SURFACE_TYPES = ("plane", "cylinder", "sphere", "cone", "torus")
#: A step below this (mm, rotations times the part's size) ends an iteration.
SETTLED_MM = 1e-9
#: Singular values of the fit's Jacobian below this share of the largest are free dofs.
FREE_RCOND = 1e-6
#: Share of the measured points within the features' bands above which a principal-axes
#: start is taken without trying the (slower) feature-matching registration.
GOOD_SHARE = 0.5
#: Share of the points within 8 mm of the features' surfaces that must lie within their
#: bands for a best fit from where the cloud lies to be taken without a coarse start.
SETTLED_SHARE = 0.85
#: Measured points the coarse start works on at most (a seeded random subset).
COARSE_POINTS = 20000
#: Points sampled on the nominal surfaces for the coarse start.
COARSE_SAMPLES = 20000
_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


# --------------------------------------------------------------------------- small geometry
def apply(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) mapped by the 4×4 rigid transform ``T``."""
    return np.asarray(points, dtype=float) @ T[:3, :3].T + T[:3, 3]


def _rodrigues(w: np.ndarray) -> np.ndarray:
    t = float(np.linalg.norm(w))
    if t < 1e-300:
        return np.eye(3)
    k = w / t
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def _step(delta: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The rigid 4×4 of a Gauss-Newton step (rotation vector ``delta[:3]`` about ``c``,
    then translation ``delta[3:]``): x -> R (x − c) + c + t."""
    T = np.eye(4)
    R = _rodrigues(delta[:3])
    T[:3, :3] = R
    T[:3, 3] = c - R @ c + delta[3:]
    return T


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` onto unit vector ``b``."""
    v = np.cross(a, b)
    s, c = float(np.linalg.norm(v)), float(np.dot(a, b))
    if s < 1e-15:
        if c > 0:
            return np.eye(3)
        p = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return _rodrigues(np.pi * p / np.linalg.norm(p))
    return _rodrigues(v / s * np.arctan2(s, c))


def _rigid(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def _change(T_new: np.ndarray, T_old: np.ndarray, size: float) -> float:
    """How far (mm) a step moved the part: translation plus rotation times its size."""
    D = T_new @ np.linalg.inv(T_old)
    angle = float(np.arccos(np.clip((np.trace(D[:3, :3]) - 1) / 2, -1.0, 1.0)))
    return float(np.linalg.norm(D[:3, 3])) + angle * size


def _settle(
    step: Callable[[np.ndarray], np.ndarray], T0: np.ndarray, size: float, max_iterations: int, tol: float
) -> tuple[np.ndarray, int, bool]:
    """Iterate ``T <- step(T)`` from ``T0`` until a step moves the part less than ``tol``
    (mm, :func:`_change`) or ``max_iterations`` ran: (T, iterations, settled)."""
    T = T0.copy()
    for it in range(1, max_iterations + 1):
        T_new = step(T)
        moved = _change(T_new, T, size)
        T = T_new
        if moved < tol:
            return T, it, True
    return T, max_iterations, False


def transform_summary(T: np.ndarray) -> dict[str, Any]:
    """Rotation angle (degrees) and axis, translation (mm) of a rigid transform."""
    angle = float(np.degrees(np.arccos(np.clip((np.trace(T[:3, :3]) - 1) / 2, -1.0, 1.0))))
    w = np.array([T[2, 1] - T[1, 2], T[0, 2] - T[2, 0], T[1, 0] - T[0, 1]])
    n = float(np.linalg.norm(w))
    return {
        "rotation_angle_deg": angle,
        "rotation_axis": (w / n).tolist() if n > 1e-15 else [0.0, 0.0, 1.0],
        "translation": T[:3, 3].tolist(),
    }


def surface_distance_normal(points: np.ndarray, ftype: str, nominal: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (N,) of points from a nominal surface and its gradient (N, 3), the
    unit normal there: the residual and Jacobian of the point-to-surface fit. The sign
    only has to agree with the gradient (the fit squares it). Types: :data:`SURFACE_TYPES`."""
    X = np.asarray(points, dtype=float)
    if ftype == "plane":
        n = np.asarray(nominal["normal"], float)
        return (X - nominal["point"]) @ n, np.broadcast_to(n, X.shape)
    if ftype == "sphere":
        v = X - nominal["centre"]
        r = np.linalg.norm(v, axis=1)
        return r - nominal["diameter"] / 2, v / np.maximum(r, 1e-300)[:, None]
    origin = nominal["apex"] if ftype == "cone" else nominal.get("point", nominal.get("centre"))
    a = np.asarray(nominal["axis"], float)
    v = X - origin
    h = v @ a
    radial = v - h[:, None] * a
    rho = np.linalg.norm(radial, axis=1)
    e = radial / np.maximum(rho, 1e-300)[:, None]
    if ftype == "cylinder":
        return rho - nominal["diameter"] / 2, e
    if ftype == "cone":
        half = np.radians(nominal["angle"]) / 2
        return rho * np.cos(half) - h * np.sin(half), np.cos(half) * e - np.sin(half) * a
    if ftype == "torus":
        dr = rho - nominal["major_diameter"] / 2
        s = np.hypot(dr, h)
        g = (dr[:, None] * e + h[:, None] * a) / np.maximum(s, 1e-300)[:, None]
        return s - nominal["minor_diameter"] / 2, g
    raise InputError(f"alignment: a {ftype} has no nominal surface to fit to")


def _dof_words(v: np.ndarray, c: np.ndarray) -> str:
    """A free degree of freedom (rotation vector, translation about centre ``c``) in words."""
    w, t = v[:3], v[3:]
    fmt = lambda u: "(" + ", ".join(f"{x:.3g}" for x in np.where(np.abs(u) < 1e-12, 0.0, u)) + ")"
    if np.linalg.norm(w) < 1e-9:
        return f"translation along {fmt(t / np.linalg.norm(t))}"
    k = w / np.linalg.norm(w)
    return f"rotation about {fmt(k)} through {fmt(c + np.cross(k, t) / np.linalg.norm(w))}"


# --------------------------------------------------------------------------- settings
def options(plan: Plan) -> dict[str, Any]:
    """The plan's ``alignment`` mapping (features, boxes, datums, start), checked."""
    src = plan.source and plan.source.split("/")[-1] or "plan"
    raw = plan.options.get("alignment") or {}
    if not isinstance(raw, dict):
        raise InputError(f"{src}: alignment: expected a mapping (features, boxes, datums), got {raw!r:.60}")
    out: dict[str, Any] = {}
    for key in ("features", "datums"):
        if key in raw:
            v = raw[key]
            names = [v] if isinstance(v, str) else v
            if not isinstance(names, list) or not all(isinstance(n, str) for n in names) or not names:
                raise InputError(f"{src}: alignment.{key}: expected a list of names, got {v!r:.60}")
            known = plan.features if key == "features" else plan.datums
            for n in names:
                if n not in known:
                    raise InputError(f"{src}: alignment.{key}: unknown {key[:-1]} {n!r}")
            out[key] = tuple(names)
    if "boxes" in raw:
        try:
            boxes = np.asarray(raw["boxes"], dtype=float)
        except (TypeError, ValueError):
            boxes = np.zeros(0)
        if (
            boxes.ndim != 3
            or boxes.shape[1:] != (2, 3)
            or not np.isfinite(boxes).all()
            or (boxes[:, 0] > boxes[:, 1]).any()
        ):
            raise InputError(f"{src}: alignment.boxes: expected a list of [[xmin,ymin,zmin],[xmax,ymax,zmax]] boxes")
        out["boxes"] = boxes * _unit_factor(plan)
    for key in sorted(set(raw) - {"features", "datums", "boxes"}):
        raise InputError(f"{src}: alignment.{key}: unknown key; use features, boxes or datums")
    return out


def _unit_factor(plan: Plan) -> float:
    from camcmm.api import to_mm_factor

    return float(to_mm_factor(plan.unit))


def _in_boxes(X: np.ndarray, boxes: np.ndarray | None) -> np.ndarray:
    if boxes is None:
        return np.ones(len(X), bool)
    keep = np.zeros(len(X), bool)
    for lo, hi in boxes:
        keep |= np.all((X >= lo) & (X <= hi), axis=1)
    return keep


# --------------------------------------------------------------------------- best fit to the plan
def _select(X: np.ndarray, spec: FeatureSpec, cad: Any) -> np.ndarray:
    from . import features

    return np.asarray(features.select(X, spec, cad), dtype=np.int64)


def best_fit_surfaces(
    plan: Plan,
    points: np.ndarray,
    T0: np.ndarray,
    feature_ids: tuple[str, ...] | None = None,
    boxes: np.ndarray | None = None,
    cad: Any = None,
    max_iterations: int = 50,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Iterated point-to-surface least squares from ``T0``: the points within each feature's
    band (re-selected every iteration) moved onto the nominal surfaces (Gauss-Newton on the
    six rigid parameters, rotations about the selected points' centroid). Directions the
    surfaces do not determine (a single plane's three, a cylinder's turn) are held (the
    step's truncated SVD) and reported in ``free``."""
    ids = feature_ids or tuple(f for f, s in plan.features.items() if s.type in SURFACE_TYPES)
    specs = [plan.features[f] for f in ids if plan.features[f].type in SURFACE_TYPES]
    if not specs:
        raise InputError(f"{_name(plan)}: best fit: no plane, cylinder, sphere, cone or torus feature to fit to")
    state: dict[str, Any] = {"free": [], "used": {}}

    def step(T: np.ndarray) -> np.ndarray:
        X = apply(T, points)
        rows, res = [], []
        state["used"] = {}
        for spec in specs:
            idx = _select(X, spec, cad)
            idx = idx[_in_boxes(X[idx], boxes)]
            state["used"][spec.id] = int(len(idx))
            if len(idx) < MIN_POINTS:
                continue
            d, n = surface_distance_normal(X[idx], spec.type, spec.nominal)
            rows.append((X[idx], n))
            res.append(d)
        if not res:
            raise InputError(
                f"{_name(plan)}: best fit: no feature has {MIN_POINTS} points within its band "
                "(is the cloud near the plan's coordinates? try --start coarse)"
            )
        P = np.vstack([r[0] for r in rows])
        N = np.vstack([r[1] for r in rows])
        c = P.mean(axis=0)
        J = np.hstack([np.cross(P - c, N), N])
        delta, free_vecs = _truncated_solve(J, -np.concatenate(res))
        state["free"] = [_dof_words(v, c) for v in free_vecs]
        return _step(delta, c) @ T

    T, it, converged = _settle(step, T0, _plan_size(plan), max_iterations, SETTLED_MM)
    free, used = state["free"], state["used"]
    rms, n_used = float("nan"), 0
    X = apply(T, points)
    # the rms at the final pose (the loop's is one step behind)
    res = []
    for spec in specs:
        idx = _select(X, spec, cad)
        idx = idx[_in_boxes(X[idx], boxes)]
        if len(idx) >= MIN_POINTS:
            res.append(surface_distance_normal(X[idx], spec.type, spec.nominal)[0])
    if res:
        r = np.concatenate(res)
        n_used, rms = len(r), float(np.sqrt(np.mean(r**2)))
    info = {
        "kind": "point-to-surface least squares on the plan's nominal features",
        "features": used,
        "rms": rms,
        "n_points": n_used,
        "iterations": it,
        "converged": converged,
        "free": free,
    }
    if boxes is not None:
        info["boxes"] = boxes.tolist()
    return T, info


def _truncated_solve(J: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Least-squares step of ``J x = b`` with directions of (near) zero singular value held
    (x has no component along them); returns x and those directions (unit, 6-vectors).
    The translation columns are scaled to the rotation columns' size first, so the test
    of a free direction does not depend on the part's size. Solved on the 6×6 normal
    matrix (its eigenvalues are the squared singular values): an SVD of the tall J took
    30 ms a step; the fixed point does not depend on the step's rounding."""
    scale = np.ones(6)
    rot = float(np.linalg.norm(J[:, :3])) or 1.0
    tr = float(np.linalg.norm(J[:, 3:])) or 1.0
    scale[3:] = rot / tr
    Js = J * scale
    lam, V = np.linalg.eigh(Js.T @ Js)
    sv = np.sqrt(np.maximum(lam, 0.0))
    keep = sv > FREE_RCOND * sv.max()
    x = V[:, keep] @ ((V[:, keep].T @ (Js.T @ b)) / lam[keep])
    free = [V[:, i] * scale / np.linalg.norm(V[:, i] * scale) for i in np.flatnonzero(~keep)]
    return x * scale, free


def _name(plan: Plan) -> str:
    return plan.source.replace("\\", "/").split("/")[-1] if plan.source else "plan"


def _plan_size(plan: Plan) -> float:
    pts = []
    for spec in plan.features.values():
        for key in ("point", "centre", "apex"):
            if key in spec.nominal:
                pts.append(np.asarray(spec.nominal[key], float))
        if spec.box is not None:
            pts += list(spec.box)
    if len(pts) < 2:
        return 100.0
    p = np.array(pts)
    return float(np.linalg.norm(p.max(axis=0) - p.min(axis=0))) or 100.0


# --------------------------------------------------------------------------- coarse start
def sample_nominal(spec: FeatureSpec, density: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points (uniform by area, ``density`` per mm²) and unit normals on the nominal
    surface of a feature within its box and extent; (0, 3) when the surface is unbounded
    (a plane without a box, a cone without a box)."""
    nom = spec.nominal
    box = spec.box
    empty = np.zeros((0, 3)), np.zeros((0, 3))
    if spec.type == "plane":
        if box is None:
            return empty
        nrm = np.asarray(nom["normal"], float)
        e1 = np.cross(nrm, [1.0, 0.0, 0.0] if abs(nrm[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(nrm, e1)
        corners = np.array([[box[i][0], box[j][1], box[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
        uv = (corners - nom["point"]) @ np.array([e1, e2]).T
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        n = int(np.prod(hi - lo) * density) + 1
        w = lo + (hi - lo) * rng.random((n, 2))
        X = nom["point"] + w[:, :1] * e1 + w[:, 1:] * e2
        N = np.broadcast_to(nrm, X.shape).copy()
    elif spec.type == "sphere":
        r = nom["diameter"] / 2
        v = rng.normal(size=(int(4 * np.pi * r * r * density) + 1, 3))
        v /= np.linalg.norm(v, axis=1)[:, None]
        X, N = nom["centre"] + r * v, v
    elif spec.type in ("cylinder", "cone", "torus"):
        a = np.asarray(nom["axis"], float)
        e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        if spec.type == "torus":
            R, r = nom["major_diameter"] / 2, nom["minor_diameter"] / 2
            n = int(4 * np.pi**2 * R * r * density) + 1
            u, v = rng.random(n) * 2 * np.pi, rng.random(n) * 2 * np.pi
            radial = np.cos(u)[:, None] * e1 + np.sin(u)[:, None] * e2
            N = np.cos(v)[:, None] * radial + np.sin(v)[:, None] * a
            X = nom["centre"] + R * radial + r * N
        else:
            origin = nom["apex"] if spec.type == "cone" else nom["point"]
            if spec.type == "cylinder" and "length" in nom:
                lo, hi = 0.0, float(nom["length"])
            elif box is not None:
                corners = np.array([[box[i][0], box[j][1], box[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
                h = (corners - origin) @ a
                lo, hi = float(h.min()), float(h.max())
            else:
                return empty
            if spec.type == "cylinder":
                n = int(np.pi * nom["diameter"] * (hi - lo) * density) + 1
                h = lo + (hi - lo) * rng.random(n)
                radial = _ring(rng, n, e1, e2)
                X, N = origin + h[:, None] * a + nom["diameter"] / 2 * radial, radial
            else:
                half = np.radians(nom["angle"]) / 2
                lo, hi = max(lo, 0.0), max(hi, 0.0)
                n = int(np.pi * np.tan(half) * (hi**2 - lo**2) / np.cos(half) * density) + 1
                h = np.sqrt(lo**2 + (hi**2 - lo**2) * rng.random(n))  # uniform by area on the cone
                radial = _ring(rng, n, e1, e2)
                X = origin + h[:, None] * a + (h * np.tan(half))[:, None] * radial
                N = np.cos(half) * radial - np.sin(half) * a
    else:
        return empty
    if box is not None:
        keep = np.all((X >= box[0] - 1e-9) & (X <= box[1] + 1e-9), axis=1)
        X, N = X[keep], N[keep]
    return X, N


def _ring(rng: np.random.Generator, n: int, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    u = rng.random(n) * 2 * np.pi
    return np.cos(u)[:, None] * e1 + np.sin(u)[:, None] * e2


def _enough_in_bands(plan: Plan, points: np.ndarray, cad: Any) -> tuple[bool, str]:
    """Whether the cloud as it lies is near enough the plan for the fine methods: at least
    half the features find MIN_POINTS points within their bands."""
    specs = [s for s in plan.features.values() if s.type in SURFACE_TYPES]
    if not specs:
        return True, ""
    found = sum(len(_select(points, s, cad)) >= MIN_POINTS for s in specs)
    ok = 2 * found >= len(specs)
    return ok, f"{found} of {len(specs)} features have points within their bands as the cloud lies"


def _doubtful(plan: Plan, P: np.ndarray, cad: Any, max_iterations: int = 50) -> tuple[np.ndarray, str]:
    """A best fit from where the cloud lies, and why its pose is doubtful ("" when it is
    not): fewer than :data:`GOOD_SHARE` of the points within the features' bands, or
    fewer than :data:`SETTLED_SHARE` of those within 8 mm of the surfaces (a fit caught
    in a wrong minimum keeps many points near the surfaces but off them: the test block
    turned 10° or 20° about z and fitted from there kept 46 % / 36 % of its points in the
    bands and 75 % / 79 % of the near ones, 86 % and 90-94 % when right). A doubt costs a
    coarse start (about a second), in which this fit is one of the candidates: a pose
    wrongly doubted still wins."""
    try:
        T, _ = best_fit_surfaces(plan, P, np.eye(4), cad=cad, max_iterations=max_iterations)
    except InputError:
        return np.eye(4), ""
    X = apply(T, P)
    near = _score(plan, X, cad)
    wide = _score(
        replace(plan, features={f: replace(s, band=max(s.band, WIDE_BANDS[0])) for f, s in plan.features.items()}),
        X,
        cad,
    )
    share, settled = near / max(len(P), 1), near / max(wide, 1)
    if share < GOOD_SHARE or settled < SETTLED_SHARE:
        return T, (
            f"a best fit from where the cloud lies holds {100 * share:.0f} % of the points within the features' bands "
            f"and {100 * settled:.0f} % of those within {WIDE_BANDS[0]:g} mm of the surfaces"
        )
    return T, ""


def _principal_axes(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid and principal axes (rows, largest spread first, right-handed) of points."""
    c = X.mean(axis=0)
    _, _, Vt = np.linalg.svd(X - c, full_matrices=False)
    if np.linalg.det(Vt) < 0:
        Vt[2] = -Vt[2]
    return c, Vt


def _pca_starts(P: np.ndarray, X: np.ndarray) -> list[np.ndarray]:
    """The four proper rotations taking the measured principal axes onto the target's
    (the signs of two axes are unknown), with the centroids matched: 4×4 starts."""
    cp, Vp = _principal_axes(P)
    cx, Vx = _principal_axes(X)
    out = []
    for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        S = np.diag([s1, s2, s1 * s2])
        R = Vx.T @ S @ Vp
        out.append(_rigid(R, cx - R @ cp))
    return out


def _score(plan: Plan, X: np.ndarray, cad: Any) -> int:
    """Points within the bands of the plan's surface features (the more, the better the pose)."""
    return sum(len(_select(X, s, cad)) for s in plan.features.values() if s.type in SURFACE_TYPES)


#: Bands (mm) of the best fits that take a coarse start to the features' own bands: a
#: registration to sampled surfaces ends a few mm off, which a 0.5 mm band would not see.
WIDE_BANDS = (8.0, 4.0, 2.0, 1.0)


def _widening_fit(plan: Plan, P: np.ndarray, T0: np.ndarray, cad: Any) -> np.ndarray:
    """Best fits from ``T0`` with every feature's band first widened to each of
    :data:`WIDE_BANDS` (never below its own), 10 iterations each."""
    T = T0
    for band in WIDE_BANDS:
        wide = replace(plan, features={f: replace(s, band=max(s.band, band)) for f, s in plan.features.items()})
        try:
            T, _ = best_fit_surfaces(wide, P, T, cad=cad, max_iterations=10)
        except InputError:
            continue
    return T


def coarse_start(
    plan: Plan,
    points: np.ndarray,
    nominal: Any = None,
    seed: int = 0,
    cad: Any = None,
    candidates: list[tuple[str, np.ndarray]] | None = None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """A rough pose for a cloud delivered in another frame. Candidates: the four
    principal-axes starts (the measured cloud's axes onto those of the target: the nominal
    geometry when given, else points sampled on the plan features' nominal surfaces), each
    refined by ``inspect.align`` icp; when none brings :data:`GOOD_SHARE` of the points
    into the features' bands, also ``inspect.align`` global+icp (FPFH + RANSAC, then ICP).
    Each candidate is best-fitted to the plan's surfaces in widening-to-narrow bands
    (:data:`WIDE_BANDS`); the one with the most points within the features' bands wins
    (a block registered upside down keeps fewer). ``candidates``: (name, T) starts to
    weigh as well (a fit from where the cloud lay). Returns (T, info)."""
    target = nominal  # inspect.align takes a CAD model as it is (its exact surface)
    kind = "nominal geometry"
    X = None
    if target is None:
        specs = [s for s in plan.features.values() if s.type in SURFACE_TYPES]
        rng = np.random.default_rng(seed)
        parts = [sample_nominal(s, 1.0, rng) for s in specs]  # 1 per mm², then thinned
        X = np.vstack([p[0] for p in parts]) if parts else np.zeros((0, 3))
        N = np.vstack([p[1] for p in parts]) if parts else np.zeros((0, 3))
        if len(X) > COARSE_SAMPLES:
            keep = rng.choice(len(X), COARSE_SAMPLES, replace=False)
            X, N = X[keep], N[keep]
        if len(X) < 100:
            raise InputError(
                f"{_name(plan)}: the cloud is far from the plan's coordinates and the plan's features do not bound "
                "surfaces to register it to (give boxes, lengths, or a --nominal)"
            )
        target = PointCloud(X, normals=N, name="plan's nominal surfaces")
        kind = f"{len(X)} points sampled on the nominal surfaces of {len(specs)} features"
    elif isinstance(target, PointCloud):
        X = target.points
    elif isinstance(target, CadModel):  # uniform by area, as the measured points are
        X = target.sample(None, COARSE_SAMPLES, seed).points
    elif hasattr(target, "vertices"):
        X = np.asarray(target.vertices, float)
    P = np.asarray(points, float)
    if len(P) > COARSE_POINTS:  # a seeded subset: the start needs the shape, not every point
        P = P[np.random.default_rng(seed).choice(len(P), COARSE_POINTS, replace=False)]
    icp = get_algorithm("inspect.align")
    tried: dict[str, int] = {}
    best: tuple[int, str, np.ndarray] = (-1, "", np.eye(4))

    def consider(name: str, T0: np.ndarray) -> None:
        nonlocal best
        T1 = _widening_fit(plan, P, T0, cad)
        tried[name] = _score(plan, apply(T1, P), cad)
        if tried[name] > best[0]:
            best = (tried[name], name, T1)

    for name, T0 in candidates or []:  # e.g. a fit from where the cloud lay
        consider(name, T0)
    if X is not None and len(X) >= 10:
        for i, T0 in enumerate(_pca_starts(P, X)):
            try:
                out = icp(cloud=PointCloud(apply(T0, P), name="measured"), nominal=target, align="icp", seed=seed)
            except GeometryError:
                continue
            consider(f"principal axes {i + 1}+icp", np.asarray(out["transform"], float) @ T0)
    if best[0] < GOOD_SHARE * len(P):
        # the principal axes did not find the part (a partial scan, a symmetric part):
        # feature matching (FPFH + RANSAC) does not need them, at ten times their cost
        try:
            out = icp(cloud=PointCloud(P, name="measured"), nominal=target, align="global+icp", seed=seed)
            consider("global+icp", np.asarray(out["transform"], float))
        except GeometryError:
            pass
    if best[0] < 0:
        raise InputError(f"coarse start: the cloud could not be registered to the {kind}")
    return best[2], {
        "kind": f"{best[1]} to the {kind}, then best fits in bands of {', '.join(f'{b:g}' for b in WIDE_BANDS)} mm",
        "candidates": tried,
    }


# --------------------------------------------------------------------------- datums
def datum_labels(plan: Plan, opts: dict[str, Any]) -> tuple[str, ...]:
    """The datums of the datum alignment: ``alignment.datums``, else the longest datum list
    a characteristic names (the first of those), else the declared datums (up to three)."""
    if "datums" in opts:
        return tuple(opts["datums"])
    lists = [c.datums for c in plan.characteristics if c.datums]
    if lists:
        return max(lists, key=len)
    if not plan.datums:
        raise InputError(f"{_name(plan)}: datums: the datum alignment needs datums; the plan declares none")
    return tuple(list(plan.datums)[:3])


def _associate(plan: Plan, X: np.ndarray, spec: FeatureSpec, cad: Any, association: str | None = None) -> Any:
    """The feature associated on the points within its band (pose X); a feature the
    alignment rests on with too few points is a refusal naming the plan and the feature."""
    from . import features

    idx = _select(X, spec, cad)
    if len(idx) < MIN_POINTS:
        raise InputError(
            f"{_name(plan)}: features.{spec.id}: {len(idx)} points within its band of {spec.band:g} mm; "
            "the alignment rests on this feature"
        )
    return features.associate(X, idx, spec, association)


def datum_alignment(
    plan: Plan, points: np.ndarray, T0: np.ndarray, labels: tuple[str, ...], cad: Any = None, max_iterations: int = 30
) -> tuple[np.ndarray, dict[str, Any]]:
    """The DRF of ``labels`` as the part's coordinates, iterated from ``T0`` until it settles."""
    from . import datums as dmod

    fids = sorted({f for lab in labels for f in plan.datums[lab]})
    state: dict[str, Any] = {"free": []}

    def step(T: np.ndarray) -> np.ndarray:
        X = apply(T, points)
        frame = dmod.datum_frame(plan, {f: _associate(plan, X, plan.features[f], cad) for f in fids}, labels)
        state["free"] = list(frame.free)
        return np.asarray(frame.transform, float) @ T

    T, it, converged = _settle(step, T0, _plan_size(plan), max_iterations, 10 * SETTLED_MM)
    free = state["free"]
    return T, {
        "kind": f"datum reference frame {'|'.join(labels)} (ISO 5459)",
        "datums": list(labels),
        "iterations": it,
        "converged": converged,
        "free": free,
    }


# --------------------------------------------------------------------------- 3-2-1 and RPS
def _element(a: Any) -> tuple[str, np.ndarray, np.ndarray]:
    """(kind, point, direction) of an associated or nominal element: kind 'plane' (point,
    normal), 'axis' (point, direction) or 'point' (point, zero direction)."""
    p = a.params if hasattr(a, "params") else a
    t = a.type
    if t == "plane":
        return "plane", np.asarray(p["point"], float), np.asarray(p["normal"], float)
    if t in ("cylinder", "cone", "line"):
        d = p.get("axis", p.get("direction"))
        return "axis", np.asarray(p.get("apex", p.get("point")), float), np.asarray(d, float)
    if t in ("sphere", "circle", "point", "torus"):
        return "point", np.asarray(p.get("centre", p.get("point")), float), np.zeros(3)
    raise InputError(f"feature {getattr(a, 'id', '')}: a {t} cannot serve in a 3-2-1 alignment")


class _Nominal:
    """A feature's nominal element with the attribute names of an Associated."""

    def __init__(self, spec: FeatureSpec):
        self.id, self.type, self.params = spec.id, spec.type, spec.nominal


def _closest_on_axis(p: np.ndarray, d: np.ndarray, q: np.ndarray) -> np.ndarray:
    return p + float((q - p) @ d) * d


def _point_of(kind: str, m: np.ndarray, d: np.ndarray, q: np.ndarray) -> np.ndarray:
    """A point-like element's point: its centre, or the point of its axis nearest ``q``."""
    return _closest_on_axis(m, d, q) if kind == "axis" else m


def three_two_one(
    plan: Plan, points: np.ndarray, T0: np.ndarray, ids: tuple[str, ...], cad: Any = None, max_iterations: int = 30
) -> tuple[np.ndarray, dict[str, Any]]:
    """3-2-1 on least-squares elements of features ``ids``, iterated until the pose settles.

    The primary is a plane (its normal and offset: 3). Either the secondary is a plane or
    an axis across the primary normal (its direction about the normal, its offset across
    it: 2) and the tertiary a plane, axis or point (the offset left: 1); or the secondary
    is a hole — a point, or an axis along the primary normal (its position in the plane:
    2) — and the tertiary another (the turn about the normal towards it: 1), the
    plane-hole-slot alignment."""
    name = _name(plan)
    if len(ids) != 3:
        raise InputError(f"{name}: alignment.features: 3-2-1 takes three features, got {len(ids)}")
    specs = [plan.features[f] for f in ids]
    nomi = [_element(_Nominal(s)) for s in specs]
    kinds = [e[0] for e in nomi]
    if kinds[0] != "plane":
        raise InputError(f"{name}: alignment.features: the 3-2-1 primary {ids[0]} must be a plane")
    n1 = nomi[0][2]
    hole = kinds[1] == "point" or (kinds[1] == "axis" and abs(float(nomi[1][2] @ n1)) > 1 - 1e-9)
    if hole and kinds[2] == "plane":
        raise InputError(f"{name}: alignment.features: after the hole {ids[1]}, the tertiary {ids[2]} must be a hole")

    def across(v: np.ndarray, what: str) -> np.ndarray:
        w = v - (v @ n1) * n1
        if np.linalg.norm(w) < 1e-6:
            raise InputError(f"{name}: alignment.features: {what} is parallel to the primary {ids[0]}'s normal")
        return w / np.linalg.norm(w)

    def step(T: np.ndarray) -> np.ndarray:
        X = apply(T, points)
        meas = [_element(_associate(plan, X, s, cad, "ls")) for s in specs]
        # rotations: the primary normal onto its nominal, then turned about that normal so
        # that the secondary's direction (or, after a hole, the direction to the tertiary
        # hole) lies as nominal
        R1 = _rotation_between(meas[0][2], n1)
        if hole:
            pts = [_point_of(kinds[i], R1 @ meas[i][1], R1 @ meas[i][2], nomi[i][1]) for i in (1, 2)]
            pm = across(pts[1] - pts[0], f"the line from {ids[1]} to {ids[2]}")
            pn = across(nomi[2][1] - nomi[1][1], f"the line from {ids[1]} to {ids[2]}")
        else:
            pm, pn = across(R1 @ meas[1][2], ids[1]), across(nomi[1][2], ids[1])
            if kinds[1] == "axis" and pm @ pn < 0:  # an axis has no sense
                pm = -pm
        R = _rodrigues(n1 * np.arctan2(np.cross(pm, pn) @ n1, pm @ pn)) @ R1
        # translations: the primary's offset along n1, then the secondary's across it
        # (both in-plane directions for a hole), then the tertiary's along what is left
        e2 = pn if kinds[1] == "plane" else np.cross(n1, pn)
        e3 = np.cross(n1, e2)
        rows, rhs = [n1], [float(n1 @ (nomi[0][1] - R @ meas[0][1]))]
        fixes = [(1, e2), (1, e3)] if hole else [(1, e2), (2, nomi[2][2] if kinds[2] == "plane" else e3)]
        for i, e in fixes:
            kind, q, _ = nomi[i]
            m = _point_of(kind, R @ meas[i][1], R @ meas[i][2], q)
            rows.append(e)
            rhs.append(float(e @ (q - m)))
        E = np.array(rows)
        if abs(np.linalg.det(E)) < 1e-6:
            raise InputError(f"{name}: alignment.features: {', '.join(ids)} do not fix the three translations")
        return _rigid(R, np.linalg.solve(E, np.array(rhs))) @ T

    T, it, converged = _settle(step, T0, _plan_size(plan), max_iterations, 10 * SETTLED_MM)
    dofs = "(3), " + (f"{ids[1]} (2, a hole), {ids[2]} (1, the turn)" if hole else f"{ids[1]} (2), {ids[2]} (1)")
    return T, {
        "kind": f"3-2-1 on least-squares elements: {ids[0]} {dofs}",
        "features": list(ids),
        "iterations": it,
        "converged": converged,
        "free": [],
    }


def rps_points(plan: Plan) -> dict[str, dict[str, Any]]:
    """The plan's ``rps`` mapping, checked: name -> {feature, fixes (k, 3) unit rows, at}."""
    src = _name(plan)
    raw = plan.options.get("rps")
    if not isinstance(raw, dict) or not raw:
        raise InputError(
            f"{src}: rps: the RPS alignment needs reference points (rps: {{R1: {{feature: H1, fixes: [x, y]}}}})"
        )
    f = _unit_factor(plan)
    out = {}
    for name, ref in raw.items():
        key = f"rps.{name}"
        if not isinstance(ref, dict):
            raise InputError(f"{src}: {key}: expected a mapping with feature and fixes")
        for k in ref:
            if k not in ("feature", "fixes", "at"):
                raise InputError(f"{src}: {key}.{k}: unknown key; use feature, fixes, at")
        fid = ref.get("feature")
        if fid not in plan.features:
            raise InputError(f"{src}: {key}.feature: unknown feature {fid!r}")
        fixes = ref.get("fixes")
        fixes = [fixes] if isinstance(fixes, str) else fixes
        if not isinstance(fixes, list) or not fixes or any(a not in _AXES for a in fixes):
            raise InputError(f"{src}: {key}.fixes: expected directions among x, y, z, got {ref.get('fixes')!r:.60}")
        spec = plan.features[fid]
        at = ref.get("at")
        if at is not None:
            try:
                at = np.asarray(at, dtype=float) * f
            except (TypeError, ValueError):
                at = np.zeros(0)
            if at.shape != (3,) or not np.isfinite(at).all():
                raise InputError(f"{src}: {key}.at: expected 3 numbers")
        elif spec.type == "plane":
            raise InputError(f"{src}: {key}.at: a reference point on a plane needs its position (at: [x, y, z])")
        if spec.type not in ("plane", "cylinder", "cone", "line", "sphere", "circle", "point"):
            raise InputError(f"{src}: {key}.feature: a {spec.type} cannot carry a reference point")
        out[str(name)] = {"feature": fid, "fixes": np.array([_AXES[a] for a in fixes]), "at": at, "axes": fixes}
    return out


def _reference_point(kind: str, p: np.ndarray, d: np.ndarray, at: np.ndarray, nominal_normal: Any) -> np.ndarray:
    """The reference point of an element (see the module docstring)."""
    if kind == "plane":
        n = np.asarray(nominal_normal, float)
        denom = float(n @ d)
        return at + n * float((p - at) @ d) / denom
    if kind == "axis":
        return _closest_on_axis(p, d, at)
    return p


def rps_alignment(
    plan: Plan, points: np.ndarray, T0: np.ndarray, cad: Any = None, max_iterations: int = 30
) -> tuple[np.ndarray, dict[str, Any]]:
    """The RPS alignment (see the module docstring), iterated until the pose settles.
    ``points`` of the info: each reference point's deviation measured − nominal (mm, plan
    axes) at the final pose."""
    refs = rps_points(plan)
    state: dict[str, Any] = {"free": []}

    def deviations(T: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """name -> (measured reference point, nominal one) at pose T."""
        X = apply(T, points)
        out = {}
        for name, ref in refs.items():
            spec = plan.features[ref["feature"]]
            kind, q, dn = _element(_Nominal(spec))
            at = ref["at"] if ref["at"] is not None else q
            _, pm, dm = _element(_associate(plan, X, spec, cad, "ls"))
            out[name] = (_reference_point(kind, pm, dm, at, dn), _reference_point(kind, q, dn, at, dn))
        return out

    def step(T: np.ndarray) -> np.ndarray:
        rows, res, P = [], [], []
        for name, (m, n) in deviations(T).items():
            for e in refs[name]["fixes"]:
                rows.append(e)
                res.append(float(e @ (m - n)))
                P.append(m)
        Pm = np.array(P)
        c = Pm.mean(axis=0)
        E = np.array(rows)
        J = np.hstack([np.cross(Pm - c, E), E])
        delta, free_vecs = _truncated_solve(J, -np.array(res))
        state["free"] = [_dof_words(v, c) for v in free_vecs]
        return _step(delta, c) @ T

    T, it, converged = _settle(step, T0, _plan_size(plan), max_iterations, 10 * SETTLED_MM)
    final = deviations(T)
    return T, {
        "kind": "reference point system",
        "points": {
            k: {"feature": v["feature"], "fixes": v["axes"], "deviation": (final[k][0] - final[k][1]).tolist()}
            for k, v in refs.items()
        },
        "iterations": it,
        "converged": converged,
        "free": state["free"],
    }


# --------------------------------------------------------------------------- the entry
def align(
    method: str,
    plan: Plan,
    points: np.ndarray,
    nominal: Any = None,
    cad: Any = None,
    start: str = "auto",
    seed: int = 0,
    max_iterations: int = 50,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Align ``points`` (N, 3 mm, as measured) to the plan's coordinates by ``method``
    (:data:`.model.ALIGNMENTS`); returns (T 4×4 measured -> plan, info). ``nominal`` a
    TriangleMesh / PointCloud / CAD model in plan coordinates (best fit goes to it);
    ``cad`` the CAD model whose faces ``face`` features name. ``start``: auto | coarse |
    none (see the module docstring)."""
    if method not in ALIGNMENTS:
        raise InputError(f"align: unknown method {method!r}; use one of {', '.join(ALIGNMENTS)}")
    P = np.asarray(points, dtype=float)
    opts = options(plan)
    T = np.eye(4)
    info: dict[str, Any] = {"method": method}
    stages: list[dict[str, Any]] = []
    if method != "none":
        need = start == "coarse"
        why = "asked for"
        tried: list[tuple[str, np.ndarray]] = []
        if start == "auto":
            ok, why = _enough_in_bands(plan, P, cad)
            need = not ok
            if ok:  # near enough for a fit: is where it ends believable?
                T, why = _doubtful(plan, P, cad, max_iterations)
                need = bool(why)
                tried = [("as delivered", T)]
        if need:
            T, cinfo = coarse_start(plan, P, nominal, seed, cad, tried)
            stages.append({"stage": "coarse start", "why": why, **cinfo})
    if method == "best-fit" and nominal is not None:
        # a CAD model as it is: inspect.align pairs points with its exact surface, not
        # with its tessellation (whose facets would bias the pose by their chordal error)
        mesh = nominal
        params: dict[str, Any] = {"align": "icp", "seed": seed}
        if "boxes" in opts:
            if len(opts["boxes"]) > 1:
                raise InputError(f"{_name(plan)}: alignment.boxes: a best fit to a nominal takes one box (region)")
            params["region"] = [float(v) for v in opts["boxes"][0].ravel()]
        out = get_algorithm("inspect.align")(cloud=PointCloud(apply(T, P), name="measured"), nominal=mesh, **params)
        T = np.asarray(out["transform"], float) @ T
        a = out["alignment"]
        stages.append({"stage": "fine", "kind": "inspect.align icp to the nominal", "rms": out["rms"]})
        info.update(
            rms=float(out["rms"]),
            iterations=int(a.get("iterations", 0)),
            converged=bool(out["converged"]),
            free=list(out.get("held_dofs", [])),
        )
    elif method == "best-fit":
        T, fine = best_fit_surfaces(plan, P, T, opts.get("features"), opts.get("boxes"), cad, max_iterations)
        stages.append({"stage": "fine", **fine})
        info.update({k: fine[k] for k in ("rms", "iterations", "converged", "free", "n_points")})
    elif method in ("datums", "3-2-1", "rps"):
        # a best fit first (when the plan has surfaces to fit to): the pose within the
        # bands, and the values of the degrees of freedom the method leaves free
        if any(s.type in SURFACE_TYPES for s in plan.features.values()):
            T, pre = best_fit_surfaces(plan, P, T, cad=cad, max_iterations=max_iterations)
            stages.append({"stage": "best fit (start)", **pre})
        if method == "datums":
            T, fine = datum_alignment(plan, P, T, datum_labels(plan, opts), cad)
        elif method == "3-2-1":
            ids = opts.get("features") or tuple(f[0] for f in plan.datums.values() if len(f) == 1)[:3]
            T, fine = three_two_one(plan, P, T, tuple(ids), cad)
        else:
            T, fine = rps_alignment(plan, P, T, cad)
        stages.append({"stage": "fine", **fine})
        info.update({k: fine[k] for k in ("iterations", "converged", "free")})
        info["rms"] = _rms_to_nominals(plan, apply(T, P), cad)
    else:
        info.update(rms=_rms_to_nominals(plan, P, cad), iterations=0, converged=True, free=[])
    info["transform"] = T.tolist()
    info.update(transform_summary(T))
    info["stages"] = stages
    return T, info


def _rms_to_nominals(plan: Plan, X: np.ndarray, cad: Any) -> float:
    """RMS distance (mm) of the points within the surface features' bands from their nominals."""
    res = []
    for spec in plan.features.values():
        if spec.type in SURFACE_TYPES:
            idx = _select(X, spec, cad)
            if len(idx):
                res.append(surface_distance_normal(X[idx], spec.type, spec.nominal)[0])
    return float(np.sqrt(np.mean(np.concatenate(res) ** 2))) if res else float("nan")
