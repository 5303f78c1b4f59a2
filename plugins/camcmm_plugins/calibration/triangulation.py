"""Triangulation from two or more calibrated cameras, with per-point covariance.

* ``linear``: eq. 3.2, A X = 0 with rows u p^3 - p^1 and v p^3 - p^2 per camera (p^k:
  row k of P = K [R | t]), solved with X_4 = 1 by the 3x3 normal equations of all points
  at once (closed form); the pixels are undistorted first (Newton, :func:`_undistort`).
  10^5 points take ~0.4 x the time of cv2.undistortPoints + cv2.triangulatePoints
  (benchmarks/bench_calibration.py), at the same error against the true points.
* ``optimal``: the point with the least reprojection error (in undistorted pixel
  coordinates), by Gauss-Newton from the linear solution, for any number of cameras.
  For two cameras this is Hartley-Sturm's optimum (cv2.correctMatches, then the linear
  solution; the tests check they agree), found ~10x faster than correctMatches, whose
  per-point polynomial root finding takes ~45 us a point.

Covariance to first order (implicit-function theorem on the least-squares problem):
with A = d pixels / d X (2V, 3) and B = d pixels / d theta (calibration parameters),
H = (A^T A)^-1 A^T and Sigma_X = H (s^2 I + B Sigma_theta B^T) H^T.

Why not the uncertainty plugin's batched triangulation: plugins may not import each
other, and that one serves the Monte Carlo of distortion-free perturbed pinholes with two
cameras; this one undistorts with OpenCV's full model, takes N cameras and gives each
point's covariance.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from camcmm.api import CameraModel, InputError

#: Newton's undistortion stops when no point moved more than this (normalised image
#: coordinates, ~2e-12 px at f = 2000 px): convergence is quadratic, so the error left is
#: far below it; points still moving after ``NEWTON_MAX`` steps go to OpenCV's iteration.
NEWTON_TOL = 1e-14
NEWTON_MAX = 20


def _undistort(cam: CameraModel, px: np.ndarray) -> np.ndarray:
    """Undistorted pixels (N, 2) of distorted ones, px (OpenCV's model, eqs. 2.3-2.6).

    Newton's method on the distortion map, all points at once (the 2x2 Jacobian of each
    point inverted in closed form), started from the distorted point: 4-6 steps reach
    machine precision, where cv2.undistortPoints' fixed-point iteration takes all of its
    100 steps and converges only linearly. The pixel <-> normalised conversions are
    OpenCV's (the inverse ignores the skew K[0, 1], the forward map applies K), so a
    point comes out as cv2.undistortPoints(..., P=K) would give it converged. Points
    where Newton does not converge (beyond the fold of a strong distortion) and the
    14-coefficient tilted model go to cv2.undistortPoints itself (100 iterations,
    1e-14 px)."""
    px = np.asarray(px, np.float64)
    d = cam.dist_coeffs
    if not np.any(d):
        return px.copy()
    if d.size > 12:
        return _undistort_cv2(cam, px)
    k = np.zeros(12)
    k[: d.size] = d
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = k
    K = cam.camera_matrix
    xo = (px[:, 0] - K[0, 2]) / K[0, 0]
    yo = (px[:, 1] - K[1, 2]) / K[1, 1]
    x, y = xo.copy(), yo.copy()
    rational = bool(k4 or k5 or k6)
    ok = np.zeros(len(px), bool)
    for _ in range(NEWTON_MAX):
        xx, yy, xy = x * x, y * y, x * y
        r2 = xx + yy
        num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d num / d r2
        if rational:
            den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
            rad = num / den
            drad = (dnum - rad * (k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2))) / den
        else:
            rad, drad = num, dnum
        tx = s1 + s2 * r2  # thin prism: s1 r2 + s2 r4, derivative (s1 + 2 s2 r2) d r2
        ty = s3 + s4 * r2
        fx = x * rad + 2.0 * p1 * xy + p2 * (r2 + 2.0 * xx) + tx * r2 - xo
        fy = y * rad + p1 * (r2 + 2.0 * yy) + 2.0 * p2 * xy + ty * r2 - yo
        gx = 2.0 * (drad * x + p2 + s1 + 2.0 * s2 * r2)  # shared parts of the Jacobian
        gy = 2.0 * (drad * y + p1 + s3 + 2.0 * s4 * r2)
        jxx = rad + x * gx + 2.0 * p1 * y + 4.0 * p2 * x
        jxy = y * (2.0 * drad * x + 2.0 * p2 + 2.0 * s1 + 4.0 * s2 * r2) + 2.0 * p1 * x
        jyx = x * (2.0 * drad * y + 2.0 * p1 + 2.0 * s3 + 4.0 * s4 * r2) + 2.0 * p2 * y
        jyy = rad + y * gy + 4.0 * p1 * y + 2.0 * p2 * x
        det = jxx * jyy - jxy * jyx
        dx = (jyy * fx - jxy * fy) / det
        dy = (jxx * fy - jyx * fx) / det
        x -= dx
        y -= dy
        ok = np.abs(dx) + np.abs(dy) <= NEWTON_TOL * (1.0 + np.abs(x) + np.abs(y))
        if ok.all():
            break
    out = np.column_stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]])
    if not ok.all():  # NaN steps (det 0) count as not converged too
        bad = ~ok
        out[bad] = _undistort_cv2(cam, px[bad])
    return out


def _undistort_cv2(cam: CameraModel, px: np.ndarray) -> np.ndarray:
    import cv2

    if len(px) == 0:
        return np.zeros((0, 2))
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-14)
    return cv2.undistortPoints(
        px.reshape(-1, 1, 2).astype(np.float64), cam.camera_matrix, cam.dist_coeffs, P=cam.camera_matrix, criteria=crit
    ).reshape(-1, 2)


def _solve_sym3(m: list[np.ndarray], b: list[np.ndarray]) -> np.ndarray:
    """Solve N symmetric 3x3 systems at once by cofactors: ``m`` the entries
    [m00, m01, m02, m11, m12, m22] (each (N,)), ``b`` the right-hand sides [b0, b1, b2];
    returns (N, 3). (A batched LAPACK solve costs ~20x more for 3x3 matrices.)"""
    m00, m01, m02, m11, m12, m22 = m
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    c11 = m00 * m22 - m02 * m02
    c12 = m01 * m02 - m00 * m12
    c22 = m00 * m11 - m01 * m01
    det = m00 * c00 + m01 * c01 + m02 * c02
    out = np.empty((len(det), 3))
    out[:, 0] = (c00 * b[0] + c01 * b[1] + c02 * b[2]) / det
    out[:, 1] = (c01 * b[0] + c11 * b[1] + c12 * b[2]) / det
    out[:, 2] = (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det
    return out


def _normal_equations(rows: list[tuple[np.ndarray, np.ndarray]]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Entries of Σ g gᵀ and Σ g e over rows (g (3, N), e (N,)) given as pairs (g, e)."""
    m = [np.zeros(0)] * 6
    b = [np.zeros(0)] * 3
    pairs = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
    for j, (g, e) in enumerate(rows):
        for q, (i, k) in enumerate(pairs):
            t = g[i] * g[k]
            m[q] = t if j == 0 else m[q] + t
        for i in range(3):
            t = g[i] * e
            b[i] = t if j == 0 else b[i] + t
    return m, b


def _linear(P: np.ndarray, x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Eq. 3.2 for N points: P (V, 3, 4), x (V, N, 2) undistorted px, f (V,) focal
    lengths px -> (N, 3).

    The rows u p^3 - p^1 and v p^3 - p^2 of each camera, divided by its focal length, are
    solved in the inhomogeneous form (X_4 = 1: the least-squares X of A[:, :3] X =
    -A[:, 3]) through the 3x3 normal equations of every point at once. A row's residual
    is then depth x pixel error / f = depth x angle, alike for all cameras and whatever
    the position of the world origin (the homogeneous SVD form weighs a point by the
    norm of (X, 1) instead, and rows scaled to unit norm would ignore a camera far from
    the origin). Hartley & Zisserman, Multiple View Geometry, 2nd ed., sec. 12.2."""
    rows = []
    for v in range(len(P)):
        a = P[v] / f[v]
        for c in (0, 1):
            row = x[v, :, c][None, :] * a[2][:, None] - a[c][:, None]  # (4, N)
            rows.append((row[:3], -row[3]))
    m, b = _normal_equations(rows)
    return _solve_sym3(m, b)


def _project(P: np.ndarray, X: np.ndarray) -> np.ndarray:
    h = np.einsum("vij,nj->vni", P[:, :, :3], X) + P[:, None, :, 3]
    return h[..., :2] / h[..., 2:]


def _gauss_newton(P: np.ndarray, x: np.ndarray, X: np.ndarray, iterations: int = 20) -> np.ndarray:
    """Least reprojection error (undistorted px) by Gauss-Newton from X (N, 3), all
    points at once: per camera and image coordinate the Jacobian row
    d(h_c / w)/dX = (p^c - (h_c / w) p^3) / w (h = P X), the 3x3 normal equations
    solved by cofactors."""
    Xt = np.ascontiguousarray(X.T)  # (3, N): contiguous coordinate rows
    for _ in range(iterations):
        rows = []
        for v in range(len(P)):
            h = P[v, :, :3] @ Xt + P[v, :, 3:]  # (3, N)
            iw = 1.0 / h[2]
            for c in (0, 1):
                q = h[c] * iw
                g = (P[v, c, :3][:, None] - q * P[v, 2, :3][:, None]) * iw
                rows.append((g, x[v, :, c] - q))
        m, b = _normal_equations(rows)
        step = _solve_sym3(m, b).T
        Xt += step
        if np.max(np.abs(step)) < 1e-12 * max(1.0, np.max(np.abs(Xt))):
            break
    return Xt.T.copy()


def fundamental(c1: CameraModel, c2: CameraModel) -> np.ndarray:
    R = c2.rotation @ c1.rotation.T
    t = c2.translation - R @ c1.translation
    tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
    return np.linalg.inv(c2.camera_matrix).T @ tx @ R @ np.linalg.inv(c1.camera_matrix)


def triangulate(
    cameras: Sequence[CameraModel],
    pixels,
    *,
    method: str = "optimal",
    pixel_sigma: float | None = None,
    parameter_covariance: np.ndarray | None = None,
) -> dict[str, Any]:
    """Triangulate N points seen by V >= 2 cameras.

    Parameters
    ----------
    cameras : sequence of CameraModel, length V >= 2
    pixels : array_like, shape (V, N, 2)
        Observed (distorted) pixel coordinates, px; camera k's in row k.
    method : {"optimal", "linear"}, default "optimal"
        Least reprojection error, or the linear (DLT) solution (module docstring).
    pixel_sigma : float, optional
        px, standard deviation per image coordinate.
    parameter_covariance : ndarray, optional
        Over each camera's intrinsics fx fy cx cy dist..., then each camera k >= 1's pose
        rx ry rz tx ty tz (as a stereo calibration's ``parameter_covariance``).

    Returns
    -------
    dict
        ``points`` (N, 3) mm in the world frame (camera 0's for a calibration),
        ``reprojection_rms`` (N,) px; with ``pixel_sigma`` and/or
        ``parameter_covariance`` also ``covariance`` (N, 3, 3) mm² and ``std`` (N, 3) mm.
    """
    cams = list(cameras)
    x = np.asarray(pixels, np.float64)
    if len(cams) < 2:
        raise InputError(f"triangulation needs at least 2 cameras, got {len(cams)}")
    if x.ndim != 3 or x.shape[0] != len(cams) or x.shape[2] != 2:
        raise InputError(f"pixels must be (cameras={len(cams)}, points, 2), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise InputError("pixels contain NaN or infinite values")
    if method not in ("linear", "optimal"):
        raise InputError(f"triangulation method {method!r}: use linear or optimal")
    u = np.stack([_undistort(c, x[k]) for k, c in enumerate(cams)])
    P = np.stack([c.projection_matrix for c in cams])
    f = np.array([np.sqrt(abs(c.camera_matrix[0, 0] * c.camera_matrix[1, 1])) for c in cams])
    if method == "linear":
        X = _linear(P, u, f)
    else:
        X = _gauss_newton(P, u, _linear(P, u, f))
    rep = _project(P, X) - u
    out = {"points": X, "reprojection_rms": np.sqrt(np.mean(np.sum(rep**2, 2), 0)), "method": method}
    if pixel_sigma is not None or parameter_covariance is not None:
        cov = point_covariance(cams, X, pixel_sigma or 0.0, parameter_covariance)
        out["covariance"] = cov
        out["std"] = np.sqrt(np.einsum("nii->ni", cov))
    return out


def point_covariance(
    cameras: Sequence[CameraModel], X: np.ndarray, pixel_sigma: float, parameter_covariance: np.ndarray | None
) -> np.ndarray:
    """(N, 3, 3) first-order covariance of triangulated points X (N, 3) (module docstring)."""
    import cv2

    cams = list(cameras)
    n = len(X)
    sizes = [4 + c.dist_coeffs.size for c in cams]
    n_theta = sum(sizes) + 6 * (len(cams) - 1)
    A = np.zeros((n, 2 * len(cams), 3))
    B = np.zeros((n, 2 * len(cams), n_theta))
    off = np.concatenate([[0], np.cumsum(sizes)])
    for k, c in enumerate(cams):
        rvec = cv2.Rodrigues(c.rotation)[0]
        _, jac = cv2.projectPoints(X.reshape(-1, 1, 3), rvec, c.translation, c.camera_matrix, c.dist_coeffs)
        jac = jac.reshape(n, 2, -1)
        A[:, 2 * k : 2 * k + 2] = jac[:, :, 3:6] @ c.rotation  # d q / d X = d q / d x_cam R
        B[:, 2 * k : 2 * k + 2, off[k] : off[k + 1]] = jac[:, :, 6:]
        if k >= 1:
            p0 = off[-1] + 6 * (k - 1)
            B[:, 2 * k : 2 * k + 2, p0 : p0 + 6] = jac[:, :, :6]
    H = np.linalg.solve(np.einsum("nki,nkj->nij", A, A), np.transpose(A, (0, 2, 1)))  # (N, 3, 2V)
    S = np.broadcast_to(np.eye(2 * len(cams)) * float(pixel_sigma) ** 2, (n, 2 * len(cams), 2 * len(cams)))
    if parameter_covariance is not None:
        C = np.asarray(parameter_covariance, np.float64)
        if C.shape != (n_theta, n_theta):
            raise InputError(
                f"parameter_covariance is {C.shape}, expected {(n_theta, n_theta)} "
                f"(intrinsics of {len(cams)} cameras, then the poses of cameras 2..)"
            )
        S = S + np.einsum("nkp,pq,nlq->nkl", B, C, B)
    return np.einsum("nik,nkl,njl->nij", H, S, H)
