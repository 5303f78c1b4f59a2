"""Sphere segmentation: NIST's real laser scans of 50 mm-radius spheres (raw scans with
mount and background, and NIST's own segmented versions), and synthetic ball bars and
ball plates whose sphere centres are known."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from camcmm.api import GeometryError, InputError, read
from camcmm_plugins.fitting.api import extract_sphere, fit_sphere, segment_spheres

NIST = Path(__file__).parent / "data" / "nist_spheres"
SCANS = ("101", "102", "110")


def _nist(name):
    return read(NIST / name, unit="m").points  # metres on file, mm here


@pytest.mark.parametrize("scan", SCANS)
def test_nist_raw_scan_to_sphere(scan):
    raw = _nist(f"SPH{scan}.xyz")
    truncated = _nist(f"tSPH{scan}.xyz")
    nist = fit_sphere(truncated)  # NIST's segmentation, our fit
    assert abs(nist.radius - 50.0) < 0.25
    naive = fit_sphere(raw)  # mount and background included
    assert abs(naive.radius - 50.0) > 5.0
    # band extraction with the nominal radius: near 50 mm
    band = extract_sphere(raw, 50.0)
    assert abs(band.radius - 50.0) < 0.3
    assert np.linalg.norm(band.center - nist.center) < 0.3
    assert len(raw) > len(band.indices) > len(truncated)
    # with NIST's cone truncation (ASTM E3125: 120° cone towards the scanner at the origin)
    cone = extract_sphere(raw, 50.0, cone_half_angle=60.0)
    assert np.linalg.norm(cone.center - nist.center) < 0.05
    assert abs(cone.radius - nist.radius) < 0.03
    assert abs(len(cone.indices) - len(truncated)) <= 0.03 * len(truncated)
    # without a nominal radius (RANSAC) the same sphere
    free = extract_sphere(raw)
    assert np.linalg.norm(free.center - band.center) < 0.05
    assert abs(free.radius - band.radius) < 0.05


def test_nist_fitted_radii_are_near_50_mm():
    radii = [fit_sphere(_nist(f"tSPH{s}.xyz"), "vdi2634").radius for s in SCANS]
    assert all(49.7 < r < 50.3 for r in radii), radii


def _sphere_points(rng, centre, radius, n, visible_z=-0.3, noise=0.005):
    u = rng.normal(size=(3 * n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u = u[u[:, 2] > visible_z][:n]
    return centre + (radius + rng.normal(scale=noise, size=len(u)))[:, None] * u


def _ball_bar(rng, far):
    c1, c2 = far + np.array([0.0, 0, 0]), far + np.array([100.0, 0, 0])
    s1, s2 = _sphere_points(rng, c1, 10.0, 3000), _sphere_points(rng, c2, 10.0, 3000)
    # the bar: a cylinder of radius 3 between the spheres, and a background plane
    t = rng.uniform(np.sqrt(100 - 9), 100 - np.sqrt(100 - 9), 3000)
    phi = rng.uniform(0, np.pi, 3000)
    bar = far + np.column_stack([t, 3 * np.cos(phi), 3 * np.sin(phi)])
    plane = far + np.column_stack([rng.uniform(-40, 140, 3000), rng.uniform(-40, 40, 3000), np.full(3000, -25.0)])
    pts = np.vstack([plane, s1, bar, s2])
    return pts, (c1, c2)


def test_ball_bar_segmentation():
    rng = np.random.default_rng(1)
    far = np.array([5000.0, -3000.0, 2000.0])
    pts, (c1, c2) = _ball_bar(rng, far)
    seg = segment_spheres(pts, 10.0)
    assert len(seg.spheres) == 2
    a, b = seg.spheres
    assert np.linalg.norm(a.center - c1) < 0.01 and np.linalg.norm(b.center - c2) < 0.01
    assert abs(np.linalg.norm(a.center - b.center) - 100.0) < 0.01
    assert abs(a.radius - 10) < 0.01 and abs(b.radius - 10) < 0.01
    # the points: almost all sphere points, no plane points, bar points only at the joints
    assert set(np.unique(seg.labels)) == {-1, 0, 1}
    assert (seg.labels[:3000] == -1).all()
    assert (seg.labels[3000:6000] == 0).mean() > 0.98 and (seg.labels[9000:] == 1).mean() > 0.98
    assert (seg.labels[6000:9000] >= 0).mean() < 0.02
    np.testing.assert_array_equal(a.indices, np.flatnonzero(seg.labels == 0))
    assert a.fit.n_points == len(a.indices)


def test_ball_plate_segmentation_and_count():
    rng = np.random.default_rng(2)
    centres = [np.array([x, y, 0.0]) for x in (0, 60, 120) for y in (0, 60, 120)]
    spheres = [_sphere_points(rng, c, 5.0, 1500, visible_z=-0.2) for c in centres]
    plate = np.column_stack([rng.uniform(-20, 140, 4000), rng.uniform(-20, 140, 4000), np.full(4000, -4.0)])
    pts = np.vstack([plate] + spheres)
    seg = segment_spheres(pts, 5.0)
    assert len(seg.spheres) == 9
    found = np.array([s.center for s in seg.spheres])
    for c in centres:
        assert np.linalg.norm(found - c, axis=1).min() < 0.01
    assert len(segment_spheres(pts, 5.0, n_spheres=4).spheres) == 4


def test_segmentation_errors():
    rng = np.random.default_rng(3)
    plane = np.column_stack([rng.uniform(0, 100, 2000), rng.uniform(0, 100, 2000), np.zeros(2000)])
    with pytest.raises(GeometryError, match="no sphere of radius 10 mm") as exc:
        segment_spheres(plane, 10.0)
    assert "\n" not in str(exc.value)
    with pytest.raises(InputError, match="positive nominal radius"):
        segment_spheres(plane, 0.0)
