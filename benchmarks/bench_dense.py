"""Benchmark: the CPU dense cloud on templeRing (47 x 640x480) with the gantry's cameras.

Prints the time, the point count, the fraction inside the published bounding box of the
temple (+1 mm), a coverage figure, and the same for a reference run in this process: plain
OpenCV (``cv2.stereoRectify`` + ``cv2.StereoSGBM`` + ``cv2.reprojectImageTo3D``), one
neighbour per view and no fusion, i.e. what the dense stage adds over single-pair stereo.
The issue's budget: dense <= 120 s on 2 cores.

    .venv/bin/python benchmarks/bench_dense.py [--views N] [--min-intensity 90]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np

from camcmm_plugins.photogrammetry.dense import dense_cloud
from camcmm_plugins.photogrammetry.pairs import cameras, depth_ranges, scene_centre

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "middlebury_mvs_templering"
LO = np.array([-0.023121, -0.038009, -0.091940])  # README.txt of the data set, m
HI = np.array([0.078626, 0.121636, -0.017395])


def load(n: int):
    """The first ``n`` views with the published cameras. The images of positive latitude
    (templeR_ang.txt; README: "rotated 180 degrees in the image plane") are stored turned by
    180 deg against their published K, R, t: turned back, SIFT matches meet the published
    epipolar geometry to 0.1 px (1 px within that group, 200 px across groups as stored)."""
    rows = [ln.split() for ln in (DATA / "templeR_par.txt").read_text().splitlines()[1:] if ln.strip()][:n]
    lat = {r[2]: float(r[0]) for r in (ln.split() for ln in (DATA / "templeR_ang.txt").read_text().splitlines()) if r}
    images, views = [], []
    for row in rows:
        v = np.array(row[1:], float)
        img = cv2.cvtColor(cv2.imread(str(DATA / row[0])), cv2.COLOR_BGR2RGB)
        images.append(np.ascontiguousarray(img[::-1, ::-1]) if lat[row[0]] > 0 else img)
        views.append({"K": v[:9].reshape(3, 3), "dist": np.zeros(5), "R": v[9:18].reshape(3, 3), "t": v[18:]})
    return images, views


def inside(P: np.ndarray, margin: float = 1e-3) -> float:
    return float(np.all((P >= LO - margin) & (P <= HI + margin), axis=1).mean()) if len(P) else 0.0


def coverage(P: np.ndarray, images, views, min_intensity: int) -> float:
    """Mean over views of the fraction of bright (temple) pixels onto which a dense point
    projects (points hidden behind others count too: an upper bound)."""
    fr = []
    for im, v in zip(images, views, strict=True):
        x = (P @ v["R"].T + v["t"]) @ v["K"].T
        u = np.rint(x[:, :2] / x[:, 2:]).astype(int)
        h, w = im.shape[:2]
        ok = (u[:, 0] >= 0) & (u[:, 0] < w) & (u[:, 1] >= 0) & (u[:, 1] < h)
        hit = np.zeros((h, w), np.uint8)
        hit[u[ok, 1], u[ok, 0]] = 1
        hit = hit > 0
        fg = cv2.cvtColor(im, cv2.COLOR_RGB2GRAY) >= min_intensity
        fr.append((hit & fg).sum() / max(fg.sum(), 1))
    return float(np.mean(fr))


def reference(images, views, min_intensity: int):
    """Plain OpenCV single-pair stereo: each view with its nearest neighbour on the side
    ``cv2.stereoRectify`` calls right (or below), no consistency check."""
    cams = cameras(views, images[0].shape[:2])
    zr = depth_ranges(cams, scene_centre(cams))
    C = np.array([c.centre for c in cams])
    h, w = images[0].shape[:2]
    pts = []
    for i, ci in enumerate(cams):
        for j in np.argsort(np.linalg.norm(C - C[i], axis=1))[1:3]:
            cj = cams[j]
            R = cj.R @ ci.R.T
            T = (cj.t - R @ ci.t).reshape(3, 1)
            R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(ci.K, ci.dist, cj.K, cj.dist, (w, h), R, T)
            vertical = abs(P2[1, 3]) > abs(P2[0, 3])
            if (P2[1, 3] if vertical else P2[0, 3]) > 0:
                continue  # this neighbour lies on the wrong side for SGBM's positive disparities
            m1 = cv2.initUndistortRectifyMap(ci.K, ci.dist, R1, P1, (w, h), cv2.CV_32FC1)
            m2 = cv2.initUndistortRectifyMap(cj.K, cj.dist, R2, P2, (w, h), cv2.CV_32FC1)
            a = cv2.remap(cv2.cvtColor(images[i], cv2.COLOR_RGB2GRAY), *m1, cv2.INTER_LINEAR)
            b = cv2.remap(cv2.cvtColor(images[j], cv2.COLOR_RGB2GRAY), *m2, cv2.INTER_LINEAR)
            if vertical:
                a, b = a.T.copy(), b.T.copy()
            f, B = P1[0, 0], np.linalg.norm(T)
            dmin = int(f * B / zr[i, 1])
            nd = int(np.ceil((f * B / zr[i, 0] - dmin) / 16) * 16)
            sgbm = cv2.StereoSGBM_create(dmin, nd, 5, 200, 800, 1, 0, 10, 100, 2, cv2.STEREO_SGBM_MODE_SGBM_3WAY)
            pad = dmin + nd  # SGBM leaves the leftmost minDisparity + numDisparities columns empty
            pa, pb = (cv2.copyMakeBorder(x, 0, 0, pad, 0, cv2.BORDER_CONSTANT) for x in (a, b))
            d = sgbm.compute(pa, pb)[:, pad:].astype(np.float32) / 16
            if vertical:
                d, a = d.T.copy(), a.T.copy()
            X = cv2.reprojectImageTo3D(d, Q)
            ok = (d > dmin) & (a >= min_intensity)
            Xc = X[ok].astype(np.float64)  # rectified first camera -> camera i -> world
            pts.append((Xc @ R1 - ci.t) @ ci.R)
            break
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--views", type=int, default=47)
    ap.add_argument("--min-intensity", type=int, default=90)
    a = ap.parse_args()
    if not DATA.is_dir():
        raise SystemExit(f"{DATA} is absent")
    images, views = load(a.views)
    t0 = time.perf_counter()
    r = dense_cloud(images, views, min_intensity=a.min_intensity)
    t1 = time.perf_counter()
    ref = reference(images, views, a.min_intensity)
    t2 = time.perf_counter()
    print(
        f"templeRing, {len(images)} views {images[0].shape[1]}x{images[0].shape[0]}, cv2 threads {cv2.getNumThreads()}"
    )
    print(
        f"dense_cloud:       {t1 - t0:6.1f} s  {len(r.points):8d} points  in bbox(+1 mm) {inside(r.points):.4f}  "
        f"strict {inside(r.points, 0):.4f}  coverage {coverage(r.points, images, views, a.min_intensity):.3f}"
    )
    print(
        f"  timings {', '.join(f'{k} {v:.1f} s' for k, v in r.timings.items())}; pairs {len(r.pairs)}; "
        f"median n_views {np.median(r.n_views):.0f}, median quality {np.median(r.quality):.2f}"
    )
    print(
        f"reference (plain OpenCV SGBM, 1 pair/view, no fusion): {t2 - t1:6.1f} s  {len(ref):8d} points  "
        f"in bbox(+1 mm) {inside(ref):.4f}"
    )
    print(
        f"ratio time dense/reference {(t1 - t0) / (t2 - t1):.2f}; outside-bbox fraction dense/reference "
        f"{(1 - inside(r.points)) / max(1 - inside(ref), 1e-9):.3f}"
    )


if __name__ == "__main__":
    main()
