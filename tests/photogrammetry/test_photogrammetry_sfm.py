"""Structure from motion (photogrammetry.reconstruct, issue 16): the similarity and the camera
mapping exact by construction, the input refusals, and the CLI on a few real images."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import Cancelled, InputError
from camcmm_plugins.photogrammetry import cameras, inputs, similarity
from camcmm_plugins.photogrammetry.sfm import reconstruct_sparse
from helpers.cli import main_json, main_refused
from helpers.paths import SHARED_DATA

TEMPLE = SHARED_DATA / "middlebury_mvs_templering"


def _rot(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    t = np.radians(deg)
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


# -- similarity ---------------------------------------------------------------------------------
def test_similarity_recovers_a_known_transform_exactly():
    rng = np.random.default_rng(1)
    src = rng.normal(size=(20, 3))
    R, s, t = _rot([1, 2, 3], 73.0), 0.0123, np.array([5.0, -2.0, 0.3])
    dst = s * src @ R.T + t
    out = similarity.similarity(src, dst)
    assert out["scale"] == pytest.approx(s, rel=1e-12)
    np.testing.assert_allclose(out["R"], R, atol=1e-12)
    np.testing.assert_allclose(out["t"], t, atol=1e-12)
    assert out["rms"] < 1e-12
    # noise: the rms is the residual's, not zero
    noisy = dst + rng.normal(scale=1e-3, size=dst.shape)
    assert 5e-4 < similarity.similarity(src, noisy)["rms"] < 2e-3


def test_similarity_refuses_collinear_points_and_bad_shapes():
    line = np.outer(np.arange(5.0), [1, 2, 3])
    with pytest.raises(InputError, match="collinear"):
        similarity.similarity(line, line)
    with pytest.raises(InputError, match="N >= 3"):
        similarity.similarity(np.zeros((2, 3)), np.zeros((2, 3)))


def test_circle_radius_and_rotation_angle_exact():
    a = np.linspace(0, 2 * np.pi, 17, endpoint=False)
    ring = np.column_stack([0.7 * np.cos(a), 0.7 * np.sin(a), np.zeros_like(a)]) @ _rot([1, 1, 0], 30).T + 4.0
    assert similarity.circle_radius(ring) == pytest.approx(0.7, rel=1e-12)
    assert similarity.circle_radius(ring[:5]) == pytest.approx(0.7, rel=1e-12)  # an arc of 5 views
    assert similarity.rotation_angle_deg(_rot([0, 0, 1], 12.5), np.eye(3)) == pytest.approx(12.5, abs=1e-9)


# -- camera models -------------------------------------------------------------------------------
K = np.array([[1520.4, 0, 302.32], [0, 1525.9, 246.87], [0, 0, 1]])


@pytest.mark.parametrize("dist", [[-0.1, 0.05, 1e-3, -2e-3, 0.0], [-0.1, 0.05, 1e-3, -2e-3, 0.02]])
def test_camera_mapping_projects_as_opencv_does(dist):
    # the reference is OpenCV's own projectPoints; the mapped camera is projected by COLMAP
    import cv2
    import pycolmap

    scale = (0.5, 0.5)
    model, params = cameras.colmap_from_opencv(K, dist, scale)
    assert model == ("FULL_OPENCV" if dist[4] else "OPENCV")
    cam = pycolmap.Camera.create_from_model_name(1, model, 1.0, 320, 240)
    cam.params = params
    rng = np.random.default_rng(2)
    X = np.column_stack([rng.uniform(-0.1, 0.1, (50, 2)), rng.uniform(0.8, 1.2, 50)])
    ref, _ = cv2.projectPoints(X, np.zeros(3), np.zeros(3), K, np.asarray(dist))
    got = cam.img_from_cam(X)
    np.testing.assert_allclose(got / 0.5 - 0.5, ref[:, 0], atol=1e-6)
    back = cameras.opencv_from_colmap(model, params, scale)
    assert [back["fx"], back["fy"], back["cx"], back["cy"]] == pytest.approx([1520.4, 1525.9, 302.32, 246.87])
    assert back["dist"] == pytest.approx(dist)


def test_camera_mapping_of_one_focal_models_and_refusals():
    back = cameras.opencv_from_colmap("SIMPLE_RADIAL", [800.0, 160.5, 120.5, -0.2], (0.25, 0.25))
    assert (back["fx"], back["fy"], back["cx"], back["cy"]) == (3200.0, 3200.0, 641.5, 481.5)
    assert back["dist"] == [-0.2, 0.0, 0.0, 0.0, 0.0]
    with pytest.raises(InputError, match="skew"):
        cameras.colmap_from_opencv([[1000, 5, 300], [0, 1000, 200], [0, 0, 1]])
    with pytest.raises(InputError, match="no OpenCV equivalent"):
        cameras.opencv_from_colmap("FISHEYE", [1, 2, 3])


def test_corner_distortion_of_a_radial_lens_is_k_r_squared():
    """SIMPLE_RADIAL moves a point at normalised radius r by k r^2 of r: at the corners of a
    600 x 400 image with f = 1906 px and the principal point at the centre, r^2 = 0.0358,
    so k = -3.69 (a virtual nylon part's self-calibration) moves them 13.2 % of the
    half-diagonal, and a pinhole 0; OpenCV's projectPoints gives the same displacement."""
    import cv2
    import pycolmap

    from camcmm_plugins.photogrammetry.sfm import MAX_CORNER_DISTORTION, corner_distortion

    cam = pycolmap.Camera.create_from_model_name(1, "SIMPLE_RADIAL", 1906.0, 600, 400)
    cam.params = [1906.0, 300.0, 200.0, -3.69]
    r2 = (300.0**2 + 200.0**2) / 1906.0**2
    assert corner_distortion(cam) == pytest.approx(3.69 * r2, rel=1e-9)
    assert corner_distortion(cam) > MAX_CORNER_DISTORTION
    ray = np.array([[-300.0 / 1906.0, -200.0 / 1906.0, 1.0]])
    K = np.array([[1906.0, 0, 300.0], [0, 1906.0, 200.0], [0, 0, 1]])
    ref, _ = cv2.projectPoints(ray, np.zeros(3), np.zeros(3), K, np.array([-3.69, 0, 0, 0, 0]))
    assert 1 - np.hypot(*(ref[0, 0] - [300.0, 200.0])) / np.hypot(300.0, 200.0) == pytest.approx(3.69 * r2, rel=1e-9)
    cam.params = [1906.0, 300.0, 200.0, 0.0]
    assert corner_distortion(cam) == pytest.approx(0.0, abs=1e-12)


# -- refusals -------------------------------------------------------------------------------------
def _grey(n, w=64, h=48):
    return [np.full((h, w), 128, np.uint8) for _ in range(n)], [f"im{i}.png" for i in range(n)]


def test_too_few_images_refused_naming_them():
    ims, names = _grey(2)
    with pytest.raises(InputError, match=r"2 image\(s\) \(im0.png, im1.png\).*at least 3") as e:
        reconstruct_sparse(ims, names)
    assert "\n" not in str(e.value)


def test_images_of_different_sizes_refused_naming_the_odd_ones():
    ims, names = _grey(4)
    ims[2] = np.zeros((50, 64), np.uint8)
    with pytest.raises(InputError, match=r"most are 64x48 px.*im2.png 64x50|most are 64x48\): im2.png 64x50"):
        inputs.check_series(ims, names)
    ims[2] = np.zeros((3, 64, 7), np.uint8)
    with pytest.raises(InputError, match="not images.*im2.png"):
        inputs.check_series(ims, names)


def test_after_sfm_no_texture_and_no_overlap_are_one_line_reasons():
    rows = [{"image": f"im{i}", "n_features": f, "n_matched": 0, "registered": False} for i, f in enumerate([3, 0, 12])]
    with pytest.raises(InputError, match=r"no texture.*im0 3 features, im1 0 features, im2 12 features"):
        inputs.check_registration(rows, 0, 0)
    rows = [{"image": f"im{i}", "n_features": 900, "n_matched": 0, "registered": False} for i in range(3)]
    with pytest.raises(InputError, match=r"no overlap.*\(im0, im1, im2\)"):
        inputs.check_registration(rows, 0, 0)
    rows[2]["n_matched"], rows[0]["registered"], rows[1]["registered"] = 0, True, True
    rows[2]["reason"] = inputs.reason_unregistered(900, 0)
    (w,) = inputs.check_registration(rows, 2, 1)
    assert w == "1 of 3 images not registered: no verified matches: im2"
    assert inputs.reason_unregistered(12, 0) == "12 features"


def test_calibration_for_another_image_size_refused():
    ims, names = _grey(3)
    cal = {"camera_matrix": K, "dist_coeffs": np.zeros(5), "image_size": (640, 480)}
    with pytest.raises(InputError, match="640x480 px images, the series.*64x48"):
        reconstruct_sparse(ims, names, calibration=cal)


def test_cancel_before_the_first_stage(tmp_path):
    rng = np.random.default_rng(0)
    ims = [rng.integers(0, 255, (48, 64), dtype=np.uint8) for _ in range(3)]
    with pytest.raises(Cancelled):
        reconstruct_sparse(ims, ["a", "b", "c"], cancel=lambda: True, workdir=tmp_path)


def test_cancel_inside_a_pycolmap_stage_is_cancelled_not_a_failure():
    # pycolmap answers its cancellation token with InterruptedError from inside a stage (seen in
    # the browser: "failed: InterruptedError: Operation cancelled"); the operator asked for it
    import pycolmap

    from camcmm_plugins.photogrammetry.progress import Stages

    def stage():
        raise InterruptedError("Operation cancelled")

    st = Stages(pycolmap, None, lambda: False)
    with pytest.raises(Cancelled):
        st.run("extract", "SIFT features", stage)


@pytest.mark.slow
def test_texture_less_series_refused_as_no_texture():
    # smooth shading only: SIFT finds (almost) nothing, SfM must say so, naming the images
    y, x = np.mgrid[0:240, 0:320]
    ims = [((x + 3 * i) * 0.3 + y * 0.2).astype(np.uint8) for i in range(4)]
    with pytest.raises(InputError, match=r"no texture.*t0.png \d+ features") as e:
        reconstruct_sparse(ims, [f"t{i}.png" for i in range(4)])
    assert "\n" not in str(e.value)


# -- the CLI on real images ----------------------------------------------------------------------
KEYS = {
    "n_images",
    "n_registered",
    "unregistered",
    "reprojection_rms_px",
    "camera",
    "views",
    "n_points_sparse",
    "n_points_dense",
    "scale",
    "warnings",
    "timings",
}


@pytest.mark.slow
def test_cli_reconstruct_sparse_only_on_eight_temple_views(shared_data, tmp_path, capfd):
    files = [TEMPLE / f"templeR{i:04d}.png" for i in range(13, 21)]  # consecutive views of the ring
    out = tmp_path / "sparse.ply"
    proj = tmp_path / "proj"
    doc = main_json(
        capfd, "photogrammetry", "reconstruct", *files, "--sparse-only", "--json", "--out", out, "--project", proj
    )
    assert KEYS <= set(doc)
    assert doc["n_images"] == 8 and doc["n_registered"] == 8 and doc["unregistered"] == {}
    assert set(doc["camera"]) >= {"model", "fx", "fy", "cx", "cy", "dist"}
    # the gantry's focal length is 1520-1526 px: a short arc still finds it within 10 %
    assert doc["camera"]["fx"] == pytest.approx(1523, rel=0.1)
    assert doc["reprojection_rms_px"] < 1.0
    assert [v["image"] for v in doc["views"]] == [f.name for f in files]
    for v in doc["views"]:
        R, t, c = np.array(v["R"]), np.array(v["t"]), np.array(v["centre"])
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
        np.testing.assert_allclose(c, -R.T @ t, atol=1e-9)
    assert doc["n_points_sparse"] > 500 and doc["n_points_dense"] == 0
    assert doc["scale"] == {"method": "none", "factor": 1.0, "u": 0.0}
    assert {"extract", "match", "map"} <= set(doc["timings"])
    assert [r["image"] for r in doc["images"]] == [f.name for f in files]
    assert all(r["n_features"] > 500 and r["registered"] for r in doc["images"])
    from camcmm.api import read

    assert read(out).n_points == doc["n_points_sparse"]
    from camcmm.project import Project

    with Project.open(proj) as project:  # recorded with its provenance and its clouds
        stored = project.result(doc["result_id"])
        assert stored["plugin"] == "photogrammetry.reconstruct" and {"cloud", "sparse"} <= set(stored["files"])


@pytest.mark.slow
def test_cli_refuses_bad_series_in_one_line(shared_data, tmp_path, capfd):
    import cv2

    files = [TEMPLE / f"templeR{i:04d}.png" for i in (13, 14)]
    err = main_refused(
        capfd, "photogrammetry", "reconstruct", *files, "--sparse-only", "--project", tmp_path / "p", code=2
    )
    assert "templeR0013.png, templeR0014.png" in err and "at least 3" in err
    assert not (tmp_path / "p").exists()  # nothing half-written
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), cv2.imread(str(files[0]))[::2, ::2])
    err = main_refused(capfd, "photogrammetry", "reconstruct", *files, small, "--sparse-only", code=2)
    assert "small.png 320x240" in err
    err = main_refused(capfd, "photogrammetry", "reconstruct", tmp_path / "nothing", code=2)
    assert "nothing: no such image file or folder" in err


def test_reconstruction_json_keys_and_scale_applied_to_views():
    from camcmm_plugins.photogrammetry.plugin import reconstruction_json
    from camcmm_plugins.photogrammetry.sparse import SparseResult

    R = _rot([0, 1, 0], 20)
    t = np.array([0.1, 0.2, 3.0])
    sp = SparseResult(
        camera={"model": "OPENCV", "fx": 1.0, "fy": 1.0, "cx": 0.0, "cy": 0.0, "dist": [0.0] * 5, "K": np.eye(3)},
        views=[{"image": "a.png", "R": R, "t": t, "centre": -R.T @ t}],
        points=np.zeros((4, 3)),
        colours=np.zeros((4, 3), np.uint8),
        track_lengths=np.full(4, 2),
        images=[{"image": "a.png", "n_features": 1, "n_matched": 1, "registered": True, "reason": ""}],
        unregistered={},
        reprojection_rms_px=0.5,
        image_size=(64, 48),
        timings={"extract": 1.0},
    )
    doc = reconstruction_json(sp, None, {"method": "bar", "factor": 2.5, "u": 0.01}, ["w"])
    assert KEYS <= set(doc) and set(doc["camera"]) == {"model", "fx", "fy", "cx", "cy", "dist"}
    (v,) = doc["views"]
    np.testing.assert_allclose(v["t"], 2.5 * t)
    np.testing.assert_allclose(v["centre"], -2.5 * R.T @ t)
    np.testing.assert_allclose(v["R"], R)
    assert doc["scale"] == {"method": "bar", "factor": 2.5, "u": 0.01}
    assert (doc["n_points_sparse"], doc["n_points_dense"], doc["warnings"]) == (4, 0, ["w"])


@pytest.mark.slow
def test_cli_import_colmap_model_and_refusal(tmp_path, capfd):
    from helpers.paths import REPO

    model = REPO / "tests" / "data" / "photogrammetry" / "colmap_text"
    out = tmp_path / "imported.ply"
    doc = main_json(capfd, "photogrammetry", "import", model, "--json", "--out", out)
    assert doc["n_points"] == 3 and len(doc["views"]) == 3 and doc["written"] == {"cloud": str(out)}
    assert {"camera", "views", "source"} <= set(doc)
    assert "no such file or folder" in main_refused(capfd, "photogrammetry", "import", tmp_path / "none", code=2)
