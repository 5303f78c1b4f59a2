"""camcmm.io refuses bad files with one InputError line that names the file; no raw
library exception and no silently wrong result."""

from __future__ import annotations

import re
import struct

import numpy as np
import pytest

import camcmm.io as cio
from camcmm.errors import InputError
from camcmm.model import PointCloud, TriangleMesh


def refused(path, *needles, unit=None):
    """Read ``path``; it must raise InputError, one line, naming the file and ``needles``."""
    with pytest.raises(InputError) as err:
        cio.read(path, unit=unit)
    assert type(err.value) is InputError
    msg = str(err.value)
    assert "\n" not in msg and path.name in msg, msg
    for n in needles:
        assert n in msg, msg
    with pytest.raises(InputError):  # info goes the same way
        cio.info(path, unit=unit)
    return msg


def ply_bytes(n=4, body=None, fmt="binary_little_endian"):
    head = (
        f"ply\nformat {fmt} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    )
    if body is None:
        body = (
            np.arange(n * 3, dtype="<f4").tobytes()
            if fmt != "ascii"
            else "".join(f"{i} {i} {i}\n" for i in range(n)).encode()
        )
    return head.encode() + body


def test_missing_file(tmp_path):
    refused(tmp_path / "missing.ply", "not found")


def test_empty_file(tmp_path):
    for ext in (".ply", ".xyz", ".stl", ".e57", ".png"):
        path = tmp_path / f"empty{ext}"
        path.write_bytes(b"")
        refused(path, "empty")


def test_unknown_extension(tmp_path):
    path = tmp_path / "scan.las"
    path.write_bytes(b"LASF")
    refused(path, "unknown file format", ".las")
    with pytest.raises(InputError, match="scan.las"):
        cio.write(PointCloud(np.zeros((1, 3))), path)


def test_a_folder_is_not_a_file(tmp_path):
    (tmp_path / "dir.ply").mkdir()
    refused(tmp_path / "dir.ply", "not a file")


def test_truncated_binary_ply(tmp_path):
    path = tmp_path / "cut.ply"
    path.write_bytes(ply_bytes(1000)[:-7])
    refused(path, "truncated", "1000 vertex")


def test_truncated_binary_ply_mesh(tmp_path):
    path = tmp_path / "cutmesh.ply"
    mesh = TriangleMesh(np.random.default_rng(0).normal(size=(30, 3)), [[0, 1, 2]] * 40)
    cio.write(mesh, path)
    path.write_bytes(path.read_bytes()[:-5])
    refused(path, "truncated")


def test_truncated_ascii_ply(tmp_path):
    path = tmp_path / "cut_ascii.ply"
    path.write_bytes(ply_bytes(10, fmt="ascii").rsplit(b"\n", 4)[0] + b"\n")
    refused(path, "truncated", "10 vertex")


@pytest.mark.parametrize(
    "content,needle",
    [
        (b"\x00\x01garbage" * 100, "not a PLY file"),
        (b"ply\nformat binary_little_endian 1.0\nelement vertex many\nend_header\n", "bad PLY header line 3"),
        (b"ply\nformat wavelet 1.0\nend_header\n", "format"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n0\n", "property"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "no end_header"),
        (b"ply\nformat ascii 1.0\nmystery line\nend_header\n", "unknown keyword"),
        (b"ply\nelement vertex 1\nproperty float x\nend_header\n1\n", "no format line"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nend_header\n1 1\n", "twice"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n", "no x/y/z"),
        (
            b"ply\nformat ascii 1.0\nelement vertex 2\n"
            b"property float x\nproperty float y\nproperty float z\nend_header\n"
            b"1 2 3\n4 five 6\n",
            "vertex 1",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 2\n"
            b"property float x\nproperty float y\nproperty float z\nend_header\n"
            b"1 2 3\n4 5\n",
            "expected 3 values",
        ),
    ],
)
def test_garbage_ply(tmp_path, content, needle):
    path = tmp_path / "bad.ply"
    path.write_bytes(content)
    refused(path, needle)


def test_ply_face_index_out_of_range(tmp_path):
    path = tmp_path / "faces.ply"
    path.write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        b"element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"
    )
    refused(path, "face indices")


@pytest.mark.parametrize("ext", [".ply", ".xyz", ".csv", ".pcd"])
def test_nan_coordinates(tmp_path, ext):
    path = tmp_path / f"nan{ext}"
    pts = np.arange(30, dtype=float).reshape(10, 3)
    cio.write(PointCloud(pts), path, binary=False)
    path.write_text(re.sub(r"\n12(\.0)?([ ,])", r"\nnan\2", path.read_text(), count=1))
    refused(path, "NaN or Inf", "index 4")


def test_inf_in_binary_ply(tmp_path):
    path = tmp_path / "inf.ply"
    body = np.arange(12, dtype="<f4")
    body[7] = np.inf
    path.write_bytes(ply_bytes(4, body.tobytes()))
    refused(path, "NaN or Inf", "index 2")


def test_unknown_unit_in_file(tmp_path):
    path = tmp_path / "furlong.ply"
    data = ply_bytes(2, fmt="ascii").replace(b"format ascii 1.0\n", b"format ascii 1.0\ncomment unit furlongs\n")
    path.write_bytes(data)
    refused(path, "furlongs", "unit=")
    assert cio.read(path, unit="mm").source_unit == "mm"  # the caller can settle it


@pytest.mark.parametrize(
    "name,content,needle",
    [
        ("points.csv", "x,y,z\n1,2,3\na;b;c\n", "points.csv line 3: expected 3 numeric columns separated by ','"),
        ("points.csv", "1;2;3\n4;5;6\n7,8,9\n", "line 3: expected 3 numeric columns separated by ';'"),
        (
            "points.xyz",
            "1 2 3\n4 5 6 7\n",
            "line 2: expected 3 numeric columns separated by spaces but found '4 5 6 7'",
        ),
        ("points.txt", "1\t2\t3\n4 5 6\n", "line 2: expected 3 numeric columns separated by tab"),
        ("points.xyz", "1 2\n3 4\n", "line 1: expected 3 or more numeric columns"),
        ("points.xyz", "# only a comment\n", "no data lines"),
        ("points.csv", "x,y\n1,2,3\n", "header names 2 columns"),
        ("points.xyz", "1 2 3\n4 5 six\n", "line 2"),
    ],
)
def test_bad_text(tmp_path, name, content, needle):
    path = tmp_path / name
    path.write_text(content)
    refused(path, needle)


def test_stl_without_triangles(tmp_path):
    binary = tmp_path / "empty_bin.stl"
    binary.write_bytes(b"\0" * 80 + struct.pack("<I", 0))
    refused(binary, "mesh has no faces")
    ascii_ = tmp_path / "empty_ascii.stl"
    ascii_.write_text("solid nothing\nendsolid nothing\n")
    refused(ascii_, "mesh has no faces")


def test_truncated_stl(tmp_path):
    path = tmp_path / "cut.stl"
    mesh = TriangleMesh(np.eye(3), [[0, 1, 2]] * 5)
    cio.write(mesh, path)
    path.write_bytes(path.read_bytes()[:-20])
    refused(path, "truncated")
    ascii_ = tmp_path / "cut_ascii.stl"
    cio.write(mesh, ascii_, binary=False)
    ascii_.write_text(ascii_.read_text()[:-60])
    refused(ascii_, "not a multiple of 3")


def test_obj_without_faces(tmp_path):
    path = tmp_path / "points.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    refused(path, "mesh has no faces")
    path2 = tmp_path / "text.obj"
    path2.write_text("hello world\n")
    refused(path2, "no vertices")
    path3 = tmp_path / "bad.obj"
    path3.write_text("v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n")
    refused(path3, "bad.obj line 2: vertex")


def test_bad_pcd(tmp_path):
    cut = tmp_path / "cut.pcd"
    cio.write(PointCloud(np.ones((50, 3))), cut)
    cut.write_bytes(cut.read_bytes()[:-10])
    refused(cut, "truncated")
    junk = tmp_path / "junk.pcd"
    junk.write_text("hello\nworld\n")
    refused(junk, "not a PCD file")
    nodata = tmp_path / "nodata.pcd"
    nodata.write_text("VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nCOUNT 1 1 1\nPOINTS 1\nDATA ascii\n1 2 3\n")
    refused(nodata, "different lengths")


def test_garbage_e57(tmp_path):
    path = tmp_path / "fake.e57"
    path.write_bytes(b"this is not an e57 file" * 100)
    refused(path, "E57")


def test_corrupt_image(tmp_path):
    path = tmp_path / "frame.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + b"rubbish" * 10)
    refused(path, "cannot read the image size", "not decoded")  # no IHDR: its size is unknown


def test_write_errors_name_the_file(tmp_path):
    with pytest.raises(InputError, match="nowhere.ply.*does not exist"):
        cio.write(PointCloud(np.zeros((1, 3))), tmp_path / "no" / "nowhere.ply")
    bad_field = PointCloud(np.zeros((2, 3)), fields={"signed distance": np.zeros(2)})
    for ext in (".ply", ".csv", ".pcd"):
        with pytest.raises(InputError, match=rf"out{ext}.*'signed distance'"):
            cio.write(bad_field, tmp_path / f"out{ext}")
    with pytest.raises(InputError, match="field 'x'"):
        cio.write(PointCloud(np.zeros((2, 3)), fields={"x": np.zeros(2)}), tmp_path / "clash.ply")
    assert list(tmp_path.iterdir()) == []


def test_bad_ascii_stl_vertex(tmp_path):
    path = tmp_path / "bad_ascii.stl"
    path.write_text(
        "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 zero\nvertex 0 1 0\n"
        "endloop\nendfacet\nendsolid x\n"
    )
    refused(path, "'1 0 zero' is not three numbers")
