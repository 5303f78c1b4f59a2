"""``camcmm photogrammetry reconstruct|import``

* ``reconstruct IMAGES... [--calibration CAL.yaml] [--dense/--sparse-only]
  [--scale spheres:R1,R2|lengths:FILE|bar:L] [--max-image-size PX] [--dense-max-image-size PX]
  [--turntable-angles DEG,...|step:D] [--out cloud.ply] [--project DIR] [--json]``: runs the
  plugin that provides ``photogrammetry`` (camcmm's ``photogrammetry.reconstruct``) through
  the host (so the result carries its provenance); its declared parameters are the options,
  with the manifest's help, limits and defaults (``camcmm photogrammetry reconstruct
  --help``; ``--sparse-only`` is ``--dense`` false). JSON keys ``n_images, n_registered, unregistered,
  reprojection_rms_px, camera {model fx fy cx cy dist}, views [{image R t centre}],
  n_points_sparse, n_points_dense, scale {method factor u}, warnings, timings`` (+ ``images``
  per-image feature/match counts, ``plugin``, ``written``, ``result_id``). IMAGES may be
  files or folders (their image files in natural order).
* ``import PATH [--out cloud.ply] [--json]``: a COLMAP model folder or a Metashape export
  (``photogrammetry.import``).

``--project DIR`` records the run (outputs and provenance) in a project folder only after the
whole reconstruction succeeded (nothing half-written), with ``camcmm.api.record_result``.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Any

from camcmm.api import InputError, add_declared_options, declared_values, default_host, record_result, write

IMAGE_EXTS = (".png", ".bmp", ".tif", ".tiff", ".jpg", ".jpeg", ".pgm", ".ppm")
#: The task ``camcmm photogrammetry reconstruct`` runs: its provider's parameters are the options.
TASK = "photogrammetry"
#: ``--dense`` (the declared bool, given without a value) and its opposite, as before.
SPARSE_ONLY = ("--sparse-only", "stop after structure from motion (dense false)")


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{reconstruct,import}")
    r = sub.add_parser("reconstruct", help="structure from motion (+ dense cloud, + scale) of an image series")
    r.add_argument("images", nargs="+", help="image files or folders of one camera's series (3 or more)")
    r.add_argument("--calibration", metavar="CAL", help="hold the camera fixed to this calibration (camcmm calibrate)")
    # --dense/--sparse-only, --max-image-size, --scale, --matching, --camera-model ...: every
    # declared parameter of the reconstruction, with the manifest's help, limits and default
    add_declared_options(r, default_host().provider(TASK).parameters, negations={"dense": SPARSE_ONLY})
    r.add_argument("--out", metavar="cloud.ply", help="write the cloud (dense, or sparse with --sparse-only)")
    r.add_argument("--project", metavar="DIR", help="record the result in this project folder")
    i = sub.add_parser("import", help="read a COLMAP model or a Metashape export")
    i.add_argument("path", help="COLMAP model folder, Metashape point cloud or camera XML")
    i.add_argument("--out", metavar="cloud.ply", help="write the imported cloud")
    for sp in (r, i):
        sp.add_argument(
            "--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout"
        )


def image_files(items: list[str]) -> list[str]:
    """The image files named, folders expanded (natural order: img2 before img10)."""

    def key(p: Path):
        return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", p.name)]

    out: list[str] = []
    for it in items:
        p = Path(it)
        if p.is_dir():
            files = sorted((f for f in p.iterdir() if f.is_file() and f.suffix.lower() in IMAGE_EXTS), key=key)
            if not files:
                raise InputError(f"{p}: no image files ({', '.join(IMAGE_EXTS)})")
            out += [str(f) for f in files]
        elif p.is_file():
            out.append(str(p))
        else:
            raise InputError(f"{p}: no such image file or folder")
    return out


def run(args: argparse.Namespace) -> dict[str, Any]:
    host = default_host()
    if args.what == "import":
        if not Path(args.path).exists():
            raise InputError(f"{args.path}: no such file or folder")
        res = host.run("photogrammetry.import", {"path": str(args.path)}, {})
        out = dict(res.outputs["reconstruction"])
        out["n_points"] = res.outputs["cloud"].n_points
        out["warnings"] = res.warnings
        if args.out:
            write(res.outputs["cloud"], args.out)
            out["written"] = {"cloud": str(args.out)}
        return out
    params = declared_values(args, host.provider(TASK).parameters)  # checked first: a bad value reads no image
    files = image_files(args.images)
    inputs: dict[str, Any] = {"images": files}
    if args.calibration:
        if not Path(args.calibration).is_file():
            raise InputError(f"{args.calibration}: calibration file not found")
        inputs["calibration"] = str(args.calibration)
    res = host.run_task(TASK, inputs, params)
    o = res.outputs
    out = dict(o["reconstruction"])
    out["warnings"] = list(res.warnings)
    out["plugin"] = res.provenance()
    if args.out:
        write(o["cloud"], args.out)
        out["written"] = {"cloud": str(args.out)}
    if args.project:
        out["result_id"] = record_result(args.project, res)
    return out


def text(r: dict[str, Any]) -> str:
    """Human-readable summary."""
    if "n_registered" not in r:  # import
        lines = [f"imported {r.get('n_points', 0)} points, {len(r.get('views', []))} views"]
    else:
        c = r["camera"]
        lines = [
            f"{r['n_registered']} of {r['n_images']} images registered, reprojection RMS "
            f"{r['reprojection_rms_px']:.3f} px",
            f"  camera {c['model']}: fx {c['fx']:.2f} fy {c['fy']:.2f} cx {c['cx']:.2f} cy {c['cy']:.2f} px, "
            "dist " + ", ".join(f"{v:.4g}" for v in c["dist"]),
            f"  points: {r['n_points_sparse']} sparse, {r['n_points_dense']} dense",
        ]
        s = r["scale"]
        if s["method"] != "none":
            lines.append(f"  scale ({s['method']}): {s['factor']:.6g} mm per unit, u {s['u']:.3g}")
        tt = r.get("turntable")
        if tt:
            lines.append(
                f"  turntable: {tt['n_views']} views within {tt['angle_rms_deg']:.2f} deg RMS "
                f"(max {tt['angle_max_deg']:.2f}) of their table angles"
            )
        for name, why in r["unregistered"].items():
            lines.append(f"  not registered: {name} ({why})")
        lines.append("  times: " + ", ".join(f"{k} {v:.1f} s" for k, v in r["timings"].items()))
    for w in r.get("warnings", []):
        lines.append(f"  warning: {w}")
    if r.get("written"):
        lines.append("  wrote " + ", ".join(r["written"].values()))
    if r.get("result_id") is not None:
        lines.append(f"  recorded as result {r['result_id']}")
    return "\n".join(lines)
