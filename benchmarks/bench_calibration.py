"""Benchmark: triangulation and the projection-uncertainty map of the calibration plugin.

In one run:

* triangulation of N points seen by two distorted cameras (``triangulate``: undistortion,
  linear eq. 3.2, optimal Hartley-Sturm, and the per-point covariance), against OpenCV's
  cv2.undistortPoints + cv2.triangulatePoints as the reference, with points per second,
  the ratio and the largest difference between the linear points and OpenCV's;
* the projection-uncertainty map (64 x 48 grid, first order, mrcal's method) against
  the Monte Carlo it replaces (re-calibrating noisy copies, mapping the grid through each),
  timed on ``--mc`` calibrations, with the ratio of the times and of the map values.

    .venv/bin/python benchmarks/bench_calibration.py [--points 100000] [--mc 100] [--repeat 3] [--skip-map]
"""

from __future__ import annotations

import argparse
import os
import time

import cv2
import numpy as np

from camcmm.api import CameraModel
from camcmm_plugins.calibration.boards import parse_board
from camcmm_plugins.calibration.covariance import Observation, assemble, covariance, free_intrinsics
from camcmm_plugins.calibration.projection import projection_gradient
from camcmm_plugins.calibration.synthetic import look_at_poses, project
from camcmm_plugins.calibration.triangulation import triangulate


def _cams():
    k1 = np.array([[2000.0, 0, 1000], [0, 2001, 750], [0, 0, 1]])
    k2 = np.array([[1990.0, 0, 1010], [0, 1992, 740], [0, 0, 1]])
    r2 = cv2.Rodrigues(np.array([0, 0.46, 0.01]))[0]
    return [
        CameraModel(k1, [-0.1, 0.05, 0.001, 0, 0]),
        CameraModel(k2, [-0.12, 0.07, 0, 0.001, 0.01], r2, -r2 @ [200.0, 0, 0]),
    ]


def _opencv_linear(cams, x):
    """The reference: cv2.undistortPoints (100 iterations, as camcmm asked it before) and
    cv2.triangulatePoints (homogeneous DLT by SVD)."""
    u = [
        cv2.undistortPoints(
            x[k].reshape(-1, 1, 2), c.camera_matrix, c.dist_coeffs, P=c.camera_matrix, criteria=(3, 100, 1e-14)
        ).reshape(-1, 2)
        for k, c in enumerate(cams)
    ]
    Xh = cv2.triangulatePoints(cams[0].projection_matrix, cams[1].projection_matrix, u[0].T, u[1].T)
    return (Xh[:3] / Xh[3]).T


def bench_triangulation(n: int, repeat: int) -> None:
    """Best of ``repeat`` runs, the reference and camcmm's methods taking turns (a
    disturbance of the shared machine hits them alike); errors against the true points
    (exact by construction: projected with cv2.projectPoints, then 0.3 px noise)."""
    cams = _cams()
    rng = np.random.default_rng(0)
    X = rng.uniform([-50, -50, 350], [50, 50, 450], (n, 3))
    x = np.stack(
        [
            cv2.projectPoints(X, cv2.Rodrigues(c.rotation)[0], c.translation, c.camera_matrix, c.dist_coeffs)[
                0
            ].reshape(-1, 2)
            for c in cams
        ]
    ) + rng.normal(0, 0.3, (2, n, 2))
    runs = {
        "reference": lambda: _opencv_linear(cams, x),
        "linear": lambda: triangulate(cams, x, method="linear")["points"],
        "optimal": lambda: triangulate(cams, x, method="optimal")["points"],
        "optimal + covariance": lambda: triangulate(cams, x, method="optimal", pixel_sigma=0.3)["points"],
    }
    times = {k: np.inf for k in runs}
    out = {}
    for _ in range(repeat):
        for k, fn in runs.items():
            t = time.perf_counter()
            out[k] = fn()
            times[k] = min(times[k], time.perf_counter() - t)
    t_ref = times["reference"]

    def err(p):
        return f"RMS error {np.sqrt(np.mean(np.sum((p - X) ** 2, axis=1))) * 1e3:.3f} um"

    print(f"triangulation of {n} points, 2 cameras with distortion, 0.3 px noise (best of {repeat})")
    print(
        f"  reference cv2.undistortPoints + triangulatePoints: {t_ref:.3f} s ({n / t_ref:,.0f} points/s), "
        f"{err(out['reference'])}"
    )
    for label in ("linear", "optimal", "optimal + covariance"):
        dt = times[label]
        extra = (
            f", max |linear - OpenCV| {np.abs(out[label] - out['reference']).max() * 1e3:.3f} um"
            if label == "linear"
            else ""
        )
        print(
            f"  camcmm {label:22s}: {dt:.3f} s ({n / dt:,.0f} points/s), {dt / t_ref:.2f} x reference, "
            f"{err(out[label])}{extra}"
        )


def bench_projection_map(n_mc: int) -> None:
    b = parse_board("chessboard:10x7:25")
    K = np.array([[800.0, 0, 330], [0, 805, 235], [0, 0, 1]])
    D = np.array([-0.2, 0.08, 0.001, -0.0005, 0.01])
    poses = look_at_poses(12, 380, b, seed=3, tilt_deg=40)
    sigma, z = 0.3, 500.0
    Q = [project(b, K, D, r, t) for r, t in poses]
    rv = np.array([np.ravel(p[0]) for p in poses])
    tv = np.array([np.ravel(p[1]) for p in poses])
    uu, vv = np.meshgrid(np.linspace(0, 639, 64), np.linspace(0, 479, 48))
    pix = np.column_stack([uu.ravel(), vv.ravel()])
    t = time.perf_counter()
    obs = [Observation(v, 0, b.object_points, Q[v]) for v in range(len(poses))]
    jtj, _, sse, rows, _ = assemble([(K, D)], [], poses, obs, [free_intrinsics(0, 5)])
    cov, _ = covariance(jtj, sse, rows, sigma=sigma)
    G, p = projection_gradient(K, D, rv, tv, pix, z)
    pred = np.sqrt(np.linalg.eigvalsh(np.einsum("mip,pq,mjq->mij", G, cov, G))[:, 1])
    t_first = time.perf_counter() - t
    t = time.perf_counter()
    p_board = [(p - tv[v]) @ cv2.Rodrigues(rv[v])[0] for v in range(len(poses))]
    rng = np.random.default_rng(0)
    qs = []
    for _ in range(n_mc):
        img = [(q + rng.normal(0, sigma, q.shape)).astype(np.float32) for q in Q]
        _, K2, D2, r2, t2 = cv2.calibrateCamera([b.object_points] * len(Q), img, (640, 480), None, None)
        pc = np.mean([p_board[v] @ cv2.Rodrigues(r2[v])[0].T + t2[v].ravel() for v in range(len(Q))], axis=0)
        qs.append(cv2.projectPoints(pc, np.zeros(3), np.zeros(3), K2, D2)[0].reshape(-1, 2))
    t_mc = time.perf_counter() - t
    qs = np.array(qs)
    emp = np.sqrt(np.linalg.eigvalsh(np.einsum("kmi,kmj->mij", qs - qs.mean(0), qs - qs.mean(0)) / (n_mc - 1))[:, 1])
    ratio = emp / pred
    print(f"projection-uncertainty map, 64 x 48 grid, 12 views, sigma {sigma} px, z {z:g} mm")
    print(f"  first order (camcmm): {t_first * 1e3:.1f} ms; map {pred.min():.3f} .. {pred.max():.3f} px")
    print(
        f"  Monte Carlo of {n_mc} re-calibrations (reference): {t_mc:.2f} s = {t_mc / t_first:,.0f} x; "
        f"MC / first order: median {np.median(ratio):.3f}, 5-95 % {np.percentile(ratio, 5):.3f} .. "
        f"{np.percentile(ratio, 95):.3f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--mc", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-map", action="store_true", help="only the triangulation")
    args = ap.parse_args()
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    bench_triangulation(args.points, args.repeat)
    if args.skip_map:
        return
    bench_projection_map(args.mc)


if __name__ == "__main__":
    main()
