"""One case of the speckle study (thesis ch. 6.2.2): capture (or read) the turntable
series, reconstruct, align to the CAD with scale, signed cloud-to-mesh deviations, and
the area coverage per face class. Every other plugin is reached through the host.

Alignment ("auto"): photogrammetry has no scale, so the fine alignment is the
inspection's ICP with one uniform scale (``similarity``). Its start, the thesis's manual
coarse registration, is a set of point pairs: in the virtual lab the reconstructed
camera centres against the true ones (truth.json), for real captures the three points a
user picked (``pairs`` in the study file); without pairs FPFH features
(``global+similarity``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import GeometryError, InputError, PointCloud, TriangleMesh


def cad(ctx, artefact: str, sizes: dict[str, Any]) -> dict[str, Any]:
    """The CAD mesh and its face classes (virtuallab.am-artefact)."""
    return ctx.algorithm("virtuallab.am-artefact")(artefact=artefact, sizes=sizes or None)


def coverage_by_class(
    covered: np.ndarray, triangle: np.ndarray, face_class: np.ndarray, classes: list[str]
) -> dict[str, float | None]:
    """Covered share of each face class's area: the area-uniform surface samples
    (inspection's coverage, each standing for the same area) of the class that are
    covered, over all of its samples; None for a class without area."""
    cls = np.asarray(face_class)[np.asarray(triangle, np.int64)]
    cov = np.asarray(covered, bool)
    return {c: (float(cov[cls == i].mean()) if np.any(cls == i) else None) for i, c in enumerate(classes)}


def visible_fraction(covered: np.ndarray, triangle: np.ndarray, face_class: np.ndarray, classes: list[str]) -> float:
    """Covered share of the area a camera above the table can see (all but ``bottom``)."""
    cls = np.asarray(face_class)[np.asarray(triangle, np.int64)]
    keep = cls != classes.index("bottom")
    return float(np.asarray(covered, bool)[keep].mean())


def capture(ctx, study: dict[str, Any], case: dict[str, Any], folder: Path) -> dict[str, Any]:
    """The case's images: rendered into ``folder`` (simulated) or the study's folder."""
    if study["simulated"] is not None:
        sim = study["simulated"]
        res = ctx.algorithm("virtuallab.turntable-series")(
            out=str(folder / "images"),
            artefact=case["artefact"],
            material=case["material"],
            speckle=case["condition"] == "on",
            sizes=case["sizes"] or None,
            **sim,
        )
        truth = json.loads(Path(res["truth"]).read_text("utf-8"))
        centres = {v["image"]: v["centre"] for v in truth["views"]}
        return {"files": res["files"], "centres": centres, "pairs": None}
    src = study["images"][case["id"]]
    exts = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"}
    files = sorted(str(f) for f in Path(src["folder"]).iterdir() if f.suffix.lower() in exts)
    if len(files) < 3:
        raise InputError(f"{src['folder']}: {len(files)} images (need at least 3) for case {case['id']}")
    return {"files": files, "centres": None, "pairs": src.get("pairs")}


def run_case(ctx, study: dict[str, Any], case: dict[str, Any], folder: Path) -> dict[str, Any]:
    """Compute one case; returns its result (JSON-able) and its deviation cloud."""
    t0 = time.perf_counter()
    nominal = cad(ctx, case["artefact"], case["sizes"])
    cap = capture(ctx, study, case, folder)
    t1 = time.perf_counter()
    rec = ctx.algorithm("photogrammetry.reconstruct")(images=cap["files"], **study["reconstruct"])
    t2 = time.perf_counter()
    cloud: PointCloud = rec["cloud"]
    info = rec.get("reconstruction") or {}
    method = study["align"]["method"]
    pairs = cap["pairs"]
    if cap["centres"] is not None:
        views = [v for v in info.get("views") or [] if Path(str(v["image"])).name in cap["centres"]]
        if len(views) >= 3:
            pairs = {
                "measured": [list(map(float, v["centre"])) for v in views],
                "nominal": [cap["centres"][Path(str(v["image"])).name] for v in views],
            }
    if method == "auto":
        method = "pairs+similarity" if pairs else "global+similarity"
    if cloud.n_points < 10:
        raise GeometryError(f"case {case['id']}: the reconstruction has {cloud.n_points} points")
    mesh: TriangleMesh = nominal["mesh"]
    extra = {k: v for k, v in study["align"].items() if k != "method"}
    al = ctx.algorithm("inspect.align")(
        cloud=cloud, nominal=mesh, pairs=pairs if method.startswith("pairs") else None, align=method, **extra
    )
    t3 = time.perf_counter()
    cov = study["coverage"]
    dv = ctx.algorithm("inspect.deviations")(
        cloud=al["aligned"],
        nominal=mesh,
        coverage_distance=float(cov["distance"]) or None,
        coverage_samples=int(cov["samples"]),
    )
    t4 = time.perf_counter()
    cc = dv["coverage_cloud"]
    fc = np.asarray(nominal["face_class"])
    tri = np.asarray(cc.fields["triangle"], np.int64)
    if tri.max() >= len(fc):
        raise GeometryError(f"case {case['id']}: the coverage samples name triangles the CAD does not have")
    classes = list(nominal["face_classes"])
    dev = np.asarray(dv["deviations"].fields["deviation"], float)
    result = {
        "id": case["id"],
        "artefact": case["artefact"],
        "material": case["material"],
        "condition": case["condition"],
        "std_um": float(np.std(dev) * 1000.0),
        "mean_um": float(np.mean(dev) * 1000.0),
        "n_points": int(cloud.n_points),
        "coverage_area_fraction": visible_fraction(cc.fields["covered"], tri, fc, classes),
        "coverage_by_face": coverage_by_class(cc.fields["covered"], tri, fc, classes),
        "coverage_distance_mm": float(dv["coverage_info"]["distance"]),
        "class_areas_mm2": nominal["class_areas"],
        "n_images": len(cap["files"]),
        "n_registered": len(info.get("views") or []),
        "alignment": {
            "method": method,
            "scale": float(al["scale"]),
            "rms_um": float(al["rms"]) * 1000.0,
            "converged": bool(al["converged"]),
            "transform": np.asarray(al["transform"]).tolist(),
        },
        "timings": {"capture_s": t1 - t0, "reconstruct_s": t2 - t1, "align_s": t3 - t2, "deviations_s": t4 - t3},
    }
    if not al["converged"]:
        result["warning"] = f"case {case['id']}: the alignment did not converge ({al['reason']})"
    return {"result": result, "deviations": dv["deviations"]}
