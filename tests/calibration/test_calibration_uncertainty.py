"""Uncertainties checked by Monte Carlo on exact-by-construction synthetic calibrations:
the projection-uncertainty map (mrcal's method) and the stereo R, T standard deviations."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.calibration.boards import Detection, parse_board
from camcmm_plugins.calibration.camera import calibrate_camera, calibration_dict
from camcmm_plugins.calibration.covariance import Observation, assemble, covariance, free_intrinsics
from camcmm_plugins.calibration.projection import projection_at, projection_gradient, projection_uncertainty
from camcmm_plugins.calibration.stereo import calibrate_stereo
from camcmm_plugins.calibration.synthetic import look_at_poses, project

K1 = np.array([[800.0, 0, 330], [0, 805, 235], [0, 0, 1]])
D1 = np.array([-0.2, 0.08, 0.001, -0.0005, 0.01])
SIZE = (640, 480)


def _ratio_ok(emp, pred, lo=0.75, hi=1.33):
    r = np.asarray(emp) / np.asarray(pred)
    assert np.all((r > lo) & (r < hi)), r


@pytest.mark.slow
def test_projection_uncertainty_monte_carlo():
    """Re-calibrate 200 noisy copies of one synthetic data set; map each calibration's
    board frames and intrinsics back to pixels as mrcal does; the spread of those pixels
    matches the first-order prediction at the centre and the corners."""
    b = parse_board("chessboard:10x7:25")
    poses = look_at_poses(12, 380, b, seed=3, tilt_deg=40)
    sigma, z = 0.3, 500.0
    obj = b.object_points
    Q = [project(b, K1, D1, r, t) for r, t in poses]
    obs = [Observation(v, 0, obj, Q[v]) for v in range(len(poses))]
    jtj, _, sse, rows, _ = assemble([(K1, D1)], [], poses, obs, [free_intrinsics(0, 5)])
    cov, _ = covariance(jtj, sse, rows, sigma=sigma)
    rv = np.array([np.ravel(p[0]) for p in poses])
    tv = np.array([np.ravel(p[1]) for p in poses])
    pix = np.array([[320, 240], [20, 20], [620, 460], [100, 400], [630, 10]], float)
    G, p = projection_gradient(K1, D1, rv, tv, pix, z)
    pred = np.sqrt(np.linalg.eigvalsh(np.einsum("mip,pq,mjq->mij", G, cov, G))[:, 1])
    p_board = [(p - tv[v]) @ cv2.Rodrigues(rv[v])[0] for v in range(len(poses))]
    rng = np.random.default_rng(0)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-15)
    qs = []
    for _ in range(200):
        img = [(q + rng.normal(0, sigma, q.shape)).astype(np.float32) for q in Q]
        _, K, D, r2, t2 = cv2.calibrateCamera([obj] * len(Q), img, SIZE, None, None, criteria=crit)
        pc = np.mean([p_board[v] @ cv2.Rodrigues(r2[v])[0].T + t2[v].ravel() for v in range(len(Q))], axis=0)
        qs.append(cv2.projectPoints(pc, np.zeros(3), np.zeros(3), K, D)[0].reshape(-1, 2))
    qs = np.array(qs)
    emp = [np.sqrt(np.linalg.eigvalsh(np.cov(qs[:, m].T))[1]) for m in range(len(pix))]
    _ratio_ok(emp, pred, 0.85, 1.18)
    assert pred[0] < 0.5 * pred[1:].min()  # the centre is better known than the corners
    # the "intrinsics only" variant ignores what the board poses absorb: larger at the centre
    Gi, _ = projection_gradient(K1, D1, rv, tv, pix[:1], z, method="intrinsics")
    assert np.sqrt(np.linalg.eigvalsh(Gi[0] @ cov @ Gi[0].T)[1]) > 3 * pred[0]


def test_projection_map_from_a_calibration_and_a_file(tmp_path):
    b = parse_board("chessboard:10x7:25")
    rng = np.random.default_rng(1)
    dets = []
    for i, (r, t) in enumerate(look_at_poses(10, 380, b, seed=8, tilt_deg=40)):
        q = project(b, K1, D1, r, t) + rng.normal(0, 0.2, (70, 2))
        dets.append(Detection(f"v{i}", SIZE, q.astype(np.float32), b.object_points, np.arange(70, dtype=np.int32)))
    res = calibrate_camera(dets, b)
    m = projection_uncertainty(res, 450, grid=(9, 7))
    assert m["map"].shape == (7, 9) and m["u"][[0, -1]].tolist() == [0, 639] and m["v"][[0, -1]].tolist() == [0, 479]
    np.testing.assert_allclose(m["map"][3, 4], projection_at(res, [[m["u"][4], m["v"][3]]], 450)[0])
    from camcmm.api import read_calibration, write_calibration

    write_calibration(tmp_path / "c.yaml", calibration_dict(res))
    back = projection_uncertainty(read_calibration(tmp_path / "c.yaml"), 450, grid=(9, 7))
    np.testing.assert_allclose(back["map"], m["map"], rtol=1e-6)
    with pytest.raises(InputError, match="distance"):
        projection_uncertainty(res, -1)
    with pytest.raises(InputError, match="views"):
        projection_uncertainty({"cameras": res["camera"] and [res["camera"]]}, 450)


# a stereo rig: right camera 120 mm to the side, turned in by 15 degrees
K2 = np.array([[790.0, 0, 320], [0, 792, 245], [0, 0, 1]])
D2 = np.array([-0.15, 0.05, 0, 0.001, 0.0])
RV = np.array([0.0, 0.26, 0.01])
TR = -cv2.Rodrigues(RV)[0] @ np.array([120.0, 0, 0])


def _stereo_views(board, poses, sigma, seed):
    rng = np.random.default_rng(seed)
    n = len(board.object_points)
    ids = np.arange(n, dtype=np.int32)
    left, right = [], []
    for i, (r, t) in enumerate(poses):
        ql = project(board, K1, D1, r, t) + rng.normal(0, sigma, (n, 2))
        r3, t3 = cv2.composeRT(np.ravel(r), np.ravel(t), RV, TR)[:2]
        qr = project(board, K2, D2, r3, t3) + rng.normal(0, sigma, (n, 2))
        left.append(Detection(f"left{i}", SIZE, ql.astype(np.float32), board.object_points, ids))
        right.append(Detection(f"right{i}", SIZE, qr.astype(np.float32), board.object_points, ids))
    return left, right


def test_stereo_exact_data():
    b = parse_board("chessboard:8x6:25")
    poses = look_at_poses(8, 450, b, seed=4, tilt_deg=35)
    res = calibrate_stereo(*_stereo_views(b, poses, 0.0, 0), b)  # exact but for float32 pixels
    np.testing.assert_allclose(res["rvec"], RV, atol=1e-6)
    np.testing.assert_allclose(res["T"], TR, atol=1e-4)
    np.testing.assert_allclose(res["cameras"][1].camera_matrix, K2, atol=1e-3)
    assert res["rms"] < 1e-4 and res["epipolar"]["max"] < 1e-4 and res["rectified_dy"]["max"] < 1e-3
    assert res["baseline"] == pytest.approx(120.0, abs=1e-4)
    # fundamental matrix of eq. 2.5 from the projection matrices: the same up to scale
    P1 = K1 @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = K2 @ np.hstack([cv2.Rodrigues(RV)[0], TR[:, None]])
    e2 = P2 @ np.r_[0, 0, 0, 1.0]
    F = np.array([[0, -e2[2], e2[1]], [e2[2], 0, -e2[0]], [-e2[1], e2[0], 0]]) @ P2 @ np.linalg.pinv(P1)
    np.testing.assert_allclose(res["F"] / res["F"][2, 2], F / F[2, 2], rtol=1e-5, atol=1e-9)


@pytest.mark.slow
def test_stereo_uncertainty_monte_carlo():
    """std of the rotation vector and T (Jacobian of the joint problem) against the
    spread of 60 calibrations of noisy copies (sampling error of a std: ~9 %)."""
    b = parse_board("chessboard:6x5:30")
    poses = look_at_poses(10, 450, b, seed=4, tilt_deg=35)
    runs = [calibrate_stereo(*_stereo_views(b, poses, 0.2, s), b, outlier_factor=0) for s in range(60)]
    T = np.array([r["T"] for r in runs])
    rv = np.array([r["rvec"] for r in runs])
    _ratio_ok(T.std(0, ddof=1), np.mean([r["std_T"] for r in runs], 0))
    _ratio_ok(rv.std(0, ddof=1), np.mean([r["std_rvec"] for r in runs], 0))
    base = np.array([r["baseline"] for r in runs])
    _ratio_ok([base.std(ddof=1)], [np.mean([r["baseline_std"] for r in runs])])
    assert abs(base.mean() - 120) < 4 * base.std(ddof=1) / np.sqrt(len(base))


def test_stereo_with_partial_charuco_views():
    """ChArUco views where each camera misses different corners: pairs use the ids both
    saw; exact data give the rig back."""
    b = parse_board("charuco:9x7:25:18")
    poses = look_at_poses(8, 450, b, seed=6, tilt_deg=30)
    left, right = _stereo_views(b, poses, 0.0, 0)
    rng = np.random.default_rng(5)
    for d in left + right:  # drop a different third of the corners in each view
        keep = np.sort(rng.choice(len(d.ids), size=2 * len(d.ids) // 3, replace=False))
        d.image_points, d.object_points, d.ids = d.image_points[keep], d.object_points[keep], d.ids[keep]
    res = calibrate_stereo(left, right, b)
    assert len(res["pairs"]) == 8
    np.testing.assert_allclose(res["T"], TR, atol=1e-3)
    np.testing.assert_allclose(res["rvec"], RV, atol=1e-5)
