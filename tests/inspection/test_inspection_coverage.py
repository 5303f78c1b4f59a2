"""Coverage by area (thesis ch. 6.2.4), against areas known by geometry.

A covered patch counts its own area plus a band of width ``distance`` around its rim
(the nominal samples that close to a measured point): expected = (patch area + rim
length × distance) / total area. The tolerance is three binomial standard errors of
the sampled estimate plus the band's corner terms.
"""

from __future__ import annotations

import numpy as np
import pytest

from camcmm_plugins.inspection.coverage import coverage, default_distance, sample_surface
from helpers.shapes import box_mesh, rotate


def test_samples_are_uniform_by_area():
    V, F = box_mesh([0, 0, 0], [30, 10, 10], 1)  # faces of 300 and 100 mm², two triangles each
    pts, tid = sample_surface(V, F, 140000, seed=1)
    assert abs(len(pts) - 140000) < 50
    share_x = np.mean(np.isclose(pts[:, 0], 0) | np.isclose(pts[:, 0], 30))  # the two 10 × 10 ends
    assert share_x == pytest.approx(200 / 1400, abs=3 * np.sqrt(0.14 * 0.86 / 140000))


@pytest.mark.slow
def test_top_face_of_a_cube():
    V, F = box_mesh([0, 0, 0], [10, 10, 10], 4)
    g = np.linspace(0, 10, 501)
    X, Y = np.meshgrid(g, g)
    top = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 10.0)])
    r = 0.05
    c = coverage(rotate(top), rotate(V), F, distance=r, n_samples=200_000)
    expected = (100 + 40 * r) / 600
    tol = 3 * np.sqrt(expected * (1 - expected) / c["n_samples"]) + 4 * r * r / 600
    assert c["fraction"] == pytest.approx(expected, abs=tol)
    assert c["area"] == pytest.approx(600.0)
    assert c["covered_area"] == pytest.approx(c["fraction"] * 600.0)


def test_area_not_point_count():
    """250 000 points on one face cover a sixth; 15 606 spread over all faces cover all."""
    V, F = box_mesh([0, 0, 0], [10, 10, 10], 4)
    g = np.linspace(0, 10, 501)
    X, Y = np.meshgrid(g, g)
    dense_top = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 10.0)])
    sparse, _ = box_mesh([0, 0, 0], [10, 10, 10], 50)  # a 0.2 mm grid on every face
    a = coverage(dense_top, V, F, distance=0.15)
    b = coverage(sparse, V, F, distance=0.15)
    assert len(dense_top) > 10 * len(sparse)
    assert a["fraction"] < 0.18
    assert b["fraction"] == 1.0


def test_spherical_cap():
    import open3d as o3d

    R, theta = 10.0, np.radians(60.0)
    m = o3d.geometry.TriangleMesh.create_sphere(radius=R, resolution=200)
    V, F = np.asarray(m.vertices), np.asarray(m.triangles)
    n = 200_000  # Fibonacci points on the cap cos(polar angle) >= cos(theta)
    k = np.arange(n) + 0.5
    z = 1 - (1 - np.cos(theta)) * k / n
    phi = np.pi * (1 + 5**0.5) * k
    s = np.sqrt(1 - z * z)
    cap = R * np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    r = 0.1
    c = coverage(cap, V, F, distance=r, n_samples=300_000, seed=2)
    expected = (2 * np.pi * R * R * (1 - np.cos(theta)) + 2 * np.pi * R * np.sin(theta) * r) / (4 * np.pi * R * R)
    assert c["fraction"] == pytest.approx(expected, abs=3 * np.sqrt(expected * (1 - expected) / c["n_samples"]) + 1e-3)


def test_default_distance_is_three_spacings():
    g = np.arange(0, 50, 0.25)
    X, Y = np.meshgrid(g, g)
    grid = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    assert default_distance(grid) == pytest.approx(0.75)


def test_reference_cloud_nominal_and_samples():
    ref = np.random.default_rng(3).uniform(0, 10, (5000, 3))
    c = coverage(ref[:2500], reference_points=ref, distance=1e-9, return_samples=True)
    assert c["fraction"] == pytest.approx(0.5) and c["area"] is None
    assert c["covered"].sum() == 2500 and c["samples"].shape == (5000, 3)
