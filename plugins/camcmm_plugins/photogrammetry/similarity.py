"""7-parameter similarity (Helmert) between two point sets, and the ring-radius measure.

A structure-from-motion result has its own origin, orientation and scale (scale is not
observable from images alone), so it is compared with a reference (the templeRing gantry's
cameras) after the least-squares similarity ``dst ≈ s R src + t`` (Umeyama 1991, "Least-
squares estimation of transformation parameters between two point patterns", IEEE PAMI 13(4)).
Written out here (a dozen lines of SVD) because OpenCV's estimateAffine3D is affine, not a
similarity, and pycolmap's Sim3d estimator works on its own reconstruction types.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError


def similarity(src: np.ndarray, dst: np.ndarray) -> dict[str, Any]:
    """Least-squares similarity mapping ``src`` onto ``dst`` (Umeyama 1991, eqs. 40-42).

    Parameters
    ----------
    src, dst : (N, 3) arrays of corresponding points, N >= 3 and not collinear.

    Returns
    -------
    dict with ``scale`` (s), ``R`` (3, 3) proper rotation, ``t`` (3,), ``residuals`` (N, 3)
    = s R src + t - dst (in dst's units) and ``rms`` (root mean square of their lengths).
    """
    a = np.asarray(src, dtype=np.float64)
    b = np.asarray(dst, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3 or len(a) < 3:
        raise InputError(f"similarity: need two (N, 3) arrays of the same N >= 3, got {a.shape} and {b.shape}")
    ma, mb = a.mean(0), b.mean(0)
    da, db = a - ma, b - mb
    var_a = (da**2).sum() / len(a)
    cov = db.T @ da / len(a)
    u, sig, vt = np.linalg.svd(cov)
    if var_a <= 0 or sig[1] <= 1e-12 * sig[0]:
        raise InputError("similarity: the points are collinear (or coincide); the rotation is not determined")
    d = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:  # a reflection fits better: take the best rotation
        d[2] = -1.0
    rot = u @ np.diag(d) @ vt
    scale = float((sig * d).sum() / var_a)
    t = mb - scale * rot @ ma
    res = scale * a @ rot.T + t - b
    return {"scale": scale, "R": rot, "t": t, "residuals": res, "rms": float(np.sqrt((res**2).sum(1).mean()))}


def circle_radius(points: np.ndarray) -> float:
    """Radius of the circle fitted to points lying near a circle in 3-D (a camera ring).

    The points' best plane (least squares, via SVD) takes them to 2-D, where the algebraic
    circle fit (Kåsa 1976) gives the radius; for points on a circle both are exact.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 3:
        raise InputError(f"circle_radius: need (N, 3) points with N >= 3, got {p.shape}")
    c = p.mean(0)
    _, _, vt = np.linalg.svd(p - c)
    xy = (p - c) @ vt[:2].T
    a = np.column_stack([2 * xy, np.ones(len(xy))])
    sol, *_ = np.linalg.lstsq(a, (xy**2).sum(1), rcond=None)
    return float(np.sqrt(sol[2] + sol[0] ** 2 + sol[1] ** 2))


def rotation_angle_deg(r1: np.ndarray, r2: np.ndarray) -> float:
    """Angle (degrees) of the rotation r1 r2^T: how far apart two orientations are."""
    c = (np.trace(np.asarray(r1) @ np.asarray(r2).T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
