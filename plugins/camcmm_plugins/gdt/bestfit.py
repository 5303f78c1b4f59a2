"""The point-to-surface best fit and the rigid-motion geometry the alignments share
(:mod:`.alignment`, :mod:`.coarse`, :mod:`.references`).

:func:`best_fit_surfaces` moves the measured points onto the nominal surfaces of the
plan's features: iterated least squares (Gauss-Newton on the six rigid parameters,
rotations about the selected points' centroid) over the points within each feature's
band and extent (:func:`.features.select`, re-selected at every iteration), the residual
the signed distance to the nominal surface and its gradient the surface normal
(:func:`surface_distance_normal`). Directions the surfaces do not determine are held and
named (:func:`dof_words`). Lengths in mm, angles in radians inside.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from camcmm.api import InputError

from . import features
from .model import FeatureSpec, Plan

#: Least points a feature needs to take part in an alignment.
MIN_POINTS = 3
#: Feature types whose nominal surfaces the point-to-surface best fit uses.
SURFACE_TYPES = ("plane", "cylinder", "sphere", "cone", "torus")
#: A step below this (mm, rotations times the part's size) ends an iteration.
SETTLED_MM = 1e-9
#: Singular values of the fit's Jacobian below this share of the largest are free dofs.
FREE_RCOND = 1e-6


# --------------------------------------------------------------------------- small geometry
def apply(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) mapped by the 4×4 rigid transform ``T``."""
    return np.asarray(points, dtype=float) @ T[:3, :3].T + T[:3, 3]


def rodrigues(w: np.ndarray) -> np.ndarray:
    t = float(np.linalg.norm(w))
    if t < 1e-300:
        return np.eye(3)
    k = w / t
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def step_transform(delta: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The rigid 4×4 of a Gauss-Newton step (rotation vector ``delta[:3]`` about ``c``,
    then translation ``delta[3:]``): x -> R (x − c) + c + t."""
    T = np.eye(4)
    R = rodrigues(delta[:3])
    T[:3, :3] = R
    T[:3, 3] = c - R @ c + delta[3:]
    return T


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` onto unit vector ``b``."""
    v = np.cross(a, b)
    s, c = float(np.linalg.norm(v)), float(np.dot(a, b))
    if s < 1e-15:
        if c > 0:
            return np.eye(3)
        p = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return rodrigues(np.pi * p / np.linalg.norm(p))
    return rodrigues(v / s * np.arctan2(s, c))


def rigid(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def change(T_new: np.ndarray, T_old: np.ndarray, size: float) -> float:
    """How far (mm) a step moved the part: translation plus rotation times its size."""
    D = T_new @ np.linalg.inv(T_old)
    angle = float(np.arccos(np.clip((np.trace(D[:3, :3]) - 1) / 2, -1.0, 1.0)))
    return float(np.linalg.norm(D[:3, 3])) + angle * size


def settle(
    step: Callable[[np.ndarray], np.ndarray], T0: np.ndarray, size: float, max_iterations: int, tol: float
) -> tuple[np.ndarray, int, bool]:
    """Iterate ``T <- step(T)`` from ``T0`` until a step moves the part less than ``tol``
    (mm, :func:`change`) or ``max_iterations`` ran: (T, iterations, settled)."""
    T = T0.copy()
    for it in range(1, max_iterations + 1):
        T_new = step(T)
        moved = change(T_new, T, size)
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
    """Signed distance (N,) of points from a nominal surface (:func:`.features.surface_distance`,
    outward sign: the fit squares it) and its gradient (N, 3), the unit normal there: the
    residual and Jacobian of the point-to-surface fit. Types: :data:`SURFACE_TYPES`."""
    X = np.asarray(points, dtype=float)
    if ftype not in SURFACE_TYPES:
        raise InputError(f"alignment: a {ftype} has no nominal surface to fit to")
    d = features.surface_distance(X, ftype, {**nominal, "internal": False})
    if ftype == "plane":
        return d, np.broadcast_to(np.asarray(nominal["normal"], float), X.shape)
    if ftype == "sphere":
        v = X - nominal["centre"]
        return d, v / np.maximum(np.linalg.norm(v, axis=1), 1e-300)[:, None]
    origin = nominal["apex"] if ftype == "cone" else nominal.get("point", nominal.get("centre"))
    a = np.asarray(nominal["axis"], float)
    v = X - origin
    h = v @ a
    radial = v - h[:, None] * a
    e = radial / np.maximum(np.linalg.norm(radial, axis=1), 1e-300)[:, None]
    if ftype == "cylinder":
        return d, e
    if ftype == "cone":
        half = np.radians(nominal["angle"]) / 2
        return d, np.cos(half) * e - np.sin(half) * a
    dr = np.linalg.norm(radial, axis=1) - nominal["major_diameter"] / 2  # torus
    g = dr[:, None] * e + h[:, None] * a
    return d, g / np.maximum(np.linalg.norm(g, axis=1), 1e-300)[:, None]


def dof_words(v: np.ndarray, c: np.ndarray) -> str:
    """A free degree of freedom (rotation vector, translation about centre ``c``) in words."""
    w, t = v[:3], v[3:]
    fmt = lambda u: "(" + ", ".join(f"{x:.3g}" for x in np.where(np.abs(u) < 1e-12, 0.0, u)) + ")"
    if np.linalg.norm(w) < 1e-9:
        return f"translation along {fmt(t / np.linalg.norm(t))}"
    k = w / np.linalg.norm(w)
    return f"rotation about {fmt(k)} through {fmt(c + np.cross(k, t) / np.linalg.norm(w))}"


def unit_factor(plan: Plan) -> float:
    from camcmm.api import to_mm_factor

    return float(to_mm_factor(plan.unit))


def in_boxes(X: np.ndarray, boxes: np.ndarray | None) -> np.ndarray:
    if boxes is None:
        return np.ones(len(X), bool)
    keep = np.zeros(len(X), bool)
    for lo, hi in boxes:
        keep |= np.all((X >= lo) & (X <= hi), axis=1)
    return keep


# --------------------------------------------------------------------------- best fit to the plan
def select(X: np.ndarray, spec: FeatureSpec, cad: Any) -> np.ndarray:
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
        raise InputError(f"{plan_name(plan)}: best fit: no plane, cylinder, sphere, cone or torus feature to fit to")
    state: dict[str, Any] = {"free": [], "used": {}}

    def step(T: np.ndarray) -> np.ndarray:
        X = apply(T, points)
        rows, res = [], []
        state["used"] = {}
        for spec in specs:
            idx = select(X, spec, cad)
            idx = idx[in_boxes(X[idx], boxes)]
            state["used"][spec.id] = int(len(idx))
            if len(idx) < MIN_POINTS:
                continue
            d, n = surface_distance_normal(X[idx], spec.type, spec.nominal)
            rows.append((X[idx], n))
            res.append(d)
        if not res:
            raise InputError(
                f"{plan_name(plan)}: best fit: no feature has {MIN_POINTS} points within its band "
                "(is the cloud near the plan's coordinates? try --start coarse)"
            )
        P = np.vstack([r[0] for r in rows])
        N = np.vstack([r[1] for r in rows])
        c = P.mean(axis=0)
        J = np.hstack([np.cross(P - c, N), N])
        delta, free_vecs = truncated_solve(J, -np.concatenate(res))
        state["free"] = [dof_words(v, c) for v in free_vecs]
        return step_transform(delta, c) @ T

    T, it, converged = settle(step, T0, plan_size(plan), max_iterations, SETTLED_MM)
    free, used = state["free"], state["used"]
    rms, n_used = float("nan"), 0
    X = apply(T, points)
    # the rms at the final pose (the loop's is one step behind)
    res = []
    for spec in specs:
        idx = select(X, spec, cad)
        idx = idx[in_boxes(X[idx], boxes)]
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


def truncated_solve(J: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
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


def plan_name(plan: Plan) -> str:
    return plan.source.replace("\\", "/").split("/")[-1] if plan.source else "plan"


def plan_size(plan: Plan) -> float:
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


def associate(plan: Plan, X: np.ndarray, spec: FeatureSpec, cad: Any, association: str | None = None) -> Any:
    """The feature associated on the points within its band (pose X); a feature the
    alignment rests on with too few points is a refusal naming the plan and the feature."""
    from . import features

    idx = select(X, spec, cad)
    if len(idx) < MIN_POINTS:
        raise InputError(
            f"{plan_name(plan)}: features.{spec.id}: {len(idx)} points within its band of {spec.band:g} mm; "
            "the alignment rests on this feature"
        )
    return features.associate(X, idx, spec, association)


def rms_to_nominals(plan: Plan, X: np.ndarray, cad: Any) -> float:
    """RMS distance (mm) of the points within the surface features' bands from their nominals."""
    res = []
    for spec in plan.features.values():
        if spec.type in SURFACE_TYPES:
            idx = select(X, spec, cad)
            if len(idx):
                res.append(surface_distance_normal(X[idx], spec.type, spec.nominal)[0])
    return float(np.sqrt(np.mean(np.concatenate(res) ** 2))) if res else float("nan")
