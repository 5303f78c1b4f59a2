"""Benchmark: what down-scaling costs the dense stage in accuracy (``dense_max_image_size``).

The 6 MP DSLR series of the speckled 10 mm sphere (benchmarks/bench_photogrammetry_dslr.py
renders it into DIR/images) with its TRUE cameras (truth.json: no SfM error), the first
``--views`` consecutive views (6 degrees apart). ``dense_cloud`` at each of ``--sizes`` (px of
the longest side; 0 = the full 3000 px): time, points, and the least-squares sphere through
the points within 0.5 mm of the true surface (drops the holder): radius and centre error, and
the form (rms and 95th percentile of the radial residuals) against the truth. Ratios against
the full-size run in the same process. The load average is printed beside the times.

    .venv/bin/python benchmarks/bench_dense_scale.py [--work /tmp/camcmm_bench_dslr] [--views 10]
        [--sizes 1000,1600,2400,0]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import cv2
import numpy as np

from camcmm_plugins.photogrammetry.dense import dense_cloud


def sphere_fit(P: np.ndarray) -> tuple[np.ndarray, float]:
    """Linear least-squares sphere: centre (3,), radius."""
    A = np.column_stack([2 * P, np.ones(len(P))])
    sol = np.linalg.lstsq(A, (P**2).sum(1), rcond=None)[0]
    return sol[:3], float(np.sqrt(sol[3] + sol[:3] @ sol[:3]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/camcmm_bench_dslr")
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--sizes", default="1000,1600,2400,0")
    args = ap.parse_args()
    img_dir = Path(args.work) / "images"
    truth = json.loads((img_dir / "truth.json").read_text())
    sph = truth["spheres"][0]
    c0, r0 = np.array(sph["center"], float), sph["diameter"] / 2
    images, views = [], []
    for v in truth["views"][: args.views]:
        images.append(cv2.cvtColor(cv2.imread(str(img_dir / v["image"])), cv2.COLOR_BGR2RGB))
        views.append({k: np.asarray(v[k], float) for k in ("K", "R", "t")} | {"dist": np.zeros(5)})
    h, w = images[0].shape[:2]
    # each view's depth range: the sphere's centre depth +- 1.6 radii (the sphere and the holder's top)
    zc = np.array([v["R"][2] @ c0 + v["t"][2] for v in views])
    zr = np.c_[zc - 1.6 * r0, zc + 1.6 * r0]
    print(f"{len(images)} views {w} x {h} px, true cameras; sphere r = {r0} mm")
    rows = []
    for size in [int(s) for s in args.sizes.split(",")]:
        t0 = time.perf_counter()
        r = dense_cloud(images, views, depth_range=zr, max_image_size=size)
        dt = time.perf_counter() - t0
        P = np.asarray(r.points)
        near = P[np.abs(np.linalg.norm(P - c0, axis=1) - r0) < 0.5]
        c, rad = sphere_fit(near)
        res = np.linalg.norm(near - c, axis=1) - rad
        row = {
            "size": list(r.image_size),
            "time_s": dt,
            "points": len(P),
            "near": len(near) / max(len(P), 1),
            "radius_um": 1000 * (rad - r0),
            "centre_um": 1000 * float(np.linalg.norm(c - c0)),
            "form_rms_um": 1000 * float(np.sqrt(np.mean(res**2))),
            "form_p95_um": 1000 * float(np.percentile(np.abs(res), 95)),
        }
        rows.append(row)
        load = " / ".join(f"{x:.1f}" for x in os.getloadavg())
        print(
            f"dense at {row['size']} px: {dt:.0f} s (load {load}), {row['points']} points "
            f"({100 * row['near']:.1f} % within 0.5 mm), radius error {row['radius_um']:+.1f} um, centre error "
            f"{row['centre_um']:.1f} um, form rms {row['form_rms_um']:.1f} um, 95 % {row['form_p95_um']:.1f} um",
            flush=True,
        )
    ref = max(rows, key=lambda x: x["size"][0])
    for row in rows:
        print(
            f"  {row['size'][0]} px / {ref['size'][0]} px: time {row['time_s'] / ref['time_s']:.2f}, "
            f"form rms {row['form_rms_um'] / ref['form_rms_um']:.2f}"
        )


if __name__ == "__main__":
    main()
