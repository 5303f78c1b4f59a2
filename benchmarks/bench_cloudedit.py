"""Benchmark: a lasso selection and a box crop of a 2 M-point cloud, and the components of a 200 k one.

In one run, on the same data (2 000 000 points uniform in a 200 x 100 x 50 mm box, seen
through a perspective view; a lasso of 256 vertices, a wobbly circle over the middle selecting about a third):

* camcmm's selection (``crop.polygon_mask``: projection, w > 0, even-odd rule with the
  points sorted by y so each edge touches only its y-band) against, as the reference,
  matplotlib's ``Path.contains_points`` (C++, AGG's point-in-polygon) on the same
  projected points — their ratio and how many points they disagree on (only points on
  an edge may differ: matplotlib's rule there is unspecified);
* the client view's own selection (``clientview.selection_mask``, every edge against
  every point) for information;
* a box crop (``crop.box_mask``) and the whole ``crop.lasso`` plugin through the host
  (mask plus the subset of points and fields);
* ``segment.components`` (Open3D DBSCAN) on 200 000 points in two blobs.

    .venv/bin/python benchmarks/bench_cloudedit.py [-n 2000000] [--repeat 3]

Each figure is the best of ``--repeat`` runs taking turns; load average printed.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from camcmm.host import default_host
from camcmm.model import PointCloud
from camcmm_plugins.cloudtools.crop import box_mask, polygon_mask, project_ndc


def best(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def perspective(eye, target, fov=40.0, aspect=1.5, near=10.0, far=2000.0) -> list[float]:
    """gluPerspective x gluLookAt, column-major (WebGL's), as the client view sends it."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, [0.0, 0.0, 1.0])
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = s, u, -f
    view[:3, 3] = -view[:3, :3] @ eye
    t = 1 / np.tan(np.radians(fov / 2))
    proj = np.array(
        [
            [t / aspect, 0, 0, 0],
            [0, t, 0, 0],
            [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
            [0, 0, -1, 0],
        ]
    )
    return (proj @ view).T.ravel().tolist()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=2_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    rng = np.random.default_rng(0)
    pts = rng.uniform([0, 0, 0], [200, 100, 50], (a.n, 3))
    mvp = perspective([100, -250, 200], [100, 50, 25])
    k = np.arange(256) / 256 * 2 * np.pi
    r = 0.25 + 0.04 * np.sin(7 * k)
    poly = np.column_stack([r * np.cos(k), r * np.sin(k)])

    from matplotlib.path import Path

    from camcmm.gui.clientview import selection_mask

    t_ours, mask = best(lambda: polygon_mask(pts, poly.ravel(), mvp), a.repeat)

    def reference():
        xy, front = project_ndc(pts, mvp)
        inside = np.zeros(len(pts), bool)
        inside[front] = Path(poly).contains_points(xy[front])
        return inside

    t_ref, ref = best(reference, a.repeat)
    t_cv, cvm = best(lambda: selection_mask(pts, {"polygon": poly.tolist(), "mvp": mvp}), 1)
    print(f"lasso 256 vertices, {a.n:,} points: {int(mask.sum()):,} selected")
    print(f"  camcmm polygon_mask      {t_ours:7.3f} s")
    print(f"  matplotlib contains      {t_ref:7.3f} s   ratio camcmm / matplotlib = {t_ours / t_ref:.2f}")
    print(f"  clientview selection_mask {t_cv:6.3f} s   (every edge x every point)")
    print(f"  disagreements: matplotlib {int(np.sum(mask != ref))}, clientview {int(np.sum(mask != cvm))}")
    t_box, bm = best(lambda: box_mask(pts, [50, 20, 10], [150, 80, 40]), a.repeat)
    print(f"box mask: {t_box:.3f} s ({int(bm.sum()):,} inside)")
    host = default_host()
    cloud = PointCloud(pts, fields={"d": pts[:, 2].copy()})
    params = {"polygon": poly.ravel().tolist(), "mvp": mvp}
    t_plug, out = best(lambda: host.run("crop.lasso", {"cloud": cloud}, params).outputs, a.repeat)
    print(f"crop.lasso plugin (mask + subset of points and a field): {t_plug:.3f} s, kept {out['n_kept']:,}")
    m = 100_000
    blobs = np.vstack([rng.normal(0, 5, (m, 3)), rng.normal(0, 5, (m, 3)) + [100, 0, 0]])
    t_seg, seg = best(
        lambda: host.run("segment.components", {"cloud": PointCloud(blobs)}, {"eps": 1.0, "min_points": 5}).outputs,
        1,
    )
    print(f"segment.components, {2 * m:,} points, eps 1 mm: {t_seg:.3f} s, sizes {seg['sizes'][:3]}")
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")


if __name__ == "__main__":
    main()
