"""Real images: OpenCV's own unit-test reference for its left-camera samples, the stereo
pair, and Bouguet's calibration example (from ../shared, skipped when absent).

Reference (tests/data/opencv_stereo_chessboard/SOURCE.txt, quoting opencv/opencv
modules/python/test/test_calibration.py at 20a13ea): 13 left images, pattern (9, 6),
square 1, findChessboardCorners + cornerSubPix (5, 5), calibrateCamera(flags=0);
|rms - 0.196334638034| < 0.01, L1(K - K_ref) < 10, L1(dist - dist_ref) < normDistEps.
That commit has normDistEps = 0.001; OpenCV's later test (with ``import cv2 as cv``)
relaxed it to 0.05. OpenCV 5.0 gives an L1 of 0.0057, driven by k2 and k3 (each well
within a tenth of its own standard deviation), and so does OpenCV 4.10 running the test's
own procedure (checked 2026-11-21 with opencv-python-headless 4.10.0.84: rms 0.196235,
K L1 0.0804, dist L1 0.005731, identical digits): the reference distortion predates both,
which is why upstream relaxed the tolerance. The test holds the current upstream
tolerance and asserts the per-coefficient agreement in standard deviations.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from camcmm_plugins.calibration.boards import detect_all
from camcmm_plugins.calibration.camera import calibrate_camera
from camcmm_plugins.calibration.projection import projection_uncertainty
from camcmm_plugins.calibration.stereo import calibrate_stereo, rectify_images

DATA = Path(__file__).parents[1] / "data" / "opencv_stereo_chessboard"
K_REF = np.array([[532.80992189, 0.0, 342.4952186], [0.0, 532.93346422, 233.8879292], [0.0, 0.0, 1.0]])
D_REF = np.array([-2.81325576e-01, 2.91130406e-02, 1.21234330e-03, -1.40825372e-04, 1.54865844e-01])
RMS_REF = 0.196334638034


@pytest.fixture(scope="module")
def opencv_left():
    files = sorted(DATA.glob("left*.jpg"))
    assert len(files) == 13
    dets = detect_all("chessboard:9x6:1", files, detector="classic", subpix_window=5)
    return dets, calibrate_camera(dets, "chessboard:9x6:1", outlier_factor=0)


def test_opencv_left_camera_reference(opencv_left):
    dets, res = opencv_left
    assert all(d.found for d in dets) and res["rejected"] == []
    assert abs(res["rms"] - RMS_REF) < 0.01
    assert np.abs(res["camera_matrix"] - K_REF).sum() < 10.0
    d_l1 = np.abs(res["dist_coeffs"] - D_REF).sum()
    assert d_l1 < 0.05  # OpenCV's current tolerance (0.001 at 20a13ea: see the module docstring)
    assert np.all(np.abs(res["dist_coeffs"] - D_REF) < 0.1 * res["std_intrinsics"][4:])
    assert np.all(np.abs(np.diag(res["camera_matrix"])[:2] - np.diag(K_REF)[:2]) < 0.2 * res["std_intrinsics"][:2])


def test_opencv_left_our_covariance_matches_opencv_std(opencv_left):
    """The Jacobian assembled here (projectPoints/composeRT derivatives) gives the same
    standard deviations as OpenCV's calibrateCameraExtended, computed independently."""
    _, res = opencv_left
    np.testing.assert_allclose(np.sqrt(np.diag(res["covariance"])), res["std_intrinsics"], rtol=1e-5)


@pytest.mark.slow
def test_opencv_left_default_pipeline_and_heat_map():
    """The default detector (SB, classic fallback, cornerSubPix) with outlier rejection
    lands within OpenCV's tolerances too; the heat map is smallest near the views."""
    dets = detect_all("chessboard:9x6:1", sorted(DATA.glob("left*.jpg")))
    res = calibrate_camera(dets, "chessboard:9x6:1")
    assert len(res["per_view_rms"]) >= 12
    assert abs(res["rms"] - RMS_REF) < 0.01
    assert np.abs(res["camera_matrix"] - K_REF).sum() < 10.0
    z = float(np.median(res["views"]["tvecs"][:, 2]))
    pu = projection_uncertainty(res, z, grid=(16, 12))
    assert pu["map"].shape == (12, 16)
    assert pu["centre"] < 0.1 < pu["max"]  # well determined where the board was, not in the corners
    assert pu["map"][6, 8] < pu["map"][0, 0]


def test_opencv_stereo_pair():
    """13 pairs, square 1 unit: the right camera sits ~3.3 squares to the side, nearly
    parallel; the joint fit agrees with the per-view relative poses."""
    left = detect_all("chessboard:9x6:1", sorted(DATA.glob("left*.jpg")), detector="classic")
    right = detect_all("chessboard:9x6:1", sorted(DATA.glob("right*.jpg")), detector="classic")
    res = calibrate_stereo(left, right, "chessboard:9x6:1")
    assert len(res["pairs"]) == 13 and res["rejected"] == []
    assert res["rms"] < 0.25
    T, b = res["T"], res["baseline"]
    assert 2.5 < b < 4.5 and abs(T[0]) / b > 0.99 and T[0] < 0  # right camera on the +x side of the left
    angle = np.degrees(np.linalg.norm(res["rvec"]))
    assert angle < 2.0
    sp = res["spread"]
    assert sp["n"] == 13
    assert np.all(np.abs(sp["T_mean"] - T) < 4 * np.hypot(sp["T_sem"], res["std_T"]))
    assert np.all(np.abs(sp["rvec_mean"] - res["rvec"]) < 4 * np.hypot(sp["rvec_sem"], res["std_rvec"]))
    assert res["epipolar"]["rms"] < 0.3 and res["rectified_dy"]["rms"] < 0.3
    assert 0 < res["baseline_std"] < 0.01 * b
    # E and F as OpenCV defines them: E = [T]x R, x_r^T F x_l = 0 on the corners
    tx = np.array([[0, -T[2], T[1]], [T[2], 0, -T[0]], [-T[1], T[0], 0]])
    np.testing.assert_allclose(res["E"], tx @ res["R"], atol=1e-9)
    # rectified images: the corners found again in them lie on common rows
    import cv2

    rl, rr = rectify_images(res, cv2.imread(str(DATA / "left03.jpg"), 0), cv2.imread(str(DATA / "right03.jpg"), 0))
    ok_l, cl = cv2.findChessboardCorners(rl, (9, 6))
    ok_r, cr = cv2.findChessboardCorners(rr, (9, 6))
    assert ok_l and ok_r
    term = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.01)
    cl = cv2.cornerSubPix(rl, cl, (5, 5), (-1, -1), term).reshape(-1, 2)
    cr = cv2.cornerSubPix(rr, cr, (5, 5), (-1, -1), term).reshape(-1, 2)
    assert np.abs(cl[:, 1] - cr[:, 1]).mean() < 0.5 and np.all(cl[:, 0] > cr[:, 0])  # disparity > 0


@pytest.mark.slow
def test_bouguet_example(shared_data):
    """Bouguet's toolbox example: 20 images, 13 x 12 inner corners, 30 mm squares. No
    reference values are given with the data; the figures must be self-consistent."""
    folder = shared_data / "bouguet_calib_example"
    files = sorted(folder.glob("Image*.tif"), key=lambda p: int(p.stem[5:]))
    assert len(files) == 20
    dets = detect_all("chessboard:13x12:30", files)
    assert all(d.found for d in dets)
    res = calibrate_camera(dets, "chessboard:13x12:30")
    print(
        f"Bouguet: rms {res['rms']:.4f} px, K {res['camera_matrix'][[0, 1, 0, 1], [0, 1, 2, 2]]}, "
        f"dist {res['dist_coeffs']}, std {res['std_intrinsics'][:4]}, rejected {res['rejected']}"
    )
    assert res["rms"] < 0.3 and len(res["per_view_rms"]) >= 19
    k = res["camera_matrix"]
    assert abs(k[0, 0] / k[1, 1] - 1) < 0.005  # square pixels
    assert abs(k[0, 2] - 320) < 40 and abs(k[1, 2] - 240) < 40
    assert np.all(res["std_intrinsics"][:4] < 0.5)
    d = np.linalg.norm(res["views"]["tvecs"], axis=1)
    assert 200 < d.min() and d.max() < 1500  # mm: a desk-top board, as the 30 mm squares say
