"""Boards and single-camera calibration on data with known truth: board images rendered
through a known camera (synthetic.render_view) and exact projections plus noise."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import InputError, ParameterError
from camcmm_plugins.calibration.boards import Detection, detect, detect_all, parse_board
from camcmm_plugins.calibration.camera import calibrate_camera
from camcmm_plugins.calibration.covariance import Observation, assemble, free_intrinsics
from camcmm_plugins.calibration.synthetic import look_at_poses, project, render_view

K = np.array([[800.0, 0, 330.0], [0, 805.0, 235.0], [0, 0, 1]])
D = np.array([-0.2, 0.08, 0.001, -0.0005, 0.0])
SIZE = (640, 480)


def test_board_specs():
    b = parse_board("chessboard:9x6:25")
    assert (b.kind, b.cols, b.rows, b.square) == ("chessboard", 9, 6, 25.0)
    assert b.object_points.shape == (54, 3) and b.object_points[1, 0] == 25 and b.object_points[9, 1] == 25
    a = parse_board("acircles:4x11:10")
    np.testing.assert_array_equal(a.object_points[[0, 1, 4, 5], :2], [[0, 0], [20, 0], [10, 10], [30, 10]])
    c = parse_board("charuco:8x6:20:15")
    assert c.pattern_size == (7, 5) and c.dictionary == "DICT_5X5_100"
    np.testing.assert_array_equal(c.object_points, np.asarray(c.charuco().getChessboardCorners(), np.float32))
    assert parse_board("circles:7x6:20").spec == "circles:7x6:20"
    for bad, why in [
        ("chess:9x6:25", "unknown kind"),
        ("chessboard:9by6:25", "COLSxROWS"),
        ("chessboard:9x6", "expected"),
        ("chessboard:9x6:-1", "positive"),
        ("chessboard:1x6:25", "at least"),
        ("charuco:8x6:20:25", "smaller"),
        ("charuco:8x6:20:15:DICT_NOPE", "dictionary"),
    ]:
        with pytest.raises(InputError, match=why):
            parse_board(bad)


@pytest.mark.parametrize(
    "spec,distance",
    [("chessboard:9x6:20", 450), ("circles:7x6:20", 450), ("acircles:4x11:10", 350), ("charuco:8x6:20:15", 450)],
)
@pytest.mark.slow
def test_detection_matches_exact_projection(spec, distance):
    """Detected points lie within 0.15 px of the exact projections of the board points,
    in the board's own order (ids), on images rendered through a distorted camera."""
    b = parse_board(spec)
    for i, (r, t) in enumerate(look_at_poses(3, distance, b, seed=1)):
        img = render_view(b, K, D, r, t, SIZE, noise=1.0, blur=0.5, seed=i)
        det = detect(b, f"v{i}", img)
        assert det.found, det.reason
        err = np.linalg.norm(det.image_points - project(b, K, D, r, t)[det.ids], axis=1)
        assert np.median(err) < 0.08 and err.max() < 0.15


def test_subpix_window_is_refused_before_opencv_asserts():
    """cornerSubPix asserts on a window < 1 or wider than the image - 5 px (an 'internal
    error' from OpenCV); detect refuses both in one line naming the window and the image."""
    b = parse_board("chessboard:5x4:10")
    r, t = look_at_poses(1, 140, b, tilt_deg=10, seed=1)[0]
    img = render_view(b, np.array([[120.0, 0, 50], [0, 120, 40], [0, 0, 1]]), np.zeros(5), r, t, (100, 80))
    assert detect(b, "tiny.png", img, detector="classic", subpix_window=37).found  # 2 * 37 + 5 <= 80
    with pytest.raises(ParameterError, match=r"tiny.png: subpix window 38 px .* 100x80 px image \(at most 37"):
        detect(b, "tiny.png", img, detector="classic", subpix_window=38)
    for w in (0, -1, 2.5, True):
        with pytest.raises(ParameterError, match="subpix window"):
            detect(b, "tiny.png", img, subpix_window=w)


def test_chessboard_order_is_canonical_when_the_board_is_turned():
    """Turned by 180 degrees in the image, the corners still come in the board's order."""
    b = parse_board("chessboard:9x6:20")
    r, t = look_at_poses(1, 450, b, seed=2)[0]
    turn = cv2.Rodrigues(np.array([0, 0, np.pi]))[0]
    r2 = cv2.Rodrigues(turn @ cv2.Rodrigues(r)[0])[0].ravel()
    c = b.object_points.mean(0)
    t2 = turn @ (cv2.Rodrigues(r)[0] @ c + t) - cv2.Rodrigues(r2)[0] @ c
    for rv, tv in ((r, t), (r2, t2)):
        det = detect(b, "v", render_view(b, K, D, rv, tv, SIZE))
        assert np.linalg.norm(det.image_points - project(b, K, D, rv, tv), axis=1).max() < 0.15


# One xdist work unit: the tests share the rendered board views (module fixtures), built once per
# run instead of once per worker (under --dist loadgroup an ungrouped test is scheduled alone).
pytestmark = pytest.mark.xdist_group("calibration-camera")


@pytest.fixture(scope="module")
def rendered():
    b = parse_board("chessboard:9x6:20")
    poses = look_at_poses(10, 420, b, seed=5, tilt_deg=40)
    imgs = [
        (f"view{i:02d}.png", render_view(b, K, D, r, t, SIZE, noise=1.5, blur=0.6, seed=i))
        for i, (r, t) in enumerate(poses)
    ]
    return b, imgs


@pytest.mark.slow
def test_calibration_recovers_the_rendering_camera(rendered):
    b, imgs = rendered
    blank = ("blank.png", np.full(SIZE[::-1], 200, np.uint8))
    res = calibrate_camera(detect_all(b, imgs + [blank]), b)
    assert res["rejected"] == [{"image": "blank.png", "reason": "chessboard 9x6 not found"}]
    assert len(res["per_view_rms"]) == 10 and res["rms"] < 0.1
    truth = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], D]
    est = np.r_[res["camera_matrix"][[0, 1, 0, 1], [0, 1, 2, 2]], res["dist_coeffs"]]
    z = (est - truth) / res["std_intrinsics"]
    assert np.all(np.abs(z) < 4), z
    assert abs(est[0] - 800) < 2 and abs(est[2] - 330) < 2


def test_outlier_view_is_left_out(rendered):
    b, imgs = rendered
    dets = detect_all(b, imgs)
    rng = np.random.default_rng(0)
    dets[3].image_points = dets[3].image_points + rng.normal(0, 1.5, dets[3].image_points.shape).astype(np.float32)
    res = calibrate_camera(dets, b)
    assert [r["image"] for r in res["rejected"]] == ["view03.png"]
    assert res["rejected"][0]["reason"].startswith("outlier: view RMS")
    assert res["rms"] < 0.1 and "view03.png" not in res["per_view_rms"]
    kept = calibrate_camera(dets, b, outlier_factor=0)
    assert kept["rms"] > 0.3 and kept["rejected"] == []


@pytest.mark.slow
def test_bad_inputs(rendered):
    b, imgs = rendered
    small = ("small.png", cv2.resize(imgs[0][1], (320, 240)))
    with pytest.raises(InputError, match=r"mixed sizes: small.png \(320x240\)"):
        detect_all(b, imgs[:4] + [small])
    wrong = parse_board("chessboard:12x11:20")
    with pytest.raises(InputError, match=r"not found in any of the 3 images \(view00.png, view01.png, view02.png\)"):
        calibrate_camera(detect_all(wrong, imgs[:3]), wrong)
    with pytest.raises(InputError, match="only 2 image"):
        calibrate_camera(detect_all(b, imgs[:2]), b)
    with pytest.raises(InputError, match="nope.png"):
        detect_all(b, ["nope.png"])


def _synthetic_views(board, K_, D_, n, sigma, seed):
    rng = np.random.default_rng(seed)
    poses = look_at_poses(n, 420, board, seed=seed, tilt_deg=40)
    dets = []
    for i, (r, t) in enumerate(poses):
        q = project(board, K_, D_, r, t) + rng.normal(0, sigma, (len(board.object_points), 2))
        dets.append(
            Detection(f"v{i}", SIZE, q.astype(np.float32), board.object_points, np.arange(len(q), dtype=np.int32))
        )
    return dets, poses


def test_thin_prism_model():
    """Data made with thin-prism terms: the thin-prism model recovers them, the standard
    model cannot (its RMS stays above the noise)."""
    b = parse_board("chessboard:11x8:20")
    Dp = np.r_[-0.2, 0.08, 0.001, -0.0005, 0.0, 0, 0, 0, 0.02, -0.005, -0.015, 0.005]
    dets, _ = _synthetic_views(b, K, Dp, 14, 0.05, 7)
    thin = calibrate_camera(dets, b, model="thin-prism")
    std = calibrate_camera(dets, b)
    assert thin["dist_coeffs"].size == 12 and thin["std_intrinsics"].size == 16
    assert thin["rms"] < 0.08 and std["rms"] > 1.4 * thin["rms"]  # noise 0.05 px per coordinate: RMS 0.07
    s = thin["dist_coeffs"][8:12]
    assert np.all(np.abs(s - Dp[8:12]) < 4 * thin["std_intrinsics"][12:16])
    assert np.all(thin["std_intrinsics"][9:12] == 0)  # k4-k6 not estimated


def test_jacobian_against_finite_differences():
    """J^T J assembled from OpenCV's analytic derivatives (and composeRT's chain rule for a
    second camera) equals that of a central-difference Jacobian of the residuals."""
    b = parse_board("chessboard:5x4:20")
    poses = [(np.ravel(r), np.ravel(t)) for r, t in look_at_poses(2, 400, b, seed=3)]
    K2 = K + [[5, 0, -10], [0, 4, 6], [0, 0, 0]]
    D2 = np.array([-0.1, 0.02, 0.0, 0.001, 0.01])
    rel = (np.array([0.02, -0.3, 0.01]), np.array([-150.0, 2.0, 20.0]))
    obs = [Observation(v, k, b.object_points, np.zeros((20, 2))) for v in range(2) for k in range(2)]
    masks = [np.ones(9, bool), np.ones(9, bool)]
    jtj, _, _, _, lay = assemble([(K, D), (K2, D2)], [rel], poses, obs, masks)

    def residuals(theta):
        def intr(p):
            return np.array([[p[0], 0, p[2]], [0, p[1], p[3]], [0, 0, 1]]), p[4:9]

        k1, d1 = intr(theta[0:9])
        k2, d2 = intr(theta[9:18])
        rr, tr = theta[18:21], theta[21:24]
        out = []
        for v in range(2):
            rv, tv = theta[24 + 6 * v : 27 + 6 * v], theta[27 + 6 * v : 30 + 6 * v]
            out.append(project(b, k1, d1, rv, tv).ravel())
            r3, t3 = cv2.composeRT(rv, tv, rr, tr)[:2]
            out.append(project(b, k2, d2, r3, t3).ravel())
        return np.concatenate(out)

    theta = np.r_[
        K[0, 0],
        K[1, 1],
        K[0, 2],
        K[1, 2],
        D,
        K2[0, 0],
        K2[1, 1],
        K2[0, 2],
        K2[1, 2],
        D2,
        *rel,
        *[x for p in poses for x in p],
    ]
    J = np.zeros((residuals(theta).size, theta.size))
    for j in range(theta.size):
        h = 1e-6 * max(1.0, abs(theta[j]))
        e = np.zeros_like(theta)
        e[j] = h
        J[:, j] = (residuals(theta + e) - residuals(theta - e)) / (2 * h)
    assert lay["n"] == theta.size
    np.testing.assert_allclose(jtj, J.T @ J, rtol=2e-5, atol=1e-6 * np.abs(J.T @ J).max())


def test_fixed_parameters_have_no_variance():
    b = parse_board("chessboard:9x6:20")
    dets, _ = _synthetic_views(b, K, D, 8, 0.1, 11)
    res = calibrate_camera(dets, b, flags=cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST)
    sd = np.sqrt(np.diag(res["covariance"]))
    assert np.all(sd[[6, 7, 8]] == 0) and np.all(sd[:6] > 0)
    np.testing.assert_allclose(sd, res["std_intrinsics"], rtol=1e-5)
    assert free_intrinsics(cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST, 5).tolist() == [True] * 6 + [False] * 3
