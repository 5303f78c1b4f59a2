"""Alignments on reference elements: 3-2-1 (plane, line or axis, point; or plane, hole,
slot) on least-squares elements, and RPS (named reference points each fixing given plan
directions). Both iterate — re-select the features' points in the new pose, associate,
solve — until the pose settles. See :mod:`.alignment` for the plan keys.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError

from .bestfit import (
    SETTLED_MM,
    apply,
    associate,
    dof_words,
    plan_name,
    plan_size,
    rigid,
    rodrigues,
    rotation_between,
    settle,
    step_transform,
    truncated_solve,
    unit_factor,
)
from .model import FeatureSpec, Plan

_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


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
    name = plan_name(plan)
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
        meas = [_element(associate(plan, X, s, cad, "ls")) for s in specs]
        # rotations: the primary normal onto its nominal, then turned about that normal so
        # that the secondary's direction (or, after a hole, the direction to the tertiary
        # hole) lies as nominal
        R1 = rotation_between(meas[0][2], n1)
        if hole:
            pts = [_point_of(kinds[i], R1 @ meas[i][1], R1 @ meas[i][2], nomi[i][1]) for i in (1, 2)]
            pm = across(pts[1] - pts[0], f"the line from {ids[1]} to {ids[2]}")
            pn = across(nomi[2][1] - nomi[1][1], f"the line from {ids[1]} to {ids[2]}")
        else:
            pm, pn = across(R1 @ meas[1][2], ids[1]), across(nomi[1][2], ids[1])
            if kinds[1] == "axis" and pm @ pn < 0:  # an axis has no sense
                pm = -pm
        R = rodrigues(n1 * np.arctan2(np.cross(pm, pn) @ n1, pm @ pn)) @ R1
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
        return rigid(R, np.linalg.solve(E, np.array(rhs))) @ T

    T, it, converged = settle(step, T0, plan_size(plan), max_iterations, 10 * SETTLED_MM)
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
    src = plan_name(plan)
    raw = plan.options.get("rps")
    if not isinstance(raw, dict) or not raw:
        raise InputError(
            f"{src}: rps: the RPS alignment needs reference points (rps: {{R1: {{feature: H1, fixes: [x, y]}}}})"
        )
    f = unit_factor(plan)
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
            _, pm, dm = _element(associate(plan, X, spec, cad, "ls"))
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
        delta, free_vecs = truncated_solve(J, -np.array(res))
        state["free"] = [dof_words(v, c) for v in free_vecs]
        return step_transform(delta, c) @ T

    T, it, converged = settle(step, T0, plan_size(plan), max_iterations, 10 * SETTLED_MM)
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
