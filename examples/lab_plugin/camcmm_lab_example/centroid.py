"""The lab's algorithm: plain numpy, using only camcmm's public API."""

import numpy as np

from camcmm.api import GeometryError, PointCloud, RunContext


def run(ctx: RunContext, cloud: PointCloud, trim_percent: float) -> dict:
    """Centroid (mm) and axis-aligned extent (mm) of the points that lie inside the
    [trim, 100 - trim] percentiles on every axis."""
    p = cloud.points
    lo, hi = np.percentile(p, [trim_percent, 100.0 - trim_percent], axis=0)
    keep = np.all((p >= lo) & (p <= hi), axis=1)
    if not keep.any():
        raise GeometryError(f"{cloud.name}: no point left after trimming {trim_percent} %")
    ctx.progress(0.5, "trimmed")
    q = p[keep]
    return {"centroid": q.mean(axis=0), "extent": q.max(axis=0) - q.min(axis=0), "n_used": int(keep.sum())}
