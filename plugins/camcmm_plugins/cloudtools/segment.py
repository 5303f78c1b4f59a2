"""Connected components of a cloud by density (DBSCAN; Ester, Kriegel, Sander & Xu, KDD
1996) through Open3D's ``cluster_dbscan``: two points are neighbours within ``eps`` mm, a
core point has at least ``min_points`` neighbours (itself included), a component is what
core points reach; the rest is noise.

Components are numbered by size, largest first (ties: the one holding the lower point
index first), so that "component 1" means the same whatever order Open3D found them in.
"""

from __future__ import annotations

import numpy as np
import open3d as o3d

from camcmm.api import GeometryError, ParameterError, PointCloud, RunContext, check_budget

from .crop import kept_cloud

#: Points sampled to estimate the neighbour lists' memory before clustering.
SAMPLE = 2000
#: Bytes Open3D keeps per neighbour (an int in a std::vector per point, with slack) and per point.
BYTES_PER_NEIGHBOUR, BYTES_PER_POINT = 8, 64


def neighbour_memory(pc, eps: float, rng: np.random.Generator) -> float:
    """Bytes the neighbour lists of all points within ``eps`` will take, estimated from a
    sample of :data:`SAMPLE` points: DBSCAN holds every list at once, and an ``eps`` far
    above the point spacing would otherwise exhaust the memory before any answer."""
    n = len(pc.points)
    tree = o3d.geometry.KDTreeFlann(pc)
    pick = rng.choice(n, size=min(SAMPLE, n), replace=False)
    pts = np.asarray(pc.points)
    counts = [tree.search_radius_vector_3d(pts[i], eps)[0] for i in pick]
    return n * (BYTES_PER_POINT + BYTES_PER_NEIGHBOUR * float(np.mean(counts)))


def ranked_labels(labels: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Open3D's labels renumbered 0, 1, ... by size, largest first (noise stays -1), and the sizes."""
    labels = np.asarray(labels, dtype=np.int64)
    valid = labels >= 0
    if not valid.any():
        return labels, []
    sizes = np.bincount(labels[valid])
    first = np.full(len(sizes), len(labels))
    np.minimum.at(first, labels[valid], np.flatnonzero(valid))
    order = np.lexsort((first, -sizes))  # by size descending, then by first point
    rank = np.empty(len(sizes), dtype=np.int64)
    rank[order] = np.arange(len(sizes))
    out = np.full(len(labels), -1, dtype=np.int64)
    out[valid] = rank[labels[valid]]
    return out, [int(s) for s in sizes[order]]


def components(ctx: RunContext, cloud: PointCloud, *, eps: float, min_points: int, keep: str, component: int) -> dict:
    """Keep the largest component (``keep: largest``), component number ``component``
    (``keep: component``; 1 is the largest), or every point with its component number as
    the field ``component`` (``keep: all``; 0 is noise)."""
    if cloud.n_points == 0:
        raise GeometryError(f"{cloud.name}: no points to segment")
    pc = cloud.to_open3d()
    check_budget(
        f"segment.components: eps = {eps:g} mm on {cloud.n_points} points",
        neighbour_memory(pc, eps, np.random.default_rng(0)),
    )
    ctx.progress(0.1, "clustering")
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        labels = np.asarray(pc.cluster_dbscan(eps=eps, min_points=min_points, print_progress=False))
    rank, sizes = ranked_labels(labels)
    n_noise = int(np.sum(rank < 0))
    counts = {"n_components": len(sizes), "sizes": sizes, "n_noise": n_noise}
    if not sizes:
        raise GeometryError(
            f"{cloud.name}: no component with eps = {eps:g} mm and min_points = {min_points}: every point is noise "
            "(raise eps or lower min_points)"
        )
    if keep == "all":
        out = cloud.subset(slice(None))
        out.fields = {**out.fields, "component": (rank + 1).astype(float)}
        out.field_units = {**out.field_units, "component": ""}
        out.name = f"{cloud.name} · components"
        return {"cloud": out, "n_kept": cloud.n_points, "n_removed": 0, **counts}
    number = 1 if keep == "largest" else int(component)
    if number > len(sizes):
        raise ParameterError(
            f"segment.components: parameter 'component' = {number}, but there are {len(sizes)} components"
        )
    label = "largest component" if keep == "largest" else f"component {number} of {len(sizes)}"
    return {**kept_cloud(ctx, cloud, rank == number - 1, label, label), **counts}
