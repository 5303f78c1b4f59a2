"""Sizes of features of size (ISO 14405-1:2016): global sizes by an association
criterion, local two-point sizes, and the width between two opposite planes.

* :func:`global_size` — the diameter of the circle, cylinder or sphere associated with
  the feature's points by least squares (GG), the minimum circumscribed (GN) or the
  maximum inscribed (GX) criterion, or minimum zone (GC), through
  :func:`.features.associate`.
* :func:`two_point_sizes` — the local two-point sizes (LP): the distances between
  opposite points of the feature, measured through the associated axis or centre (the
  construction is in the function's docstring); their distribution gives the local
  size's min, max, mean and range (ISO 14405-1 rank-order sizes are statistics of it).
* :func:`width` — the least-squares width between two opposite parallel planes (two
  planes of one common normal, each with its own offset).

Lengths in mm. References: ISO 14405-1:2016 §3.5-3.8 and Table 1 (specification
modifiers LP, GG, GX, GN, GC); ISO 17450-3 (the two-point size as an opposite pair).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import GeometryError, ParameterError

from .features import associate
from .model import Associated, FeatureSpec

#: Global size criteria (ISO 14405-1 GG, GN, GX, GC).
CRITERIA = ("ls", "mincircumscribed", "maxinscribed", "minzone")
_SIZED = ("circle", "cylinder", "sphere")


def _points(points: Any, associated: Associated) -> np.ndarray:
    x = np.asarray(points, dtype=float)
    if len(associated.indices) and int(associated.indices.max()) >= len(x):
        raise ParameterError(f"feature {associated.id}: its point indices do not fit the {len(x)} points given")
    return x[associated.indices]


def global_size(points: Any, associated: Associated, criterion: str = "ls") -> float:
    """The global size (mm) of a circle, cylinder or sphere: the diameter of the element
    associated with its points by ``criterion`` (ls, mincircumscribed, maxinscribed or
    minzone). ``points`` is the evaluated cloud (N, 3), the one ``associated.indices``
    index; ``associated`` gives the type, the ``internal`` flag and the points. The
    associated element is reused when it already is of that criterion."""
    if criterion not in CRITERIA:
        raise ParameterError(f"unknown size criterion {criterion!r}; use one of {', '.join(CRITERIA)}")
    if associated.type not in _SIZED:
        raise ParameterError(
            f"feature {associated.id}: a global size is a diameter of a circle, cylinder or sphere, "
            f"not of a {associated.type} (for two planes: width)"
        )
    if associated.association == criterion:
        return float(associated.params["diameter"])
    spec = FeatureSpec(
        id=associated.id,
        type=associated.type,
        nominal=dict(associated.params),
        band=float("inf"),
        association=criterion,
    )
    return float(associate(points, associated.indices, spec, criterion).params["diameter"])


def two_point_sizes(
    points: Any, associated: Associated, thickness: float | None = None, max_gap_deg: float = 10.0
) -> np.ndarray:
    """Local two-point sizes (mm, one per point that has an opposite) of a circle,
    cylinder or sphere.

    Construction (ISO 14405-1 LP, the opposite points through the associated axis):

    * cylinder — the points are cut into sections normal to the associated axis: the
      distinct heights along it when the points lie in a few sections (a scan by
      sections: ≤ n/8 distinct heights at 1e-9 of the length), else slabs of
      ``thickness`` mm (default: the length divided into slabs of about 200 points). In a
      section, point i at angle θᵢ and distance ρᵢ from the axis has as its opposite the
      section's surface at θᵢ + π: ρ interpolated linearly in angle between the two
      points of the section nearest that direction, which must be at most
      ``max_gap_deg`` apart (else point i has no opposite: a partial arc). The size is
      ρᵢ + ρ(θᵢ + π), the length of the chord through the axis.
    * circle — one section: the circle's plane.
    * sphere — the opposite of point i is the point whose direction from the centre is
      nearest −uᵢ (within ``max_gap_deg``); the size is ρᵢ + ρⱼ.

    An opposite pair appears twice (once from each end), which leaves the distribution's
    statistics unchanged. Exact when every point has a sampled antipode (the
    interpolation then lands on it); otherwise the interpolation error is that of a
    chord over the angular spacing.
    """
    x = _points(points, associated)
    t = associated.type
    p = associated.params
    gap = np.radians(max_gap_deg)
    if t == "sphere":
        return _sphere_pairs(x, np.asarray(p["centre"], float), gap)
    if t == "circle":
        a, origin = np.asarray(p["normal"], float), np.asarray(p["centre"], float)
    elif t == "cylinder":
        a, origin = np.asarray(p["axis"], float), np.asarray(p["point"], float)
    else:
        raise ParameterError(
            f"feature {associated.id}: two-point sizes are for a circle, cylinder or sphere, not a {t}"
        )
    a = a / np.linalg.norm(a)
    w = x - origin
    h = w @ a
    wp = w - h[:, None] * a
    b1 = wp[int(np.argmax(np.einsum("ij,ij->i", wp, wp)))] if len(wp) else np.zeros(3)
    if not np.linalg.norm(b1) > 0:
        raise GeometryError(f"feature {associated.id}: all points lie on the axis")
    b1 = b1 / np.linalg.norm(b1)
    b2 = np.cross(a, b1)
    theta = np.arctan2(wp @ b2, wp @ b1)
    rho = np.hypot(wp @ b1, wp @ b2)
    labels = np.zeros(len(x), dtype=np.int64) if t == "circle" else _sections(h, thickness)
    out = []
    for s in np.unique(labels):
        m = labels == s
        out.append(_opposite_sizes(theta[m], rho[m], gap))
    return np.concatenate(out) if out else np.zeros(0)


def _sections(h: np.ndarray, thickness: float | None) -> np.ndarray:
    """Section labels of heights h along the axis."""
    span = float(h.max() - h.min()) if len(h) else 0.0
    if thickness is None:
        key = np.round((h - h.min()) / max(span * 1e-9, 1e-300))
        distinct = np.unique(key)
        if len(distinct) <= max(1, len(h) // 8):
            return np.searchsorted(distinct, key)
        thickness = span / max(1, round(len(h) / 200)) if span > 0 else 1.0
    if not thickness > 0:
        raise ParameterError(f"section thickness must be > 0 mm, got {thickness}")
    return np.floor((h - h.min()) / thickness).astype(np.int64)


def _opposite_sizes(theta: np.ndarray, rho: np.ndarray, gap: float) -> np.ndarray:
    """ρᵢ + ρ(θᵢ + π) for the points of one section whose opposite direction lies
    between two points at most ``gap`` apart (periodic linear interpolation)."""
    if len(theta) < 2:
        return np.zeros(0)
    order = np.argsort(theta)
    th, r = theta[order], rho[order]
    # periodic extension: one copy of each end on the other side
    th_ext = np.concatenate([th[-1:] - 2 * np.pi, th, th[:1] + 2 * np.pi])
    r_ext = np.concatenate([r[-1:], r, r[:1]])
    target = np.mod(theta + np.pi + np.pi, 2 * np.pi) - np.pi  # θ + π wrapped into [−π, π)
    j = np.clip(np.searchsorted(th_ext, target, side="right"), 1, len(th_ext) - 1)
    t0, t1 = th_ext[j - 1], th_ext[j]
    span = t1 - t0
    ok = span <= gap
    f = np.where(span > 0, (target - t0) / np.where(span > 0, span, 1.0), 0.0)
    opposite = r_ext[j - 1] + f * (r_ext[j] - r_ext[j - 1])
    return (rho + opposite)[ok]


def _sphere_pairs(x: np.ndarray, centre: np.ndarray, gap: float) -> np.ndarray:
    from scipy.spatial import cKDTree

    w = x - centre
    rho = np.linalg.norm(w, axis=1)
    u = w / np.where(rho > 0, rho, 1.0)[:, None]
    # chord length between unit vectors at angle gap: 2 sin(gap / 2)
    d, j = cKDTree(u).query(-u, k=1, distance_upper_bound=2 * np.sin(gap / 2))
    ok = np.isfinite(d)
    return rho[ok] + rho[j[ok]]


def width(points: Any, side1: Associated, side2: Associated) -> float:
    """Least-squares width (mm) between two opposite planar faces: the two parallel
    planes of one common normal, each with its own offset, that minimise the sum of the
    squared distances of both faces' points; the width is the distance between them.
    The common normal is the least eigenvector of the pooled scatter of the two faces'
    points, each centred on its own centroid."""
    for s in (side1, side2):
        if s.type != "plane":
            raise ParameterError(f"feature {s.id}: a width is between two planes, not a {s.type}")
    x1, x2 = _points(points, side1), _points(points, side2)
    if len(x1) < 3 or len(x2) < 3:
        raise GeometryError("a width needs at least 3 points on each face")
    c1, c2 = x1.mean(axis=0), x2.mean(axis=0)
    pooled = np.vstack([x1 - c1, x2 - c2])
    n = np.linalg.svd(pooled, full_matrices=False)[2][-1]
    return float(abs((c2 - c1) @ n))
