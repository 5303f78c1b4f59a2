"""The data model: validation at construction, conversions to Open3D and pyvista."""

import numpy as np
import pytest

from camcmm.errors import InputError, ParameterError
from camcmm.model import Artefact, CameraModel, Certificate, PointCloud, TriangleMesh
from camcmm.units import to_mm_factor


def test_nan_and_inf_coordinates_are_refused_with_the_name():
    pts = np.zeros((10, 3))
    pts[4, 1] = np.nan
    pts[7, 2] = np.inf
    with pytest.raises(InputError, match=r"scan.ply: 2 of 10 points have NaN or Inf coordinates \(first at index 4\)"):
        PointCloud(pts, name="scan.ply")


def test_shapes_are_checked():
    with pytest.raises(InputError, match=r"shape \(N, 3\)"):
        PointCloud(np.zeros((4, 2)))
    with pytest.raises(InputError, match="field 'dev' has 3 rows for 4 items"):
        PointCloud(np.zeros((4, 3)), fields={"dev": np.zeros(3)})
    with pytest.raises(InputError, match="mesh has no faces"):
        TriangleMesh(np.zeros((3, 3)), np.zeros((0, 3)), name="part.stl")
    with pytest.raises(InputError, match="face indices run 0..3 but there are 3 vertices"):
        TriangleMesh(np.zeros((3, 3)), [[0, 1, 3]])


def test_open3d_and_pyvista_round_trip():
    rng = np.random.default_rng(0)
    cloud = PointCloud(
        rng.normal(size=(100, 3)),
        colors=rng.integers(0, 256, (100, 3)),
        fields={"dev": rng.normal(size=100)},
        field_units={"dev": "mm"},
    )
    back = PointCloud.from_open3d(cloud.to_open3d())
    np.testing.assert_array_equal(back.points, cloud.points)
    np.testing.assert_array_equal(back.colors, cloud.colors)
    poly = cloud.to_pyvista()
    assert poly.n_points == 100 and np.allclose(poly.point_data["dev"], cloud.fields["dev"])
    mesh = TriangleMesh([[0, 0, 0], [10, 0, 0], [0, 10, 0]], [[0, 1, 2]])
    assert mesh.area() == pytest.approx(50.0)
    assert TriangleMesh.from_open3d(mesh.to_open3d()).n_faces == 1
    assert mesh.to_pyvista().n_cells == 1


def test_units_and_certificates():
    assert to_mm_factor("m") == 1000.0 and to_mm_factor("µm") == 1e-3
    with pytest.raises(ParameterError, match="unknown length unit 'furlong'"):
        to_mm_factor("furlong")
    c = Certificate(20.001, 0.001, 2.0)
    assert c.standard_uncertainty == pytest.approx(0.0005)
    with pytest.raises(InputError, match="must be > 0"):
        Certificate(1.0, 0.1, 0.0)
    a = Artefact("s", "sphere", certificates={"diameter": c})
    assert Artefact.from_dict(a.to_dict()) == a


def test_camera_projection_matrix():
    cam = CameraModel([[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], translation=[0, 0, 100])
    x = cam.projection_matrix @ np.array([10.0, 5.0, 0.0, 1.0])
    assert x[:2] / x[2] == pytest.approx([420.0, 290.0])
