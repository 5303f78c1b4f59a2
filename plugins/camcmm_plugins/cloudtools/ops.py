"""Entry callables of the cloudtools plugins: thin wrappers over Open3D. Parameters are
keyword-only without defaults (plugin.yaml holds them; the host passes them all)."""

from __future__ import annotations

import numpy as np
import open3d as o3d

from camcmm.api import GeometryError, PointCloud, RunContext


def downsample(ctx: RunContext, cloud: PointCloud, *, voxel_size: float) -> dict:
    """Voxel-grid downsampling: every occupied voxel of edge ``voxel_size`` mm becomes
    the centroid of its points (colours and normals averaged; scalar fields dropped)."""
    out = cloud.to_open3d().voxel_down_sample(voxel_size)
    result = PointCloud.from_open3d(out, name=f"{cloud.name} (voxel {voxel_size:g} mm)")
    return {"cloud": result, "n_points": result.n_points}


def denoise(ctx: RunContext, cloud: PointCloud, *, neighbours: int, std_ratio: float) -> dict:
    """Statistical outlier removal; keeps all per-point data of the kept points."""
    if cloud.n_points <= neighbours:
        raise GeometryError(f"{cloud.name}: {cloud.n_points} points, need more than {neighbours} neighbours")
    _, kept = cloud.to_open3d().remove_statistical_outlier(neighbours, std_ratio)
    kept = np.asarray(kept, dtype=np.int64)
    return {"cloud": cloud.subset(kept), "n_removed": cloud.n_points - len(kept)}


def normals(ctx: RunContext, cloud: PointCloud, *, neighbours: int, viewpoint) -> dict:
    """Unit normals of the local least-squares plane through the ``neighbours`` nearest
    points, oriented towards ``viewpoint`` (mm) or away from the cloud's centroid."""
    if cloud.n_points < 3:
        raise GeometryError(f"{cloud.name}: {cloud.n_points} points, need at least 3 for normals")
    pc = cloud.to_open3d()
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(neighbours))
    n = np.asarray(pc.normals)
    if viewpoint is None:
        # Open3D orients towards a camera location; "away from the centroid" is the
        # convention that suits closed parts, so flip by hand.
        flip = np.einsum("ij,ij->i", n, cloud.points - cloud.points.mean(axis=0)) < 0
    else:
        flip = np.einsum("ij,ij->i", n, np.asarray(viewpoint) - cloud.points) < 0
    n[flip] *= -1
    out = cloud.subset(slice(None))
    out.normals = n
    return {"cloud": out}
