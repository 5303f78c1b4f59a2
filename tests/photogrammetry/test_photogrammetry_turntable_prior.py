"""The turntable prior of photogrammetry.reconstruct (issue 16): the angle forms and their
refusals, the pairs the window keeps, the check of the cameras against the table angles
(exact by construction, then on a virtual-lab series whose true cameras are known)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from camcmm.api import InputError
from camcmm_plugins.photogrammetry.turntable import angle_pairs, check_turntable, parse_angles, write_pair_list


# -- the angle forms ----------------------------------------------------------------------------
def test_angle_forms_read_alike():
    want = [0.0, 12.0, 24.0, 36.5]
    for form in (want, tuple(want), np.array(want), "0,12,24,36.5", "[0, 12, 24, 36.5]", "0 12 24 36.5"):
        np.testing.assert_array_equal(parse_angles(form, 4), want)
    np.testing.assert_array_equal(parse_angles("step:12", 4), [0.0, 12.0, 24.0, 36.0])
    np.testing.assert_array_equal(parse_angles(" step: -7.5 ", 3), [0.0, -7.5, -15.0])
    for none in (None, "", "  ", "none"):
        assert parse_angles(none, 4) is None


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("0,12,24", "'0,12,24': 3 angles for 4 images"),
        ([0, 12, 24, 36, 48], "5 angles for 4 images"),
        ("0,12,x,36", "'x' is not a finite angle"),
        ([0, 12, "nan", 36], "'nan' is not a finite angle"),
        ("step:abc", "step 'abc' is not a number"),
        ("step:0", "finite non-zero"),
        ([0, True, 2, 3], "True is not a finite angle"),
    ],
)
def test_bad_angles_refused_in_one_line_naming_the_value(value, words):
    with pytest.raises(InputError, match="turntable_angles") as exc:
        parse_angles(value, 4)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_window_keeps_the_pairs_within_it_across_the_ring_closure(tmp_path):
    ring = parse_angles("step:45", 8)  # a full ring: 315 deg and 0 deg are neighbours
    pairs = angle_pairs(ring, 60.0)
    assert pairs == sorted({(i, (i + 1) % 8) if i < 7 else (0, 7) for i in range(8)})
    assert len(angle_pairs(ring, 90.0)) == 16
    assert len(angle_pairs(ring, 0.0)) == len(angle_pairs(ring, 180.0)) == 28  # every pair
    files = [f"{i:05d}_v.png" for i in range(8)]
    text = write_pair_list(tmp_path / "pairs.txt", files, pairs).read_text()
    assert text.splitlines()[0] == "00000_v.png 00001_v.png" and len(text.splitlines()) == 8
    with pytest.raises(InputError, match="'00001_a b.png'"):
        write_pair_list(tmp_path / "p.txt", ["00000_a.png", "00001_a b.png"], [(0, 1)])


# -- the check, exact by construction ----------------------------------------------------------
def _turntable_views(theta_deg, axis, point, noise_deg=0.0, noise_centre=0.0, seed=0):
    """Cameras of a turntable: R_i = R_c A(θ_i) about ``axis`` through ``point``, the fixed camera
    at centre c0 (an arbitrary frame and scale), with optional noise on rotations and centres."""
    rng = np.random.default_rng(seed)
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    rc = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    c0 = np.asarray(point) + 2.5 * np.cross(a, [0.3, 0.5, 0.8]) / np.linalg.norm(np.cross(a, [0.3, 0.5, 0.8]))
    views = []
    for k, th in enumerate(theta_deg):
        A = Rotation.from_rotvec(np.radians(th) * a).as_matrix()
        R = rc @ A
        # object turned by θ under the fixed camera = the camera turned by -θ about the axis
        c = A.T @ (c0 - point) + point
        R = Rotation.from_rotvec(rng.normal(scale=np.radians(noise_deg), size=3)).as_matrix() @ R
        views.append({"image": f"v{k}", "R": R, "centre": c + rng.normal(scale=noise_centre, size=3)})
    return views


def test_check_recovers_axis_circle_and_angles_exactly():
    theta = np.linspace(0, 180, 13)
    axis, point = np.array([0.2, -0.5, 0.8]), np.array([1.0, 2.0, -0.5])
    views = _turntable_views(theta, axis, point)
    rep, warnings = check_turntable(views, {v["image"]: t for v, t in zip(views, theta)})
    assert warnings == [] and rep["n_views"] == 13
    np.testing.assert_allclose(rep["axis"], axis / np.linalg.norm(axis), atol=1e-9)  # +θ about it
    assert rep["radius"] == pytest.approx(2.5, rel=1e-9)
    a = axis / np.linalg.norm(axis)
    off = np.asarray(rep["axis_point"]) - point
    assert np.linalg.norm(off - (off @ a) * a) < 1e-9  # on the axis line
    assert rep["angle_max_deg"] < 1e-6 and rep["centre_angle_max_deg"] < 1e-6 and rep["axis_tilt_deg"] < 1e-6
    # a prior of the opposite sense (the table's angles counted the other way) and a common offset
    rep2, _ = check_turntable(views, {v["image"]: 40.0 - t for v, t in zip(views, theta)})
    np.testing.assert_allclose(rep2["axis"], -a, atol=1e-9)
    assert rep2["angle_max_deg"] < 1e-6 and rep2["centre_angle_max_deg"] < 1e-6


def test_check_within_the_noise_and_names_a_view_20_degrees_off():
    theta = np.arange(16) * 11.25
    sigma_deg, sigma_c = 0.1, 0.01  # centres on a circle of radius 2.5: 0.23 deg per sigma
    views = _turntable_views(theta, [0, 0, 1], [0, 0, 0], sigma_deg, sigma_c, seed=3)
    prior = {v["image"]: t for v, t in zip(views, theta)}
    rep, warnings = check_turntable(views, prior)
    # twist of an isotropic rotation noise: sigma about the axis; centres: sigma_c / r rad in angle
    assert rep["angle_rms_deg"] < 3 * sigma_deg and rep["centre_angle_rms_deg"] < 3 * np.degrees(sigma_c / 2.5)
    assert rep["angle_rms_deg"] > 0.2 * sigma_deg  # the noise is seen, not smoothed away
    assert warnings == []
    prior["v5"] += 20.0
    rep, warnings = check_turntable(views, prior)
    assert len(warnings) == 1 and "v5 (-" in warnings[0] and "1 view(s)" in warnings[0]
    row = next(r for r in rep["views"] if r["image"] == "v5")
    assert row["deviation_deg"] == pytest.approx(-20.0, abs=1.0)
    others = [r for r in rep["views"] if r["image"] != "v5"]
    assert max(abs(r["deviation_deg"]) for r in others) < 1.0  # the median offset: one view does not drag the rest
    rep, warnings = check_turntable(views[:2], prior)
    assert rep == {} and "needs 3" in warnings[0]


# -- a virtual-lab series with known truth -------------------------------------------------------
def _series(tmp_path, n=16, arc=180.0):
    from camcmm.api import default_host

    host = default_host()
    common = {"artefact": "sphere", "n_images": n, "arc_deg": arc, "downscale": 12, "supersample": 1, "diffuser": 0.1}
    res = host.run("virtuallab.turntable-series", {}, {**common, "out": str(tmp_path / "s")})
    truth = json.loads((tmp_path / "s" / "truth.json").read_text())
    return host, res.outputs["files"], str(tmp_path / "s" / "calibration.yaml"), truth


@pytest.mark.slow
def test_virtual_lab_series_angles_recovered_and_window_matches_fewer_pairs(tmp_path):
    """16 views through 180 deg (11.25 deg apart), 500 x 333 px, the DSLR calibration fixed.
    Run 1 matches every pair (window 0) with one view's prior 20 deg wrong; run 2 the 60 deg
    window with the true angles."""
    from camcmm_plugins.photogrammetry.similarity import similarity

    host, files, cal, truth = _series(tmp_path)
    angles = [v["angle_deg"] for v in truth["views"]]
    inputs = {"images": files, "calibration": cal}
    wrong = list(angles)
    wrong[7] += 20.0
    res = host.run(
        "photogrammetry.reconstruct",
        inputs,
        {"dense": False, "turntable_window": 0, "turntable_angles": ",".join(map(str, wrong))},
    )
    every = res.outputs["reconstruction"]
    named = [w for w in res.warnings if "turntable prior" in w]
    assert len(named) == 1 and "1 view(s)" in named[0] and "image007.png (-" in named[0], res.warnings
    assert every["turntable"]["views"][7]["deviation_deg"] == pytest.approx(-20.0, abs=1.5)
    res = host.run(
        "photogrammetry.reconstruct", inputs, {"dense": False, "turntable_angles": "step:11.25", "turntable_window": 60}
    )
    rec = res.outputs["reconstruction"]
    assert not any("turntable prior" in w for w in res.warnings), res.warnings
    # the window (60 deg: 5 neighbours either side) lists 65 of the 120 pairs and loses no view
    assert every["options"]["pairs_listed"] == 120 and rec["options"]["pairs_listed"] == 65
    assert every["options"]["pairs_verified"] > rec["options"]["pairs_verified"]
    assert [v["image"] for v in rec["views"]] == [v["image"] for v in every["views"]]
    assert rec["n_registered"] >= 14, rec["unregistered"]
    # the tolerance from the cameras' own error: centre error vs truth over the ring radius
    true_c = {v["image"]: np.asarray(v["centre"]) for v in truth["views"]}
    src = np.array([v["centre"] for v in rec["views"]])
    dst = np.array([true_c[v["image"]] for v in rec["views"]])
    sim = similarity(src, dst)
    radius = float(np.mean(np.linalg.norm(dst[:, :2], axis=1)))
    noise_deg = float(np.degrees(sim["rms"] / radius))
    tt = rec["turntable"]
    print(
        f"angle RMS {tt['angle_rms_deg']:.3f} deg (centres {tt['centre_angle_rms_deg']:.3f}), "
        f"centre noise {noise_deg:.3f} deg; pairs verified {rec['options']['pairs_verified']} of "
        f"{rec['options']['pairs_listed']} vs {every['options']['pairs_verified']} of 120; "
        f"match {rec['timings']['match']:.2f} s vs {every['timings']['match']:.2f} s"
    )
    assert tt["n_views"] == rec["n_registered"]
    assert tt["centre_angle_rms_deg"] <= 3 * noise_deg and tt["angle_rms_deg"] <= 3 * noise_deg
    # the table's +z axis, as the reconstruction's axis mapped into the true frame (+θ about it:
    # the virtual lab turns the table by +θ, its camera at azimuth -θ)
    assert float(sim["R"] @ np.asarray(tt["axis"]) @ [0, 0, 1]) > np.cos(np.radians(2.0))


@pytest.mark.slow
def test_cli_refuses_bad_angles_in_one_line_before_any_work(tmp_path, capfd):
    import cv2

    from helpers.cli import main_refused  # in-process (the CLI's main): only the output counts

    files = []
    for k in range(3):
        f = tmp_path / f"v{k}.png"
        cv2.imwrite(str(f), np.full((48, 64), 40 * k, np.uint8))
        files.append(f)
    err = main_refused(
        capfd, "photogrammetry", "reconstruct", *files, "--sparse-only", "--turntable-angles", "0,15", code=2
    )
    assert "turntable_angles '0,15': 2 angles for 3 images" in err
    bad = ("--turntable-angles", "0,15,abc", "--project", tmp_path / "p")
    err = main_refused(capfd, "photogrammetry", "reconstruct", *files, *bad)
    assert "'abc' is not a finite angle" in err
    assert not (tmp_path / "p").exists()  # nothing half-written
