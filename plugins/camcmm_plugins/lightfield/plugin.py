"""Host entries of ``lightfield.gradient`` and ``lightfield.study`` (plugin.yaml, docs/studies.md)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from camcmm.api import InputError, PointCloud

from . import depthmap, lytro
from . import gradient as grad
from . import study as study_mod


def _polygon(text: str) -> list | None:
    if not text or not str(text).strip():
        return None
    try:
        p = json.loads(text)
    except ValueError:
        raise InputError(f"polygon {text!r}: give JSON [[u, v], [u, v], [u, v], ...] (px)") from None
    depthmap.polygon_mask(p, (2, 2))  # the shape check, one line
    return p


def gradient(
    ctx,
    cloud: PointCloud,
    views: Any,
    depth_maps: Any,
    *,
    lambda_range: str = "",
    lambda_convention: str = "eq6.5",
    band: float = 0.5,
    robust: bool = True,
    depth_measure: str = "distance",
    tolerance: float = 0.002,
    scale: float = 1.0,
    region: str = "all",
    region_tolerance: float = 0.5,
    polygon: str = "",
    scatter_points: int = 1000,
    min_pixels: int = 100,
    sigma_lambda: float = 0.0,
) -> dict[str, Any]:
    """lightfield.gradient: see plugin.yaml and docs/studies.md."""
    if cloud.n_points == 0:
        raise InputError(f"{cloud.name or 'cloud'}: no points")
    rng = lytro.parse_range(lambda_range)
    poly = _polygon(polygon)
    ctx.progress(0.02, "reading the views")

    def importer(path: str) -> dict:
        return ctx.algorithm("photogrammetry.import")(path=path)["reconstruction"]

    vs = grad.load_views(views, importer)
    pts = np.asarray(cloud.points, float)
    keep = None
    if region == "plane":
        ctx.progress(0.04, "selecting the flat region")
        keep = depthmap.plane_points(pts * float(scale), float(region_tolerance))
    out = grad.gradients(
        pts,
        vs,
        depth_maps,
        lambda_range=rng,
        convention=lambda_convention,
        band=float(band),
        robust=bool(robust),
        measure=depth_measure,
        tolerance=float(tolerance),
        scale=float(scale),
        keep=keep,
        polygon=poly,
        scatter_points=int(scatter_points),
        min_pixels=int(min_pixels),
        sigma_lambda=float(sigma_lambda),
        progress=ctx.progress,
    )
    res = out["result"]
    res.update(
        lambda_convention=lambda_convention,
        band=float(band),
        depth_measure=depth_measure,
        region=region,
        sigma_lambda=float(sigma_lambda),
        n_points_region=int(keep.sum()) if keep is not None else cloud.n_points,
    )
    for name, why in res["skipped"].items():
        ctx.warn(f"{name}: skipped ({why})")
    if res["std"] is not None and res["mean"] and abs(res["std"] / res["mean"]) > 0.05:
        ctx.warn(
            f"the views' gradients scatter by {100 * res['std'] / res['mean']:.1f} % of their mean "
            "(the thesis saw 1-2 %): check the region, the lambda band and the scale"
        )
    low = [r["image"] for r in res["views"] if not r["r2"] >= 0.9]  # NaN (depth constant over the view) too
    if low:
        ctx.warn(f"{len(low)} view(s) with r2 < 0.9 (depth not linear in lambda there): {', '.join(low[:5])}")
    res["warnings"] = list(ctx.warnings)
    return out


def study(ctx, study: Any, *, predict_focal_mm: float | None = None, **params: Any) -> dict[str, Any]:
    """lightfield.study: see plugin.yaml and docs/studies.md."""
    alg = ctx.algorithm("lightfield.gradient")
    out = study_mod.run_study(study, alg, predict_focal_mm=predict_focal_mm, params=params, progress=ctx.progress)
    if out["focal"] is None:
        ctx.warn("fewer than two focal lengths: no gradient-against-focal-length fit")
    tab = out["table"]
    for s, sd, m in zip(tab["sets"], tab["std"], tab["mean"]):
        if sd is not None and m and sd / m > 0.05:
            ctx.warn(f"{s}: the artefacts' gradients scatter by {100 * sd / m:.1f} % (the thesis: 1-2 %)")
    out["warnings"] = list(ctx.warnings)
    return {
        "table": tab,
        "focal": out["focal"],
        "runs": out["runs"],
        "scatter": out["scatter"],
        "truth": out["truth"],
        "result": {k: out[k] for k in ("name", "table", "focal", "truth", "warnings")},
    }
