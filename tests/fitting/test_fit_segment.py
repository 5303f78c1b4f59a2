"""Sphere segmentation: NIST's real laser scans of 50 mm-radius spheres (raw scans with
mount and background, and NIST's own segmented versions), and synthetic ball bars and
ball plates whose sphere centres are known."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from camcmm.api import GeometryError, InputError, read
from camcmm_plugins.fitting.api import extract_sphere, fit_sphere, segment_spheres

NIST = Path(__file__).parents[1] / "data" / "nist_spheres"
SCANS = ("101", "102", "110")


def _nist(name):
    return read(NIST / name, unit="m").points  # metres on file, mm here


@pytest.mark.parametrize("scan", SCANS)
@pytest.mark.slow
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


@pytest.mark.slow
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


# ------------------------------------------- extraction that finds nothing like the nominal (issue 15)
def _cap_cloud(r=0.0666, n=6474):
    """Issue 15's cloud: a hemisphere of a ball of radius r mm (0.13 mm wide), n exact points."""
    rng = np.random.default_rng(15)
    u = rng.normal(size=(3 * n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u = u[u[:, 2] > 0][:n]
    assert len(u) == n
    return np.array([1.0, 2.0, 3.0]) + r * u


def _ball_in_clutter(noise=0.0, seed=5):
    """A ball (radius 10 mm, 3000 points seen from above: z > -R/2 about its centre) on a
    stem (cylinder of radius 3 mm down to a table) and the table (5000 points): points
    0-4999 table, 5000-7999 ball, 8000-9999 stem. Without noise every ball point is on
    the sphere exactly."""
    rng = np.random.default_rng(seed)
    c, r = np.array([120.0, -40.0, 30.0]), 10.0
    u = rng.normal(size=(9000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u = u[u[:, 2] > -0.5][:3000]
    ball = c + (r + rng.normal(scale=noise, size=len(u)) if noise else np.full(len(u), r))[:, None] * u
    t = rng.uniform(-25.0, -np.sqrt(r**2 - 9.0), 2000)
    phi = rng.uniform(0, 2 * np.pi, 2000)
    stem = c + np.column_stack([3 * np.cos(phi), 3 * np.sin(phi), t])
    table = c + np.column_stack([rng.uniform(-60, 60, 5000), rng.uniform(-60, 60, 5000), np.full(5000, -25.0)])
    return np.vstack([table, ball, stem]), c, r


def test_extract_with_a_wrong_nominal_is_refused():
    x = _cap_cloud()
    assert fit_sphere(x).radius == pytest.approx(0.0666, abs=1e-12)  # what the cloud is
    with pytest.raises(GeometryError) as exc:
        extract_sphere(x, 50.0)
    msg = str(exc.value)
    assert "\n" not in msg
    assert "no sphere of radius 50 mm (±20 %)" in msg and "6474 points spanning 0.133" in msg, msg
    assert "radius is 0.0666 mm" in msg and "all of them" in msg, msg
    assert "a file in metres read as mm?" in msg  # 50 / 0.0666 = 751, within 500-2000
    with pytest.raises(GeometryError) as exc:  # 50 / 0.0666 / 10 = 75: no unit hint
        extract_sphere(x * 10, 50.0)
    assert "radius is 0.666 mm" in str(exc.value) and str(exc.value).endswith("check the nominal radius and the unit")


def test_nist_scan_in_metres_read_as_mm_is_refused():
    # issue 15 as seen: SPH101.xyz (metres) read as mm, nominal 50 mm -> all 6474 points, r = 0.0666
    raw = read(NIST / "SPH101.xyz", unit="mm").points
    with pytest.raises(GeometryError) as exc:
        extract_sphere(raw, 50.0)
    msg = str(exc.value)
    assert "no sphere of radius 50 mm" in msg and "6474 points spanning 0.1379" in msg, msg
    assert "radius is 0.0666 mm" in msg and "a file in metres read as mm? give its unit" in msg, msg
    truncated = read(NIST / "tSPH101.xyz", unit="mm").points  # r = 0.0501 mm: 1/998 of 50 mm
    with pytest.raises(GeometryError, match="a file in metres read as mm"):
        extract_sphere(truncated, 50.0)


def test_extract_wrong_nominal_from_the_cli(tmp_path, capsys):
    from camcmm.api import PointCloud, write
    from helpers.cli import refused

    path = tmp_path / "cap.ply"
    write(PointCloud(_cap_cloud(), name="cap"), path)
    line = refused(capsys, ["fit", "sphere", path, "--extract", "--nominal-radius", "50"], "no sphere of radius 50 mm")
    assert "radius is 0.0666 mm" in line


def test_extract_ball_among_clutter_exact():
    x, c, r = _ball_in_clutter()
    seg = extract_sphere(x, 10.0)
    np.testing.assert_array_equal(seg.indices, np.arange(5000, 8000))
    assert abs(seg.radius - r) < 1e-9 and np.linalg.norm(seg.center - c) < 1e-9


def test_extract_ball_among_clutter_noisy(tmp_path, capsys):
    from camcmm.api import PointCloud, write
    from camcmm.cli.main import main

    x, c, r = _ball_in_clutter(noise=0.005)
    seg = extract_sphere(x, 10.0)
    ball = (seg.indices >= 5000) & (seg.indices < 8000)
    assert ball.sum() > 0.99 * 3000 and (~ball).sum() < 0.01 * 3000
    # sigma 5 um on 3000 points: u(r) ~ 0.1 um, u(centre) ~ 0.2 um; 20x that allowed
    assert abs(seg.radius - r) < 0.002 and np.linalg.norm(seg.center - c) < 0.004
    path = tmp_path / "ball.ply"
    write(PointCloud(x, name="ball"), path)
    assert main(["fit", "sphere", str(path), "--extract", "--nominal-radius", "10", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_points_raw"] == 10_000 and out["n_points"] == len(seg.indices)
    assert out["radius"] == pytest.approx(seg.radius, abs=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("off,found", [(0.19, True), (-0.19, True), (0.21, False), (-0.21, False)])
def test_extract_at_the_20_percent_boundary(off, found):
    # the ball's radius is 10 mm exactly; the nominal R is such that (10 - R) / R = off
    x, c, r = _ball_in_clutter()
    nominal = r / (1 + off)
    if found:
        seg = extract_sphere(x, nominal)
        np.testing.assert_array_equal(seg.indices, np.arange(5000, 8000))
        assert abs(seg.radius - r) < 1e-9 and np.linalg.norm(seg.center - c) < 1e-9
    else:
        with pytest.raises(GeometryError, match=r"radius is 10 mm, not within ±20 %"):
            extract_sphere(x, nominal)


def test_nominal_sphere_rule():
    from camcmm_plugins.fitting.checks import nominal_sphere_mismatch as why

    assert why(59.9, 0.1, 1000, 50.0) is None and why(40.1, 0.1, 1000, 50.0) is None
    assert "not within ±20 % of 50 mm" in why(60.1, 0.1, 1000, 50.0)
    assert why(50.0, 10 / 3 - 1e-9, 1000, 50.0) is None  # 3 u = the 10 mm band
    assert "ill-determined" in why(50.0, 10 / 3 + 1e-9, 1000, 50.0)
    assert "only 29 points" in why(50.0, 0.1, 29, 50.0) and why(50.0, 0.1, 30, 50.0) is None
    assert "not within" in why(float("nan"), 0.1, 1000, 50.0)
