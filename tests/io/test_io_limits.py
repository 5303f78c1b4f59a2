"""camcmm.io refuses what it cannot read honestly: data beyond the counts a header
declares (which used to be dropped in silence), images too large to decode (checked
from the header, before any pixel is decoded), images whose content is another format
than the extension, and it folds the decoders' own messages into its one error line."""

from __future__ import annotations

import resource
import struct
import zlib

import numpy as np
import pytest

import camcmm.io as cio
from camcmm.errors import InputError, ParameterError
from camcmm.io.image import MAX_IMAGE_PIXELS, image_size
from camcmm.model import PointCloud, TriangleMesh


def refused(path, *needles):
    with pytest.raises(InputError) as err:
        cio.read(path)
    msg = str(err.value)
    assert "\n" not in msg and path.name in msg, msg
    for n in needles:
        assert n in msg, msg
    return msg


def _cloud(n=50):
    return PointCloud(np.random.default_rng(0).uniform(-5, 5, (n, 3)), name="c")


def _lie_about_count(data: bytes, old: bytes, new: bytes) -> bytes:
    assert old in data
    return data.replace(old, new, 1)


# -- data beyond the declared count ------------------------------------------------------
@pytest.mark.parametrize("binary", [True, False])
def test_ply_with_more_vertices_than_declared(tmp_path, binary):
    p = tmp_path / "more.ply"
    cio.write(_cloud(50), p, binary=binary)
    p.write_bytes(_lie_about_count(p.read_bytes(), b"element vertex 50", b"element vertex 10"))
    refused(p, "10 vertex", "40 more")


def test_ply_mesh_with_more_faces_than_declared(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] * 5)
    p = tmp_path / "faces.ply"
    cio.write(TriangleMesh(v, f), p)
    p.write_bytes(_lie_about_count(p.read_bytes(), b"element face 20", b"element face 4"))
    refused(p, "4 face", "16 more face rows")


def test_ply_mesh_of_mixed_polygons_with_more_faces_than_declared(tmp_path):
    """Triangles and quads (rows of different lengths, read by plyfile) behind a face
    count that is too small; a closing newline alone is still read."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], "<f4")
    head = (
        b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
        b"property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
    )
    tri = bytes([3]) + np.array([0, 1, 2], "<i4").tobytes()
    body = head + v.tobytes() + tri + bytes([4]) + np.array([0, 1, 3, 4], "<i4").tobytes()
    p = tmp_path / "mixed.ply"
    p.write_bytes(body + b"\n")
    assert cio.read(p).n_faces == 3
    p.write_bytes(body + tri * 5)
    refused(p, "2 face", "65 bytes")


def test_ply_with_a_closing_newline_after_the_binary_rows_is_read(tmp_path):
    """Fewer bytes than one row cannot be data that was dropped."""
    p = tmp_path / "nl.ply"
    cio.write(_cloud(50), p)
    p.write_bytes(p.read_bytes() + b"\n")
    assert cio.read(p).n_points == 50


@pytest.mark.parametrize("binary", [True, False])
def test_pcd_with_more_points_than_declared(tmp_path, binary):
    p = tmp_path / "more.pcd"
    cio.write(_cloud(50), p, binary=binary)
    p.write_bytes(_lie_about_count(p.read_bytes(), b"POINTS 50", b"POINTS 10").replace(b"WIDTH 50", b"WIDTH 10"))
    refused(p, "10 points")


def test_pcd_whose_points_and_width_disagree(tmp_path):
    p = tmp_path / "wh.pcd"
    cio.write(_cloud(50), p, binary=False)
    p.write_bytes(_lie_about_count(p.read_bytes(), b"WIDTH 50", b"WIDTH 7"))
    refused(p, "POINTS 50", "7 x 1")


def test_pcd_compressed_block_that_claims_another_size(tmp_path):
    """The unpacked size must be what the points need; a block that claims 2 GB is
    refused before it is unpacked, not after."""
    n = 10
    raw = np.arange(3 * n, dtype="<f4").tobytes()
    blob = b"".join(bytes([len(raw[i : i + 32]) - 1]) + raw[i : i + 32] for i in range(0, len(raw), 32))
    head = (
        b"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 10\nHEIGHT 1\n"
        b"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 10\nDATA binary_compressed\n"
    )
    ok = tmp_path / "ok.pcd"
    ok.write_bytes(head + struct.pack("<II", len(blob), len(raw)) + blob)
    np.testing.assert_array_equal(cio.read(ok).points[:, 0], np.arange(10))  # stored field by field
    big = tmp_path / "big.pcd"
    big.write_bytes(head + struct.pack("<II", len(blob), 2**31) + blob)
    refused(big, str(2**31), "120")


def _stl(n_records: int, n_header: int) -> bytes:
    rec = np.zeros(n_records, [("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
    rec["corners"] = np.arange(9 * n_records, dtype=np.float32).reshape(-1, 3, 3)
    return b"x".ljust(80, b" ") + struct.pack("<I", n_header) + rec.tobytes()


def test_binary_stl_with_more_triangles_than_declared(tmp_path):
    """The issue's file: 1520 triangles behind a count of 10 read as 10."""
    p = tmp_path / "more.stl"
    p.write_bytes(_stl(1520, 10))
    refused(p, "10 triangles", "1510 more")


def test_binary_stl_with_padding_shorter_than_a_triangle_is_read(tmp_path):
    p = tmp_path / "pad.stl"
    p.write_bytes(_stl(4, 4) + b"\0" * 49)
    assert cio.read(p).n_faces == 4


# -- images ---------------------------------------------------------------------------------
def _png(w: int, h: int) -> bytes:
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    c = zlib.compressobj(9)
    idat = b"".join(c.compress(b"\0" * (w + 1)) for _ in range(h)) + c.flush()
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
        + chunk(b"IDAT", idat)
        + chunk(b"IEND", b"")
    )


def test_a_png_bomb_is_refused_before_decoding(tmp_path):
    """12000 x 12000 px in ~150 kB: refused from its header, no 144 MB image made."""
    p = tmp_path / "bomb.png"
    p.write_bytes(_png(12000, 12000))
    assert p.stat().st_size < 1_000_000
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    refused(p, "12000 x 12000", "CAMCMM_MAX_IMAGE_PIXELS")
    grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert grown_mb < 50


def test_the_pixel_cap_follows_the_environment(tmp_path, monkeypatch):
    p = tmp_path / "small.png"
    p.write_bytes(_png(64, 48))
    assert cio.read(p).data.shape == (48, 64)
    monkeypatch.setenv("CAMCMM_MAX_IMAGE_PIXELS", "3000")
    refused(p, "64 x 48", "0.003 Mpx")
    monkeypatch.setenv("CAMCMM_MAX_IMAGE_PIXELS", "3072")  # exactly 64 x 48: allowed
    assert cio.read(p).data.shape == (48, 64)
    for bad in ("lots", "-5", "0", "1.5"):
        monkeypatch.setenv("CAMCMM_MAX_IMAGE_PIXELS", bad)
        with pytest.raises(ParameterError, match="CAMCMM_MAX_IMAGE_PIXELS"):
            cio.read(p)
    assert MAX_IMAGE_PIXELS == 100_000_000


@pytest.mark.parametrize(
    "ext,shape",
    [
        (".png", (30, 50)),
        (".jpg", (30, 50, 3)),
        (".tif", (30, 50)),
        (".tif", (30, 50, 3)),
        (".bmp", (30, 50, 3)),
        (".png", (30, 50, 4)),
    ],
)
def test_image_size_from_the_header_agrees_with_opencv(ext, shape):
    import cv2

    ok, enc = cv2.imencode(ext, np.zeros(shape, np.uint8))
    assert ok and image_size(memoryview(enc)) == (50, 30)
    assert image_size(b"not an image at all") is None
    assert image_size(memoryview(enc)[:10]) is None or ext == ".bmp"


def test_a_big_tiff_whose_directory_is_at_the_end_is_measured(tmp_path):
    """libtiff may write the image directory after the pixels."""
    w, h = 40000, 40000
    body = b"\0" * 64
    entries = [(256, 4, 1, w), (257, 4, 1, h), (258, 3, 1, 8), (262, 3, 1, 1), (273, 4, 1, 8), (279, 4, 1, 64)]
    ifd = (
        struct.pack("<H", len(entries))
        + b"".join(
            struct.pack("<HHI", t, typ, c) + (struct.pack("<HH", v, 0) if typ == 3 else struct.pack("<I", v))
            for t, typ, c, v in entries
        )
        + b"\0\0\0\0"
    )
    p = tmp_path / "big.tif"
    p.write_bytes(b"II*\0" + struct.pack("<I", 8 + len(body)) + body + ifd)
    refused(p, "40000 x 40000")


@pytest.mark.parametrize("w,h", [(0, 10), (10, 0)])
def test_an_image_of_no_pixels(tmp_path, w, h):
    p = tmp_path / "none.png"
    good = _png(max(w, 1), max(h, 1))
    p.write_bytes(good.replace(struct.pack(">II", max(w, 1), max(h, 1)), struct.pack(">II", w, h)))
    refused(p, f"{w} x {h}")


def test_an_image_with_the_wrong_extension(tmp_path):
    p = tmp_path / "photo.jpg"
    p.write_bytes(_png(8, 8))
    refused(p, "holds a PNG image, not JPEG", "rename it to .png")


def test_a_corrupt_png_is_one_line_with_the_decoders_reason(tmp_path, capfd):
    good = _png(64, 48)
    p = tmp_path / "corrupt.png"
    p.write_bytes(good[:-8] + b"\0\0\0\0IEND")  # a broken last chunk
    msg = refused(p, "cannot decode")
    assert "libpng" in msg or "PNG" in msg
    assert capfd.readouterr().err == ""  # nothing of libpng's on stderr


def test_text_lines_of_more_than_1000_columns(tmp_path):
    p = tmp_path / "wide.xyz"
    p.write_text(" ".join(["1.5"] * 5000) + "\n")
    refused(p, "5000 columns")


def test_ply_element_with_rows_but_no_properties(tmp_path):
    p = tmp_path / "empty_el.ply"
    p.write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        b"element junk 1000000000000\nend_header\n1 2 3\n"
    )
    refused(p, "'junk'", "1000000000000")
