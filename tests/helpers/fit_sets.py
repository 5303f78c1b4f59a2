"""Reference sets for least-squares fits whose solution is known exactly (the null-space method of
ISO 10360-6 annex B): points on the nominal element, residuals along the normals projected onto
the orthogonal complement of the fit's Jacobian columns, so the nominal *is* the LS solution."""

from __future__ import annotations

import numpy as np

FAR = np.array([10_000.0, -10_000.0, 10_000.0])


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def _null_project(e: np.ndarray, *columns: np.ndarray) -> np.ndarray:
    """e minus its projection on span(columns): then Jᵀ e = 0 exactly (to rounding)."""
    q, _ = np.linalg.qr(np.column_stack(columns))
    e = e - q @ (q.T @ e)
    return e - q @ (q.T @ e)  # a second pass removes the rounding of the first


def _angle(u, v):
    u, v = np.asarray(u) / np.linalg.norm(u), np.asarray(v) / np.linalg.norm(v)
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), abs(u @ v)))


def _dist_point_line(p, q, a):
    a = a / np.linalg.norm(a)
    d = p - q
    return float(np.linalg.norm(d - (d @ a) * a))


# -- generators --------------------------------------------------------------------------


def sphere_set(rng, n, radius, half_angle_deg=None, sigma=0.01, center=FAR):
    """Points on a sphere (or a cap of the given half-angle about a random axis)."""
    rot = _rotation(rng)
    if half_angle_deg is None:
        u = rng.normal(size=(n, 3))
        u /= np.linalg.norm(u, axis=1)[:, None]
    else:  # uniform on the cap
        cmin = np.cos(np.radians(half_angle_deg))
        z = rng.uniform(cmin, 1.0, n)
        phi = rng.uniform(0, 2 * np.pi, n)
        s = np.sqrt(1 - z * z)
        u = np.column_stack([s * np.cos(phi), s * np.sin(phi), z]) @ rot.T
    e = _null_project(rng.normal(scale=sigma, size=n), u[:, 0], u[:, 1], u[:, 2], np.ones(n))
    return center + (radius + e)[:, None] * u, e


def circle2d_set(rng, n, radius, arc_deg=360.0, sigma=0.01, center=FAR[:2]):
    t = rng.uniform(0, np.radians(arc_deg), n) + rng.uniform(0, 2 * np.pi)
    u = np.column_stack([np.cos(t), np.sin(t)])
    e = _null_project(rng.normal(scale=sigma, size=n), u[:, 0], u[:, 1], np.ones(n))
    return center + (radius + e)[:, None] * u, e


def circle3d_set(rng, n, radius, arc_deg=360.0, sigma=0.01, center=FAR):
    rot = _rotation(rng)
    b1, b2, nrm = rot[:, 0], rot[:, 1], rot[:, 2]
    t = rng.uniform(0, np.radians(arc_deg), n)
    c, s = np.cos(t), np.sin(t)
    one = np.ones(n)
    e = _null_project(rng.normal(scale=sigma, size=n), one, c, s)
    h = _null_project(rng.normal(scale=sigma, size=n), one, c, s)
    pts = center + (radius + e)[:, None] * (c[:, None] * b1 + s[:, None] * b2) + h[:, None] * nrm
    return pts, np.where(e >= 0, 1.0, -1.0) * np.hypot(e, h), nrm


def cylinder_set(rng, n, radius, length, arc_deg=360.0, sigma=0.01, point=FAR):
    rot = _rotation(rng)
    b1, b2, axis = rot[:, 0], rot[:, 1], rot[:, 2]
    z = rng.uniform(-length / 2, length / 2, n)
    t = rng.uniform(0, np.radians(arc_deg), n)
    c, s = np.cos(t), np.sin(t)
    e = _null_project(rng.normal(scale=sigma, size=n), np.ones(n), c, s, z * c, z * s)
    pts = point + z[:, None] * axis + (radius + e)[:, None] * (c[:, None] * b1 + s[:, None] * b2)
    return pts, e, axis


def plane_set(rng, n, width, depth, sigma=0.01, point=FAR):
    rot = _rotation(rng)
    b1, b2, nrm = rot[:, 0], rot[:, 1], rot[:, 2]
    xi = rng.uniform(-width / 2, width / 2, n)
    eta = rng.uniform(-depth / 2, depth / 2, n)
    h = _null_project(rng.normal(scale=sigma, size=n), np.ones(n), xi, eta)
    return point + xi[:, None] * b1 + eta[:, None] * b2 + h[:, None] * nrm, h, nrm


def line_set(rng, n, length, sigma=0.01, point=FAR):
    rot = _rotation(rng)
    a, b1, b2 = rot[:, 0], rot[:, 1], rot[:, 2]
    t = rng.uniform(-length / 2, length / 2, n)
    e1 = _null_project(rng.normal(scale=sigma, size=n), np.ones(n), t)
    e2 = _null_project(rng.normal(scale=sigma, size=n), np.ones(n), t)
    return point + t[:, None] * a + e1[:, None] * b1 + e2[:, None] * b2, np.hypot(e1, e2), a


# -- tests -------------------------------------------------------------------------------
