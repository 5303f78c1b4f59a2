"""Benchmark: structure from motion on templeRing (47 views x 0.3 MP) against plain pycolmap.

In one run, on the same images (../shared/data/middlebury_mvs_templering, the views in the
orientation their gantry cameras describe):

* plain pycolmap with its defaults, as a user would call it (one shared SIMPLE_RADIAL camera:
  ``extract_features(camera_mode=SINGLE)``, ``match_exhaustive``, ``incremental_mapping``);
* camcmm's ``reconstruct_sparse`` self-calibrating (target: <= 60 s on 2 cores);
* camcmm's ``reconstruct_sparse`` with the gantry's intrinsics held fixed;

each with its wall time and, after a 7-parameter similarity onto the gantry's camera centres,
the centre RMS in % of the ring radius (target <= 0.3 %), the largest orientation error and
the focal length's deviation from the gantry's (target within 2 %), and the ratios
camcmm / plain pycolmap.

    .venv/bin/python benchmarks/bench_photogrammetry.py [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from camcmm_plugins.photogrammetry.reference import compare, read_gantry, read_series
from camcmm_plugins.photogrammetry.sfm import reconstruct_sparse

TEMPLE = Path(__file__).resolve().parents[2] / "shared" / "data" / "middlebury_mvs_templering"


def plain_pycolmap(ims, names):
    """pycolmap's defaults on the same images; views in camcmm's convention."""
    import cv2
    import pycolmap

    pycolmap.logging.minloglevel = 2
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for im, n in zip(ims, names, strict=True):
            cv2.imwrite(str(root / n), cv2.cvtColor(im, cv2.COLOR_RGB2BGR))
        t0 = time.perf_counter()
        db = root / "database.db"
        pycolmap.extract_features(db, root, image_names=names, camera_mode=pycolmap.CameraMode.SINGLE)
        pycolmap.match_exhaustive(db)
        recs = pycolmap.incremental_mapping(db, root, root)
        elapsed = time.perf_counter() - t0
    rec = max(recs.values(), key=lambda r: r.num_reg_images())
    views = []
    for im in sorted(rec.images.values(), key=lambda i: i.name):
        pose = im.cam_from_world()
        R, t = pose.rotation.matrix(), np.asarray(pose.translation)
        views.append({"image": im.name, "R": R, "t": t, "centre": -R.T @ t})
    focal = next(iter(rec.cameras.values())).mean_focal_length()
    return elapsed, views, focal


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args()
    if not TEMPLE.is_dir():
        print(f"{TEMPLE} is absent: nothing to measure", file=sys.stderr)
        return 1
    gantry = read_gantry(TEMPLE)
    ims, names = read_series(TEMPLE)
    K = gantry[names[0]][0]
    f_ref = (K[0, 0] + K[1, 1]) / 2
    rows = {}

    t_plain, views, focal = plain_pycolmap(ims, names)
    rows["plain pycolmap"] = {"time_s": t_plain, "n_registered": len(views), "focal": focal, **compare(views, gantry)}

    t0 = time.perf_counter()
    r = reconstruct_sparse(ims, names)
    rows["camcmm self-calibrating"] = {
        "time_s": time.perf_counter() - t0,
        "n_registered": len(r.views),
        "focal": (r.camera["fx"] + r.camera["fy"]) / 2,
        "camera_model": r.camera["model"],
        "timings": r.timings,
        **compare(r.views, gantry),
    }
    t0 = time.perf_counter()
    cal = {"camera_matrix": K, "dist_coeffs": np.zeros(5), "image_size": (640, 480)}
    r = reconstruct_sparse(ims, names, calibration=cal)
    rows["camcmm known intrinsics"] = {
        "time_s": time.perf_counter() - t0,
        "n_registered": len(r.views),
        "focal": (r.camera["fx"] + r.camera["fy"]) / 2,
        "timings": r.timings,
        **compare(r.views, gantry),
    }

    print(f"templeRing: {len(names)} views {ims[0].shape[1]}x{ims[0].shape[0]} px; gantry focal {f_ref:.1f} px")
    print(f"{'':26s} {'time s':>7s} {'reg':>4s} {'centre RMS %':>13s} {'mm':>6s} {'max angle':>10s} {'focal %':>8s}")
    for name, row in rows.items():
        row["focal_error_pct"] = 100 * (row["focal"] / f_ref - 1)
        print(
            f"{name:26s} {row['time_s']:7.1f} {row['n_registered']:4d} {row['centre_rms_pct']:13.3f} "
            f"{row['centre_rms_mm']:6.2f} {row['max_angle_deg']:9.3f}° {row['focal_error_pct']:+8.2f}"
        )
    base, ours = rows["plain pycolmap"], rows["camcmm self-calibrating"]
    ratios = {
        "time": ours["time_s"] / base["time_s"],
        "centre_rms": ours["centre_rms_pct"] / base["centre_rms_pct"],
        "known_intrinsics_centre_rms": rows["camcmm known intrinsics"]["centre_rms_pct"] / base["centre_rms_pct"],
    }
    print(
        f"ratios camcmm / plain pycolmap: time {ratios['time']:.2f}, centre RMS {ratios['centre_rms']:.2f} "
        f"(known intrinsics {ratios['known_intrinsics_centre_rms']:.2f})"
    )
    print(f"camcmm stages (s): {ours['timings']}")
    targets = {
        "sfm_time_le_60s": bool(ours["time_s"] <= 60),
        "centre_rms_le_0p3pct_self_calibrating": bool(ours["centre_rms_pct"] <= 0.3),
        "centre_rms_le_0p3pct_known_intrinsics": bool(rows["camcmm known intrinsics"]["centre_rms_pct"] <= 0.3),
        "focal_within_2pct": bool(abs(ours["focal_error_pct"]) <= 2),
    }
    print("targets: " + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in targets.items()))
    if args.json:
        Path(args.json).write_text(
            json.dumps({"runs": rows, "ratios": ratios, "targets": targets}, indent=2, default=float)
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
