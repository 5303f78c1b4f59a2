"""Gauge block wrung on a platen (thesis 3.2.4, 3.3.3, fig. 3.12): height, flatness of
both surfaces and the error against the calibrated length.

The cloud holds points on the platen and on the block's measuring face. The two
surfaces are split along the normal of the dominant plane (Open3D's RANSAC
segment_plane): points within half the nominal length of it belong to it, the others to
the second surface; then both are fitted by least squares (SVD, orthogonal distances)
and the split repeated with the refined platen plane; points more than 4 robust
standard deviations (1.4826 MAD) off their surface's plane (side walls, strays) are
left out. The platen is the surface with
the larger in-plane extent (the block's face is the smaller one) unless ``up`` says
which way the block stands.

height = n_p . (c_top - c_p): the top face's centroid to the platen plane along the
platen normal n_p (the thesis' "orientated with the platen surface on the z axis"),
flatness = peak-to-valley of the residuals to each LS plane, std = their standard
deviation (the thesis quotes the std: 32 um and 27 um), error = height - nominal.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import GeometryError, InputError, ParameterError

#: ``up`` only says which side of the platen the block stands on: it may be rough, but
#: beyond this angle from the surfaces' normal the sign of up . (top - platen) depends
#: as much on where the face sits sideways as on which surface is higher.
MAX_UP_ANGLE_DEG = 60.0


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares plane (centroid (3,), unit normal (3,)) through (N, 3) points."""
    c = points.mean(0)
    n = np.linalg.svd(points - c, full_matrices=False)[2][2]
    return c, n


def _extent(points: np.ndarray, normal: np.ndarray) -> float:
    # in-plane spread: sum of the two largest principal variances
    c = points - points.mean(0)
    c = c - np.outer(c @ normal, normal)
    return float(np.sum(np.linalg.svd(c, compute_uv=False)[:2] ** 2) / len(points))


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (deg) between the lines along unit vectors a and b, 0 .. 90.

    atan2(|a x b|, |a . b|) rather than arccos(a . b): near 0 the cosine is flat, so
    arccos cannot resolve angles below ~1e-6 deg (one rounding step under 1.0 is
    already 8.5e-7 deg); the cross product keeps full relative precision."""
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), abs(float(np.dot(a, b))))))


def gauge_block(
    points, nominal: float, *, up=None, ransac_threshold: float | None = None, seed: int = 0
) -> dict[str, Any]:
    """Height of a gauge block over its platen from an (N, 3) cloud in mm.

    ``nominal``: calibrated (or nominal) length, mm; ``up``: optional (3,) direction
    from the platen towards the block's face (within MAX_UP_ANGLE_DEG of the normal);
    ``ransac_threshold``: inlier band of the first plane, mm (default nominal / 10). Returns
    ``height``, ``error`` (height - nominal), ``nominal``, ``platen`` and ``top`` ({point, normal, n_points, flatness,
    std}), ``parallelism`` (angle between the normals, deg), ``labels`` (N,) 0 platen,
    1 top, -1 neither.
    """
    pts = np.asarray(points, np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"gauge block: points must be (N, 3), got {pts.shape}")
    pts = pts[np.all(np.isfinite(pts), 1)]
    if not (np.isfinite(nominal) and nominal > 0):
        raise InputError(f"gauge block: nominal length {nominal!r} must be a positive number of mm")
    if len(pts) < 20:
        raise GeometryError(f"gauge block: {len(pts)} points; need at least 20 on the two surfaces")
    if ransac_threshold is not None and not (np.isfinite(ransac_threshold) and ransac_threshold > 0):
        raise ParameterError(f"gauge block: ransac threshold {ransac_threshold!r} must be a positive number of mm")
    u = None
    if up is not None:
        try:
            u = np.asarray(up, np.float64).ravel()
        except (TypeError, ValueError):
            u = np.array([np.nan])
        if u.shape != (3,) or not np.all(np.isfinite(u)) or not np.any(u):
            raise ParameterError(f"gauge block: up {up!r} must be 3 finite numbers, not all zero")
        u = u / np.abs(u).max()  # first, so that neither 1e-320 nor 1e308 under- or overflows the norm
        u = u / np.linalg.norm(u)
    thr = float(ransac_threshold) if ransac_threshold is not None else nominal / 10.0
    import open3d as o3d

    o3d.utility.random.seed(int(seed))
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    model, _ = pc.segment_plane(distance_threshold=thr, ransac_n=3, num_iterations=2000)
    n = np.asarray(model[:3], np.float64)
    n /= np.linalg.norm(n)
    c = pts[np.argmin(np.abs(pts @ n + model[3] / np.linalg.norm(model[:3])))]
    labels = np.full(len(pts), -1)
    for _ in range(5):
        h = (pts - c) @ n
        a = np.abs(h) < nominal / 2
        far = (np.abs(h) >= nominal / 2) & (np.abs(h) < 1.5 * nominal)
        # the second surface is on one side: keep the side holding most of the far points
        side = np.sign(np.median(h[far])) if far.any() else 1.0
        b = far & (np.sign(h) == side)
        if a.sum() < 3 or b.sum() < 3:
            raise GeometryError(
                f"gauge block: found only one surface ({int(a.sum())} and {int(b.sum())} points "
                f"within +-{nominal / 2:g} mm of two planes {nominal:g} mm apart)"
            )
        new = np.where(a, 0, np.where(b, 1, -1))
        c, n = fit_plane(pts[a])
        if np.array_equal(new, labels):
            break
        labels = new
    for k in (0, 1):  # points off the surface (the block's side walls, stray points)
        idx = np.flatnonzero(labels == k)
        for _ in range(3):
            c0, n0 = fit_plane(pts[idx])
            r = (pts[idx] - c0) @ n0
            mad = 1.4826 * np.median(np.abs(r - np.median(r)))
            keep = np.abs(r - np.median(r)) <= max(4.0 * mad, 1e-12 * nominal)
            if keep.all() or keep.sum() < 3:
                break
            labels[idx[~keep]] = -1
            idx = idx[keep]
    ca, na = fit_plane(pts[labels == 0])
    cb, nb = fit_plane(pts[labels == 1])
    if u is not None:
        off = _angle_deg(na, u)
        if off > MAX_UP_ANGLE_DEG:
            raise GeometryError(
                f"gauge block: up {up!r} is {off:.0f} deg from the surfaces' normal (at most "
                f"{MAX_UP_ANGLE_DEG:g}); it must point from the platen to the block's face"
            )
        platen_is_a = np.dot(cb - ca, u) > 0
    else:
        platen_is_a = _extent(pts[labels == 0], na) >= _extent(pts[labels == 1], nb)
    if not platen_is_a:
        labels = np.where(labels == 0, 1, np.where(labels == 1, 0, -1))
        (ca, na), (cb, nb) = (cb, nb), (ca, na)
    if np.dot(cb - ca, na) < 0:
        na = -na
    if np.dot(nb, na) < 0:
        nb = -nb

    def surface(c0, n0, mask):
        r = (pts[mask] - c0) @ n0
        return {
            "point": c0,
            "normal": n0,
            "n_points": int(mask.sum()),
            "flatness": float(np.ptp(r)),
            "std": float(r.std(ddof=3)) if mask.sum() > 3 else float("nan"),
        }

    height = float(np.dot(cb - ca, na))
    return {
        "height": height,
        "error": height - float(nominal),
        "nominal": float(nominal),
        "platen": surface(ca, na, labels == 0),
        "top": surface(cb, nb, labels == 1),
        "parallelism": _angle_deg(na, nb),
        "labels": labels,
        "unit": "mm",
    }
