"""The coarse start of an alignment: a pose for a cloud delivered in another frame (a
scanner's: rotated, far from the plan), or for a best fit from where the cloud lies that
looks caught in a wrong minimum (:func:`doubtful`).

Candidates: the cloud's principal axes onto those of points sampled on the nominal
surfaces of the plan's features (:func:`sample_nominal`, within their boxes and extents;
or of the nominal geometry when given), each of the four sign choices refined by
``inspect.align`` ICP; FPFH + RANSAC registration (``inspect.align`` global+icp) when none
brings half the points into the features' bands. Each candidate is best-fitted in bands
narrowing from 8 mm to 1 mm (:data:`WIDE_BANDS`); the one with most points within the
features' own bands wins.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from camcmm.api import CadModel, GeometryError, InputError, PointCloud, get_algorithm

from .bestfit import MIN_POINTS, SURFACE_TYPES, apply, best_fit_surfaces, plan_name, rigid, select
from .model import FeatureSpec, Plan

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


def enough_in_bands(plan: Plan, points: np.ndarray, cad: Any) -> tuple[bool, str]:
    """Whether the cloud as it lies is near enough the plan for the fine methods: at least
    half the features find MIN_POINTS points within their bands."""
    specs = [s for s in plan.features.values() if s.type in SURFACE_TYPES]
    if not specs:
        return True, ""
    found = sum(len(select(points, s, cad)) >= MIN_POINTS for s in specs)
    ok = 2 * found >= len(specs)
    return ok, f"{found} of {len(specs)} features have points within their bands as the cloud lies"


def doubtful(plan: Plan, P: np.ndarray, cad: Any, max_iterations: int = 50) -> tuple[np.ndarray, str]:
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
    near = score(plan, X, cad)
    wide = score(
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
        out.append(rigid(R, cx - R @ cp))
    return out


def score(plan: Plan, X: np.ndarray, cad: Any) -> int:
    """Points within the bands of the plan's surface features (the more, the better the pose)."""
    return sum(len(select(X, s, cad)) for s in plan.features.values() if s.type in SURFACE_TYPES)


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
                f"{plan_name(plan)}: the cloud is far from the plan's coordinates and the plan's features do not bound "
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
        tried[name] = score(plan, apply(T1, P), cad)
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
