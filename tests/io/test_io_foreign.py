"""camcmm.io reads what other libraries write (Open3D, plyfile, pye57, OpenCV), and
they read what camcmm writes."""

from __future__ import annotations

import numpy as np
import pytest

import camcmm.io as cio
from camcmm.model import PointCloud, TriangleMesh

o3d = pytest.importorskip("open3d")


@pytest.fixture
def arrays():
    rng = np.random.default_rng(11)
    n = 300
    pts = rng.uniform(-200.0, 200.0, (n, 3))
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    colors = rng.integers(0, 256, (n, 3)).astype(np.uint8)
    return pts, colors, normals


def o3d_cloud(pts, colors, normals):
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    pc.colors = o3d.utility.Vector3dVector(colors / 255.0)
    pc.normals = o3d.utility.Vector3dVector(normals)
    return pc


def o3d_box():
    m = o3d.geometry.TriangleMesh.create_box(10.0, 20.0, 30.0)
    m.compute_vertex_normals()
    m.compute_triangle_normals()
    return m


# -- Open3D ---------------------------------------------------------------------------
@pytest.mark.parametrize("ascii_", [True, False], ids=["ascii", "binary"])
def test_read_open3d_ply_cloud(tmp_path, arrays, ascii_):
    pts, colors, normals = arrays
    path = tmp_path / "o3d.ply"
    assert o3d.io.write_point_cloud(str(path), o3d_cloud(pts, colors, normals), write_ascii=ascii_)
    back = cio.read(path)
    if ascii_:  # Open3D prints ascii PLY with 6 significant digits
        np.testing.assert_allclose(back.points, pts, rtol=1e-5, atol=1e-3)
        np.testing.assert_allclose(back.normals, normals, atol=1e-5)
    else:
        np.testing.assert_array_equal(back.points, pts)
        np.testing.assert_array_equal(back.normals, normals)
    np.testing.assert_array_equal(back.colors, colors)
    assert back.source_unit == "mm"


@pytest.mark.parametrize("mode", ["ascii", "binary", "compressed"])
def test_read_open3d_pcd(tmp_path, arrays, mode):
    pts, colors, normals = arrays
    path = tmp_path / "o3d.pcd"
    assert o3d.io.write_point_cloud(
        str(path), o3d_cloud(pts, colors, normals), write_ascii=mode == "ascii", compressed=mode == "compressed"
    )
    back = cio.read(path)
    # Open3D stores PCD coordinates as float32
    np.testing.assert_allclose(back.points, pts, rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(back.normals, normals, atol=1e-6)
    np.testing.assert_array_equal(back.colors, colors)


@pytest.mark.parametrize(
    "ext,ascii_",
    [(".ply", True), (".ply", False), (".stl", False), (".obj", True)],
    ids=["ply-ascii", "ply-binary", "stl-binary", "obj"],
)  # Open3D writes no ascii STL
def test_read_open3d_mesh(tmp_path, ext, ascii_):
    box = o3d_box()
    path = tmp_path / f"box{ext}"
    assert o3d.io.write_triangle_mesh(str(path), box, write_ascii=ascii_)
    back = cio.read(path)
    assert isinstance(back, TriangleMesh) and back.n_faces == 12
    ref = np.asarray(box.vertices)[np.asarray(box.triangles)]
    np.testing.assert_allclose(back.vertices[back.faces], ref, atol=1e-6)
    assert back.area() == pytest.approx(2 * (10 * 20 + 20 * 30 + 10 * 30))


@pytest.mark.parametrize("binary", [True, False], ids=["binary", "ascii"])
@pytest.mark.parametrize("ext", [".ply", ".pcd", ".xyz"])
def test_open3d_reads_our_clouds(tmp_path, arrays, ext, binary):
    pts, colors, normals = arrays
    path = tmp_path / f"ours{ext}"
    cio.write(
        PointCloud(pts, colors if ext != ".xyz" else None, normals if ext != ".xyz" else None), path, binary=binary
    )
    if ext == ".xyz":  # Open3D's xyz reader wants bare numbers: drop our unit comment and header
        path.write_text("".join(path.read_text().splitlines(keepends=True)[2:]))
    pc = o3d.io.read_point_cloud(str(path))
    rtol = 1e-7 if ext == ".pcd" else 1e-12  # PCD holds float32
    np.testing.assert_allclose(np.asarray(pc.points), pts, rtol=rtol)
    if ext != ".xyz":
        np.testing.assert_array_equal(np.round(np.asarray(pc.colors) * 255).astype(np.uint8), colors)
        np.testing.assert_allclose(np.asarray(pc.normals), normals, rtol=rtol, atol=1e-7)


@pytest.mark.parametrize("binary", [True, False], ids=["binary", "ascii"])
@pytest.mark.parametrize("ext", [".ply", ".stl", ".obj"])
def test_open3d_reads_our_meshes(tmp_path, ext, binary):
    box = o3d_box()
    ours = TriangleMesh(np.asarray(box.vertices), np.asarray(box.triangles))
    path = tmp_path / f"ours{ext}"
    cio.write(ours, path, binary=binary)
    m = o3d.io.read_triangle_mesh(str(path))
    assert len(m.triangles) == 12
    np.testing.assert_allclose(np.asarray(m.vertices)[np.asarray(m.triangles)], ours.vertices[ours.faces], atol=1e-6)


# -- plyfile --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text,byte_order", [(False, "<"), (False, ">"), (True, "=")], ids=["binary_le", "binary_be", "ascii"]
)
def test_read_plyfile_cloud_with_custom_fields(tmp_path, arrays, text, byte_order):
    plyfile = pytest.importorskip("plyfile")
    pts, colors, _ = arrays
    n = len(pts)
    vert = np.empty(
        n,
        [
            ("x", "f8"),
            ("y", "f8"),
            ("z", "f8"),
            ("red", "u1"),
            ("green", "u1"),
            ("blue", "u1"),
            ("deviation", "f4"),
            ("classification", "u2"),
        ],
    )
    vert["x"], vert["y"], vert["z"] = pts.T
    vert["red"], vert["green"], vert["blue"] = colors.T
    vert["deviation"] = np.linspace(-0.05, 0.05, n)
    vert["classification"] = np.arange(n) % 7
    el = plyfile.PlyElement.describe(vert, "vertex")
    path = tmp_path / "pf.ply"
    plyfile.PlyData([el], text=text, byte_order=byte_order, comments=["units: meters"]).write(str(path))
    back = cio.read(path)
    assert back.source_unit == "m"
    np.testing.assert_allclose(back.points, pts * 1000.0, rtol=1e-12)
    np.testing.assert_array_equal(back.colors, colors)
    np.testing.assert_array_equal(back.fields["deviation"], vert["deviation"])
    np.testing.assert_array_equal(back.fields["classification"], vert["classification"])
    assert back.fields["classification"].dtype == np.uint16


@pytest.mark.parametrize("text", [False, True], ids=["binary", "ascii"])
def test_read_plyfile_mesh_with_mixed_polygons(tmp_path, text):
    plyfile = pytest.importorskip("plyfile")
    # a unit cube: two faces as quads, the rest as triangles (ragged lists)
    v = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)], float)
    polys = [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5],
        [0, 5, 4],
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 0, 4],
        [3, 4, 7],
    ]
    vert = np.array([tuple(p) for p in v], [("x", "f4"), ("y", "f4"), ("z", "f4")])
    face = np.empty(len(polys), [("vertex_indices", object)])
    face["vertex_indices"] = [np.array(p, np.int32) for p in polys]
    path = tmp_path / "cube.ply"
    plyfile.PlyData(
        [plyfile.PlyElement.describe(vert, "vertex"), plyfile.PlyElement.describe(face, "face")], text=text
    ).write(str(path))
    back = cio.read(path)
    assert isinstance(back, TriangleMesh) and back.n_faces == 12
    assert back.area() == pytest.approx(6.0)


def test_plyfile_reads_our_fields(tmp_path, arrays):
    plyfile = pytest.importorskip("plyfile")
    pts, colors, normals = arrays
    dev = np.linspace(0, 1, len(pts))
    cio.write(PointCloud(pts, colors, normals, {"deviation": dev}), tmp_path / "ours.ply")
    data = plyfile.PlyData.read(str(tmp_path / "ours.ply"))
    v = data["vertex"]
    np.testing.assert_array_equal(v["deviation"], dev)
    np.testing.assert_array_equal(np.column_stack([v["x"], v["y"], v["z"]]), pts)
    assert "unit mm" in data.comments


# -- pye57 ----------------------------------------------------------------------------
def test_read_pye57_scan_in_metres(tmp_path):
    pye57 = pytest.importorskip("pye57")
    rng = np.random.default_rng(5)
    n = 1000
    xyz = rng.uniform(-2.0, 2.0, (n, 3))  # metres
    data = {
        "cartesianX": xyz[:, 0],
        "cartesianY": xyz[:, 1],
        "cartesianZ": xyz[:, 2],
        "intensity": rng.uniform(0, 1, n).astype(np.float32),
        "colorRed": rng.integers(0, 256, n).astype(np.uint8),
        "colorGreen": rng.integers(0, 256, n).astype(np.uint8),
        "colorBlue": rng.integers(0, 256, n).astype(np.uint8),
    }
    path = tmp_path / "scan.e57"
    e = pye57.E57(str(path), mode="w")
    e.write_scan_raw(data)
    e.write_scan_raw({k: v[:10] for k, v in data.items()}, translation=np.array([1.0, 0.0, 0.0]))
    e.close()
    back = cio.read(path)
    assert back.source_unit == "m" and back.n_points == n + 10
    # pye57 stores single precision: about 0.1 µm at 2 m
    np.testing.assert_allclose(back.points[:n], xyz * 1000.0, atol=1e-3)
    np.testing.assert_allclose(back.points[n:], (xyz[:10] + [1.0, 0.0, 0.0]) * 1000.0, atol=1e-3)
    np.testing.assert_array_equal(back.colors[:n, 0], data["colorRed"])
    np.testing.assert_allclose(back.fields["intensity"][:n], data["intensity"], atol=1e-6)
    info = cio.info(path)
    assert info["source_unit"] == "m" and info["fields"] == ["intensity"] and info["bbox"]["max"][0] > 1000


def test_pye57_reads_our_e57(tmp_path, arrays):
    pye57 = pytest.importorskip("pye57")
    pts, colors, _ = arrays
    cio.write(PointCloud(pts, colors, fields={"intensity": np.arange(len(pts), dtype=float)}), tmp_path / "o.e57")
    e = pye57.E57(str(tmp_path / "o.e57"))
    d = e.read_scan(0, intensity=True, colors=True, ignore_missing_fields=True)
    e.close()
    np.testing.assert_allclose(
        np.column_stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]]), pts / 1000.0, rtol=1e-14
    )
    np.testing.assert_array_equal(d["colorBlue"], colors[:, 2])


# -- OpenCV ---------------------------------------------------------------------------
@pytest.mark.parametrize("ext", [".png", ".tif", ".bmp"])
def test_read_opencv_images(tmp_path, ext):
    cv2 = pytest.importorskip("cv2")
    data = np.random.default_rng(0).integers(0, 255, (30, 40, 3)).astype(np.uint8)
    path = tmp_path / f"cam{ext}"
    assert cv2.imwrite(str(path), data)
    back = cio.read(path)
    np.testing.assert_array_equal(back.data, data)
    assert back.size == (40, 30) and back.metadata["channel_order"] == "BGR"
