"""Benchmark: structure from motion on templeRing (47 views x 0.3 MP) against plain pycolmap,
and on a long virtual turntable series where the global mapper should pull ahead (issue 29).

In one run, on the same images (../shared/data/middlebury_mvs_templering, the views in the
orientation their gantry cameras describe):

* plain pycolmap as a user would call it (one shared SIMPLE_RADIAL camera:
  ``extract_features(camera_mode=SINGLE)``, ``match_exhaustive``, ``incremental_mapping``),
  timed as features + matching and mapping; then, on the same database, COLMAP 4's global
  mapper (``pycolmap.global_mapping``) as the second plain reference;
* camcmm's ``reconstruct_sparse`` with its defaults (ring matching: each view with its 8 most
  alike by visual words, incremental mapper, robust final adjustment), self-calibrating;
* the same with ``mapper="global"``;
* the same as the first with the gantry's intrinsics held fixed;

each with its wall time and CPU time (user + system of this process, all threads: less
sensitive than the wall time to other jobs on a shared machine) and, after a 7-parameter
similarity onto the gantry's camera centres,
the centre RMS in % of the ring radius (target <= 0.25 %), the largest orientation error and
the focal length's deviation from the gantry's, and the ratios camcmm / plain pycolmap
(target: whole SfM <= 0.5x plain's exhaustive + incremental).

``--virtual N`` adds a virtual turntable series of N views through 360 deg
(``virtuallab.turntable-series``: the 10 mm carbide sphere with its two scale spheres under
laser speckle, 600 x 400 px, rendered once into ``--work``) reconstructed with the camera's
calibration by camcmm's ring matching with the incremental mapper, then with the global mapper
on the same features and matches (so only mapping and refinement differ); centre RMS in % of
the ring radius against the rendered truth. Plain pycolmap's exhaustive matching
is not run there (N(N-1)/2 pairs: 44 850 for 300 views); its time is estimated from
templeRing's rate per pair.

    .venv/bin/python benchmarks/bench_photogrammetry.py [--virtual 300] [--work DIR] [--skip-templering] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from camcmm_plugins.photogrammetry.reference import compare, read_gantry, read_series
from camcmm_plugins.photogrammetry.sfm import reconstruct_sparse

TEMPLE = Path(__file__).resolve().parents[2] / "shared" / "data" / "middlebury_mvs_templering"


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def _views(rec, name_of=lambda n: n) -> list[dict]:
    views = []
    for im in sorted(rec.images.values(), key=lambda i: i.name):
        if not im.has_pose:
            continue
        pose = im.cam_from_world()
        R, t = pose.rotation.matrix(), np.asarray(pose.translation)
        views.append({"image": name_of(im.name), "R": R, "t": t, "centre": -R.T @ t})
    return views


def plain_pycolmap(ims, names) -> dict[str, dict]:
    """pycolmap's defaults on the same images: exhaustive + incremental, then the global
    mapper on the same database (its matching time counted to both)."""
    import cv2
    import pycolmap

    pycolmap.logging.minloglevel = 2
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for im, n in zip(ims, names, strict=True):
            cv2.imwrite(str(root / n), cv2.cvtColor(im, cv2.COLOR_RGB2BGR))
        db = root / "database.db"
        c0, t0 = time.process_time(), time.perf_counter()
        pycolmap.extract_features(db, root, image_names=names, camera_mode=pycolmap.CameraMode.SINGLE)
        t1 = time.perf_counter()
        pycolmap.match_exhaustive(db)
        c2, t2 = time.process_time(), time.perf_counter()
        for mapper in ("incremental", "global"):
            (root / mapper).mkdir()
            c3, t3 = time.process_time(), time.perf_counter()
            if mapper == "incremental":
                recs = pycolmap.incremental_mapping(db, root, root / mapper)
            else:
                recs = pycolmap.global_mapping(db, root, root / mapper)
            c4, t4 = time.process_time(), time.perf_counter()
            rec = max(recs.values(), key=lambda r: r.num_reg_images())
            out[f"plain pycolmap exhaustive + {mapper}"] = {
                "time_s": (t2 - t0) + (t4 - t3),
                "cpu_s": (c2 - c0) + (c4 - c3),
                "timings": {"extract": t1 - t0, "match": t2 - t1, "map": t4 - t3},
                "views": _views(rec),
                "focal": next(iter(rec.cameras.values())).mean_focal_length(),
                "pairs": len(names) * (len(names) - 1) // 2,
            }
    return out


def camcmm_run(ims, names, **kw) -> dict:
    c0, t0 = time.process_time(), time.perf_counter()
    r = reconstruct_sparse(ims, names, **kw)
    return {
        "time_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
        "timings": r.timings,
        "views": r.views,
        "focal": (r.camera["fx"] + r.camera["fy"]) / 2,
        "pairs": r.options.get("pairs_listed", len(names) * (len(names) - 1) // 2),
        "pairs_verified": r.options["pairs_verified"],
        "warnings": r.warnings,
    }


def print_rows(rows: dict, f_ref: float) -> None:
    head = f"{'time s':>7s} {'CPU s':>6s} {'pairs':>6s} {'reg':>4s} {'centre RMS %':>13s} {'max angle':>10s}"
    print(f"{'':40s} {head} {'focal %':>8s}")
    for name, row in rows.items():
        print(
            f"{name:40s} {row['time_s']:7.1f} {row.get('cpu_s', float('nan')):6.1f} {row['pairs']:6d} "
            f"{row['n_registered']:4d} {row['centre_rms_pct']:13.3f} "
            f"{row['max_angle_deg']:9.2f}° {100 * (row['focal'] / f_ref - 1):+8.2f}"
        )
        print(f"{'':40s} stages: " + ", ".join(f"{k} {v:.1f}" for k, v in row["timings"].items()))


def templering() -> dict:
    gantry = read_gantry(TEMPLE)
    ims, names = read_series(TEMPLE)
    K = gantry[names[0]][0]
    f_ref = (K[0, 0] + K[1, 1]) / 2
    size = f"{ims[0].shape[1]}x{ims[0].shape[0]} px"
    print(f"templeRing: {len(names)} views {size}; gantry focal {f_ref:.1f} px; {load()}")
    rows = plain_pycolmap(ims, names)
    rows["camcmm (ring, incremental)"] = camcmm_run(ims, names)
    rows["camcmm (ring, global)"] = camcmm_run(ims, names, mapper="global")
    cal = {"camera_matrix": K, "dist_coeffs": np.zeros(5), "image_size": (640, 480)}
    rows["camcmm (ring, incremental), gantry K fixed"] = camcmm_run(ims, names, calibration=cal)
    for row in rows.values():
        row.update(compare(row["views"], gantry), n_registered=len(row.pop("views")))
    print_rows(rows, f_ref)
    base = rows["plain pycolmap exhaustive + incremental"]
    ours = rows["camcmm (ring, incremental)"]
    ratios = {
        "time": ours["time_s"] / base["time_s"],
        "time_global": rows["camcmm (ring, global)"]["time_s"] / base["time_s"],
        "cpu": ours["cpu_s"] / base["cpu_s"],
        "centre_rms": ours["centre_rms_pct"] / base["centre_rms_pct"],
    }
    print(
        f"ratios camcmm / plain pycolmap (exhaustive + incremental): time {ratios['time']:.2f} "
        f"(global mapper {ratios['time_global']:.2f}), CPU time {ratios['cpu']:.2f}, "
        f"centre RMS {ratios['centre_rms']:.2f}; "
        f"{load()}"
    )
    targets = {
        "time_le_0p5x_plain": bool(ratios["time"] <= 0.5),
        "centre_rms_le_0p25pct": bool(ours["centre_rms_pct"] <= 0.25),
        "global_centre_rms_le_0p25pct": bool(rows["camcmm (ring, global)"]["centre_rms_pct"] <= 0.25),
        "focal_within_2pct": bool(abs(ours["focal"] / f_ref - 1) <= 0.02),
    }
    print("targets: " + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in targets.items()))
    # plain exhaustive matching's time per pair, for the estimate on long series
    rate = base["timings"]["match"] / base["pairs"]
    return {"runs": rows, "ratios": ratios, "targets": targets, "plain_match_s_per_pair": rate}


def global_on_the_same_matches(sfm_dir: Path, names: list[str], incremental: dict) -> dict:
    """camcmm's global mapper and final adjustment (calibrated camera) on the features and
    matches of the incremental run in ``sfm_dir``: the same work as
    ``reconstruct_sparse(mapper="global")`` without extracting and matching again (300 views
    on a shared 2-core machine), so only the mapping and refinement differ."""
    import shutil

    import pycolmap

    from camcmm_plugins.photogrammetry import sfm

    db = sfm_dir / "database_global.db"
    shutil.copy(sfm_dir / "database.db", db)
    out = sfm_dir / "sparse_global"
    out.mkdir(exist_ok=True)
    t0 = time.perf_counter()
    recs = pycolmap.global_mapping(db, sfm_dir / "images", out, sfm._global_options(pycolmap, 0, True))
    t1 = time.perf_counter()
    rec = max(recs.values(), key=lambda r: r.num_reg_images())
    rec, _ = sfm._final_refinement(pycolmap, rec, True, False)
    t2 = time.perf_counter()
    timings = {k: incremental["timings"][k] for k in ("extract", "match")}
    timings.update(map=t1 - t0, refine=t2 - t1)
    by_file = {f"{i:05d}_{Path(nm).stem}.png": nm for i, nm in enumerate(names)}
    return {
        "time_s": sum(timings.values()),
        "timings": timings,
        "views": _views(rec, lambda f: by_file[f]),
        "focal": incremental["focal"],  # the calibrated camera, held fixed in both
        "pairs": incremental["pairs"],
    }


def virtual_series(n: int, work: Path, rate: float | None) -> dict:
    """camcmm's ring matching with both mappers on an n-view rendered turntable ring."""
    from camcmm.api import default_host, read

    folder = work / f"turntable{n}"
    truth_file = folder / "truth.json"
    if not truth_file.is_file() or json.loads(truth_file.read_text())["turntable"]["n_images"] != n:
        t0 = time.perf_counter()
        params = {
            "out": str(folder),
            "artefact": "sphere_with_scale",
            "n_images": n,
            "arc_deg": 360.0,
            "downscale": 10.0,  # 600 x 400 px
            "magnification": 0.45,  # the three spheres fill about half the frame
            "grain": 0.6,  # mm: ~7 px speckle grains, which SIFT follows
            "supersample": 1,
            "depth_of_field": False,
        }
        default_host().run("virtuallab.turntable-series", {}, params)
        print(f"rendered {n} views in {time.perf_counter() - t0:.0f} s")
    truth = json.loads(truth_file.read_text())
    names = [v["image"] for v in truth["views"]]
    ims = [np.asarray(read(folder / nm).data) for nm in names]
    ref = {v["image"]: (np.array(v["K"]), np.array(v["R"]), np.array(v["t"])) for v in truth["views"]}
    K = ref[names[0]][0]
    cal = {"camera_matrix": K, "dist_coeffs": np.zeros(5), "image_size": (ims[0].shape[1], ims[0].shape[0])}
    print(f"virtual turntable: {n} views {ims[0].shape[1]}x{ims[0].shape[0]} px, camera calibrated; {load()}")
    sfm_dir = work / f"sfm{n}"
    row = camcmm_run(ims, names, calibration=cal, workdir=sfm_dir)
    row.update(compare(row["views"], ref), n_registered=len(row.pop("views")))
    rows = {"camcmm (ring, incremental)": row}
    print(f"  incremental done; {load()}", flush=True)
    row = global_on_the_same_matches(sfm_dir, names, row)
    row.update(compare(row["views"], ref), n_registered=len(row.pop("views")))
    rows["camcmm (ring, global)"] = row
    print(f"  global done; {load()}", flush=True)
    print_rows(rows, (K[0, 0] + K[1, 1]) / 2)
    inc, glo = rows["camcmm (ring, incremental)"], rows["camcmm (ring, global)"]
    out = {
        "runs": rows,
        "mapping_ratio_global_over_incremental": glo["timings"]["map"] / inc["timings"]["map"],
        "total_ratio_global_over_incremental": glo["time_s"] / inc["time_s"],
    }
    print(
        f"global / incremental: mapping {out['mapping_ratio_global_over_incremental']:.2f}, "
        f"whole SfM {out['total_ratio_global_over_incremental']:.2f}; {load()}"
    )
    if rate is not None:
        out["plain_exhaustive_match_estimate_s"] = rate * n * (n - 1) / 2
        print(
            f"plain pycolmap's exhaustive matching of {n * (n - 1) // 2} pairs at templeRing's "
            f"{1000 * rate:.1f} ms per pair: ~{out['plain_exhaustive_match_estimate_s']:.0f} s (estimate, not run)"
        )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--virtual", type=int, default=0, metavar="N", help="also an N-view virtual turntable ring")
    ap.add_argument("--work", default=None, help="folder for the rendered series (kept, reused)")
    ap.add_argument("--skip-templering", action="store_true")
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args()
    result: dict = {}
    rate = None
    if not args.skip_templering:
        if not TEMPLE.is_dir():
            print(f"{TEMPLE} is absent: nothing to measure", file=sys.stderr)
            return 1
        result["templering"] = templering()
        rate = result["templering"]["plain_match_s_per_pair"]
    if args.virtual:
        work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="camcmm-bench-sfm-"))
        result["virtual"] = virtual_series(args.virtual, work, rate)
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
