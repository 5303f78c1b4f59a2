"""Built-in cloudtools plugins against exact-by-construction and analytic cases."""

import numpy as np
import pytest

from camcmm.errors import GeometryError
from camcmm.host import default_host
from camcmm.model import PointCloud


def run(pid, cloud, **params):
    return default_host().run(pid, {"cloud": cloud}, params).outputs


def test_downsample_gives_each_voxels_centroid():
    rng = np.random.default_rng(1)
    # Open3D anchors its grid half a voxel below the cloud's minimum corner; clusters of
    # +-0.3 mm on a 30 mm lattice then sit in the middle of distinct 10 mm voxels, so the
    # centroid of each voxel is known exactly.
    centres = np.array([[0.0, 0.0, 0.0], [30.0, 0.0, 0.0], [0.0, 60.0, 30.0]])
    pts = np.vstack([c + rng.uniform(-0.3, 0.3, (50, 3)) for c in centres])
    out = run("cloud.downsample", PointCloud(pts), voxel_size=10.0)
    got = out["cloud"].points[np.lexsort(out["cloud"].points.T[::-1])]
    want = np.array([pts[i * 50 : (i + 1) * 50].mean(axis=0) for i in range(3)])
    want = want[np.lexsort(want.T[::-1])]
    assert out["n_points"] == 3
    np.testing.assert_allclose(got, want, atol=1e-12)


def test_denoise_removes_far_points_only():
    rng = np.random.default_rng(2)
    plane = np.column_stack([rng.uniform(0, 50, (5000, 2)), rng.normal(0, 0.01, 5000)])
    far = np.array([[25, 25, 30.0], [10, 40, -25.0], [60, 60, 60.0]])
    cloud = PointCloud(np.vstack([plane, far]), fields={"id": np.arange(5003)})
    out = run("cloud.denoise", cloud, neighbours=20, std_ratio=3.0)
    kept = set(out["cloud"].fields["id"].tolist())
    assert not kept & {5000, 5001, 5002}
    assert len(kept) > 4950 and out["n_removed"] == 5003 - len(kept)


def test_normals_on_a_sphere_are_radial():
    rng = np.random.default_rng(3)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    centre = np.array([100.0, -50.0, 20.0])
    out = run("cloud.normals", PointCloud(centre + 25.0 * d), neighbours=20)
    cos = np.einsum("ij,ij->i", out["cloud"].normals, d)
    assert cos.min() > 0.999  # outward and within ~2.5 degrees everywhere


def test_too_few_points_is_a_clear_error():
    with pytest.raises(GeometryError, match="need more than 20 neighbours"):
        run("cloud.denoise", PointCloud(np.zeros((5, 3))), neighbours=20)
