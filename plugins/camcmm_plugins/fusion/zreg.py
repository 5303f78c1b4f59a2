"""Step 5 (thesis ch. 6.1): z registration of a CSI map on the cloud by mean heights, then
an ICP restricted to the three degrees of freedom the images do not fix (tz, rx, ry).

Open3D's ICP has no way to lock degrees of freedom, and a full 6-DOF ICP would let the
noisy, coarse photogrammetry surface pull the lateral position and the in-plane angle away
from the image registration (which is the more precise of the two for them). So this is a
small Gauss-Newton on the three parameters, with the CSI map as a height field: each
photogrammetry point's residual is its distance to the CSI surface along the surface normal
(point-to-plane), the CSI height read by bilinear interpolation of its grid.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates


def tilt(rx: float, ry: float) -> np.ndarray:
    """Rotation Ry(ry)·Rx(rx), rad."""
    cx, sx, cy, sy = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry)
    return np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]) @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])


class Placement:
    """Where a CSI map sits in the fused frame: a map point (x, y, h) goes to
    Rt(rx, ry)·(R(θ)(x − xc, y − yc), h − zc) + (bx, by, tz)."""

    def __init__(self, theta: float, centre_map: np.ndarray, zc: float, centre_fused: np.ndarray, tz: float = 0.0):
        self.theta, self.xc, self.zc, self.b = (
            theta,
            np.asarray(centre_map, float),
            float(zc),
            np.asarray(centre_fused, float),
        )
        self.tz, self.rx, self.ry = float(tz), 0.0, 0.0

    def matrix(self) -> np.ndarray:
        """4×4: map (x, y, h) mm -> fused frame (plane coordinates) mm."""
        c, s = np.cos(self.theta), np.sin(self.theta)
        rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        r = tilt(self.rx, self.ry) @ rz
        t = np.array([self.b[0], self.b[1], self.tz]) - r @ np.array([self.xc[0], self.xc[1], self.zc])
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = r, t
        return m


def _inverse_points(m: np.ndarray, q: np.ndarray) -> np.ndarray:
    return (q - m[:3, 3]) @ m[:3, :3]


def residuals(m, q, heights, gx, gy, x0, y0, dx, dy):
    """Signed normal distances (mm) of points q (fused frame) to the CSI surface, NaN off it."""
    a = _inverse_points(m, q)
    coords = np.vstack([(a[:, 1] - y0) / dy, (a[:, 0] - x0) / dx])
    h = map_coordinates(heights, coords, order=1, mode="constant", cval=np.nan)
    hx = map_coordinates(gx, coords, order=1, mode="constant", cval=np.nan)
    hy = map_coordinates(gy, coords, order=1, mode="constant", cval=np.nan)
    return (a[:, 2] - h) / np.sqrt(1 + hx * hx + hy * hy)


def icp_3dof(
    place: Placement, q: np.ndarray, hm, max_distance: float, iterations: int = 50, tol: float = 1e-10
) -> dict:
    """Gauss-Newton on (tz, rx, ry) of ``place`` (changed in place), q: (n, 3) photogrammetry
    points in the fused frame near the map. Pairs farther than ``max_distance`` (mm) are
    left out. Returns tz (mm), rx_deg, ry_deg, rms (mm), converged, iterations, n_used."""
    heights = hm.heights
    gy, gx = np.gradient(heights, hm.dy, hm.dx)
    x0, y0 = hm.origin
    args = (heights, gx, gy, x0, y0, hm.dx, hm.dy)
    converged, it, r, ok = False, 0, np.zeros(0), np.zeros(0, bool)
    for it in range(1, iterations + 1):  # noqa: B007 (it is reported)
        p0 = np.array([place.tz, place.rx, place.ry])
        r = residuals(place.matrix(), q, *args)
        ok = np.isfinite(r) & (np.abs(r) <= max_distance)
        if ok.sum() < 6:
            break
        # Jacobian by central differences: the interpolated surface is piecewise bilinear,
        # an analytic derivative would gain nothing but code
        jac = np.empty((int(ok.sum()), 3))
        for k, step in enumerate((1e-6, 1e-7, 1e-7)):
            for sign in (1, -1):
                place.tz, place.rx, place.ry = p0 + sign * step * np.eye(3)[k]
                rk = residuals(place.matrix(), q[ok], *args)
                jac[:, k] = rk if sign == 1 else (jac[:, k] - rk) / (2 * step)
        place.tz, place.rx, place.ry = p0
        good = np.all(np.isfinite(jac), axis=1)
        delta = np.linalg.lstsq(jac[good], -r[ok][good], rcond=None)[0]
        place.tz, place.rx, place.ry = p0 + delta
        if abs(delta[0]) < tol * 1e3 and max(abs(delta[1]), abs(delta[2])) < tol:
            converged = True
            break
    r = residuals(place.matrix(), q, *args)
    ok = np.isfinite(r) & (np.abs(r) <= max_distance)
    return {
        "tz": place.tz,
        "rx_deg": float(np.degrees(place.rx)),
        "ry_deg": float(np.degrees(place.ry)),
        "rms": float(np.sqrt(np.mean(r[ok] ** 2))) if ok.any() else float("nan"),
        "converged": bool(converged),
        "iterations": it,
        "n_used": int(ok.sum()),
    }
