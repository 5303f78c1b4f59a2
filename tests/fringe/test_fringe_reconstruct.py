"""Fringe 3-D reconstruction against a synthetic scene of known geometry.

Two distorted cameras and a distorted projector look at a 20 mm-radius sphere in front of
a plane. Each camera pixel's ray is intersected with the scene (exactly), the point is
projected into the projector (OpenCV's lens model), the captures are rendered from those
projector coordinates, decoded and triangulated; the points must lie on the true surface.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import CameraModel, InputError, get_algorithm
from camcmm_plugins.fringe.decode import decode
from camcmm_plugins.fringe.reconstruct import projector_points, stereo_points
from camcmm_plugins.fringe.resample import bilinear, second_differences
from camcmm_plugins.fringe.synthetic import render_captures
from camcmm_plugins.fringe.triangulate import camera_rays, intersect_stripe, project

W, H = 800, 600
CENTRE, RADIUS, PLANE_Z = np.array([25.0, 0.0, 300.0]), 20.0, 330.0
SEQ = {
    "projector": {"width": 912, "height": 1140},
    "frames": [
        "white",
        "black",
        {"type": "phase", "direction": "vertical", "steps": 4, "period": 24},
        {"type": "gray", "direction": "vertical", "period": 12},
        {"type": "phase", "direction": "horizontal", "steps": 4, "period": 24},
        {"type": "gray", "direction": "horizontal", "period": 12},
    ],
}


def rot(axis, deg):
    r, _ = cv2.Rodrigues(np.asarray(axis, float) * np.radians(deg))
    return r


def rig():
    k = np.array([[1600.0, 0, W / 2 - 0.5], [0, 1600.0, H / 2 - 0.5], [0, 0, 1]])
    cam1 = CameraModel(k, [-0.08, 0.05, 0.001, -0.0005, 0.0], image_size=(W, H), name="cam1")
    r2, c2 = rot([0, 1, 0], 7), np.array([60.0, 0, 0])
    cam2 = CameraModel(k * [[1.01], [1.01], [1]], [0.05, -0.02, 0, 0.001, 0], r2, -r2 @ c2, (W, H), name="cam2")
    rp, cp = rot([0, 1, 0], -6) @ rot([1, 0, 0], 3), np.array([30.0, -15.0, 0])
    proj = CameraModel(
        [[1400.0, 0, 456], [0, 1400.0, 570], [0, 0, 1]],
        [0.03, -0.01, 0.0005, 0, 0],
        rp,
        -rp @ cp,
        (912, 1140),
        name="projector",
    )
    return cam1, cam2, proj


def scene(cam, proj):
    """True points (H, W, 3) and projector coordinates u, v (H, W) seen by the camera."""
    yy, xx = np.mgrid[0:H, 0:W]
    o, d = camera_rays(cam, np.c_[xx.ravel(), yy.ravel()].astype(float))
    oc = o - CENTRE
    b = d @ oc
    disc = b * b - (oc @ oc - RADIUS**2)
    t = np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), (PLANE_Z - o[2]) / d[:, 2])
    x = o + t[:, None] * d
    uv = project(proj, x)
    return x.reshape(H, W, 3), uv[:, 0].reshape(H, W), uv[:, 1].reshape(H, W)


def surface_distance(p):
    return np.minimum(np.abs(np.linalg.norm(p - CENTRE, axis=1) - RADIUS), np.abs(p[:, 2] - PLANE_Z))


def captures(cam, proj, noise, dtype):
    _, u, v = scene(cam, proj)
    lit = (u >= 0) & (u < 912) & (v >= 0) & (v < 1140)
    return render_captures(
        SEQ,
        u=np.where(lit, u, 0),
        v=np.where(lit, v, 0),
        mean=np.where(lit, 100.0, 4.0),
        modulation=np.where(lit, 60.0, 0.0),
        noise=noise,
        dtype=dtype,
        seed=7,
    )


# One xdist work unit: the tests share the exact rendered captures (module fixtures), built once
# per run instead of once per worker (under --dist loadgroup an ungrouped test is scheduled
# alone).
pytestmark = pytest.mark.xdist_group("fringe-reconstruct")


@pytest.fixture(scope="module")
def exact():
    cam1, cam2, proj = rig()
    return (
        cam1,
        cam2,
        proj,
        decode(SEQ, captures(cam1, proj, 0, np.float64)),
        decode(SEQ, captures(cam2, proj, 0, np.float64)),
    )


def test_lens_model_matches_opencv_projectpoints():
    cam1, cam2, proj = rig()
    rng = np.random.default_rng(1)
    pts = rng.uniform([-60, -50, 250], [60, 50, 400], (2000, 3))
    full = CameraModel(
        cam1.camera_matrix,
        [0.1, -0.2, 0.001, 0.002, 0.05, 0.01, 0.02, 0.03, 0.001, 0.002, 0.003, 0.004],
        proj.rotation,
        proj.translation,
    )
    for cam in (cam1, cam2, proj, full):
        rvec, _ = cv2.Rodrigues(cam.rotation)
        ref, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), rvec, cam.translation, cam.camera_matrix, cam.dist_coeffs)
        # OpenCV 5 projects in single precision: agreement to ~1e-4 px
        assert np.abs(project(cam, pts) - ref.reshape(-1, 2)).max() < 2e-3


def test_stripe_intersection_lands_on_its_stripe_and_pixel():
    """The fixed-point iteration for the projector's distortion: the point projects onto
    the given projector column (row) and onto the camera pixel it came from."""
    cam1, _, proj = rig()
    rng = np.random.default_rng(2)
    pix = rng.uniform([0, 0], [W, H], (500, 2))
    truth, _, _ = scene(cam1, proj)
    for axis in (0, 1):
        x_true = np.array([truth[int(p[1]), int(p[0])] for p in pix])
        coord = project(proj, x_true)[:, axis]
        o, d = camera_rays(cam1, pix)
        pts = intersect_stripe(cam1, proj, pix, coord, axis)
        assert np.abs(project(proj, pts)[:, axis] - coord).max() < 1e-4
        assert np.abs(project(cam1, pts) - pix).max() < 1e-6


@pytest.mark.parametrize("mode", ["auto", "vertical", "horizontal", "rays"])
@pytest.mark.slow
def test_camera_projector_points_are_on_the_true_surface(exact, mode):
    cam1, _, proj, dec1, _ = exact
    pts, idx = projector_points(dec1, cam1, proj, mode)
    assert len(pts) > 0.9 * dec1.mask.sum()
    assert surface_distance(pts).max() < 1e-3  # mm, noise-free captures
    truth, _, _ = scene(cam1, proj)
    assert np.abs(pts - truth.reshape(-1, 3)[idx]).max() < 2e-3


@pytest.mark.slow
def test_camera_camera_phase_matching_is_on_the_true_surface(exact):
    cam1, cam2, _, dec1, dec2 = exact
    pts, fields, direction = stereo_points(dec1, dec2, cam1, cam2)
    assert direction == "vertical"  # the cameras are side by side
    e = surface_distance(pts)
    assert len(pts) > 50000
    assert np.median(e) < 2e-4 and np.percentile(e, 99) < 5e-3
    assert np.mean(e > 0.05) < 3e-3  # grazing and depth-edge samples, (almost) all rejected
    assert np.allclose(fields["quality"], 0.6, atol=1e-3)  # I''/I' = 60/100


def test_curvature_corrected_resampling_is_exact_for_a_quadratic_field():
    """Analytic reference: a quadratic field sampled at random positions. Plain bilinear
    interpolation exceeds it by exactly f_xx fx (1 - fx) / 2 + f_yy fy (1 - fy) / 2 (the
    chord above a convex field: the bias the rectification put into a curved phase map); with the second differences
    the samples are the field itself. A step in the field (a depth edge) leaves NaN
    around it instead of a corrected value."""
    yy, xx = np.mgrid[0:60, 0:80].astype(np.float64)
    a, b, c, dxx, dxy, dyy = 300.0, 0.9, 0.2, 0.04, -0.03, 0.02

    def field(x, y):
        return a + b * x + c * y + 0.5 * dxx * x * x + dxy * x * y + 0.5 * dyy * y * y

    img = field(xx, yy).astype(np.float32)
    rng = np.random.default_rng(3)
    mx, my = rng.uniform(1, 78, 5000), rng.uniform(1, 58, 5000)
    fx, fy = mx - np.floor(mx), my - np.floor(my)
    truth = field(mx, my)
    plain = bilinear(img, mx, my)
    expected_bias = 0.5 * (dxx * fx * (1 - fx) + dyy * fy * (1 - fy))
    assert np.abs(plain - truth - expected_bias).max() < 1e-4  # float32 at ~300
    assert np.abs(expected_bias).max() > 5e-3
    curv = second_differences(img, jump=1.0)
    assert np.allclose(curv[1:-1, 1:-1].real, dxx, atol=1e-4) and np.allclose(curv[1:-1, 1:-1].imag, dyy, atol=1e-4)
    corrected = bilinear(img, mx, my, curvature=curv)
    assert np.abs(corrected - truth).max() < 1e-4
    # a step of 20 between columns 39 and 40: the columns next to it have no curvature
    stepped = img.copy()
    stepped[:, 40:] += 20
    curv = second_differences(stepped, jump=1.0)
    assert np.isnan(curv[5, 39]) and np.isnan(curv[5, 40]) and np.isfinite(curv[5, 38]) and np.isfinite(curv[5, 41])
    assert np.isnan(curv[0]).all() and np.isnan(curv[:, -1]).all()
    assert np.isnan(bilinear(stepped, np.array([39.6]), np.array([5.2]), curvature=curv))[0]


def test_camera_camera_sphere_radius_is_unbiased(exact):
    """The exact-by-construction sphere (100 px in radius in the images), noise-free:
    the radial residuals of the stereo points are centred on the true sphere at every
    viewing angle up to 60 deg, and a sphere fitted to them has the true radius. Plain
    bilinear rectification put -0.3 um (face on) to -1.0 um (60 deg) into the residuals
    and -2.9 um into the fitted radius; with the curvature correction it is -0.01 um."""
    cam1, cam2, _, dec1, dec2 = exact
    pts, _, _ = stereo_points(dec1, dec2, cam1, cam2)
    p = pts[np.linalg.norm(pts - CENTRE, axis=1) < RADIUS + 3]
    normal = (p - CENTRE) / np.linalg.norm(p - CENTRE, axis=1, keepdims=True)
    view = -cam1.rotation.T @ cam1.translation - p
    angle = np.degrees(np.arccos(np.sum(normal * view, axis=1) / np.linalg.norm(view, axis=1)))
    resid = np.linalg.norm(p - CENTRE, axis=1) - RADIUS
    for lo in range(0, 60, 10):
        band = (angle >= lo) & (angle < lo + 10)
        assert band.sum() > 1000
        assert abs(np.mean(resid[band])) < 2e-5  # mm
    fit = get_algorithm("fit.sphere")(cloud=p, outliers="vdi2634")
    assert abs(fit["radius"] - RADIUS) < 2e-4
    assert np.linalg.norm(np.asarray(fit["center"]) - CENTRE) < 2e-4


@pytest.mark.slow
def test_noisy_sphere_radius_through_the_plugin():
    """8-bit captures with noise, the plugin end to end, then fit.sphere on the points
    within the sphere's image: radius and centre come back to a few micrometres."""
    cam1, cam2, proj = rig()
    cal = {"cameras": [cam1, cam2, proj]}
    fr1, fr2 = captures(cam1, proj, 0.8, np.uint8), captures(cam2, proj, 0.8, np.uint8)
    rec = get_algorithm("fringe.reconstruct")
    for kw in ({}, {"images2": fr2}):
        res = rec(sequence=SEQ, images=fr1, calibration=cal, **kw)
        cloud = res["cloud"]
        assert res["n_points"] == cloud.n_points and set(cloud.fields) == {"modulation", "quality", "x_px", "y_px"}
        near = np.linalg.norm(cloud.points - CENTRE, axis=1) < RADIUS + 3
        fit = get_algorithm("fit.sphere")(cloud=cloud.subset(near), outliers="vdi2634")
        assert fit["radius"] == pytest.approx(RADIUS, abs=0.01)
        assert np.linalg.norm(np.asarray(fit["center"]) - CENTRE) < 0.02
        assert np.asarray(res["bbox"]).shape == (2, 3)
        assert res["method"].startswith("stereo" if kw else "camera-projector")


@pytest.mark.slow
def test_calibration_that_does_not_fit_the_images_is_refused():
    cam1, cam2, proj = rig()
    frames = captures(cam1, proj, 0, np.uint8)
    small = [f[:-8] for f in frames]
    rec = get_algorithm("fringe.reconstruct")
    with pytest.raises(InputError, match="calibrated for 800x600 px but the images are 800x592 px"):
        rec(sequence=SEQ, images=small, calibration={"cameras": [cam1, proj]})
    wrong_proj = CameraModel(
        proj.camera_matrix, proj.dist_coeffs, proj.rotation, proj.translation, (1024, 768), name="projector"
    )
    with pytest.raises(InputError, match="projector is calibrated for 1024x768 px but the sequence declares 912x1140"):
        rec(sequence=SEQ, images=frames, calibration={"cameras": [cam1, wrong_proj]})
    with pytest.raises(InputError, match="needs a camera named 'projector'"):
        rec(sequence=SEQ, images=frames, calibration={"cameras": [cam1, cam2]})
    with pytest.raises(InputError, match="needs two cameras"):
        rec(sequence=SEQ, images=frames, images2=frames, calibration={"cameras": [cam1, proj]})


def test_kimthyung_calibration_board_is_planar(shared_data):
    """The kimthyung calibration (independent data): its 12 poses x 147 circle centres,
    triangulated camera-projector with the given calibration, lie on planes with the
    asymmetric grid's neighbour spacing of 10 mm * sqrt(2)."""
    from camcmm_plugins.fringe.calib import read_text_folder
    from camcmm_plugins.fringe.triangulate import triangulate_rays

    d = shared_data / "fringe_sphere_kimthyung" / "CalibrationDataDistortion"
    cam, proj = read_text_folder(d)["cameras"]
    cpts, ppts = np.loadtxt(d / "cameraCirclePointsRight.txt"), np.loadtxt(d / "projectorCirclePoints.txt")
    pts = triangulate_rays(cam, proj, cpts, ppts)
    for k in range(12):
        p = pts[147 * k : 147 * (k + 1)]
        s = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
        assert s[2] / np.sqrt(147) < 0.6  # mm off the plane (rms), at ~300 mm
        dist = np.linalg.norm(p[:, None] - p[None], axis=2) + np.eye(147) * 1e9
        assert np.median(dist.min(axis=1)) == pytest.approx(10 * np.sqrt(2), rel=0.01)
    # the stripe intersection (horizontal stripes, projector rows) agrees with the rays
    strip = intersect_stripe(cam, proj, cpts, ppts[:, 1], 1)
    assert np.median(np.linalg.norm(strip - pts, axis=1)) < 0.5
