"""Covariance of calibration parameters from the calibration Jacobian (first order).

OpenCV's calibrateCameraExtended gives only the standard deviations of the intrinsics
and stereoCalibrateExtended none at all, so the Jacobian of the reprojection residuals
(thesis eq. 2.19) is assembled here from cv2.projectPoints' and cv2.composeRT's analytic
derivatives and the covariance taken as mrcal does::

    Sigma = s^2 (J^T J)^-1,   s^2 = sum(r^2) / (2 N_points - N_free_parameters)

Parameter layout (the "full" vector; parameters the calibration held fixed have zero
rows and columns): for each camera k its intrinsics ``fx fy cx cy`` + the distortion
coefficients in OpenCV's order (k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 taux tauy, as many as
the camera has); then for each camera k >= 1 its pose in camera 0 (rvec, tvec: rad,
mm); then for each view v the board pose in camera 0 (rvec, tvec).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DIST_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "taux", "tauy")
POSE_NAMES = ("rx", "ry", "rz", "tx", "ty", "tz")


def intrinsic_names(n_dist: int) -> list[str]:
    return ["fx", "fy", "cx", "cy", *DIST_NAMES[:n_dist]]


def free_intrinsics(flags: int, n_dist: int) -> np.ndarray:
    """Boolean mask over (fx fy cx cy dist...) of what cv2.calibrateCamera estimates
    with ``flags``. CALIB_FIX_ASPECT_RATIO is handled by :func:`aspect_ratio`."""
    import cv2

    free = np.ones(4 + n_dist, bool)
    if flags & cv2.CALIB_FIX_FOCAL_LENGTH:
        free[0:2] = False
    if flags & cv2.CALIB_FIX_ASPECT_RATIO:
        free[0] = False  # fx follows fy
    if flags & cv2.CALIB_FIX_PRINCIPAL_POINT:
        free[2:4] = False
    d = np.ones(14, bool)
    if flags & cv2.CALIB_ZERO_TANGENT_DIST:
        d[2:4] = False
    for i, f in zip((0, 1, 4, 5, 6, 7), ("K1", "K2", "K3", "K4", "K5", "K6")):
        if flags & getattr(cv2, f"CALIB_FIX_{f}"):
            d[i] = False
    if not flags & cv2.CALIB_RATIONAL_MODEL:
        d[5:8] = False
    if not flags & cv2.CALIB_THIN_PRISM_MODEL or flags & cv2.CALIB_FIX_S1_S2_S3_S4:
        d[8:12] = False
    if not flags & cv2.CALIB_TILTED_MODEL or flags & cv2.CALIB_FIX_TAUX_TAUY:
        d[12:14] = False
    free[4:] = d[:n_dist]
    return free


@dataclass
class Observation:
    """The board of view ``view`` seen by camera ``camera``: board points (n, 3) mm,
    image points (n, 2) px."""

    view: int
    camera: int
    object_points: np.ndarray
    image_points: np.ndarray


def _proj(obj, rvec, tvec, K, dist):
    import cv2

    q, jac = cv2.projectPoints(
        np.asarray(obj, np.float64).reshape(-1, 1, 3),
        np.asarray(rvec, np.float64).ravel(),
        np.asarray(tvec, np.float64).ravel(),
        K,
        dist,
    )
    return q.reshape(-1, 2), jac


def _intr_jac(jac: np.ndarray, K: np.ndarray) -> np.ndarray:
    # projectPoints columns: rvec(3) tvec(3) fx fy cx cy dist(n)
    return jac[:, 6:]


def assemble(cameras, rel_poses, view_poses, observations, free_masks, aspect=None):
    """J^T J, J^T r and sum(r^2) over all observations in the full layout.

    cameras: list of (K, dist); rel_poses: list of (rvec, tvec) for cameras 1..; view_poses:
    list of (rvec, tvec) per view in camera 0; free_masks: per camera boolean masks.
    ``aspect``: per camera fx/fy for CALIB_FIX_ASPECT_RATIO (None: free fx).
    Returns (JtJ, Jtr, sse, n_rows, layout) with layout the index arrays of each block.
    """
    import cv2

    nc, nv = len(cameras), len(view_poses)
    sizes = [4 + len(np.ravel(d)) for _, d in cameras]
    off_i = np.concatenate([[0], np.cumsum(sizes)])
    off_rel = off_i[-1]
    off_v = off_rel + 6 * (nc - 1)
    n = off_v + 6 * nv
    jtj, jtr, sse, rows = np.zeros((n, n)), np.zeros(n), 0.0, 0
    for ob in observations:
        k, v = ob.camera, ob.view
        K, dist = cameras[k]
        K = np.asarray(K, np.float64)
        dist = np.asarray(dist, np.float64).ravel()
        rv, tv = (np.asarray(a, np.float64).reshape(3, 1) for a in view_poses[v])
        if k == 0:
            q, jac = _proj(ob.object_points, rv, tv, K, dist)
            dpose_v = jac[:, :6]
            blocks = [(np.arange(off_i[0], off_i[1]), _intr_jac(jac, K)), (off_v + 6 * v + np.arange(6), dpose_v)]
        else:
            rr, tr = (np.asarray(a, np.float64).reshape(3, 1) for a in rel_poses[k - 1])
            r3, t3, dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1, dt3dr2, dt3dt2 = cv2.composeRT(rv, tv, rr, tr)
            q, jac = _proj(ob.object_points, r3, t3, K, dist)
            jr, jt = jac[:, :3], jac[:, 3:6]
            dpose_v = np.hstack([jr @ dr3dr1 + jt @ dt3dr1, jr @ dr3dt1 + jt @ dt3dt1])
            drel = np.hstack([jr @ dr3dr2 + jt @ dt3dr2, jr @ dr3dt2 + jt @ dt3dt2])
            blocks = [
                (np.arange(off_i[k], off_i[k + 1]), _intr_jac(jac, K)),
                (off_rel + 6 * (k - 1) + np.arange(6), drel),
                (off_v + 6 * v + np.arange(6), dpose_v),
            ]
        # residual convention r = observed - projected; J = d(projected)/d(theta)
        r = (np.asarray(ob.image_points, np.float64).reshape(-1, 2) - q).ravel()
        idx = np.concatenate([b[0] for b in blocks])
        jl = np.hstack([b[1] for b in blocks])
        intr = jl[:, : sizes[k]]
        if aspect is not None and aspect[k] is not None:
            intr[:, 1] += aspect[k] * intr[:, 0]  # fx = a fy: fy's column carries fx's
            intr[:, 0] = 0.0
        intr[:, ~free_masks[k]] = 0.0
        jtj[np.ix_(idx, idx)] += jl.T @ jl
        jtr[idx] += jl.T @ r
        sse += float(r @ r)
        rows += r.size
    layout = {
        "intrinsics": [np.arange(off_i[k], off_i[k + 1]) for k in range(nc)],
        "relative": [off_rel + 6 * (k - 1) + np.arange(6) for k in range(1, nc)],
        "views": [off_v + 6 * v + np.arange(6) for v in range(nv)],
        "n": n,
    }
    return jtj, jtr, sse, rows, layout


def covariance(jtj: np.ndarray, sse: float, rows: int, sigma: float | None = None) -> tuple[np.ndarray, float]:
    """(Sigma, s) with Sigma = s^2 (J^T J)^+ over the free parameters (zero elsewhere).

    ``s`` is the residual standard deviation per coordinate (px) estimated from the
    residuals (``sigma`` None) or the given pixel noise.
    """
    free = np.diag(jtj) > 0
    n_free = int(free.sum())
    s = float(np.sqrt(sse / max(rows - n_free, 1))) if sigma is None else float(sigma)
    cov = np.zeros_like(jtj)
    sub = jtj[np.ix_(free, free)]
    cov[np.ix_(free, free)] = np.linalg.inv(sub) * s * s
    return cov, s


def parameter_names(camera_names, n_dists, n_views) -> list[str]:
    names = [f"{c}.{p}" for c, nd in zip(camera_names, n_dists) for p in intrinsic_names(nd)]
    names += [f"{c}.{p}" for c in camera_names[1:] for p in POSE_NAMES]
    names += [f"view{v + 1}.{p}" for v in range(n_views) for p in POSE_NAMES]
    return names
