"""Alignment against a reference cloud (not a mesh): the nearest reference point lies up
to half a spacing away sideways, which must not fail a correct alignment."""

import numpy as np
import open3d as o3d

from camcmm.host import default_host
from camcmm.model import PointCloud


def _box_samples(n, seed):
    box = o3d.geometry.TriangleMesh.create_box(40.0, 30.0, 20.0)
    pc = (
        box.sample_points_uniformly(n, seed=seed)
        if "seed" in box.sample_points_uniformly.__doc__
        else box.sample_points_uniformly(n)
    )
    return np.asarray(pc.points)


def test_icp_onto_a_reference_cloud_converges():
    rng = np.random.default_rng(3)
    reference = PointCloud(_box_samples(30_000, 1), name="reference")
    measured = _box_samples(20_000, 2)[rng.permutation(20_000)]
    angle = np.radians(1.0)
    R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    t = np.array([0.3, -0.2, 0.1])
    moved = (measured - 15.0) @ R.T + 15.0 + t
    out = (
        default_host()
        .run("inspect.align", {"cloud": PointCloud(moved, name="m"), "nominal": reference}, {"align": "icp"})
        .outputs
    )
    assert out["converged"], out["reason"]
    back = (np.asarray(out["transform"])[:3, :3] @ moved.T).T + np.asarray(out["transform"])[:3, 3]
    assert np.abs(back - measured).max() < 0.05  # well below the ~0.2 mm point spacing
