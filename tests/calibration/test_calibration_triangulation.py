"""Triangulation on generated data with known truth: exact projections through
distorted cameras, OpenCV's triangulatePoints and a brute-force least-squares solution
as independent references, covariance against Monte Carlo."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.optimize import least_squares

from camcmm.api import CameraModel, InputError
from camcmm_plugins.calibration.triangulation import _undistort, fundamental, triangulate


def _rot(*r):
    return cv2.Rodrigues(np.array(r, float))[0]


K1 = np.array([[2000.0, 0, 1000], [0, 2001, 750], [0, 0, 1]])
K2 = np.array([[1990.0, 0, 1010], [0, 1992, 740], [0, 0, 1]])
R2, R3 = _rot(0, 0.46, 0.01), _rot(-0.46, 0, 0)
CAMS = [
    CameraModel(K1, [-0.1, 0.05, 0.001, 0, 0], image_size=(2000, 1500), name="left"),
    CameraModel(K2, [-0.12, 0.07, 0, 0.001, 0.01], R2, -R2 @ [200.0, 0, 0], (2000, 1500), name="right"),
    CameraModel(K2, np.zeros(5), R3, -R3 @ [0.0, 200, 0], (2000, 1500), name="third"),
]


def _proj(cam, X):
    q, _ = cv2.projectPoints(X, cv2.Rodrigues(cam.rotation)[0], cam.translation, cam.camera_matrix, cam.dist_coeffs)
    return q.reshape(-1, 2)


@pytest.fixture(scope="module")
def truth():
    return np.random.default_rng(1).uniform([-50, -50, 350], [50, 50, 450], (200, 3))


@pytest.mark.parametrize("n_cams", [2, 3])
@pytest.mark.parametrize("method", ["linear", "optimal"])
def test_exact_projections_give_the_points(truth, n_cams, method):
    cams = CAMS[:n_cams]
    x = np.stack([_proj(c, truth) for c in cams])
    res = triangulate(cams, x, method=method)
    np.testing.assert_allclose(res["points"], truth, atol=1e-8)
    assert res["reprojection_rms"].max() < 1e-8


@pytest.mark.parametrize(
    "dist",
    [
        [-0.1, 0.05, 0.001, -0.002],
        [-0.1, 0.05, 0.001, -0.002, 0.01],
        [-0.1, 0.05, 0.001, -0.002, 0.01, 0.02, -0.01, 0.005],
        [-0.1, 0.05, 0.001, -0.002, 0.01, 0.02, -0.01, 0.005, 0.001, -0.002, 0.003, 0.0005],
        [-0.1, 0.05, 0.001, -0.002, 0.01, 0.02, -0.01, 0.005, 0.001, -0.002, 0.003, 0.0005, 0.01, -0.02],
    ],
    ids=["4", "5", "8-rational", "12-thin-prism", "14-tilted"],
)
def test_undistortion_of_every_opencv_model_gives_the_pinhole_pixels(dist):
    """Newton's undistortion against the pinhole pixels the distorted ones were made from
    (exact by construction), and against cv2.undistortPoints run to convergence."""
    cam = CameraModel(K1, dist, name="c")
    rng = np.random.default_rng(4)
    X = rng.uniform([-0.35, -0.27, 1.0], [0.35, 0.27, 1.0], (2000, 3)) * rng.uniform(300, 500, (2000, 1))
    q = _proj(cam, X)
    pinhole = (X[:, :2] / X[:, 2:]) @ K1[:2, :2].T + K1[:2, 2]
    u = _undistort(cam, q)
    assert np.abs(u - pinhole).max() < 1e-8  # px
    ref = cv2.undistortPoints(q.reshape(-1, 1, 2), K1, cam.dist_coeffs, P=K1, criteria=(3, 100, 1e-14))
    assert np.abs(u - ref.reshape(-1, 2)).max() < 1e-8


def test_undistortion_beyond_the_fold_is_opencvs():
    """A barrel distortion folds back beyond r = 1/sqrt(3|k1|): pixels further out have no
    undistorted point, Newton cannot converge there and those points get OpenCV's answer
    (its iteration, bit for bit); the others are exact."""
    cam = CameraModel(K1, [-0.5, 0, 0, 0, 0], name="c")
    r = np.array([0.1, 0.3, 0.5, 0.7, 0.9, 1.2])  # normalised distorted radii; max of r(1 - 0.5 r^2) is 0.544
    q = np.column_stack([K1[0, 0] * r + K1[0, 2], np.full(len(r), K1[1, 2])])
    u = _undistort(cam, q)
    ref = cv2.undistortPoints(q.reshape(-1, 1, 2), K1, cam.dist_coeffs, P=K1, criteria=(3, 100, 1e-14)).reshape(-1, 2)
    out = r > 0.544
    np.testing.assert_array_equal(u[out], ref[out])
    xu = (u[~out, 0] - K1[0, 2]) / K1[0, 0]  # undistorted radius: r_d = x (1 - 0.5 x^2)
    np.testing.assert_allclose(xu * (1 - 0.5 * xu**2), r[~out], atol=1e-14)


def test_linear_is_opencv_dlt_and_optimal_is_the_least_squares_point(truth):
    rng = np.random.default_rng(2)
    cams = CAMS[:2]
    x = np.stack([_proj(c, truth) for c in cams]) + rng.normal(0, 0.5, (2, len(truth), 2))
    lin = triangulate(cams, x, method="linear")["points"]
    # OpenCV's DLT on the same undistorted pixels: a different row weighting, same point to ~um
    u = [
        cv2.undistortPoints(
            x[k].reshape(-1, 1, 2), c.camera_matrix, c.dist_coeffs, P=c.camera_matrix, criteria=(3, 100, 1e-14)
        ).reshape(-1, 2)
        for k, c in enumerate(cams)
    ]
    Xh = cv2.triangulatePoints(cams[0].projection_matrix, cams[1].projection_matrix, u[0].T, u[1].T)
    assert np.abs(lin - (Xh[:3] / Xh[3]).T).max() < 0.01
    # two cameras: Hartley-Sturm's optimum (cv2.correctMatches on the epipolar geometry)
    x2 = np.stack([_proj(c, truth[:50]) for c in cams]) + rng.normal(0, 0.5, (2, 50, 2))
    u2 = [
        cv2.undistortPoints(
            x2[k].reshape(-1, 1, 2), c.camera_matrix, c.dist_coeffs, P=c.camera_matrix, criteria=(3, 100, 1e-14)
        ).reshape(1, -1, 2)
        for k, c in enumerate(cams)
    ]
    a, b = cv2.correctMatches(fundamental(cams[0], cams[1]), u2[0], u2[1])
    Xh = cv2.triangulatePoints(cams[0].projection_matrix, cams[1].projection_matrix, a[0].T, b[0].T)
    np.testing.assert_allclose(triangulate(cams, x2)["points"], (Xh[:3] / Xh[3]).T, atol=1e-7)
    for n_cams in (2, 3):
        cams = CAMS[:n_cams]
        x = np.stack([_proj(c, truth[:20]) for c in cams]) + rng.normal(0, 0.5, (n_cams, 20, 2))
        opt = triangulate(cams, x, method="optimal")
        lin = triangulate(cams, x, method="linear")
        assert np.all(opt["reprojection_rms"] <= lin["reprojection_rms"] + 1e-9)
        ud = np.stack(
            [
                cv2.undistortPoints(
                    x[k].reshape(-1, 1, 2), c.camera_matrix, c.dist_coeffs, P=c.camera_matrix, criteria=(3, 100, 1e-14)
                ).reshape(-1, 2)
                for k, c in enumerate(cams)
            ]
        )
        for i in range(20):  # brute force: scipy's least_squares on the undistorted reprojection error

            def r(X, i=i):
                return np.concatenate(
                    [
                        (c.projection_matrix @ np.r_[X, 1])[:2] / (c.projection_matrix @ np.r_[X, 1])[2] - ud[k, i]
                        for k, c in enumerate(cams)
                    ]
                )

            ref = least_squares(r, lin["points"][i], xtol=1e-14, ftol=1e-14, gtol=1e-14).x
            assert np.abs(opt["points"][i] - ref).max() < 1e-6


@pytest.mark.slow
def test_covariance_against_monte_carlo(truth):
    """Pixel noise 0.3 px and a calibration covariance (intrinsics of both cameras and the
    right camera's pose) propagated to first order vs 3000 perturbed triangulations."""
    cams = CAMS[:2]
    X = truth[:4]
    x = np.stack([_proj(c, X) for c in cams])
    sd = np.r_[[2, 2, 3, 3, 0.005, 0.02, 1e-4, 1e-4, 0.02] * 2, [1e-3] * 3, [0.3] * 3]
    res = triangulate(cams, x, pixel_sigma=0.3, parameter_covariance=np.diag(sd**2))
    rng = np.random.default_rng(3)
    pts = []
    for _ in range(3000):
        th = rng.normal(0, sd)
        cs = []
        for i, c in enumerate(cams):
            o = 9 * i
            K = c.camera_matrix + [[th[o], 0, th[o + 2]], [0, th[o + 1], th[o + 3]], [0, 0, 0]]
            R, t = c.rotation, c.translation
            if i == 1:
                R = cv2.Rodrigues(cv2.Rodrigues(R)[0].ravel() + th[18:21])[0]
                t = t + th[21:24]
            cs.append(CameraModel(K, c.dist_coeffs + th[o + 4 : o + 9], R, t))
        pts.append(triangulate(cs, x + rng.normal(0, 0.3, x.shape))["points"])
    pts = np.array(pts)
    for m in range(len(X)):
        emp = np.cov(pts[:, m].T)
        np.testing.assert_allclose(np.sqrt(np.diag(emp)), res["std"][m], rtol=0.08)
        corr = emp[0, 2] / np.sqrt(emp[0, 0] * emp[2, 2])
        pred = res["covariance"][m]
        assert abs(corr - pred[0, 2] / np.sqrt(pred[0, 0] * pred[2, 2])) < 0.08
    # pixel noise alone: the familiar depth-dominated ellipsoid
    only_px = triangulate(cams, x, pixel_sigma=0.3)["std"]
    assert np.all(only_px[:, 2] > only_px[:, 0]) and np.all(only_px < res["std"])


def test_bad_input():
    x = np.zeros((2, 3, 2))
    with pytest.raises(InputError, match="at least 2 cameras"):
        triangulate(CAMS[:1], x[:1])
    with pytest.raises(InputError, match=r"\(cameras=3, points, 2\)"):
        triangulate(CAMS, x)
    with pytest.raises(InputError, match="NaN"):
        triangulate(CAMS[:2], np.full((2, 3, 2), np.nan))
    with pytest.raises(InputError, match="method"):
        triangulate(CAMS[:2], x + 500, method="magic")
    with pytest.raises(InputError, match="parameter_covariance"):
        triangulate(CAMS[:2], x + 500, parameter_covariance=np.eye(3))
