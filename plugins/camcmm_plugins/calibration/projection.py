"""Projection uncertainty across the image, propagated from the calibration's parameter
covariance the way mrcal does it (the heat map of issue #7).

For a pixel q and a working distance z (mm, along the optical axis) the point
p = z [undistort(q), 1] is fixed in the frame of each calibration board view v,
p_v = R_v^T (p - t_v). A perturbed calibration (intrinsics and board poses together)
maps it back as p' = mean_v (R_v' p_v + t_v') and projects it with its own intrinsics,
q' = project(p'). To first order Var(q') = G Sigma G^T, G = dq'/dtheta, Sigma the
covariance of (intrinsics, board poses) from :mod:`.covariance`. Taking the mean over
the views (not the camera frame) is what makes the principal point's uncertainty, which
the board poses absorb, not show up as a spurious image-wide error.

The reported value is the worst-direction standard deviation, sqrt of the larger
eigenvalue of the 2 x 2 covariance of q', in px.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError


def _pieces(cal: dict[str, Any]):
    if "camera" in cal:
        K, D = cal["camera"].camera_matrix, cal["camera"].dist_coeffs
        size = cal["camera"].image_size
    elif "cameras" in cal:
        K, D, size = cal["cameras"][0].camera_matrix, cal["cameras"][0].dist_coeffs, cal["cameras"][0].image_size
    else:
        raise InputError("projection uncertainty needs a camera calibration (a 'camera' or 'cameras' entry)")
    views, cov = cal.get("views"), cal.get("parameter_covariance")
    if views is None or cov is None:
        raise InputError(
            "projection uncertainty needs the calibration's board poses ('views') and "
            "'parameter_covariance' (a single-camera calibration made by camcmm)"
        )
    rv = np.asarray(views["rvecs"], np.float64).reshape(-1, 3)
    tv = np.asarray(views["tvecs"], np.float64).reshape(-1, 3)
    cov = np.asarray(cov, np.float64)
    n_i = 4 + np.ravel(D).size
    if cov.shape != (n_i + 6 * len(rv),) * 2:
        raise InputError(
            f"parameter_covariance is {cov.shape}, expected {(n_i + 6 * len(rv),) * 2} "
            f"for {n_i} intrinsics and {len(rv)} views"
        )
    return np.asarray(K, np.float64), np.asarray(D, np.float64).ravel(), tuple(size), rv, tv, cov


def projection_gradient(
    K, D, rvecs, tvecs, pixels: np.ndarray, distance: float, method: str = "mrcal"
) -> tuple[np.ndarray, np.ndarray]:
    """(G (M, 2, P), p (M, 3)): gradients of the re-projected pixels with respect to
    (intrinsics, view poses), and the camera-frame points, for pixels (M, 2) at depth z."""
    import cv2

    pix = np.asarray(pixels, np.float64).reshape(-1, 1, 2)
    n = cv2.undistortPoints(pix, K, D, criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 50, 1e-12))
    p = np.column_stack([n.reshape(-1, 2), np.ones(len(pix))]) * float(distance)
    m, nv, ni = len(p), len(rvecs), 4 + D.size
    _, jac = cv2.projectPoints(p.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    jac = jac.reshape(m, 2, -1)
    dq_dp = jac[:, :, 3:6]  # d q / d(camera-frame point): the tvec columns at the identity pose
    G = np.zeros((m, 2, ni + 6 * nv))
    G[:, :, :ni] = jac[:, :, 6:]
    if method == "intrinsics":
        return G, p
    if method != "mrcal":
        raise InputError(f"projection uncertainty method {method!r}: use mrcal or intrinsics")
    for v in range(nv):
        R, dRdr = cv2.Rodrigues(rvecs[v])
        pv = (p - tvecs[v]) @ R  # R^T (p - t), row-wise
        dR = dRdr.reshape(3, 3, 3)  # [j] = d R / d r_j
        dp_dr = np.einsum("jab,mb->maj", dR, pv) / nv  # (M, 3, 3): d p' / d r_v
        G[:, :, ni + 6 * v : ni + 6 * v + 3] = np.einsum("mia,maj->mij", dq_dp, dp_dr)
        G[:, :, ni + 6 * v + 3 : ni + 6 * v + 6] = dq_dp / nv
    return G, p


def projection_uncertainty(
    cal: dict[str, Any], distance: float, *, grid: tuple[int, int] = (32, 24), method: str = "mrcal"
) -> dict[str, Any]:
    """Worst-direction projection standard deviation (px) on a grid over the image.

    ``cal``: a single-camera result of :func:`camera.calibrate_camera` or a calibration
    file dict with its ``views`` and ``parameter_covariance``; ``distance``: working
    distance z in mm; ``grid``: (columns, rows) of the map. ``method`` "mrcal" (see the
    module docstring) or "intrinsics" (point fixed in the camera frame, intrinsics'
    covariance only: larger, the board poses' compensation ignored).

    Returns ``map`` (rows, columns) px, ``u`` (columns,) and ``v`` (rows,) pixel
    coordinates of the grid, ``distance``, ``covariance`` (rows, columns, 2, 2) px^2,
    and ``min``, ``max``, ``centre`` of the map.
    """
    if not (np.isfinite(distance) and distance > 0):
        raise InputError(f"working distance {distance!r} must be a positive number of mm")
    K, D, size, rv, tv, cov = _pieces(cal)
    nx, ny = int(grid[0]), int(grid[1])
    if nx < 2 or ny < 2:
        raise InputError(f"grid {grid!r}: needs at least 2 x 2 points")
    w, h = size if size[0] > 0 else (2 * K[0, 2], 2 * K[1, 2])
    u = np.linspace(0, w - 1, nx)
    v = np.linspace(0, h - 1, ny)
    uu, vv = np.meshgrid(u, v)
    G, _ = projection_gradient(K, D, rv, tv, np.column_stack([uu.ravel(), vv.ravel()]), distance, method)
    S = np.einsum("mip,pq,mjq->mij", G, cov, G)
    worst = np.sqrt(np.maximum(np.linalg.eigvalsh(S)[:, 1], 0.0)).reshape(ny, nx)
    centre = float(projection_at(cal, [(w - 1) / 2, (h - 1) / 2], distance, method)[0])
    return {
        "map": worst,
        "u": u,
        "v": v,
        "distance": float(distance),
        "covariance": S.reshape(ny, nx, 2, 2),
        "min": float(worst.min()),
        "max": float(worst.max()),
        "centre": centre,
        "unit": "px",
        "method": method,
    }


def projection_at(cal: dict[str, Any], pixels, distance: float, method: str = "mrcal") -> np.ndarray:
    """Worst-direction projection standard deviation (px) at given pixels (M, 2)."""
    K, D, _, rv, tv, cov = _pieces(cal)
    G, _ = projection_gradient(K, D, rv, tv, np.asarray(pixels, np.float64).reshape(-1, 2), distance, method)
    S = np.einsum("mip,pq,mjq->mij", G, cov, G)
    return np.sqrt(np.maximum(np.linalg.eigvalsh(S)[:, 1], 0.0))
