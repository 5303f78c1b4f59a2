"""Camera-projector triangulation: the projector as an inverse camera (thesis ch. 2.4, 5.2.2).

    camera_rays(cam, pixels)                        -> (origin (3,), unit directions (n, 3)) in world mm
    intersect_stripe(cam, proj, pixels, coord, axis) -> (n, 3) points from one projector coordinate
    triangulate_rays(cam, proj, pixels, uv_proj)    -> (n, 3) points from both projector coordinates

Conventions: a CameraModel maps world to its frame by x_cam = R x_world + t (mm); pixel
centres at integer coordinates (OpenCV). Camera pixels are undistorted exactly
(OpenCV's iterative undistortion run to convergence).

One projector coordinate (vertical fringes give the column u_p) defines a stripe surface:
all points whose *distorted* projection has column u_p. With a distortion-free projector
it is the plane through the projector centre ``X_p - x_n Z_p = 0`` (x_n the normalised
coordinate of u_p). With distortion x_n depends on the row where the point lands, so the
plane is re-derived from the undistorted (u_p, v_hat) with v_hat the current point's
projected row, until v_hat settles (a fixed point; 3-6 iterations for real lenses).
"""

from __future__ import annotations

import numpy as np

from camcmm.api import CameraModel

_TERM = (3, 50, 1e-10)  # cv2.TERM_CRITERIA_COUNT | EPS


def undistort_normalised(cam: CameraModel, pixels: np.ndarray) -> np.ndarray:
    """(n, 2) pixels -> (n, 2) normalised, undistorted image coordinates (x/z, y/z), float64."""
    import cv2

    pts = np.ascontiguousarray(np.asarray(pixels, dtype=np.float64).reshape(-1, 1, 2))
    if not np.any(cam.dist_coeffs):
        k = cam.camera_matrix
        x = (pts[:, 0, 0] - k[0, 2] - k[0, 1] * (pts[:, 0, 1] - k[1, 2]) / k[1, 1]) / k[0, 0]
        y = (pts[:, 0, 1] - k[1, 2]) / k[1, 1]
        return np.column_stack([x, y])
    if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4
        out = cv2.undistortPointsIter(pts, cam.camera_matrix, cam.dist_coeffs, None, None, _TERM)
    else:  # OpenCV 5 takes the criteria in undistortPoints
        out = cv2.undistortPoints(pts, cam.camera_matrix, cam.dist_coeffs, criteria=_TERM)
    return out.reshape(-1, 2)


def camera_rays(cam: CameraModel, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Projection centre (3,) and unit ray directions (n, 3) of pixels, world frame, mm."""
    xy = undistort_normalised(cam, pixels)
    d = np.column_stack([xy, np.ones(len(xy))]) @ cam.rotation  # R^T d for each row
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    centre = -cam.rotation.T @ cam.translation
    return centre, d


def distort(cam: CameraModel, xy: np.ndarray) -> np.ndarray:
    """(n, 2) normalised coordinates -> (n, 2) distorted pixels (OpenCV's lens model).

    Written out in numpy because cv2.projectPoints costs ~1 s per million points here;
    k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]] are supported (checked against
    projectPoints in the tests), the tilted-sensor terms go through OpenCV.
    """
    k = np.zeros(12)
    dc = cam.dist_coeffs
    if len(dc) > 12:
        pts = np.column_stack([xy, np.ones(len(xy))])
        return project(CameraModel(cam.camera_matrix, dc, name=cam.name), pts, _opencv=True)
    k[: len(dc)] = dc
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    radial = (1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]))) / (1 + r2 * (k[5] + r2 * (k[6] + r2 * k[7])))
    xd = x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x) + r2 * (k[8] + r2 * k[9])
    yd = y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y + r2 * (k[10] + r2 * k[11])
    m = cam.camera_matrix
    return np.column_stack([m[0, 0] * xd + m[0, 1] * yd + m[0, 2], m[1, 1] * yd + m[1, 2]])


def project(cam: CameraModel, points: np.ndarray, _opencv: bool = False) -> np.ndarray:
    """(n, 3) world points -> (n, 2) distorted pixels."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not _opencv and len(cam.dist_coeffs) <= 12:
        pc = points @ cam.rotation.T + cam.translation
        with np.errstate(divide="ignore", invalid="ignore"):
            return distort(cam, pc[:, :2] / pc[:, 2:3])
    import cv2

    rvec, _ = cv2.Rodrigues(cam.rotation)
    px, _ = cv2.projectPoints(
        np.ascontiguousarray(points).reshape(-1, 1, 3),
        rvec,
        cam.translation.astype(np.float64),
        cam.camera_matrix,
        cam.dist_coeffs,
    )
    return px.reshape(-1, 2)


def intersect_stripe(
    cam: CameraModel,
    proj: CameraModel,
    pixels: np.ndarray,
    coord: np.ndarray,
    axis: int = 0,
    iterations: int = 10,
    tol: float = 1e-4,
    min_angle: float = 1.0,
) -> np.ndarray:
    """Points where camera pixels' rays meet the projector stripes of ``coord``.

    pixels : (n, 2) camera pixels (distorted, as captured).
    coord  : (n,) projector column u_p (axis 0, vertical fringes) or row v_p (axis 1), px.
    min_angle : deg; a ray meeting its stripe surface at a smaller angle gives NaN (the
             depth of such a point is ill-conditioned).
    Returns (n, 3) world points in mm; NaN where a ray is (nearly) parallel to its stripe
    or the point lies behind either device.
    """
    centre, d = camera_rays(cam, pixels)
    coord = np.asarray(coord, dtype=np.float64).ravel()
    n = len(coord)
    # the ray in projector coordinates: p0 + s dp
    p0 = proj.rotation @ centre + proj.translation
    dp = d @ proj.rotation.T
    other = np.full(n, proj.camera_matrix[1 - axis, 2])  # start on the principal row/column
    s = np.full(n, np.nan)
    sin_angle = np.zeros(n)
    active = np.arange(n)
    distorted = bool(np.any(proj.dist_coeffs))
    for _ in range(iterations if distorted else 1):
        px = np.empty((len(active), 2))
        px[:, axis], px[:, 1 - axis] = coord[active], other[active]
        xn = undistort_normalised(proj, px)[:, axis]
        denom = dp[active, axis] - xn * dp[active, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            s[active] = -(p0[axis] - xn * p0[2]) / denom
        sin_angle[active] = np.abs(denom) / np.sqrt(1.0 + xn * xn)  # |n.d| with n = (1, -x_n) normalised
        if not distorted:
            break
        pts = centre + s[active, None] * d[active]
        new = project(proj, pts)[:, 1 - axis]
        change = np.abs(new - other[active])
        other[active] = new
        # a point that settled (or went to infinity) needs no more rounds
        active = active[np.isfinite(change) & (change >= tol)]
        if not len(active):
            break
    pts = centre + s[:, None] * d
    z_proj = (pts @ proj.rotation.T + proj.translation)[:, 2]
    bad = ~(s > 0) | ~(z_proj > 0) | (sin_angle < np.sin(np.radians(min_angle)))
    pts[bad] = np.nan
    return pts


def triangulate_rays(cam: CameraModel, proj: CameraModel, pixels: np.ndarray, uv_proj: np.ndarray) -> np.ndarray:
    """Linear (DLT, cv2.triangulatePoints) triangulation of camera pixels and projector
    pixels (both distorted; undistorted here). Returns (n, 3) world points, mm."""
    import cv2

    a = undistort_normalised(cam, pixels)
    b = undistort_normalised(proj, uv_proj)
    pa = np.hstack([cam.rotation, cam.translation[:, None]])
    pb = np.hstack([proj.rotation, proj.translation[:, None]])
    h = cv2.triangulatePoints(pa, pb, np.ascontiguousarray(a.T), np.ascontiguousarray(b.T))
    with np.errstate(divide="ignore", invalid="ignore"):
        return (h[:3] / h[3]).T
