"""Photogrammetric depth maps of registered views (thesis ch. 6.3.2, eqs. 6.2-6.4, fig. 6.14).

A cloud is projected into a view with ``P = K [R T]`` (eq. 6.2, OpenCV's distortion
applied by ``cv2.projectPoints``); each point's depth is its distance from the projection
centre ``D = sqrt(X'^2 + Y'^2 + Z'^2)`` (eq. 6.3) with ``[X' Y' Z'] = [R T][X Y Z 1]``
(eq. 6.4), or ``Z'`` alone (``measure="z"``). Points are binned into their nearest pixel.

Rear surfaces (fig. 6.14): a pixel keeps only the points within ``tolerance`` (relative)
of its nearest point -- a z-buffer -- and its depth is their mean, so a pixel whose ray
also meets the far side of the part is not pulled back, and the mean of the front points
(spread evenly over the pixel) is the depth at the pixel's centre, where the minimum
would lean towards the camera on a tilted surface.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError


def camera_matrix(cam: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """``K`` (3, 3) and OpenCV distortion (k1 k2 p1 p2 [k3 ...]) of a camera dict
    ``{fx, fy, cx, cy, dist}`` (px) as written by ``photogrammetry.reconstruct`` and
    ``photogrammetry.import``."""
    try:
        fx, fy, cx, cy = (float(cam[k]) for k in ("fx", "fy", "cx", "cy"))
    except (KeyError, TypeError, ValueError, OverflowError):
        raise InputError("views: a camera needs fx, fy, cx, cy (px)") from None
    if not all(np.isfinite(v) for v in (fx, fy, cx, cy)) or fx <= 0 or fy <= 0:
        # a NaN or negative focal length would project every point nowhere or mirrored: a silent wrong gradient
        raise InputError(
            f"views: camera fx {fx:g}, fy {fy:g}, cx {cx:g}, cy {cy:g} px: fx, fy must be above 0, all finite"
        )
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    try:
        dist = np.asarray(cam.get("dist") or [], dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"views: camera dist {cam.get('dist')!r:.60}: give a list of numbers") from None
    if not np.isfinite(dist).all():
        raise InputError("views: camera dist holds non-finite values")
    # cv2 takes 4, 5, 8, 12 or 14 coefficients; a shorter list (SIMPLE_RADIAL's k1) is padded with zeros
    n = next((m for m in (4, 5, 8, 12, 14) if m >= len(dist)), None)
    if n is None:
        raise InputError(f"views: {len(dist)} distortion coefficients; OpenCV takes at most 14")
    return K, np.pad(dist, (0, n - len(dist)))


def project(
    points: np.ndarray, K: np.ndarray, dist: np.ndarray, R: np.ndarray, t: np.ndarray, measure: str = "distance"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) (OpenCV: centre of the top-left pixel at 0, 0), depth (N,)
    in the cloud's unit and a mask (N,) of the points in front of the camera (eqs. 6.2-6.4)."""
    import cv2

    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    R, t = np.asarray(R, float), np.asarray(t, float).ravel()
    # three matrix-vector products: (N, 3) @ (3, 3) goes through a threaded BLAS that is several times slower here
    Xc = np.column_stack([P @ R[i] + t[i] for i in range(3)])
    front = Xc[:, 2] > 0
    uv = np.full((len(P), 2), np.nan)
    if front.any() and np.any(dist):
        # cv2 projects from the camera frame (rvec = tvec = 0) so that points behind it never reach it
        img, _ = cv2.projectPoints(Xc[front].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, dist)
        uv[front] = img.reshape(-1, 2)
    elif front.any():  # no distortion: the same pinhole in numpy, ~5x faster than projectPoints
        x = Xc[front, :2] / Xc[front, 2:3]
        uv[front] = np.column_stack([K[0, 0] * x[:, 0] + K[0, 1] * x[:, 1] + K[0, 2], K[1, 1] * x[:, 1] + K[1, 2]])
    d = np.linalg.norm(Xc, axis=1) if measure == "distance" else Xc[:, 2]
    return uv, d, front


def depth_map(
    points: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    size: tuple[int, int],
    *,
    measure: str = "distance",
    tolerance: float = 0.002,
    keep: np.ndarray | None = None,
    edge: int = 1,
    jump: float = 8.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The photogrammetric depth map ``Im_depth,Photo`` of one view.

    Parameters
    ----------
    points : (N, 3) cloud, scaled (mm).
    K, dist, R, t : the view's camera (px) and pose ``x_cam = R X + t`` (mm).
    size : (width, height) of the map, px.
    measure : "distance" (eq. 6.3) or "z" (the optical-axis depth Z').
    tolerance : points farther than ``(1 + tolerance)`` × the pixel's nearest point are
        behind the visible surface and dropped (z-buffer).
    keep : (N,) bool, optional: after the z-buffer, a pixel counts only when all its front
        points are kept (a selected flat region); rear points never shadow it.

    Returns
    -------
    depth : (height, width) float, NaN where no point lands.
    count : (height, width) int, the front points averaged per pixel.
    """
    w, h = int(size[0]), int(size[1])
    uv, d, front = project(points, K, dist, R, t, measure)
    with np.errstate(invalid="ignore"):
        ui, vi = np.rint(uv[:, 0]), np.rint(uv[:, 1])
        inside = front & (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
    idx = np.nonzero(inside)[0]
    pix = (vi[idx].astype(np.int64) * w + ui[idx].astype(np.int64)).astype(np.int64)
    dd = d[idx]
    zmin = np.full(w * h, np.inf)
    np.minimum.at(zmin, pix, dd)
    front_pts = dd <= zmin[pix] * (1.0 + tolerance)
    pix, dd, idx = pix[front_pts], dd[front_pts], idx[front_pts]
    count = np.bincount(pix, minlength=w * h)
    total = np.bincount(pix, weights=dd, minlength=w * h)
    with np.errstate(invalid="ignore", divide="ignore"):
        depth = total / count
    if keep is not None:
        out = np.bincount(pix, weights=~np.asarray(keep, bool)[idx], minlength=w * h)
        depth[out > 0] = np.nan
    depth[count == 0] = np.nan
    depth = depth.reshape(h, w)
    if edge > 0:
        from scipy.ndimage import binary_erosion

        full = binary_erosion(np.isfinite(depth), np.ones((3, 3), bool), iterations=int(edge), border_value=0)
        depth[~full] = np.nan
    if jump > 0:
        from scipy.ndimage import maximum_filter, minimum_filter

        hi = maximum_filter(np.where(np.isfinite(depth), depth, -np.inf), size=3, mode="nearest")
        lo = minimum_filter(np.where(np.isfinite(depth), depth, np.inf), size=3, mode="nearest")
        with np.errstate(invalid="ignore"):
            depth[(hi - lo) > jump * depth / K[0, 0]] = np.nan
    return depth, count.reshape(h, w)


def polygon_mask(polygon: list[list[float]] | np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(height, width) bool mask of the pixels inside a polygon [[u, v], ...] (px)."""
    import cv2

    try:
        p = np.asarray(polygon, dtype=float)
    except (TypeError, ValueError, OverflowError):
        p = np.zeros(0)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3 or not np.isfinite(p).all():
        raise InputError(f"polygon {str(polygon)[:80]}: give at least three [u, v] corners (px), finite numbers")
    m = np.zeros((int(size[1]), int(size[0])), np.uint8)
    cv2.fillPoly(m, [np.rint(p).astype(np.int32)], 1)
    return m.astype(bool)


def plane_points(points: np.ndarray, threshold: float, seed: int = 0) -> np.ndarray:
    """(N,) bool: the points of the cloud's dominant plane (Open3D's RANSAC
    ``segment_plane``), the thesis's flat background (ch. 6.3.2)."""
    import open3d as o3d

    if len(points) < 3:
        raise InputError("cloud: fewer than three points, no plane to select")
    o3d.utility.random.seed(int(seed))
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, float)))
    _, inl = pc.segment_plane(distance_threshold=float(threshold), ransac_n=3, num_iterations=1000)
    m = np.zeros(len(points), bool)
    m[np.asarray(inl, int)] = True
    return m
