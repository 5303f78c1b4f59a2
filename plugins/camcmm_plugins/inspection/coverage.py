"""Coverage: the share of the nominal surface *area* that has measured points near it.

The thesis (ch. 6.2.4) asks for coverage "in terms of surface area, rather than the total
number of points": a reconstruction with a million points on the top face and none on
the side walls covers little of the part, however many points it has.

Method: the nominal surface is sampled uniformly by area — stratified, each triangle gets
``floor(n A_t / A)`` samples plus one more with probability equal to the remainder, at
uniformly distributed barycentric positions — so every sample stands for the same area
``A / n``. A sample is covered when a measured point (already in nominal coordinates)
lies within ``distance`` of it (Open3D nearest-neighbour search). The covered area is the
covered share of the samples times the area; its standard error is the binomial one,
``A sqrt(c (1 - c) / n)`` (an upper bound for the stratified sample).

``distance`` sets how close a point must be to count. The default (:func:`default_distance`)
is three times the median nearest-neighbour spacing s of the measured points: for
randomly scattered points of density ρ, s = sqrt(ln 2 / (π ρ)) and the chance that a
spot inside a measured patch has no point within r is exp(-π ρ r²) — 6 % for r = 2 s,
0.2 % for r = 3 s. Coverage extends about ``distance`` beyond the edge of a measured
patch, so a patch of perimeter P covers up to ``P * distance`` more than its own area.

For a reference *cloud* as nominal there is no surface to sample; its points are the
samples (each standing for the same area — exact only for evenly spaced references).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError

from .distance import knn


def sample_surface(vertices: np.ndarray, faces: np.ndarray, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` (about) points spread uniformly by area over the triangles, and their triangle ids."""
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    tri = V[F]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = float(area.sum())
    if not total > 0:
        raise InputError("coverage: the nominal mesh has no area")
    rng = np.random.default_rng(seed)
    expect = area / total * n
    count = np.floor(expect).astype(np.int64)
    count += rng.random(len(F)) < (expect - count)
    tid = np.repeat(np.arange(len(F)), count)
    r1 = np.sqrt(rng.random(tid.size))
    r2 = rng.random(tid.size)
    t = tri[tid]
    pts = (1 - r1)[:, None] * t[:, 0] + (r1 * (1 - r2))[:, None] * t[:, 1] + (r1 * r2)[:, None] * t[:, 2]
    return pts, tid


def default_distance(points: np.ndarray, n_probe: int = 20000, seed: int = 0, factor: float = 3.0) -> float:
    """``factor`` times the median nearest-neighbour spacing of the measured points (from a sample)."""
    p = np.asarray(points, dtype=float)
    if len(p) < 2:
        raise InputError("coverage: need at least 2 measured points")
    rng = np.random.default_rng(seed)
    probe = p if len(p) <= n_probe else p[rng.choice(len(p), n_probe, replace=False)]
    _, d = knn(p, probe, 2)
    return float(factor * np.median(d[:, 1]))


def coverage(
    points: Any,
    vertices: np.ndarray | None = None,
    faces: np.ndarray | None = None,
    distance: float | None = None,
    n_samples: int = 200_000,
    reference_points: np.ndarray | None = None,
    seed: int = 0,
    return_samples: bool = False,
) -> dict[str, Any]:
    """Covered share of the nominal area.

    ``points``: measured points in nominal coordinates (mm). The nominal is a mesh
    (``vertices``, ``faces``) or a reference cloud (``reference_points``).

    Returns ``fraction`` (0..1), ``percent``, ``area`` and ``covered_area`` (mm²; for a
    cloud nominal ``area`` is None), ``std_error`` (of the fraction), ``distance`` (mm),
    ``n_samples``, ``method``; with ``return_samples`` also ``samples`` (M, 3), ``covered``
    (M,) bool and, for a mesh, ``triangle`` (M,) — the sample's triangle — for a GUI or a
    report that shows which parts of the nominal were measured.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise InputError("coverage: measured points must have shape (N, 3), N > 0")
    if distance is None:
        distance = default_distance(p)
    if not distance > 0:
        raise InputError(f"coverage: distance {distance!r} mm must be > 0")
    if vertices is not None and faces is not None:
        samples, tid = sample_surface(vertices, faces, n_samples, seed)
        V = np.asarray(vertices, dtype=float)
        tri = V[np.asarray(faces, dtype=np.int64)]
        area = float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())
        method = "mesh surface sampled uniformly by area (stratified per triangle)"
    elif reference_points is not None:
        samples = np.asarray(reference_points, dtype=float)
        tid, area = None, None
        method = "reference cloud points (each taken to stand for the same area)"
    else:
        raise InputError("coverage: give a nominal mesh (vertices, faces) or reference points")
    _, d = knn(p, samples, 1)
    covered = d[:, 0] <= distance
    n = int(samples.shape[0])
    frac = float(covered.mean())
    out: dict[str, Any] = {
        "fraction": frac,
        "percent": 100.0 * frac,
        "area": area,
        "covered_area": None if area is None else frac * area,
        "std_error": float(np.sqrt(frac * (1 - frac) / n)),
        "distance": float(distance),
        "n_samples": n,
        "method": method,
    }
    if return_samples:
        out["samples"] = samples
        out["covered"] = covered
        if tid is not None:
            out["triangle"] = tid
    return out
