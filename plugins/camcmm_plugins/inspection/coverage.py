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

Big clouds: with the default distance, a cloud of more than ``max_points`` (2 000 000)
points is represented by a seeded random subsample of that many, and the distance is
three spacings *of the subsample* — the criterion is the same (0.2 % chance of a spot
inside a measured patch counting as uncovered), only the reach past a patch's edge grows
by √(N / max_points) (for 10⁷ points on a 100 mm part: 0.07 -> 0.16 mm, about 0.07 % of
the area along a 250 mm rim). ``coverage_info`` states it (``n_points_used``, ``note``).
A distance given explicitly uses all points (a subsample would miss spots the full cloud
covers). The nearest-neighbour searches use one SciPy k-d tree of the points used
(built in 0.5 s for 2·10⁶ points; Open3D's index took 10 s for 10⁷).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError

#: Above this many measured points (and with the default distance) coverage uses a seeded
#: random subsample of this many (see the module docstring).
MAX_POINTS = 2_000_000


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


def _tree(points: np.ndarray):
    from scipy.spatial import cKDTree

    # unbalanced, uncompacted: the quick build (the queries barely notice)
    return cKDTree(points, balanced_tree=False, compact_nodes=False)


def default_distance(points: np.ndarray, n_probe: int = 20000, seed: int = 0, factor: float = 3.0, tree=None) -> float:
    """``factor`` times the median nearest-neighbour spacing of the measured points (from a sample)."""
    p = np.asarray(points)
    if len(p) < 2:
        raise InputError("coverage: need at least 2 measured points")
    rng = np.random.default_rng(seed)
    probe = p if len(p) <= n_probe else p[rng.choice(len(p), n_probe, replace=False)]
    d, _ = (tree or _tree(p)).query(probe, k=2, workers=-1)
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
    max_points: int = MAX_POINTS,
) -> dict[str, Any]:
    """Covered share of the nominal area.

    ``points``: measured points in nominal coordinates (mm). The nominal is a mesh
    (``vertices``, ``faces``) or a reference cloud (``reference_points``).

    Returns ``fraction`` (0..1), ``percent``, ``area`` and ``covered_area`` (mm²; for a
    cloud nominal ``area`` is None), ``std_error`` (of the fraction), ``distance`` (mm),
    ``n_samples``, ``method``, ``n_points_used`` and ``note`` (a subsample's, see the
    module docstring; ``max_points``); with ``return_samples`` also ``samples`` (M, 3), ``covered``
    (M,) bool and, for a mesh, ``triangle`` (M,) — the sample's triangle — for a GUI or a
    report that shows which parts of the nominal were measured.
    """
    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise InputError("coverage: measured points must have shape (N, 3), N > 0")
    n_all = len(p)
    note = ""
    if distance is None and n_all > max_points:
        pick = np.sort(np.random.default_rng(seed).choice(n_all, max_points, replace=False))
        p = p[pick]
        note = (
            f"a random subsample of {max_points} of the {n_all} points, distance three of its spacings "
            f"(the reach past a patch's edge {np.sqrt(n_all / max_points):.2g} x the full cloud's)"
        )
    tree = _tree(p)
    if distance is None:
        distance = default_distance(p, tree=tree)
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
    # the bound is exclusive: nudged up one ulp so that a point at exactly ``distance`` covers
    d, _ = tree.query(samples, k=1, distance_upper_bound=float(np.nextafter(distance, np.inf)), workers=-1)
    covered = d <= distance
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
        "n_points_used": int(len(p)),
        "note": note,
    }
    if return_samples:
        out["samples"] = samples
        out["covered"] = covered
        if tid is not None:
            out["triangle"] = tid
    return out
