"""The stereo camera model of the thesis (ch. 3.2.2, eqs. 3.1-3.21).

Camera 1 sits at the origin and defines the world frame (mm); camera 2 maps world to
its own frame by ``x2 = R x + T``. Pixel coordinates follow eq. 3.1 with K of eq. 3.3;
lens distortion is the Brown model in OpenCV's order on *normalised* coordinates
(k1, k2, p1, p2, k3: eqs. 3.4-3.5 plus the tangential terms).

The Monte Carlo never inverts the distortion numerically: as in the thesis, the effect
of an error in the distortion parameters on an undistorted image point is the offset
of eq. 3.9, ``du = f x_d (db1 r_d^2 + db2 r_d^4 + db3 r_d^6 + db4 r_d^8)`` where b are
the inverse-distortion parameters of eqs. 3.10-3.13 and their uncertainties follow
from eq. 3.14 (written there without the square on the derivative; we use the GUM
form ``u^2(b_n) = sum_i (db_n/dk_i)^2 u^2(k_i)``).

The translation of camera 2 is perturbed in direction only (eqs. 3.17-3.21): its
magnitude sets the scale, which is traced separately. Eq. 3.21 as printed has
``T_x^2`` where the derivative of the azimuth gives ``T_y``: we use
``d phi/d T_x = -T_y/(T_x^2+T_y^2)``, ``d phi/d T_y = T_x/(T_x^2+T_y^2)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import InputError


# ------------------------------------------------------------------ rotations (eq. 3.15)
def rot_xyz(theta, phi, rho) -> np.ndarray:
    """R = Rx(theta) Ry(phi) Rz(rho) for scalars or arrays of angles (rad) -> (..., 3, 3)."""
    theta, phi, rho = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (theta, phi, rho)))
    ct, st, cp, sp, cr, sr = np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi), np.cos(rho), np.sin(rho)
    R = np.empty(theta.shape + (3, 3))
    # Rx Ry Rz multiplied out
    R[..., 0, 0] = cp * cr
    R[..., 0, 1] = -cp * sr
    R[..., 0, 2] = sp
    R[..., 1, 0] = ct * sr + st * sp * cr
    R[..., 1, 1] = ct * cr - st * sp * sr
    R[..., 1, 2] = -st * cp
    R[..., 2, 0] = st * sr - ct * sp * cr
    R[..., 2, 1] = st * cr + ct * sp * sr
    R[..., 2, 2] = ct * cp
    return R


# ------------------------------------------------------------ inverse distortion (3.10-3.14)
def inverse_coefficients(k) -> np.ndarray:
    """b1..b4 of eqs. 3.10-3.13 from k1..k4 (missing k's are 0)."""
    k1, k2, k3, k4 = (list(np.asarray(k, dtype=float).ravel()) + [0.0] * 4)[:4]
    return np.array(
        [
            -k1,
            3 * k1**2 - k2,
            -12 * k1**3 + 8 * k1 * k2 - k3,
            55 * k1**4 - 55 * k1**2 * k2 + 5 * k2**2 + 10 * k1 * k3 - k4,
        ]
    )


def inverse_jacobian(k) -> np.ndarray:
    """d b_n / d k_i (4 x 4) of eqs. 3.10-3.13."""
    k1, k2, k3, _ = (list(np.asarray(k, dtype=float).ravel()) + [0.0] * 4)[:4]
    return np.array(
        [
            [-1.0, 0.0, 0.0, 0.0],
            [6 * k1, -1.0, 0.0, 0.0],
            [-36 * k1**2 + 8 * k2, 8 * k1, -1.0, 0.0],
            [220 * k1**3 - 110 * k1 * k2 + 10 * k3, -55 * k1**2 + 10 * k2, 10 * k1, -1.0],
        ]
    )


def inverse_uncertainty(k, u_k) -> np.ndarray:
    """u(b_n) from u(k_i) by eq. 3.14 (GUM form, uncorrelated k)."""
    uk = (list(np.asarray(u_k, dtype=float).ravel()) + [0.0] * 4)[:4]
    J = inverse_jacobian(k)
    return np.sqrt((J**2) @ np.square(uk))


def distort(x, y, k, p=(0.0, 0.0)):
    """Brown distortion of normalised coordinates (OpenCV order; k = k1, k2, k3)."""
    k1, k2, k3 = (list(np.asarray(k, dtype=float).ravel()) + [0.0] * 3)[:3]
    p1, p2 = (list(np.asarray(p, dtype=float).ravel()) + [0.0] * 2)[:2]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return xd, yd


def undistort_series(xd, yd, b):
    """Eqs. 3.6-3.7 inverted: undistorted = distorted (1 + b1 r_d^2 + ... + b4 r_d^8)."""
    r2 = xd * xd + yd * yd
    f = 1 + sum(bn * r2 ** (n + 1) for n, bn in enumerate(np.asarray(b, dtype=float)))
    return xd * f, yd * f


# ------------------------------------------------------------ translation direction (3.17-3.21)
def to_polar(T) -> tuple[float, float, float]:
    """(T_r, T_theta, T_phi) of eqs. 3.17-3.19 (atan2 for the azimuth)."""
    Tx, Ty, Tz = (float(v) for v in T)
    Tr = math.sqrt(Tx * Tx + Ty * Ty + Tz * Tz)
    return Tr, math.acos(Tz / Tr), math.atan2(Ty, Tx)


def from_polar(Tr, theta, phi) -> np.ndarray:
    """Inverse of :func:`to_polar`, vectorised over theta/phi -> (..., 3)."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    return np.stack([Tr * np.sin(theta) * np.cos(phi), Tr * np.sin(theta) * np.sin(phi), Tr * np.cos(theta)], -1)


def polar_uncertainty(T, u_T) -> tuple[float, float]:
    """u(T_theta), u(T_phi) from u(T_x), u(T_y), u(T_z) (eqs. 3.20-3.21, see module doc)."""
    Tx, Ty, Tz = (float(v) for v in T)
    ux, uy, uz = (float(v) for v in u_T)
    rho2 = Tx * Tx + Ty * Ty
    if rho2 == 0:
        raise InputError(
            "translation of camera 2 lies on the optical axis of camera 1: its direction angles are undefined"
        )
    Tr2 = rho2 + Tz * Tz
    rho = math.sqrt(rho2)
    dth = (Tx * Tz / (Tr2 * rho), Ty * Tz / (Tr2 * rho), -rho / Tr2)
    dph = (-Ty / rho2, Tx / rho2)
    u_th = math.hypot(dth[0] * ux, dth[1] * uy, dth[2] * uz)  # hypot: no overflow in the squares
    u_ph = math.hypot(dph[0] * ux, dph[1] * uy)
    return u_th, u_ph


# ------------------------------------------------------------------ cameras
#: Largest image side (px) a camera may declare.
MAX_SIDE = 100_000


def _finite(v: Any) -> bool:
    try:
        return not isinstance(v, bool) and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _image_size(v: Any, name: str) -> tuple[int, int]:
    """(width, height) px, each 1 .. MAX_SIDE; absent: (0, 0), i.e. not known."""
    if v is None:
        return (0, 0)
    ok = isinstance(v, (list, tuple)) and len(v) == 2 and all(_finite(x) and float(x) == int(float(x)) for x in v)
    if not ok or not all(1 <= int(float(x)) <= MAX_SIDE for x in v):
        raise InputError(f"{name}: image_size {v!r} must be [width, height], whole numbers 1 .. {MAX_SIDE} px")
    return int(float(v[0])), int(float(v[1]))


@dataclass
class Camera:
    """Intrinsics of one camera: focal lengths and principal point in px, distortion."""

    fu: float
    fv: float
    u0: float
    v0: float
    k: np.ndarray = field(default_factory=lambda: np.zeros(3))
    p: np.ndarray = field(default_factory=lambda: np.zeros(2))
    image_size: tuple[int, int] = (0, 0)
    pixel_pitch: float | None = None

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fu, 0, self.u0], [0, self.fv, self.v0], [0, 0, 1.0]])

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], name: str = "camera") -> Camera:
        if not isinstance(d, Mapping):
            raise InputError(f"{name}: expected a mapping")
        size = _image_size(d.get("image_size"), name)
        for key in ("focal_length", "pixel_pitch", "fu", "fv"):
            v = d.get(key)
            if v is not None and not (_finite(v) and float(v) > 0):
                raise InputError(f"{name}: {key} = {v!r} must be a finite number > 0")
        try:
            if "camera_matrix" in d:  # CameraModel / OpenCV form
                K = np.asarray(d["camera_matrix"], dtype=float).reshape(3, 3)
                dist = list(np.asarray(d.get("dist_coeffs", [0] * 5), dtype=float).ravel()) + [0.0] * 5
                fu, fv, u0, v0 = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
                k, p = [dist[0], dist[1], dist[4]], [dist[2], dist[3]]
            else:
                pitch = d.get("pixel_pitch")
                if d.get("focal_length") is not None and pitch:  # mm -> px
                    fu = fv = float(d["focal_length"]) / float(pitch)
                else:
                    fu, fv = d.get("fu"), d.get("fv", d.get("fu"))
                if fu is None:
                    raise InputError(f"{name}: missing fu (focal length in px) or focal_length with pixel_pitch")
                u0 = d.get("u0", size[0] / 2 if size[0] else None)
                v0 = d.get("v0", size[1] / 2 if size[1] else None)
                if u0 is None or v0 is None:
                    raise InputError(f"{name}: missing principal point u0, v0 (or image_size)")
                k = list(d.get("k", [d.get("k1", 0.0), d.get("k2", 0.0), d.get("k3", 0.0)]))
                p = list(d.get("p", [d.get("p1", 0.0), d.get("p2", 0.0)]))
            cam = cls(
                float(fu),
                float(fv),
                float(u0),
                float(v0),
                np.asarray((list(k) + [0.0] * 3)[:3], float),
                np.asarray((list(p) + [0.0] * 2)[:2], float),
                size,
                d.get("pixel_pitch"),
            )
        except (TypeError, ValueError) as exc:
            raise InputError(f"{name}: intrinsics must be numbers ({exc})") from None
        if not (cam.fu > 0 and cam.fv > 0 and np.isfinite(cam.fu) and np.isfinite(cam.fv)):
            raise InputError(f"{name}: focal lengths must be finite and > 0 px (fu={cam.fu:g}, fv={cam.fv:g})")
        if not np.all(np.isfinite([cam.u0, cam.v0, *cam.k, *cam.p])):
            raise InputError(f"{name}: principal point and distortion must be finite numbers")
        return cam

    def to_model(self, R=None, T=None, name: str = "camera"):
        """The camera as a :class:`camcmm.api.CameraModel` with pose ``R`` (3, 3) and
        ``T`` (3,) mm (default: the identity, at the origin)."""
        from camcmm.api import CameraModel

        R = np.eye(3) if R is None else R
        T = np.zeros(3) if T is None else T

        dist = np.array([self.k[0], self.k[1], self.p[0], self.p[1], self.k[2]], dtype=float)
        return CameraModel(self.K, dist, R, T, self.image_size, self.pixel_pitch, name)


@dataclass
class StereoSystem:
    """Two cameras; camera 2's pose relative to camera 1 (``x2 = R x + T``)."""

    cam1: Camera
    cam2: Camera
    R: np.ndarray
    T: np.ndarray

    @property
    def poses(self) -> list[tuple[np.ndarray, np.ndarray]]:
        return [(np.eye(3), np.zeros(3)), (self.R, self.T)]

    @property
    def cameras(self) -> list[Camera]:
        return [self.cam1, self.cam2]

    @classmethod
    def from_baseline_angle(cls, cam1: Camera, cam2: Camera, baseline: float, angle_deg: float) -> StereoSystem:
        """Symmetric convergent pair in the x-z plane: camera 2 at ``baseline`` mm from
        camera 1, optical axes meeting at ``angle_deg`` (thesis: 199.35 mm, 38.64 deg,
        converging 301 mm from each camera)."""
        a = math.radians(angle_deg)
        half = a / 2
        C2 = baseline * np.array([math.cos(half), 0.0, math.sin(half)])
        z2 = np.array([-math.sin(a), 0.0, math.cos(a)])
        x2 = np.array([math.cos(a), 0.0, math.sin(a)])
        R = np.vstack([x2, [0.0, 1.0, 0.0], z2])
        return cls(cam1, cam2, R, -R @ C2)

    def convergence_point(self) -> np.ndarray:
        """Closest point between the two optical axes (world)."""
        C2 = -self.R.T @ self.T
        d1, d2 = np.array([0, 0, 1.0]), self.R.T @ np.array([0, 0, 1.0])
        w = -C2
        a, b, c = d1 @ d1, d1 @ d2, d2 @ d2
        d, e = d1 @ w, d2 @ w
        den = a * c - b * b
        if abs(den) < 1e-12:
            return np.array([0.0, 0.0, float(np.linalg.norm(C2))])
        s, t = (b * e - c * d) / den, (a * e - b * d) / den
        return 0.5 * ((s * d1) + (C2 + t * d2))

    def project(self, X: np.ndarray, distorted: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates (V, N, 2) of world points, the normalised undistorted ones
        (V, N, 2) and the depths (V, N) (eq. 3.1, with distortion when ``distorted``)."""
        pix, norm, depth = [], [], []
        for cam, (R, T) in zip(self.cameras, self.poses):
            Xc = X @ R.T + T
            z = Xc[:, 2]
            x, y = Xc[:, 0] / z, Xc[:, 1] / z
            xd, yd = distort(x, y, cam.k, cam.p) if distorted else (x, y)
            pix.append(np.column_stack([cam.fu * xd + cam.u0, cam.fv * yd + cam.v0]))
            norm.append(np.column_stack([x, y]))
            depth.append(z)
        return np.array(pix), np.array(norm), np.array(depth)

    def check_views(self, X: np.ndarray, what: str = "grid") -> None:
        """A clear error when a grid point is behind a camera or outside its image."""
        pix, _, depth = self.project(X)
        for i, cam in enumerate(self.cameras):
            behind = int(np.sum(depth[i] <= 0))
            if behind:
                raise InputError(
                    f"camera {i + 1}: {behind} of {len(X)} {what} points lie behind the camera; "
                    "the views do not overlap the measuring volume"
                )
            w, h = cam.image_size
            if w and h:
                u, v = pix[i, :, 0], pix[i, :, 1]
                out = int(np.sum((u < 0) | (u > w) | (v < 0) | (v > h)))
                if out:
                    raise InputError(
                        f"camera {i + 1}: {out} of {len(X)} {what} points fall outside its "
                        f"{w} x {h} px image; the views do not overlap the measuring volume"
                    )
