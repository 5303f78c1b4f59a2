"""Least-squares fits against reference data whose solution is known exactly.

No certified public fitting data sets could be had, so the reference sets are made
the way reference data for testing fitting software are made (the null-space method,
e.g. ISO 10360-6 annex B, NPL/PTB data generators): points on the nominal element,
residuals along the normals, and the residual vector projected onto the orthogonal
complement of the columns of the fit's Jacobian at the nominal parameters. The
nominal element then satisfies the least-squares optimality conditions exactly, so it
*is* the least-squares solution. Full elements and partial ones (caps, short arcs,
thin strips), all placed 10 000 mm from the origin; agreement is required within 1e-9
of the element's size. Also: the Gander-Golub-Strebel circle (a published result).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from camcmm_plugins.fitting.api import fit_circle, fit_cylinder, fit_line, fit_plane, fit_sphere
from helpers.fit_sets import (
    FAR,
    _angle,
    _dist_point_line,
    _null_project,
    circle2d_set,
    circle3d_set,
    cylinder_set,
    line_set,
    plane_set,
    sphere_set,
)

DATA = Path(__file__).parents[1] / "data"
TOL = 1e-9


@pytest.mark.parametrize("half_angle", [None, 90.0, 30.0, 15.0])
def test_sphere_reference(half_angle):
    """Full sphere, hemisphere, a 60° cap and a 30° cap (half-angles 30° and 15°)."""
    rng = np.random.default_rng(11)
    radius = 12.5
    pts, e = sphere_set(rng, 4000, radius, half_angle)
    res = fit_sphere(pts)
    assert np.linalg.norm(res.center - FAR) <= TOL * radius
    assert abs(res.radius - radius) <= TOL * radius
    assert np.abs(res.residuals - e).max() <= TOL * radius
    assert res.n_used == res.n_points == len(pts)


@pytest.mark.parametrize("arc", [360.0, 90.0, 30.0])
def test_circle2d_reference(arc):
    rng = np.random.default_rng(12)
    radius = 8.0
    pts, e = circle2d_set(rng, 800, radius, arc)
    res = fit_circle(pts)
    assert np.linalg.norm(res.center - FAR[:2]) <= TOL * radius
    assert abs(res.radius - radius) <= TOL * radius
    assert np.abs(res.residuals - e).max() <= TOL * radius


@pytest.mark.parametrize("arc", [360.0, 90.0, 30.0])
def test_circle3d_reference(arc):
    """Circle in space: the orthogonal distance combines the in-plane and the
    out-of-plane component; the residuals of both are made orthogonal to the
    Jacobian of the stacked components."""
    rng = np.random.default_rng(13)
    radius = 20.0
    pts, d, nrm = circle3d_set(rng, 800, radius, arc)
    res = fit_circle(pts)
    assert np.linalg.norm(res.center - FAR) <= TOL * radius
    assert abs(res.radius - radius) <= TOL * radius
    assert _angle(res.normal, nrm) <= TOL
    assert np.abs(res.residuals - d).max() <= TOL * radius


@pytest.mark.parametrize("arc, length", [(360.0, 60.0), (120.0, 30.0), (60.0, 20.0)])
def test_cylinder_reference(arc, length):
    """Full cylinder, a 120° arc and a short 60° arc (length 2 r)."""
    rng = np.random.default_rng(14)
    radius = 10.0
    pts, e, axis = cylinder_set(rng, 3000, radius, length, arc)
    res = fit_cylinder(pts)
    assert abs(res.radius - radius) <= TOL * radius
    assert _angle(res.axis, axis) <= TOL
    assert _dist_point_line(FAR, res.point, res.axis) <= TOL * radius
    assert np.abs(res.residuals - e).max() <= TOL * radius


@pytest.mark.parametrize("width, depth", [(100.0, 80.0), (100.0, 2.0)])
def test_plane_reference(width, depth):
    """A square patch and a thin strip (partial: the tilt across it is barely determined)."""
    rng = np.random.default_rng(15)
    pts, h, nrm = plane_set(rng, 2000, width, depth)
    size = np.linalg.norm(pts - pts.mean(axis=0), axis=1).max()
    res = fit_plane(pts)
    assert abs((FAR - res.point) @ res.normal) <= TOL * size
    assert _angle(res.normal, nrm) <= TOL
    sign = np.sign(res.normal @ nrm)
    assert np.abs(res.residuals - sign * h).max() <= TOL * size


@pytest.mark.parametrize("length", [200.0, 5.0])
def test_line_reference(length):
    rng = np.random.default_rng(16)
    pts, d, a = line_set(rng, 1000, length)
    size = length / 2
    res = fit_line(pts)
    assert _dist_point_line(FAR, res.point, res.direction) <= TOL * size
    assert _angle(res.direction, a) <= TOL
    assert np.abs(res.residuals - d).max() <= TOL * size


def test_line2d_reference_signed():
    rng = np.random.default_rng(17)
    a = np.array([np.cos(0.3), np.sin(0.3)])
    nrm = np.array([-a[1], a[0]])
    t = rng.uniform(-50, 50, 500)
    e = _null_project(rng.normal(scale=0.02, size=500), np.ones(500), t)
    pts = FAR[:2] + t[:, None] * a + e[:, None] * nrm
    res = fit_line(pts)
    assert abs(abs(res.direction @ a) - 1) <= TOL
    sign = np.sign(res.direction @ a)
    assert np.abs(res.residuals - sign * e).max() <= TOL * 50


def test_reference_sets_are_exact_by_construction():
    """The generator itself: the Jacobian columns are orthogonal to the residuals."""
    rng = np.random.default_rng(18)
    pts, e = sphere_set(rng, 1000, 5.0, 15.0, center=np.zeros(3))
    u = pts / np.linalg.norm(pts, axis=1)[:, None]
    j = np.column_stack([u, np.ones(len(u))])
    assert np.abs(j.T @ e).max() < 1e-13 * np.abs(e).sum()


def test_gander_golub_strebel_circle():
    """The six points of Gander, Golub & Strebel (BIT 34, 1994): geometric circle
    centre (4.7398, 2.9835), radius 4.7142 (4 decimals); the algebraic fit is far off."""
    with open(DATA / "circle_fit_gander1994" / "points.csv") as fh:
        rows = [(float(r["x"]), float(r["y"])) for r in csv.DictReader(fh)]
    pts = np.array(rows)
    res = fit_circle(pts)
    assert np.allclose(res.center, [4.7398, 2.9835], atol=5e-5)
    assert abs(res.radius - 4.7142) <= 5e-5
    assert np.sum(res.residuals**2) == pytest.approx(1.2275990781836557, rel=1e-9)
    # the same points in space (z = 0) give the same circle
    res3 = fit_circle(np.column_stack([pts, np.zeros(len(pts))]))
    assert np.allclose(res3.center, [*res.center, 0.0], atol=1e-9)
    assert abs(res3.radius - res.radius) <= 1e-9
    assert abs(abs(res3.normal[2]) - 1) <= 1e-12
    # and far from the origin
    resf = fit_circle(pts + FAR[:2])
    assert np.allclose(resf.center - FAR[:2], res.center, atol=1e-9)


@pytest.mark.slow
def test_uncertainties_match_monte_carlo():
    """The standard uncertainties from the fit covariance against the scatter of
    repeated fits with fresh noise (sphere cap and cylinder arc)."""
    rng = np.random.default_rng(19)
    u = rng.normal(size=(600, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u = u[u[:, 2] > 0.5]
    radii, reported = [], []
    for _ in range(150):
        pts = FAR + (10 + rng.normal(scale=0.02, size=len(u)))[:, None] * u
        res = fit_sphere(pts)
        radii.append(res.radius)
        reported.append(res.std_uncertainty["radius"])
    assert np.std(radii, ddof=1) == pytest.approx(np.mean(reported), rel=0.2)
    z = rng.uniform(-10, 10, 400)
    t = rng.uniform(0, np.pi / 2, 400)
    base = np.column_stack([5 * np.cos(t), 5 * np.sin(t), z])
    nrm = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    radii, reported = [], []
    for _ in range(150):
        res = fit_cylinder(FAR + base + rng.normal(scale=0.01, size=400)[:, None] * nrm)
        radii.append(res.radius)
        reported.append(res.std_uncertainty["radius"])
    assert np.std(radii, ddof=1) == pytest.approx(np.mean(reported), rel=0.2)
