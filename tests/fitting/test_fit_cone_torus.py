"""Cone and torus fits (issue 27), checked in the manner of ISO 10360-6: exact by
construction on full and partial elements far from the origin with arbitrary axes,
reference sets with known least-squares solutions (null-space method), noisy data
against the predicted uncertainties, minimum zone against a known band, starts far
from the truth, the CLI's JSON and the one-line refusals.

Tolerance of the exact cases: 1e-9 relative to the element's size (lengths) and 1e-9
rad (directions, angles). The points are placed 1000 mm from the origin, where their
coordinates carry a rounding of eps·1000 mm ≈ 1e-13 mm, i.e. ~1e-14 of a 10-40 mm
element; the worst case here (a 30° arc of a 20° cone, whose apex is extrapolated ~3
times the points' extent) amplifies it by the fit's condition (~1e2-1e3), giving at
most ~1e-11 relative (measured: 2e-13 apex, 1e-14 rad axis). 1e-9 leaves that margin
and still fails a fit stopped early (the Gauss-Newton tolerance is 1e-13; one stopped
at 1e-8 of the point spread would miss by 1e-8).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from camcmm.api import GeometryError, InputError
from camcmm_plugins.fitting._geometry import Frame
from camcmm_plugins.fitting.api import fit, fit_cone, fit_torus
from camcmm_plugins.fitting.cones import CONE
from camcmm_plugins.fitting.tori import TORUS
from helpers.cli import refused
from helpers.fit_sets import _angle, _null_project, _rotation

FAR = np.array([1000.0, -1000.0, 1000.0])
REL = 1e-9  # see the module docstring


# -- generators: points on (or at given normal offsets from) the analytic surfaces ---------


def cone_points(rng, n, angle_deg, arc_deg=360.0, heights=(10.0, 30.0), offset=None, apex=FAR, rot=None):
    """Points on a cone of full apex ``angle_deg`` (apex mm, axis = third column of rot),
    azimuths over ``arc_deg``, heights above the apex in ``heights`` (mm); each moved by
    ``offset`` (n,) mm along its outward normal. Returns (points, axis, the unit normals,
    the Jacobian columns of the residual at the feet, mm)."""
    rot = _rotation(rng) if rot is None else rot
    b1, b2, a = rot[:, 0], rot[:, 1], rot[:, 2]
    psi = np.radians(angle_deg / 2)
    t = rng.uniform(0, np.radians(arc_deg), n) + rng.uniform(0, 2 * np.pi)
    h = rng.uniform(*heights, n)
    w = np.cos(t)[:, None] * b1 + np.sin(t)[:, None] * b2
    feet = apex + h[:, None] * a + (h * np.tan(psi))[:, None] * w
    nrm = np.cos(psi) * w - np.sin(psi) * a
    e = np.zeros(n) if offset is None else offset
    cols = (np.cos(t), np.sin(t), h * np.cos(t), h * np.sin(t), np.ones(n), h)  # shifts, tilts, s, ψ
    return feet + e[:, None] * nrm, a, nrm, cols


def torus_points(rng, n, big, small, arc_deg=360.0, minor_deg=360.0, offset=None, centre=FAR, rot=None):
    """Points on a torus (centre mm, axis = third column of rot, radii ``big``, ``small`` mm),
    azimuths over ``arc_deg`` around the axis, angles over ``minor_deg`` of the tube's
    circle centred on its outer equator; moved by ``offset`` (n,) mm along the normal.
    Returns (points, axis, the Jacobian columns of the residual at the feet)."""
    rot = _rotation(rng) if rot is None else rot
    b1, b2, a = rot[:, 0], rot[:, 1], rot[:, 2]
    u = rng.uniform(0, np.radians(arc_deg), n) + rng.uniform(0, 2 * np.pi)
    v = np.radians(rng.uniform(-minor_deg / 2, minor_deg / 2, n))
    e = np.zeros(n) if offset is None else offset
    rho = big + (small + e) * np.cos(v)
    w = np.cos(u)[:, None] * b1 + np.sin(u)[:, None] * b2
    pts = centre + rho[:, None] * w + ((small + e) * np.sin(v))[:, None] * a
    # along a normal line the Jacobian rows do not change (the tilt row is big·sin v)
    cols = (np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v), np.sin(v) * np.cos(u), np.sin(v) * np.sin(u))
    return pts, a, cols + (np.cos(v), np.ones(n))


# -- exact by construction ---------------------------------------------------------------


@pytest.mark.parametrize("arc", [360, 90, 30])
@pytest.mark.parametrize("angle", [20, 60, 120])
def test_cone_exact_by_construction(arc, angle):
    rng = np.random.default_rng(100 + arc + angle)
    pts, a, _, _ = cone_points(rng, 300, angle, arc)
    res = fit_cone(pts)
    size = 30.0  # mm, the largest height of the points above the apex
    assert np.abs(res.apex - FAR).max() <= REL * size
    assert _angle(res.axis, a) <= REL and res.axis @ a > 0  # pointing into the cone
    assert abs(np.radians(res.angle - angle)) <= REL
    assert res.form["range"] <= REL * size and res.n_points == 300 and res.warnings == []


@pytest.mark.parametrize(
    "arc, minor, big, small",
    [(360, 360, 40, 10), (90, 360, 40, 10), (30, 360, 40, 10), (30, 360, 20, 8), (30, 180, 40, 10), (60, 90, 20, 8)]
    + [(360, 60, 40, 10), (360, 360, 15, 12)],
)
def test_torus_exact_by_construction(arc, minor, big, small):
    rng = np.random.default_rng(7 + arc + minor + big)
    pts, a, _ = torus_points(rng, 400, big, small, arc, minor)
    res = fit_torus(pts)
    assert np.abs(res.center - FAR).max() <= REL * big
    assert _angle(res.axis, a) <= REL
    assert abs(res.major_radius - big) <= REL * big and abs(res.minor_radius - small) <= REL * big
    assert res.form["range"] <= REL * big


def test_exact_fits_keep_their_accuracy_much_farther_out():
    """10 000 mm from the origin the rounding of the coordinates is 2e-12 mm: still 1e-9."""
    rng = np.random.default_rng(3)
    far = np.array([1e4, -1e4, 1e4])
    pts, a, _, _ = cone_points(rng, 300, 40, 30, apex=far)
    res = fit_cone(pts)
    assert np.abs(res.apex - far).max() <= REL * 30 and abs(np.radians(res.angle - 40)) <= REL
    pts, a, _ = torus_points(rng, 300, 30, 5, 30, 120, centre=far)
    res = fit_torus(pts)
    assert np.abs(res.center - far).max() <= REL * 30 and abs(res.major_radius - 30) <= REL * 30


# -- reference sets: the least-squares solution known exactly (null-space method) -----------


def test_cone_and_torus_null_space_reference_sets():
    """Residuals along the normals, projected onto the orthogonal complement of the
    Jacobian's columns (which do not change along a normal line for either surface), so
    the nominal satisfies the least-squares conditions exactly: the fit must return it,
    however large the residuals, and its form must be theirs."""
    rng = np.random.default_rng(11)
    _, _, _, cols = cone_points(rng, 500, 50, 60)
    rng = np.random.default_rng(11)  # the same feet again, now moved by the projected residuals
    e = _null_project(np.random.default_rng(12).normal(scale=0.02, size=500), *cols)
    pts, a, _, _ = cone_points(rng, 500, 50, 60, offset=e)
    res = fit_cone(pts)
    assert np.abs(res.apex - FAR).max() <= REL * 30 and _angle(res.axis, a) <= REL
    assert abs(np.radians(res.angle - 50)) <= REL
    assert np.abs(res.residuals - e).max() <= REL * 30

    rng = np.random.default_rng(13)
    _, _, cols = torus_points(rng, 500, 40, 10, 45, 200)
    rng = np.random.default_rng(13)
    e = _null_project(np.random.default_rng(14).normal(scale=0.02, size=500), *cols)
    pts, a, _ = torus_points(rng, 500, 40, 10, 45, 200, offset=e)
    res = fit_torus(pts)
    assert np.abs(res.center - FAR).max() <= REL * 40 and _angle(res.axis, a) <= REL
    assert abs(res.major_radius - 40) <= REL * 40 and abs(res.minor_radius - 10) <= REL * 40
    assert np.abs(res.residuals - e).max() <= REL * 40


# -- noisy data: the predicted standard uncertainties ----------------------------------------


def test_noisy_fits_scatter_as_their_uncertainties_predict():
    """40 noisy copies of a 90° cone and of a 60°-arc torus: each estimate within 4 u of
    the truth, and the observed scatter of the angle and major radius within 0.6-1.5
    times the mean predicted u (a covariance off by a factor 2 fails this)."""
    sigma, n = 0.005, 400
    rot = _rotation(np.random.default_rng(20))
    angles, u_angles, bigs, u_bigs = [], [], [], []
    for k in range(40):
        rng = np.random.default_rng(200 + k)
        noise = rng.normal(scale=sigma, size=n)
        pts, a, _, _ = cone_points(np.random.default_rng(21), n, 30, 90, offset=noise, rot=rot)
        res = fit_cone(pts)
        u = res.std_uncertainty
        assert np.all(np.abs(res.apex - FAR) <= 4 * u["apex"] + 1e-12)
        assert _angle(res.axis, a) <= 4 * np.linalg.norm(u["axis"])
        angles.append(res.angle)
        u_angles.append(u["angle"])
        pts, a, _ = torus_points(np.random.default_rng(22), n, 40, 10, 60, 180, offset=noise, rot=rot)
        res = fit_torus(pts)
        u = res.std_uncertainty
        assert np.all(np.abs(res.center - FAR) <= 4 * u["center"] + 1e-12)
        assert abs(res.minor_radius - 10) <= 4 * u["minor_radius"]
        assert abs(res.major_radius - 40) <= 4 * u["major_radius"]
        bigs.append(res.major_radius)
        u_bigs.append(u["major_radius"])
        assert res.warnings == []
    assert 0.6 <= np.std(angles, ddof=1) / np.mean(u_angles) <= 1.5
    assert 0.6 <= np.std(bigs, ddof=1) / np.mean(u_bigs) <= 1.5
    assert abs(np.mean(angles) - 30) <= 4 * np.mean(u_angles) / np.sqrt(40)


# -- minimum zone -------------------------------------------------------------------------------


def test_minimum_zone_of_points_on_the_two_boundaries_of_a_band():
    """Points alternately on the outer and inner boundary (±h along the normals) of a
    cone and of a torus: the minimum zone is the band, 2h, to the LP's precision (the
    true band is feasible, so it is at most 2h; with the points spread over both
    boundaries no other element does better), no wider than the least-squares form, and
    the mid-zone element is the nominal one."""
    h = 0.01
    rng = np.random.default_rng(30)
    sign = np.where(np.arange(600) % 2 == 0, 1.0, -1.0)
    pts, a, _, _ = cone_points(rng, 600, 40, 120, offset=h * sign)
    mz, ls = fit_cone(pts, method="minzone"), fit_cone(pts)
    assert 2 * h * (1 - 1e-9) <= mz.form["range"] <= 2 * h * (1 + 1e-9)
    assert mz.form["range"] <= ls.form["range"] + 1e-12
    assert abs(mz.form["max"] + mz.form["min"]) <= 1e-12  # centred on the zone
    assert np.abs(mz.apex - FAR).max() <= 1e-7 and abs(mz.angle - 40) <= 1e-7
    assert mz.method == "minzone" and np.isnan(mz.std_uncertainty["angle"])

    pts, a, _ = torus_points(rng, 600, 40, 10, 90, 270, offset=h * sign)
    mz, ls = fit_torus(pts, method="minzone"), fit_torus(pts)
    assert 2 * h * (1 - 1e-9) <= mz.form["range"] <= 2 * h * (1 + 1e-9)
    assert mz.form["range"] <= ls.form["range"] + 1e-12
    assert abs(mz.major_radius - 40) <= 1e-7 and abs(mz.minor_radius - 10) <= 1e-7


def test_minimum_zone_of_noisy_points_is_narrower_than_least_squares():
    rng = np.random.default_rng(31)
    pts, _, _, _ = cone_points(rng, 1000, 60, 360, offset=rng.uniform(-0.01, 0.01, 1000))
    mz, ls = fit_cone(pts, method="minzone"), fit_cone(pts)
    assert mz.form["range"] < ls.form["range"] and mz.form["range"] <= 0.02 + 1e-12
    pts, _, _ = torus_points(rng, 1000, 30, 6, 360, 360, offset=rng.uniform(-0.01, 0.01, 1000))
    mz, ls = fit_torus(pts, method="minzone"), fit_torus(pts)
    assert mz.form["range"] < ls.form["range"] and mz.form["range"] <= 0.02 + 1e-12


# -- starts far from the truth ---------------------------------------------------------------


def test_a_start_far_from_the_truth_converges_or_refuses_in_one_line():
    """The Gauss-Newton engine from bad starts. A cone from its axis 30° or 60° off, the
    size 30 % off and the angle 15° off: the exact answer. A torus from its axis 10° off
    and the radii 30 % off: the exact answer; from 30° off (measured: no convergence in
    100 iterations) a one-line GeometryError, never a wrong torus."""
    rng = np.random.default_rng(40)
    pts, a, _, _ = cone_points(rng, 400, 60, 90)
    tilt = np.cross(a, [1.0, 0, 0])
    tilt /= np.linalg.norm(tilt)
    frame, y = Frame.normalise(pts, "cone")
    true = CONE.fit(y).state
    for deg in (30, 60):
        start = true.copy()
        start[3:6] = np.cos(np.radians(deg)) * a + np.sin(np.radians(deg)) * tilt
        start[:3] += 0.3
        start[6] *= 1.3
        start[7] += np.radians(15)
        got = CONE.params(CONE.fit(y, start=start).state, frame)
        assert np.abs(got["apex"] - FAR).max() <= REL * 30 and abs(np.radians(got["angle"] - 60)) <= REL

    pts, a, _ = torus_points(rng, 400, 40, 10, 90, 180)
    frame, y = Frame.normalise(pts, "torus")
    true = TORUS.fit(y).state
    for deg in (10, 30):
        start = true.copy()
        start[3:6] = np.cos(np.radians(deg)) * a + np.sin(np.radians(deg)) * tilt
        start[:3] += 0.2
        start[6:] *= [1.3, 0.7]
        try:
            got = TORUS.params(TORUS.fit(y, start=start).state, frame)
        except GeometryError as exc:
            assert deg > 10 and "\n" not in str(exc) and "converge" in str(exc)
            continue
        assert abs(got["major_radius"] - 40) <= REL * 40 and np.abs(got["center"] - FAR).max() <= REL * 40


# -- warnings for ill-conditioned cases ---------------------------------------------------------


def test_warnings_for_a_cone_that_is_a_cylinder_or_a_plane_and_a_short_torus():
    rng = np.random.default_rng(50)
    # a cylinder's points: the cone's angle is ~0 and its apex far off
    t = rng.uniform(0, 2 * np.pi, 500)
    z = rng.uniform(0, 40, 500)
    cyl = FAR + np.column_stack([(10 + rng.normal(scale=0.002, size=500)) * np.cos(t), 10 * np.sin(t), z])
    res = fit_cone(cyl)
    assert any("nearly 0" in w and "fit a cylinder" in w for w in res.warnings), res.warnings
    pts, _, _, _ = cone_points(rng, 400, 172, 360, heights=(0.2, 1.0))
    assert any("nearly 180" in w for w in fit_cone(pts).warnings)
    pts, _, _, _ = cone_points(rng, 400, 60, 360, heights=(-10, 20))  # both nappes alike: no cone
    assert any("may not be a cone" in w for w in fit("cone", pts).warnings)
    rot = _rotation(rng)
    one, _, _, _ = cone_points(rng, 400, 60, 360, heights=(5, 30), rot=rot)
    other, _, _, _ = cone_points(rng, 10, 60, 360, heights=(-2, -0.5), rot=rot)  # a few past the apex
    assert any("10 points lie beyond the apex" in w for w in fit("cone", np.vstack([one, other])).warnings)
    # 20° of a torus around its axis with 0.3 mm of noise: the points hardly fix R
    rng = np.random.default_rng(51)
    pts, _, _ = torus_points(rng, 100, 60, 10, 20, 360, offset=rng.normal(scale=0.3, size=100))
    warn = fit_torus(pts).warnings
    assert any("major radius" in w and "ill-determined" in w and "around the axis" in w for w in warn), warn
    # 4° of a tube: no start value reaches a torus, or the fit creeps along R: refused in one line
    pts, _, _ = torus_points(rng, 400, 100, 5, 4, 360, offset=rng.normal(scale=0.001, size=400))
    with pytest.raises(GeometryError, match="fit a cylinder|did not converge") as exc:
        fit_torus(pts)
    assert "\n" not in str(exc.value)


# -- outlier rules, the command line, bad inputs -------------------------------------------------


def test_outlier_rule_on_a_cone_and_a_torus():
    rng = np.random.default_rng(60)
    pts, _, nrm, _ = cone_points(rng, 1000, 45, 180, offset=rng.normal(scale=0.002, size=1000))
    pts[5] += 0.5 * nrm[5]
    res = fit_cone(pts, outliers="vdi2634")
    assert res.n_removed == 3 and 5 in res.removed and abs(res.angle - 45) < 0.05
    pts, _, _ = torus_points(rng, 1000, 40, 10, 120, 360, offset=rng.normal(scale=0.002, size=1000))
    res = fit_torus(pts, outliers="sigma:3")
    assert abs(res.minor_radius - 10) < 0.01


def test_camcmm_fit_cone_and_torus_json(tmp_path, capsys):
    from camcmm.cli.main import main

    rng = np.random.default_rng(70)
    pts, a, _, _ = cone_points(rng, 800, 30, 120, offset=rng.normal(scale=0.003, size=800))
    np.savetxt(tmp_path / "cone.xyz", pts, fmt="%.9f")
    assert main(["fit", "cone", str(tmp_path / "cone.xyz"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["element"] == "cone" and out["n_points"] == 800 and out["plugin"]["id"] == "fit.cone"
    assert set(out["std_uncertainty"]) == {"apex", "axis", "angle"} and out["warnings"] == []
    assert abs(out["angle"] - 30) <= 4 * out["std_uncertainty"]["angle"]
    assert np.abs(np.subtract(out["apex"], FAR)).max() < 0.05 and np.dot(out["axis"], a) > 0.9999
    assert set(out["form"]) == {"range", "max", "min", "std", "rms"}

    pts, _, _ = torus_points(rng, 800, 40, 10, 90, 240, offset=rng.uniform(-0.005, 0.005, 800))
    np.savetxt(tmp_path / "torus.xyz", pts, fmt="%.9f")
    assert main(["fit", "torus", str(tmp_path / "torus.xyz"), "--method", "minzone", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["element"] == "torus" and out["method"] == "minzone" and out["plugin"]["id"] == "fit.torus"
    assert abs(out["major_radius"] - 40) < 0.01 and abs(out["minor_radius"] - 10) < 0.01
    assert out["form"]["range"] <= 0.01 + 1e-6  # the points' band (file rounding 1e-9 mm)
    assert out["std_uncertainty"]["major_radius"] is None  # minimum zone: no covariance

    assert main(["fit", "torus", str(tmp_path / "torus.xyz")]) == 0
    text = capsys.readouterr().out
    assert text.startswith("torus (ls") and "major_radius" in text and "minor_radius" in text
    refused(capsys, ["fit", "cone", tmp_path / "torus.xyz", "--nominal-radius", "5"], "fit.cone has no nominal radius")


def test_bad_inputs_are_refused_in_one_line(tmp_path, capsys):
    rng = np.random.default_rng(80)
    pts, _, _, _ = cone_points(rng, 50, 40, 360)
    for f, need in ((fit_cone, 6), (fit_torus, 7)):
        with pytest.raises(GeometryError, match=f"at least {need} points") as exc:
            f(pts[: need - 1])
        assert "\n" not in str(exc.value)
        line = FAR + np.outer(np.linspace(0, 10, 30), [1.0, 2.0, 3.0])
        with pytest.raises(GeometryError, match="collinear"):
            f(line)
        with pytest.raises(GeometryError, match="coplanar"):
            f(FAR + np.column_stack([rng.normal(size=(30, 2)), np.zeros(30)]))
        bad = pts.copy()
        bad[3, 1] = np.nan
        with pytest.raises(InputError, match="NaN"):
            f(bad)
    np.savetxt(tmp_path / "line.xyz", FAR + np.outer(np.linspace(0, 10, 30), [1.0, 2.0, 3.0]))
    refused(capsys, ["fit", "torus", tmp_path / "line.xyz"], "line.xyz: torus fit: the points are collinear")
    np.savetxt(tmp_path / "few.xyz", pts[:5])
    refused(capsys, ["fit", "cone", tmp_path / "few.xyz"], "cone fit needs at least 6 points")
