"""camcmm.io: what we write reads back the same, in every writable format."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import camcmm.io as cio
from camcmm.errors import InputError
from camcmm.model import Image, PointCloud, TriangleMesh

CLOUD_FORMATS = [".ply", ".pcd", ".xyz", ".txt", ".csv"]


def unit_vectors(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.fixture
def cloud():
    rng = np.random.default_rng(7)
    n = 500
    return PointCloud(
        rng.normal(0.0, 150.0, (n, 3)) + [1000.0, -20.0, 3.0],
        rng.integers(0, 256, (n, 3)).astype(np.uint8),
        unit_vectors(rng, n),
        {
            "deviation": rng.normal(0.0, 0.01, n),
            "label": rng.integers(0, 9, n).astype(np.int32),
            "quality": rng.uniform(0, 1, n).astype(np.float32),
        },
        {"deviation": "mm"},
        name="scan",
    )


@pytest.fixture
def mesh():
    rng = np.random.default_rng(3)
    v = rng.uniform(-50.0, 50.0, (40, 3))
    f = np.array([rng.permutation(40)[:3] for _ in range(60)])
    return TriangleMesh(
        v, f, unit_vectors(rng, 40), {"deviation": rng.normal(0, 0.02, 40)}, {"deviation": "mm"}, name="part"
    )


def same_triangles(a: TriangleMesh, b: TriangleMesh, atol=0.0):
    """Faces may be renumbered (STL merges corners), the triangles must be the same."""
    assert a.n_faces == b.n_faces
    np.testing.assert_allclose(a.vertices[a.faces], b.vertices[b.faces], rtol=0, atol=atol)


@pytest.mark.parametrize("binary", [True, False], ids=["binary", "ascii"])
@pytest.mark.parametrize("ext", CLOUD_FORMATS)
def test_cloud_round_trip_is_exact(tmp_path, cloud, ext, binary):
    path = tmp_path / f"scan{ext}"
    cio.write(cloud, path, binary=binary)
    back = cio.read(path)
    assert isinstance(back, PointCloud) and back.name == path.name and back.source_unit == "mm"
    if ext == ".pcd":  # float32 coordinates, as PCL and Open3D expect
        np.testing.assert_array_equal(back.points, cloud.points.astype(np.float32))
        np.testing.assert_array_equal(back.normals, cloud.normals.astype(np.float32))
    else:
        np.testing.assert_array_equal(back.points, cloud.points)
        np.testing.assert_array_equal(back.normals, cloud.normals)
    np.testing.assert_array_equal(back.colors, cloud.colors)
    assert list(back.fields) == list(cloud.fields)
    for k, v in cloud.fields.items():
        np.testing.assert_array_equal(back.fields[k], v)
    assert back.field_units == {"deviation": "mm"}


@pytest.mark.parametrize("ext", [".ply", ".pcd"])
def test_binary_formats_keep_field_types(tmp_path, cloud, ext):
    path = tmp_path / f"scan{ext}"
    cio.write(cloud, path)
    back = cio.read(path)
    assert {k: v.dtype for k, v in back.fields.items()} == {k: v.dtype for k, v in cloud.fields.items()}


def test_cloud_without_extras_round_trips(tmp_path):
    pts = np.random.default_rng(1).uniform(-1, 1, (100, 3))
    for ext in CLOUD_FORMATS + [".e57"]:
        path = tmp_path / f"plain{ext}"
        cio.write(PointCloud(pts), path)
        back = cio.read(path)
        np.testing.assert_allclose(back.points, pts, rtol=0, atol=1e-7 if ext == ".pcd" else 1e-12)
        assert back.colors is None and back.normals is None and back.fields == {}, ext


def test_e57_round_trip_in_metres_with_colours_and_intensity(tmp_path, cloud):
    cloud.fields["intensity"] = np.linspace(0.0, 1.0, cloud.n_points)
    path = tmp_path / "scan.e57"
    cio.write(cloud, path, unit="mm")  # E57 is metres whatever the caller asks
    back = cio.read(path)
    assert back.source_unit == "m"
    # stored as double-precision metres: far below a micrometre after the round trip
    np.testing.assert_allclose(back.points, cloud.points, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(back.colors, cloud.colors)
    np.testing.assert_allclose(back.fields["intensity"], cloud.fields["intensity"])
    assert back.normals is None and list(back.fields) == ["intensity"]


@pytest.mark.parametrize("binary", [True, False], ids=["binary", "ascii"])
@pytest.mark.parametrize("ext", [".ply", ".obj", ".stl"])
def test_mesh_round_trip(tmp_path, mesh, ext, binary):
    path = tmp_path / f"part{ext}"
    cio.write(mesh, path, binary=binary)
    back = cio.read(path)
    assert isinstance(back, TriangleMesh) and back.name == path.name and back.source_unit == "mm"
    # binary STL stores float32 corners
    same_triangles(back, mesh, atol=1e-5 if (ext == ".stl" and binary) else 0.0)
    if ext == ".ply":
        np.testing.assert_array_equal(back.faces, mesh.faces)
        np.testing.assert_array_equal(back.vertex_normals, mesh.vertex_normals)
        np.testing.assert_array_equal(back.fields["deviation"], mesh.fields["deviation"])
        assert back.field_units == {"deviation": "mm"}
    if ext == ".obj":
        np.testing.assert_array_equal(back.faces, mesh.faces)
        np.testing.assert_array_equal(back.vertex_normals, mesh.vertex_normals)


def test_stl_merges_shared_corners(tmp_path, mesh):
    path = tmp_path / "part.stl"
    cio.write(mesh, path, binary=False)
    back = cio.read(path)
    used = np.unique(mesh.faces)
    assert back.n_vertices == len(used)


@pytest.mark.parametrize("ext", [".ply", ".pcd", ".xyz", ".csv", ".obj", ".stl"])
def test_written_unit_is_declared_and_read_back_in_mm(tmp_path, cloud, mesh, ext):
    obj = mesh if ext in (".obj", ".stl") else cloud
    path = tmp_path / f"in_metres{ext}"
    cio.write(obj, path, unit="m", binary=False)
    text = path.read_text()
    assert ("comment unit m\n" if ext == ".ply" else "unit m") in text
    back = cio.read(path)
    assert back.source_unit == "m"
    ref = obj.points if isinstance(obj, PointCloud) else obj.vertices
    got = back.points if isinstance(back, PointCloud) else back.vertices[back.faces].reshape(-1, 3)
    if isinstance(obj, TriangleMesh):
        ref = obj.vertices[obj.faces].reshape(-1, 3)
    np.testing.assert_allclose(got, ref, rtol=1e-7 if ext == ".pcd" else 1e-14, atol=1e-12)


def test_ply_declares_mm_by_default(tmp_path, cloud):
    path = tmp_path / "scan.ply"
    cio.write(cloud, path)
    assert b"\ncomment unit mm\n" in path.read_bytes()[:1000]


def test_unit_argument_overrides_the_file(tmp_path, cloud):
    path = tmp_path / "scan.ply"
    cio.write(cloud, path)
    back = cio.read(path, unit="um")
    assert back.source_unit == "um"
    np.testing.assert_allclose(back.points, cloud.points / 1000.0)


def test_write_replaces_atomically_and_leaves_no_temp_file(tmp_path, cloud, monkeypatch):
    path = tmp_path / "scan.ply"
    cio.write(cloud, path)
    before = path.read_bytes()

    from camcmm.io import ply

    def crash(obj, tmp, **kw):
        tmp.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 1000\n")  # half a file
        raise RuntimeError("disk pulled out")

    monkeypatch.setattr(ply, "write", crash)
    with pytest.raises(InputError, match="scan.ply"):
        cio.write(PointCloud(np.zeros((3, 3))), path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scan.ply"]


def test_write_refuses_a_format_that_cannot_hold_the_object(tmp_path, cloud, mesh):
    with pytest.raises(InputError, match=r"scan\.stl.*cannot hold a pointcloud"):
        cio.write(cloud, tmp_path / "scan.stl")
    with pytest.raises(InputError, match=r"part\.xyz.*cannot hold a mesh"):
        cio.write(mesh, tmp_path / "part.xyz")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "ext,dtype,channels",
    [
        (".png", np.uint16, 1),
        (".png", np.uint8, 3),
        (".tif", np.uint16, 1),
        (".tif", np.float32, 1),
        (".bmp", np.uint8, 3),
    ],
)
def test_image_round_trip_keeps_depth_and_channels(tmp_path, ext, dtype, channels):
    rng = np.random.default_rng(0)
    shape = (48, 64) if channels == 1 else (48, 64, channels)
    hi = 1.0 if dtype == np.float32 else np.iinfo(dtype).max
    data = (rng.uniform(0, hi, shape)).astype(dtype)
    path = tmp_path / f"frame{ext}"
    cio.write(Image(data), path)
    back = cio.read(path)
    assert isinstance(back, Image) and back.name == path.name
    np.testing.assert_array_equal(back.data, data)


def test_jpeg_reads_back_close(tmp_path):
    data = np.tile(np.linspace(0, 255, 64, dtype=np.uint8), (48, 1))
    cio.write(Image(data), tmp_path / "frame.JPG")
    back = cio.read(tmp_path / "frame.JPG")
    assert back.data.shape == data.shape and np.abs(back.data.astype(int) - data).max() < 8


def test_info_is_json_and_describes_the_file(tmp_path, cloud, mesh):
    cio.write(cloud, tmp_path / "scan.ply")
    cio.write(mesh, tmp_path / "part.obj", unit="m")
    cio.write(Image(np.zeros((10, 20, 3), np.uint8)), tmp_path / "frame.png")

    d = cio.info(tmp_path / "scan.ply")
    json.dumps(d)
    assert d["file"] == "scan.ply" and d["format"] == "PLY" and d["kind"] == "pointcloud"
    assert d["n_points"] == cloud.n_points and d["unit"] == "mm" and d["source_unit"] == "mm"
    np.testing.assert_allclose(d["bbox"]["min"], cloud.points.min(axis=0))
    np.testing.assert_allclose(d["bbox"]["max"], cloud.points.max(axis=0))
    assert d["fields"] == ["deviation", "label", "quality"] and d["has_colors"] and d["has_normals"]
    assert d["bytes"] == (tmp_path / "scan.ply").stat().st_size

    m = cio.info(tmp_path / "part.obj")
    json.dumps(m)
    assert m["kind"] == "mesh" and m["n_vertices"] == mesh.n_vertices and m["n_faces"] == mesh.n_faces
    assert m["source_unit"] == "m" and m["unit"] == "mm" and m["has_normals"] and not m["has_colors"]
    np.testing.assert_allclose(m["bbox"]["max"], mesh.vertices.max(axis=0))

    i = cio.info(tmp_path / "frame.png")
    json.dumps(i)
    assert (i["kind"], i["width"], i["height"], i["channels"], i["dtype"]) == ("image", 20, 10, 3, "uint8")


def test_formats_table_is_json_and_complete():
    json.dumps(cio.FORMATS)
    for ext in (".ply", ".pcd", ".xyz", ".txt", ".csv", ".e57", ".stl", ".obj", ".png", ".jpg", ".tif", ".bmp"):
        f = cio.FORMATS[ext]
        assert f["readable"] and isinstance(f["writable"], bool) and f["kinds"]
    assert cio.FORMATS[".e57"]["default_unit"] == "m"
    assert cio.FORMATS[".stl"]["kinds"] == ["mesh"] and cio.FORMATS[".xyz"]["kinds"] == ["pointcloud"]


def test_extension_is_case_insensitive(tmp_path, cloud):
    path = tmp_path / "SCAN.PLY"
    cio.write(cloud, path)
    assert cio.read(path).n_points == cloud.n_points


def test_importing_io_loads_no_heavy_library():
    code = (
        "import sys, camcmm.io; print(','.join(m for m in ('open3d', 'cv2', 'pye57', 'plyfile') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_binary_ply_mesh_is_read_by_numpy_not_plyfile(tmp_path, mesh):
    path = tmp_path / "part.ply"
    cio.write(mesh, path)
    code = f"import sys, camcmm.io; m = camcmm.io.read({str(path)!r}); print(m.n_faces, 'plyfile' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == [str(mesh.n_faces), "False"]


@pytest.mark.slow
def test_two_million_point_binary_ply_reads_fast(tmp_path):
    import time

    n = 2_000_000
    rec = np.zeros(n, [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    rec["x"] = np.arange(n)
    path = tmp_path / "big.ply"
    with open(path, "wb") as fh:
        fh.write(
            f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n"
            "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n".encode()
        )
        rec.tofile(fh)
    t0 = time.perf_counter()
    cloud = cio.read(path)
    elapsed = time.perf_counter() - t0
    assert cloud.n_points == n and cloud.points[-1, 0] == n - 1
    assert elapsed < 3.0, f"{elapsed:.2f} s for {n} points (the benchmark does 10 M in well under a second)"


@pytest.mark.parametrize("ext", [".ply", ".pcd", ".e57"])
def test_empty_cloud_round_trips(tmp_path, ext):
    path = tmp_path / f"empty{ext}"
    cio.write(PointCloud(np.zeros((0, 3))), path)
    assert cio.read(path).n_points == 0
    assert cio.info(path)["bbox"] == {"min": [None] * 3, "max": [None] * 3}
