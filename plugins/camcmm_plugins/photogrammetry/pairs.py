"""View geometry of the dense stage: cameras, neighbour choice, depth ranges, rectification.

A view is ``dict(K=3x3, dist=(5,), R=3x3, t=(3,))`` with ``x_cam = R X + t`` (world to
camera, OpenCV convention; thesis eq. 2.1 with the lens model of eq. 2.4). Rectification is
written here by hand (Fusiello, Trucco & Verri 2000, "A compact algorithm for rectification
of stereo pairs") rather than with ``cv2.stereoRectify`` because the latter turns a mostly
vertical baseline into vertical disparities, which ``cv2.StereoSGBM`` cannot search; the
common frame built here always puts the baseline along the rectified x axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from camcmm.api import InputError


@dataclass(frozen=True)
class Camera:
    """One view: intrinsics ``K`` (px), distortion ``dist`` (OpenCV k1,k2,p1,p2,k3), world to
    camera ``R``, ``t`` and the centre ``C = -R^T t`` (world units)."""

    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray

    @property
    def centre(self) -> np.ndarray:
        return -self.R.T @ self.t

    @property
    def axis(self) -> np.ndarray:
        """Optical axis (unit vector, world)."""
        return self.R[2]


def cameras(views: list[dict], shape: tuple[int, int]) -> list[Camera]:
    """Validate the views (see the module docstring) and return them as :class:`Camera`."""
    out = []
    for i, v in enumerate(views):
        try:
            K = np.asarray(v["K"], float).reshape(3, 3)
            dist = np.zeros(5) if v.get("dist") is None else np.asarray(v["dist"], float).ravel()
            R = np.asarray(v["R"], float).reshape(3, 3)
            t = np.asarray(v["t"], float).reshape(3)
        except (KeyError, ValueError, TypeError) as exc:
            raise InputError(f"view {i}: needs K (3x3), dist (5), R (3x3), t (3): {exc}") from None
        if dist.size != 5 or not np.all(np.isfinite(np.r_[K.ravel(), dist, R.ravel(), t])):
            raise InputError(f"view {i}: dist must be 5 finite OpenCV coefficients, K/R/t finite")
        if abs(np.linalg.det(R) - 1) > 1e-3 or np.abs(R @ R.T - np.eye(3)).max() > 1e-3:
            raise InputError(f"view {i}: R is not a rotation matrix (det {np.linalg.det(R):.4g})")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise InputError(f"view {i}: focal lengths fx={K[0, 0]}, fy={K[1, 1]} must be positive")
        out.append(Camera(K, dist, R, t))
    return out


def scene_centre(cams: list[Camera]) -> np.ndarray:
    """The point all optical axes come nearest to (least squares), world units.

    Stands in for the sparse cloud's centre when the caller passes no depth range.
    """
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for c in cams:
        P = np.eye(3) - np.outer(c.axis, c.axis)  # distance to the axis line
        A += P
        b += P @ c.centre
    if np.linalg.cond(A) > 1e8:
        raise InputError("the optical axes are (nearly) parallel: pass depth_range=(zmin, zmax)")
    return np.linalg.solve(A, b)


def depth_ranges(cams: list[Camera], centre: np.ndarray, depth_range=None, margin: float = 0.35) -> np.ndarray:
    """Per view (zmin, zmax) along the optical axis, world units, shape (n, 2).

    ``depth_range`` given: ``(zmin, zmax)`` for every view or an (n, 2) array, one row per
    view (e.g. percentiles of the sparse points' depths in each view). Otherwise the depth of
    the scene centre times ``(1 - margin, 1 + margin)``.
    """
    if depth_range is not None:
        try:
            zr = np.asarray(depth_range, float)
            zr = np.tile(zr.reshape(2), (len(cams), 1)) if zr.size == 2 else zr.reshape(len(cams), 2)
        except ValueError:
            raise InputError(f"depth_range: needs (zmin, zmax) or one pair per view ({len(cams)})") from None
        if not np.all((zr[:, 0] > 0) & (zr[:, 0] < zr[:, 1])):
            raise InputError(f"depth_range {depth_range!r}: needs 0 < zmin < zmax")
        return zr
    z = np.array([c.R[2] @ centre + c.t[2] for c in cams])
    if np.any(z <= 0):
        bad = [i for i in np.flatnonzero(z <= 0)]
        raise InputError(f"views {bad}: the scene centre lies behind the camera; pass depth_range")
    return np.c_[z * (1 - margin), z * (1 + margin)]


def choose_pairs(
    cams: list[Camera], centre: np.ndarray, n_neighbours: int = 2, min_angle: float = 5.0, max_angle: float = 30.0
) -> list[tuple[int, int]]:
    """For each view the ``n_neighbours`` views of smallest triangulation angle at the scene
    centre within ``[min_angle, max_angle]`` degrees whose optical axes differ by < 60°.

    Small angles match best (similar appearance), the lower bound keeps depth precision
    (a depth error grows as 1/sin of the angle). Returns (reference, source) pairs.
    """
    C = np.array([c.centre for c in cams])
    rays = C - centre
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    ang = np.degrees(np.arccos(np.clip(rays @ rays.T, -1, 1)))
    axes = np.array([c.axis for c in cams])
    axis_ang = np.degrees(np.arccos(np.clip(axes @ axes.T, -1, 1)))
    pairs = []
    for i in range(len(cams)):
        ok = (ang[i] >= min_angle) & (ang[i] <= max_angle) & (axis_ang[i] < 60)
        ok[i] = False
        cand = np.flatnonzero(ok)
        for j in cand[np.argsort(ang[i, cand])][:n_neighbours]:
            pairs.append((i, int(j)))
    return pairs


@dataclass
class Rectified:
    """A rectified pair: both cameras share rotation ``Rn`` (world to rectified frame) and
    focal length ``f``; the right one's principal point is shifted by ``shift`` px so that the
    SGBM disparity ``d'`` runs from 0: true disparity ``d = d' + shift``, depth ``Z = f B / d``.
    """

    Rn: np.ndarray
    f: float
    cx: float
    cy: float
    shift: float
    baseline: float
    size: tuple[int, int]  # (width, height)
    n_disp: int
    maps: tuple  # (map1x, map1y, map2x, map2y) float32
    clipped: bool = False  # the depth range needed more than max_disp disparities

    def project(self, X: np.ndarray, centre: np.ndarray):
        """World points (M,3) into the left rectified image: u, v (px) and Z (world units)."""
        Y = (X - centre) @ self.Rn.T
        Z = Y[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.f * Y[:, 0] / Z + self.cx, self.f * Y[:, 1] / Z + self.cy, Z


def _edge_rays(cam: Camera, w: int, h: int) -> np.ndarray:
    """Normalised, undistorted rays (camera frame) through points along the image border."""
    s = np.linspace(0, 1, 17)
    pts = np.r_[np.c_[s * (w - 1), 0 * s], np.c_[s * (w - 1), 0 * s + h - 1], np.c_[0 * s, s * (h - 1)]]
    pts = np.r_[pts, np.c_[0 * s + w - 1, s * (h - 1)]]
    n = cv2.undistortPoints(pts.reshape(-1, 1, 2), cam.K, cam.dist).reshape(-1, 2)
    return np.c_[n, np.ones(len(n))]


def rectify(
    left: Camera,
    right: Camera,
    w: int,
    h: int,
    zrange: tuple[float, float],
    max_pixels: float = 4.0,
    max_disp: int = 1024,
) -> Rectified | None:
    """Common rectified frame of a pair (None when the geometry is unusable).

    ``zrange``: depth range of the left view (world units) that fixes the disparity search.
    ``max_pixels``: the rectified canvas holds at most this many times the image's pixels
    (the focal length is reduced if needed). ``max_disp``: at most this many disparities are
    searched (SGBM's time and memory grow with it); the near end of the range is cut.
    """
    b = right.centre - left.centre
    B = float(np.linalg.norm(b))
    if B == 0:
        return None
    x = b / B
    z = left.axis + right.axis
    y = np.cross(z, x)
    if np.linalg.norm(y) < 1e-6:
        return None  # the baseline runs along the viewing direction
    y /= np.linalg.norm(y)
    Rn = np.array([x, y, np.cross(x, y)])
    f = float(np.mean([left.K[0, 0], left.K[1, 1], right.K[0, 0], right.K[1, 1]]))
    zmin, zmax = 0.9 * zrange[0], 1.1 * zrange[1]  # rectified Z differs a little from the view's z
    shift = float(np.floor(f * B / zmax))
    bounds = []
    for cam, dx in ((left, 0.0), (right, shift)):
        r = _edge_rays(cam, w, h) @ (Rn @ cam.R.T).T
        if np.any(r[:, 2] <= 0.05 * np.linalg.norm(r, axis=1)):
            return None  # the image border turns (nearly) parallel to the rectified plane
        bounds.append(np.c_[r[:, 0] / r[:, 2] + dx / f, r[:, 1] / r[:, 2]])
    bb = np.concatenate(bounds)
    (x0, y0), (x1, y1) = bb.min(0), bb.max(0)
    scale = min(1.0, np.sqrt(max_pixels * w * h / ((x1 - x0) * (y1 - y0) * f * f)))
    f *= scale
    shift = float(np.floor(f * B / zmax))
    n_disp = int(np.ceil((f * B / zmin - shift + 2) / 16) * 16)
    clipped = n_disp > max_disp
    n_disp = min(n_disp, max(16, max_disp // 16 * 16))
    W = int(np.ceil((x1 - x0) * f)) + n_disp  # SGBM leaves the leftmost n_disp columns empty
    H = int(np.ceil((y1 - y0) * f))
    cx, cy = -x0 * f + n_disp, -y0 * f
    maps: list[Any] = []
    for cam, dx in ((left, 0.0), (right, shift)):
        Kn = np.array([[f, 0, cx + dx], [0, f, cy], [0, 0, 1]])
        maps += cv2.initUndistortRectifyMap(cam.K, cam.dist, Rn @ cam.R.T, Kn, (W, H), cv2.CV_32FC1)
    return Rectified(Rn, f, cx, cy, shift, B, (W, H), n_disp, tuple(maps), clipped)


def depth_range_from_points(points: np.ndarray, views: list[dict], margin: float = 0.1) -> np.ndarray:
    """Per-view ``depth_range`` (n, 2) from sparse points (M,3), world units: the 1st..99th
    percentile of the depths of the points in front of each view, widened by ``margin`` of
    that span (at least 1 % of the depth) each way. Views seeing no point get the others'
    overall range."""
    X = np.asarray(points, float).reshape(-1, 3)
    out = np.full((len(views), 2), np.nan)
    for i, v in enumerate(views):
        z = X @ np.asarray(v["R"], float)[2] + float(np.asarray(v["t"], float).ravel()[2])
        z = z[z > 0]
        if len(z) >= 10:
            lo, hi = np.percentile(z, [1, 99])
            pad = max(margin * (hi - lo), 0.01 * hi)
            out[i] = max(lo - pad, 1e-3 * hi), hi + pad
    ok = np.isfinite(out[:, 0])
    if not ok.any():
        raise InputError("depth_range_from_points: fewer than 10 points in front of every view")
    out[~ok] = out[ok, 0].min(), out[ok, 1].max()
    return out
