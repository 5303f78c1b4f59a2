"""Benchmark: the chapter-4 DSLR series end to end (issue 16).

30 images of the speckled 10 mm carbide sphere through 180 degrees, rendered by
``virtuallab.turntable-series`` at 6 MP (the 24 MP frame down-scaled by 2), then
``photogrammetry.reconstruct`` (SfM + dense) with the DSLR's calibration, and in the same
process plain pycolmap with its defaults on the same images (SIFT, exhaustive matching,
incremental mapping, self-calibrated SIMPLE_RADIAL; no dense: pycolmap's dense stage needs
CUDA). For both: time, registered views, and the sphere's radius and centre error against
the truth after the 7-parameter similarity of the camera centres onto the true ones (the
reconstruction's own scale is arbitrary); the sphere is fitted (linear least squares) to
the points within 0.5 mm of the true surface (drops the holder). Peak memory: ru_maxrss.
The issue's budget: <= 10 min end to end on 2 cores.

    .venv/bin/python benchmarks/bench_photogrammetry_dslr.py [--downscale 2] [--n 30] [--work DIR]

Images already rendered in DIR/images (same settings) are reused.
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import time
from pathlib import Path

import numpy as np

from camcmm.api import default_host


def umeyama(src: np.ndarray, dst: np.ndarray):
    """s, R, t with dst ≈ s R src + t (Umeyama 1991)."""
    ma, mb = src.mean(0), dst.mean(0)
    a, b = src - ma, dst - mb
    u, sig, vt = np.linalg.svd(b.T @ a / len(a))
    d = np.diag([1, 1, np.sign(np.linalg.det(u @ vt))])
    R = u @ d @ vt
    s = float(np.trace(np.diag(sig) @ d) / ((a**2).sum() / len(a)))
    return s, R, mb - s * R @ ma


def sphere_error(points: np.ndarray, centres: dict, truth: dict) -> dict:
    """Align by the camera centres, fit the sphere near the true one; errors in mm."""
    names = [v["image"] for v in truth["views"] if v["image"] in centres]
    if len(names) < 3:
        return {"error": f"only {len(names)} registered views"}
    true_c = {v["image"]: np.array(v["centre"]) for v in truth["views"]}
    s, R, t = umeyama(np.array([centres[n] for n in names]), np.array([true_c[n] for n in names]))
    cam_rms = float(np.sqrt(np.mean([np.sum((s * R @ centres[n] + t - true_c[n]) ** 2) for n in names])))
    P = s * np.asarray(points, float) @ R.T + t
    sph = truth["spheres"][0]
    c0, r0 = np.array(sph["center"]), sph["diameter"] / 2
    near = P[np.abs(np.linalg.norm(P - c0, axis=1) - r0) < 0.5]
    if len(near) < 10:
        return {"error": f"only {len(near)} points near the sphere", "camera_rms_mm": cam_rms}
    A = np.column_stack([2 * near, np.ones(len(near))])
    sol = np.linalg.lstsq(A, (near**2).sum(1), rcond=None)[0]
    c = sol[:3]
    r = float(np.sqrt(sol[3] + c @ c))
    return {
        "n_points_on_sphere": int(len(near)),
        "radius_error_um": 1000 * (r - r0),
        "centre_error_um": float(1000 * np.linalg.norm(c - c0)),
        "camera_rms_mm": cam_rms,
    }


def plain_pycolmap(images: Path, work: Path, K: np.ndarray | None = None) -> tuple[dict, float]:
    """pycolmap's defaults; with ``K`` its one change: the focal length and principal point
    given (SIMPLE_PINHOLE) and held in bundle adjustment."""
    import pycolmap

    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    t0 = time.perf_counter()
    db = work / "db.db"
    reader, opts = pycolmap.ImageReaderOptions(), pycolmap.IncrementalPipelineOptions()
    if K is not None:
        reader.camera_model = "SIMPLE_PINHOLE"
        reader.camera_params = f"{K[0, 0]},{K[0, 2] + 0.5},{K[1, 2] + 0.5}"  # COLMAP: pixel centres at +0.5
        opts.ba_refine_focal_length = opts.ba_refine_extra_params = False
    pycolmap.extract_features(db, images, camera_mode=pycolmap.CameraMode.SINGLE, reader_options=reader)
    pycolmap.match_exhaustive(db)
    maps = pycolmap.incremental_mapping(db, images, work / "sparse", options=opts)
    dt = time.perf_counter() - t0
    if not maps:
        return {"n_registered": 0}, dt
    rec = max(maps.values(), key=lambda m: m.num_reg_images())
    centres = {im.name: np.asarray(im.projection_center()) for im in rec.images.values() if im.has_pose}
    pts = np.array([p.xyz for p in rec.points3D.values()])
    return {"n_registered": len(centres), "centres": centres, "points": pts}, dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--downscale", type=float, default=2.0)
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--supersample", type=int, default=1)
    ap.add_argument("--work", default="/tmp/camcmm_bench_dslr")
    ap.add_argument("--known-focal", action="store_true", help="also plain pycolmap with the focal length given")
    ap.add_argument("--skip-ours", action="store_true", help="only the pycolmap references")
    args = ap.parse_args()
    work = Path(args.work)
    img_dir = work / "images"
    host = default_host()
    params = {
        "out": str(img_dir),
        "artefact": "sphere",
        "n_images": args.n,
        "downscale": args.downscale,
        "supersample": args.supersample,
        "seed": 4,
    }
    stamp = work / "settings.json"
    if not (stamp.is_file() and json.loads(stamp.read_text()) == params):
        t0 = time.perf_counter()
        host.run("virtuallab.turntable-series", {}, params)
        stamp.write_text(json.dumps(params))
        print(f"rendered {args.n} images in {time.perf_counter() - t0:.0f} s")
    truth = json.loads((img_dir / "truth.json").read_text())
    files = sorted(str(p) for p in img_dir.glob("image*.png"))
    w, h = truth["camera"]["width"], truth["camera"]["height"]
    print(f"{len(files)} images {w} x {h} px ({w * h / 1e6:.1f} MP); speckle {truth['speckle']}")

    t_ours = float("nan")
    if not args.skip_ours:
        t_ours = run_ours(host, files, img_dir, truth, w, h)
    plain, t_plain = plain_pycolmap(img_dir, work / "plain")
    err = sphere_error(plain["points"], plain["centres"], truth) if plain["n_registered"] else {}
    reg = f"{plain['n_registered']}/{len(files)}"
    print(f"plain pycolmap (defaults, sparse only): {t_plain:.0f} s, registered {reg}, sphere {err}")
    print(f"time ratio reconstruct / plain pycolmap: {t_ours / t_plain:.2f}")
    if args.known_focal:
        K = np.array(truth["views"][0]["K"])
        kp, t_kp = plain_pycolmap(img_dir, work / "plain_known", K)
        err = sphere_error(kp["points"], kp["centres"], truth) if kp["n_registered"] else {}
        print(f"plain pycolmap, focal known: {t_kp:.0f} s, registered {kp['n_registered']}/{len(files)}, sphere {err}")
    print(f"peak memory (ru_maxrss): {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


def run_ours(host, files, img_dir: Path, truth: dict, w: int, h: int) -> float:
    t0 = time.perf_counter()
    res = host.run(
        "photogrammetry.reconstruct",
        {"images": files, "calibration": str(img_dir / "calibration.yaml")},
        {"dense": True, "max_image_size": max(w, h)},
    )
    t_ours = time.perf_counter() - t0
    rec = res.outputs["reconstruction"]
    centres = {v["image"]: np.array(v["centre"], float) for v in rec["views"]}
    cloud = res.outputs["cloud"]
    ours = sphere_error(np.asarray(cloud.points), centres, truth)
    print(
        f"photogrammetry.reconstruct: {t_ours:.0f} s ({rec.get('timings')}), registered "
        f"{rec['n_registered']}/{rec['n_images']}, dense points {rec.get('n_points_dense')}, sphere {ours}"
    )
    return t_ours


if __name__ == "__main__":
    main()
