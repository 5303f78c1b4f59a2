"""Minimum-zone (Chebyshev) plane and sphere against independent answers: data whose
minimum zone is known by construction (contact points alternating between the two
bounding surfaces), an exhaustive search over all candidate directions for small
point sets (the narrowest slab is normal to a face of the hull or to two of its
edges), and the first-order optimality certificate checked by a convex-hull test."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest
from scipy.optimize import linprog

from camcmm.api import ParameterError
from camcmm_plugins.fitting.api import fit, fit_plane, fit_sphere

FAR = np.array([10_000.0, -10_000.0, 10_000.0])


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def _angle(u, v):
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), abs(u @ v)))


def test_minzone_plane_known_by_construction():
    """Three contact points on the top plane, three on the bottom one, rotated by 60°
    (their projections interleave, so no tilt narrows the slab), and interior points."""
    rng = np.random.default_rng(1)
    rot = _rotation(rng)
    w = 0.05
    ang_top = np.radians([0, 120, 240])
    ang_bot = ang_top + np.radians(60)
    top = np.column_stack([40 * np.cos(ang_top), 40 * np.sin(ang_top), np.full(3, w / 2)])
    bot = np.column_stack([40 * np.cos(ang_bot), 40 * np.sin(ang_bot), np.full(3, -w / 2)])
    inner = np.column_stack([rng.uniform(-30, 30, 500), rng.uniform(-30, 30, 500), rng.uniform(-0.45, 0.45, 500) * w])
    pts = np.vstack([inner[:250], top, inner[250:], bot]) @ rot.T + FAR
    res = fit_plane(pts, method="minzone")
    assert res.method == "minzone"
    assert res.form["range"] == pytest.approx(w, abs=1e-12 * 40)
    assert _angle(res.normal, rot[:, 2]) <= 1e-12
    assert abs((FAR - res.point) @ res.normal) <= 1e-11
    assert res.form["max"] == pytest.approx(w / 2, abs=1e-11) and res.form["min"] == pytest.approx(-w / 2, abs=1e-11)
    ls = fit_plane(pts)
    assert res.form["range"] <= ls.form["range"] + 1e-12


def _brute_force_width(x):
    """Minimum width of a point set: over the normals of all triples (facets) and all
    pairs of point pairs (edge-edge), the smallest extent max n·x − min n·x."""
    idx = list(combinations(range(len(x)), 2))
    d = np.array([x[j] - x[i] for i, j in idx])
    normals = [np.cross(x[j] - x[i], x[k] - x[i]) for i, j, k in combinations(range(len(x)), 3)]
    a, b = np.triu_indices(len(d), 1)
    normals = np.vstack([np.array(normals), np.cross(d[a], d[b])])
    norm = np.linalg.norm(normals, axis=1)
    normals = normals[norm > 1e-12 * norm.max()] / norm[norm > 1e-12 * norm.max()][:, None]
    proj = normals @ x.T
    width = proj.max(axis=1) - proj.min(axis=1)
    k = int(np.argmin(width))
    return width[k], normals[k]


@pytest.mark.parametrize("seed", [2, 3, 4, 5])
def test_minzone_plane_against_exhaustive_search(seed):
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-20, 20, 12), rng.uniform(-10, 10, 12), rng.normal(scale=0.05, size=12)])
    x = x @ _rotation(rng).T
    width, normal = _brute_force_width(x)
    res = fit_plane(x + FAR, method="minzone")
    assert res.form["range"] == pytest.approx(width, rel=1e-9, abs=1e-12)
    assert _angle(res.normal, normal) <= 1e-8


def _certificate(u_out, u_in):
    """Is 0 in the convex hull of {u_out} ∪ {−u_in}? (No centre shift then moves all
    outer contacts in and all inner contacts out: first-order optimality.)"""
    v = np.vstack([u_out, -u_in])
    k = len(v)
    a_eq = np.vstack([v.T, np.ones((1, k))])
    b_eq = np.concatenate([np.zeros(v.shape[1]), [1.0]])
    res = linprog(np.zeros(k), A_eq=a_eq, b_eq=b_eq, bounds=[(0, None)] * k, method="highs")
    return res.status == 0


def test_minzone_sphere_known_by_construction():
    """Outer contacts at the vertices of a regular tetrahedron on R2, inner contacts at
    the opposite directions on R1, interior points in between: centre and width known."""
    rng = np.random.default_rng(6)
    rot = _rotation(rng)
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3) @ rot.T
    r1, r2 = 9.97, 10.02
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    inner = u * rng.uniform(r1 + 0.002, r2 - 0.002, 2000)[:, None]
    pts = np.vstack([inner[:1000], r2 * tet, inner[1000:], -r1 * tet]) + FAR
    res = fit_sphere(pts, method="minzone")
    assert np.linalg.norm(res.center - FAR) <= 1e-11 * 10
    assert res.radius == pytest.approx((r1 + r2) / 2, abs=1e-11 * 10)
    assert res.form["range"] == pytest.approx(r2 - r1, abs=1e-11 * 10)
    assert all(v is None or np.all(np.isnan(v)) for v in res.std_uncertainty.values())


@pytest.mark.parametrize("seed, cap", [(7, None), (8, 40.0)])
def test_minzone_sphere_is_optimal(seed, cap):
    """Random data: the zone is not wider than least squares' or Nelder-Mead's best, and
    the contact points certify first-order optimality (independent convex-hull LP)."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(seed)
    u = rng.normal(size=(3000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    if cap is not None:
        u = u[u[:, 2] > np.cos(np.radians(cap))]
    pts = FAR + (10 + rng.normal(scale=0.01, size=len(u)))[:, None] * u
    res = fit_sphere(pts, method="minzone")
    ls = fit_sphere(pts)
    assert res.form["range"] <= ls.form["range"] + 1e-12

    def zone(c):
        rho = np.linalg.norm(pts - FAR - c, axis=1)
        return rho.max() - rho.min()

    best = min(
        (
            minimize(
                zone,
                ls.center - FAR + rng.normal(scale=1e-3, size=3),
                method="Nelder-Mead",
                options={"xatol": 1e-10, "fatol": 1e-13, "maxiter": 20000},
            )
            for _ in range(3)
        ),
        key=lambda r: r.fun,
    )
    assert res.form["range"] <= best.fun + 1e-12
    assert res.form["range"] == pytest.approx(zone(res.center - FAR), abs=1e-11)  # centre rounded at 1e4 mm
    rho = np.linalg.norm(pts - res.center, axis=1)
    uu = (pts - res.center) / rho[:, None]
    tol = 1e-9 * 10
    assert _certificate(uu[rho >= rho.max() - tol], uu[rho <= rho.min() + tol])


def test_minzone_plane_on_a_large_cloud():
    rng = np.random.default_rng(9)
    n = 200_000
    pts = np.column_stack([rng.uniform(-100, 100, n), rng.uniform(-100, 100, n), rng.normal(scale=0.005, size=n)])
    res = fit_plane(pts @ _rotation(rng).T + FAR, method="minzone")
    ls = fit_plane(pts @ np.eye(3) + FAR)
    assert res.form["range"] <= ls.form["range"]
    assert abs(res.form["max"] + res.form["min"]) <= 1e-12 * 100


def test_minzone_with_outlier_rule_and_unsupported_elements():
    rng = np.random.default_rng(10)
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    pts = FAR + (5 + rng.normal(scale=0.005, size=2000))[:, None] * u
    pts[7] = FAR + 5.5 * u[7]
    res = fit_sphere(pts, "vdi2634", method="minzone")
    assert res.n_removed == 6 and 7 in res.removed
    assert res.form["range"] < 0.1
    for element in ("line", "circle", "cylinder"):
        with pytest.raises(ParameterError, match="minzone"):
            fit(element, pts, method="minzone")
