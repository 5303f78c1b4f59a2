"""Plugin entry points: thin wrappers of :mod:`camcmm_plugins.fitting.api` for the host.

Each ``fit_*`` returns the JSON document of ``camcmm fit`` (lengths in mm; numpy
arrays are converted by the host) plus ``deviations``: the input cloud with the
per-point fields ``deviation`` (signed residual, mm) and ``outlier`` (1 for points the
outlier rule removed), for a deviation colour map. A mesh given as the cloud is fitted
by its vertices, with a warning (see source.py). Errors are not prefixed with the
cloud's name here: callers that fit many clouds (vdi2634) name them with their own
context, and ``camcmm fit`` names its file.

The parameters' defaults are in plugin.yaml only: the host always passes every
declared parameter, validated, so the entry functions take them keyword-only without
repeating a default that could drift.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import PointCloud, to_jsonable

from . import api
from .source import as_cloud


def _points(cloud: Any) -> np.ndarray:
    return cloud.points if hasattr(cloud, "points") else np.asarray(cloud, dtype=float)


def _input(ctx, cloud: Any, what: str) -> Any:
    """The input as a cloud (a mesh's vertices, with a warning), for fitting ``what``."""
    cloud, note = as_cloud(cloud, what)
    if note:
        ctx.warn(note)
    return cloud


def _deviations(cloud: Any, res: api.FitResult) -> PointCloud | None:
    if not isinstance(cloud, PointCloud) or cloud.points.shape[1] != 3:
        return None
    fields = dict(cloud.fields)
    fields["deviation"] = res.residuals
    fields["outlier"] = (~res.used).astype(np.uint8)
    units = dict(cloud.field_units)
    units["deviation"] = "mm"
    return PointCloud(
        cloud.points, cloud.colors, cloud.normals, fields, units, f"{cloud.name} deviations", cloud.source_unit
    )


def _fit(
    ctx, element: str, cloud: Any, outliers: str, method: str = "ls", nominal_radius: float | None = None, **kw: Any
) -> dict[str, Any]:
    ctx.progress(0.05, f"{element} fit")
    cloud = _input(ctx, cloud, element)
    res = api.fit(element, _points(cloud), outliers, method, nominal_radius=nominal_radius, **kw)
    out = res.to_dict()
    for w in out.pop("warnings", []):  # the host's result warnings: CLI JSON and GUI
        ctx.warn(w)
    out["removed_indices"] = res.removed
    # the parameters' covariance (least squares; None for minimum zone) over the model's
    # local parameters named in covariance_names (mm, rad): what an uncertainty of a
    # derived quantity (a GD&T characteristic) propagates from
    out["covariance"] = to_jsonable(res.covariance)
    out["covariance_names"] = list(res.covariance_names)
    dev = _deviations(cloud, res)
    if dev is not None:
        out["deviations"] = dev
    return out


def fit_line(ctx, cloud, *, outliers: str) -> dict[str, Any]:
    return _fit(ctx, "line", cloud, outliers)


def fit_plane(ctx, cloud, *, outliers: str, method: str) -> dict[str, Any]:
    return _fit(ctx, "plane", cloud, outliers, method)


def fit_circle(ctx, cloud, *, outliers: str, nominal_radius: float | None) -> dict[str, Any]:
    return _fit(ctx, "circle", cloud, outliers, nominal_radius=nominal_radius)


def fit_sphere(
    ctx, cloud, *, outliers: str, method: str, nominal_radius: float | None, extract: bool
) -> dict[str, Any]:
    if extract:
        ctx.progress(0.02, "extracting the sphere")
        cloud = _input(ctx, cloud, "sphere")
        seg = api.extract_sphere(_points(cloud), nominal_radius)
        sub = cloud.subset(seg.indices) if isinstance(cloud, PointCloud) else _points(cloud)[seg.indices]
        out = _fit(ctx, "sphere", sub, outliers, method, nominal_radius)
        out["n_points_raw"] = len(_points(cloud))
        out["n_extracted_away"] = out["n_points_raw"] - len(seg.indices)
        out["extracted_indices"] = seg.indices
        return out
    return _fit(ctx, "sphere", cloud, outliers, method, nominal_radius)


def fit_cylinder(ctx, cloud, *, outliers: str, nominal_radius: float | None) -> dict[str, Any]:
    return _fit(ctx, "cylinder", cloud, outliers, nominal_radius=nominal_radius)


def fit_cone(ctx, cloud, *, outliers: str, method: str) -> dict[str, Any]:
    return _fit(ctx, "cone", cloud, outliers, method)


def fit_torus(ctx, cloud, *, outliers: str, method: str) -> dict[str, Any]:
    return _fit(ctx, "torus", cloud, outliers, method)


def segment_spheres(
    ctx, cloud, *, nominal_radius: float, n_spheres: int | None, tolerance: float | None, min_points: int
) -> dict[str, Any]:
    """Split a ball-bar or ball-plate cloud into its spheres."""
    ctx.progress(0.05, "detecting spheres")
    cloud = _input(ctx, cloud, "sphere")
    seg = api.segment_spheres(
        _points(cloud), nominal_radius, n_spheres=n_spheres, tolerance=tolerance, min_points=min_points
    )
    for note in seg.notes:
        ctx.warn(note)
    out: dict[str, Any] = {
        "n_spheres": len(seg.spheres),
        "spheres": [s.to_dict() for s in seg.spheres],
        "labels": seg.labels,
    }
    if isinstance(cloud, PointCloud):
        out["clouds"] = [cloud.subset(s.indices) for s in seg.spheres]
    return out


def segment_sphere(
    ctx,
    cloud,
    *,
    nominal_radius: float | None,
    tolerance: float | None,
    viewpoint: list[float] | None,
    cone_half_angle: float | None,
) -> dict[str, Any]:
    """Extract the sphere from a raw scan holding its mount and background."""
    ctx.progress(0.05, "extracting the sphere")
    cloud = _input(ctx, cloud, "sphere")
    seg = api.extract_sphere(
        _points(cloud), nominal_radius, tolerance=tolerance, viewpoint=viewpoint, cone_half_angle=cone_half_angle
    )
    out = seg.to_dict()
    out["n_points_raw"] = len(_points(cloud))
    out["n_extracted_away"] = out["n_points_raw"] - len(seg.indices)
    if isinstance(cloud, PointCloud):
        out["cloud"] = cloud.subset(seg.indices)
    return out
