"""Generated bad inputs for every reader and every command (issue 13, "no input can
crash or exhaust it"), and the worker that runs them.

A :class:`Case` is a command line (``argv`` of ``camcmm``) run in a fresh folder that
holds ``files`` (name -> bytes; a name ending in ``/`` is a folder, ``b"->target"`` a
symlink, ``b"<fifo>"`` a named pipe). The verdict rule, applied in
tests/test_bad_inputs.py: exit non-zero with exactly one line on stderr that names the
file or the value (one of ``names``) and is no internal error, or exit 0 with an
explicit warning; never a crash, a hang or more than 1 GB.

The cases run in-process (``camcmm.cli.main.main(argv)``, no interpreter start per
case) inside a few long-lived worker processes (``python tests/badinputs.py
--worker``): each case gets its own folder, its stdout and stderr captured at the file
descriptor level (native libraries print there too) and its peak memory measured; the
parent enforces a timeout and restarts a worker that died or hung.
"""

from __future__ import annotations

import functools
import json
import os
import pickle
import select
import signal
import struct
import subprocess
import sys
import threading
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Memory a case may add to its worker's resident set (the issue's "> 1 GB").
MEMORY_LIMIT = 1 << 30
HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Case:
    id: str
    argv: tuple[str, ...]
    files: dict[str, bytes] = field(default_factory=dict, hash=False)
    names: tuple[str, ...] = ()  # the error line must contain one of these
    timeout: float = 40.0
    env: dict[str, str] = field(default_factory=dict, hash=False)


# -- valid building blocks ----------------------------------------------------------
def _rng(seed=0):
    return np.random.default_rng(seed)


def _sphere(n=400, r=10.0, seed=0):
    v = _rng(seed).normal(size=(n, 3))
    return r * v / np.linalg.norm(v, axis=1, keepdims=True)


def _xyz_text(p: np.ndarray) -> bytes:
    return "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in p.tolist()).encode()


def _ply_head(n, fmt="binary_little_endian", props=("x", "y", "z"), ftype="float", extra=""):
    return (
        f"ply\nformat {fmt} 1.0\n{extra}element vertex {n}\n"
        + "".join(f"property {ftype} {c}\n" for c in props)
        + "end_header\n"
    ).encode()


def ply_binary(p: np.ndarray, n_header=None) -> bytes:
    return _ply_head(len(p) if n_header is None else n_header) + p.astype("<f4").tobytes()


def ply_ascii(p: np.ndarray, n_header=None) -> bytes:
    return _ply_head(len(p) if n_header is None else n_header, "ascii") + _xyz_text(p)


def ply_mesh(v, f, fmt="binary_little_endian", nf=None) -> bytes:
    head = (
        f"ply\nformat {fmt} 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\n"
        f"property float z\nelement face {len(f) if nf is None else nf}\n"
        "property list uchar int vertex_indices\nend_header\n"
    ).encode()
    if fmt == "ascii":
        return head + _xyz_text(v) + "".join(f"3 {a} {b} {c}\n" for a, b, c in f).encode()
    rec = np.empty(len(f), [("n", "u1"), ("v", "<i4", (3,))])
    rec["n"], rec["v"] = 3, f
    return head + v.astype("<f4").tobytes() + rec.tobytes()


def pcd(p: np.ndarray, data="ascii", n_header=None, width=None) -> bytes:
    n = len(p) if n_header is None else n_header
    head = (
        "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
        f"WIDTH {n if width is None else width}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
    )
    body = _xyz_text(p) if data == "ascii" else p.astype("<f4").tobytes()
    return head.encode() + body


def pcd_compressed(p: np.ndarray, usize=None, csize=None, blob=None) -> bytes:
    n = len(p)
    raw = b"".join(p[:, j].astype("<f4").tobytes() for j in range(3))
    blob = _lzf_literal(raw) if blob is None else blob
    head = (
        "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
        f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary_compressed\n"
    ).encode()
    return head + struct.pack("<II", len(blob) if csize is None else csize, len(raw) if usize is None else usize) + blob


def _lzf_literal(raw: bytes) -> bytes:
    out = bytearray()
    for i in range(0, len(raw), 32):
        chunk = raw[i : i + 32]
        out += bytes([len(chunk) - 1]) + chunk
    return bytes(out)


_STL_REC = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attr", "<u2")])


def _tetra():
    v = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return v, f


def stl_binary(tri: np.ndarray, n_header=None, header=b"camcmm test") -> bytes:
    rec = np.zeros(len(tri), _STL_REC)
    rec["corners"] = tri
    n = len(tri) if n_header is None else n_header
    return header.ljust(80, b" ")[:80] + struct.pack("<I", n) + rec.tobytes()


def stl_ascii(tri: np.ndarray) -> bytes:
    out = ["solid t"]
    for t in tri:
        out += (
            ["facet normal 0 0 1", " outer loop"]
            + [f"  vertex {a!r} {b!r} {c!r}" for a, b, c in t]
            + [" endloop", "endfacet"]
        )
    return ("\n".join(out + ["endsolid t"]) + "\n").encode()


def obj(v, f) -> bytes:
    return (
        "".join(f"v {a!r} {b!r} {c!r}\n" for a, b, c in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)
    ).encode()


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png(w: int, h: int, idat: bytes | None = None, colour=0) -> bytes:
    """A grey (colour 0) or RGB (2) 8-bit PNG of w x h zeros (IDAT streamed, so a bomb
    of 12000 x 12000 px costs only its compressed size here)."""
    if idat is None:
        c = zlib.compressobj(9)
        row = b"\0" * (1 + w * (3 if colour == 2 else 1))
        idat = b"".join(c.compress(row) for _ in range(h)) + c.flush()
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour, 0, 0, 0))
        + _png_chunk(b"IDAT", idat)
        + _png_chunk(b"IEND", b"")
    )


def bmp(w: int, h: int, body: bytes | None = None) -> bytes:
    stride = (w * 3 + 3) // 4 * 4
    body = b"\0" * (stride * abs(h)) if body is None else body
    return (
        b"BM"
        + struct.pack("<IHHI", 54 + len(body), 0, 0, 54)
        + struct.pack("<IiiHHIIiiII", 40, w, h, 1, 24, 0, len(body), 2835, 2835, 0, 0)
        + body
    )


def tiff(w: int, h: int, body: bytes | None = None) -> bytes:
    body = b"\0" * (w * h) if body is None else body
    entries = [
        (256, 4, 1, w),
        (257, 4, 1, h),
        (258, 3, 1, 8),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (273, 4, 1, 8),
        (277, 3, 1, 1),
        (278, 4, 1, h),
        (279, 4, 1, len(body)),
    ]
    ifd_at = 8 + len(body)
    ifd = (
        struct.pack("<H", len(entries))
        + b"".join(
            struct.pack("<HHI", t, typ, c) + (struct.pack("<H", v) + b"\0\0" if typ == 3 else struct.pack("<I", v))
            for t, typ, c, v in entries
        )
        + b"\0\0\0\0"
    )
    return b"II*\0" + struct.pack("<I", ifd_at) + body + ifd


def jpeg_header(w: int, h: int) -> bytes:
    """A JPEG start (SOI, SOF0 with w x h) without scan data."""
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, h, w, 1) + b"\x01\x11\x00"
    return b"\xff\xd8" + sof + b"\xff\xd9"


@functools.cache
def _e57_bytes() -> bytes:
    """A valid E57 file of 200 points, written by camcmm (through pye57)."""
    import tempfile

    from camcmm.io import write
    from camcmm.model import PointCloud

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "ok.e57"
        write(PointCloud(_sphere(200), name="s"), p)
        return p.read_bytes()


@functools.cache
def png_bomb() -> bytes:
    """12000 x 12000 grey zeros: 144 Mpx, 144 MB decoded, about 140 kB on disk."""
    return png(12000, 12000)


@functools.cache
def _encoded(ext: str, shape=(48, 64)) -> bytes:
    import cv2

    img = (np.indices(shape[:2]).sum(axis=0) % 256).astype(np.uint8)
    if len(shape) == 3:
        img = np.dstack([img] * shape[2])
    return cv2.imencode(ext, img)[1].tobytes()


@functools.cache
def chessboard_png() -> bytes:
    import cv2

    sq, cols, rows = 20, 10, 7
    img = np.full((rows * sq + 80, cols * sq + 80), 255, np.uint8)
    for r in range(rows):
        for c in range(cols):
            if (r + c) % 2 == 0:
                img[40 + r * sq : 40 + (r + 1) * sq, 40 + c * sq : 40 + (c + 1) * sq] = 0
    return cv2.imencode(".png", img)[1].tobytes()


def yaml_text(s: str) -> bytes:
    return s.encode()


def _junk(n: int, seed: int = 1) -> bytes:
    return _rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes()


BAD_UTF8 = b"\xff\xfe\xfa\xc3\x28 \xa0\xa1\n\xe2\x82\n"
ALIAS_BOMB = (
    b"a: &a [x, x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
    b"c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]\n"
    b"e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]\nf: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]\n"
    b"g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]\nh: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]\n"
    b"i: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]\n"
)


# -- the cases ---------------------------------------------------------------------------
def _reader_cases() -> list[Case]:
    """Bad files of every readable format, through ``camcmm info``."""
    P = _sphere(200)
    nan, inf = P.copy(), P.copy()
    nan[5, 1], inf[7, 2] = np.nan, np.inf
    v, f = _tetra()
    tri = v[f]
    many = np.repeat(tri, 380, axis=0)  # 1520 triangles
    out: dict[str, bytes] = {}

    def add(name, data):
        out[name] = data

    # common to every format
    for ext in (".ply", ".pcd", ".xyz", ".txt", ".csv", ".stl", ".obj", ".e57", ".png", ".jpg", ".tif", ".bmp"):
        e = ext[1:]
        add(f"{e}_empty{ext}", b"")
        add(f"{e}_one_byte{ext}", b"\x00")
        add(f"{e}_newline{ext}", b"\n")
        add(f"{e}_spaces{ext}", b"   \n \t \r\n")
        add(f"{e}_junk_1k{ext}", _junk(1024))
        add(f"{e}_junk_64k{ext}", _junk(65536, 2))
        add(f"{e}_zeros_4k{ext}", b"\0" * 4096)
        add(f"{e}_bad_utf8{ext}", BAD_UTF8 * 20)
        add(f"{e}_is_png{ext}", _encoded(".png")) if ext != ".png" else add(f"{e}_is_ply{ext}", ply_binary(P))
        add(f"{e}_is_html{ext}", b"<!DOCTYPE html><html><body>404 Not Found</body></html>\n")
        add(f"{e}_utf16{ext}", "x y z\n1 2 3\n4 5 6\n7 8 9\n".encode("utf-16"))

    # PLY
    add("ply_excess_binary.ply", ply_binary(P, 10))
    add("ply_excess_ascii.ply", ply_ascii(P, 10))
    add("ply_excess_faces_binary.ply", ply_mesh(v, np.vstack([f] * 5), nf=4))
    add("ply_excess_faces_ascii.ply", ply_mesh(v, np.vstack([f] * 5), "ascii", nf=4))
    add("ply_truncated_binary.ply", ply_binary(P)[:-7])
    add("ply_truncated_ascii.ply", ply_ascii(P)[:-900])
    add("ply_truncated_header.ply", _ply_head(10)[:30])
    add("ply_huge_count_binary.ply", ply_binary(P, 2**40))
    add("ply_huge_count_ascii.ply", ply_ascii(P, 2**40))
    add("ply_count_2e32.ply", ply_binary(P, 2**32 - 1))
    add("ply_huge_faces.ply", ply_mesh(v, f, nf=2**40))
    add("ply_huge_faces_ascii.ply", ply_mesh(v, f, "ascii", nf=2**31))
    add("ply_negative_count.ply", _ply_head(-5) + P.astype("<f4").tobytes())
    add("ply_count_not_number.ply", _ply_head("ten") + P.astype("<f4").tobytes())
    add("ply_nan_binary.ply", ply_binary(nan))
    add("ply_nan_ascii.ply", ply_ascii(nan))
    add("ply_inf_binary.ply", ply_binary(inf))
    add("ply_inf_ascii.ply", ply_ascii(inf))
    add("ply_no_x.ply", _ply_head(len(P), props=("a", "y", "z")) + P.astype("<f4").tobytes())
    add(
        "ply_no_vertex.ply",
        b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
    )
    add("ply_no_format.ply", b"ply\nelement vertex 1\nproperty float x\nend_header\n1\n")
    add(
        "ply_bad_format.ply",
        b"ply\nformat binary_middle_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
    )
    add("ply_bad_type.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n1\n")
    add("ply_no_end_header.ply", _ply_head(3).replace(b"end_header\n", b""))
    add("ply_long_header_line.ply", b"ply\nformat ascii 1.0\ncomment " + b"a" * 100_000 + b"\nend_header\n")
    add("ply_many_header_lines.ply", b"ply\nformat ascii 1.0\n" + b"comment x\n" * 20_000 + b"end_header\n")
    add(
        "ply_bad_utf8_header.ply",
        b"ply\nformat ascii 1.0\ncomment \xff\xfe\nelement vertex 1\n"
        b"property float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n",
    )
    add("ply_bad_utf8_body.ply", _ply_head(2, "ascii") + b"1 2 3\n\xff\xfe \xc3\x28 4\n")
    add("ply_text_in_body.ply", _ply_head(2, "ascii") + b"1 2 3\nfour five six\n")
    add("ply_face_out_of_range.ply", ply_mesh(v, np.array([[0, 1, 99]])))
    add("ply_face_negative.ply", ply_mesh(v, np.array([[0, -1, 2]])))
    add("ply_face_out_of_range_ascii.ply", ply_mesh(v, np.array([[0, 1, 2**31 - 1]]), "ascii"))
    add(
        "ply_face_two_corners.ply",
        _ply_head(4, "ascii").replace(b"end_header\n", b"")
        + b"element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        + _xyz_text(v)
        + b"2 0 1\n",
    )
    add(
        "ply_face_list_255.ply",
        _ply_head(4, "ascii").replace(b"end_header\n", b"")
        + b"element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        + _xyz_text(v)
        + b"255 0 1 2\n",
    )
    add("ply_ragged_truncated.ply", ply_mesh(v, f)[:-3])
    add("ply_unknown_unit.ply", _ply_head(len(P), extra="comment unit furlong\n") + P.astype("<f4").tobytes())
    add("ply_dup_property.ply", _ply_head(len(P), props=("x", "y", "z", "x")) + P.astype("<f4").tobytes())
    add(
        "ply_colour_negative.ply",
        _ply_head(2, "ascii", props=("x", "y", "z", "red", "green", "blue")) + b"1 2 3 -5 0 0\n4 5 6 0 0 0\n",
    )
    add(
        "ply_colour_nan.ply",
        _ply_head(2, "ascii", props=("x", "y", "z", "red", "green", "blue")) + b"1 2 3 nan 0 0\n4 5 6 0 0 0\n",
    )
    add("ply_big_endian_excess.ply", _ply_head(3).replace(b"little", b"big") + P[:50].astype(">f4").tobytes())
    add("ply_uchar_list_len_huge.ply", ply_mesh(v, f, "ascii").replace(b"3 0 2 1", b"200 0 2 1"))
    add(
        "ply_element_zero_props.ply",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
        b"property float y\nproperty float z\nelement junk 1000000000000\nend_header\n" + P[:3].astype("<f4").tobytes(),
    )
    # PCD
    add("pcd_excess_ascii.pcd", pcd(P, n_header=10))
    add("pcd_excess_binary.pcd", pcd(P, "binary", n_header=10))
    add("pcd_truncated_ascii.pcd", pcd(P)[:-1500])
    add("pcd_truncated_binary.pcd", pcd(P, "binary")[:-5])
    add("pcd_huge_count.pcd", pcd(P, "binary", n_header=2**40))
    add("pcd_huge_count_ascii.pcd", pcd(P, n_header=2**40))
    add("pcd_negative_count.pcd", pcd(P, "binary", n_header=-10))
    add("pcd_width_mismatch.pcd", pcd(P, width=7))
    add("pcd_nan.pcd", pcd(nan))
    add("pcd_inf_binary.pcd", pcd(inf, "binary"))
    add("pcd_bad_data.pcd", pcd(P, "hdf5"))
    add("pcd_no_data_line.pcd", pcd(P).split(b"DATA")[0])
    add("pcd_bad_size.pcd", pcd(P).replace(b"SIZE 4 4 4", b"SIZE 3 4 4"))
    add("pcd_size_count_mismatch.pcd", pcd(P).replace(b"COUNT 1 1 1", b"COUNT 1 1"))
    add("pcd_negative_size.pcd", pcd(P, "binary").replace(b"SIZE 4 4 4", b"SIZE -4 4 4"))
    add("pcd_no_z.pcd", pcd(P).replace(b"FIELDS x y z", b"FIELDS x y q"))
    add("pcd_text_body.pcd", pcd(P[:2]).replace(_xyz_text(P[:2]), b"one two three\nfour five six\n"))
    add("pcd_bad_utf8_body.pcd", pcd(P[:2]).replace(_xyz_text(P[:2]), b"1 2 3\n\xff\xfe\xc3\x28 2 3\n"))
    add("pcd_compressed_ok_but_lying.pcd", pcd_compressed(P, usize=2**31))
    add("pcd_compressed_truncated.pcd", pcd_compressed(P)[:-100])
    add("pcd_compressed_csize_huge.pcd", pcd_compressed(P, csize=2**32 - 1))
    add("pcd_compressed_corrupt.pcd", pcd_compressed(P, blob=b"\xe0\xff\xff" * 400))
    add("pcd_compressed_bomb.pcd", pcd_compressed(P[:1], usize=12, blob=b"\x02" + b"\0" * 3 + b"\xe0\xff\x00" * 50000))
    add("pcd_count_zero_field.pcd", pcd(P).replace(b"COUNT 1 1 1", b"COUNT 1 1 0"))
    # text formats
    for ext in (".xyz", ".txt", ".csv"):
        e = ext[1:]
        sep = "," if ext == ".csv" else " "
        rows = [sep.join(repr(x) for x in r) for r in P[:20].tolist()]
        add(f"{e}_nan{ext}", ("\n".join(rows[:5] + [sep.join(["1", "nan", "2"])] + rows[5:]) + "\n").encode())
        add(f"{e}_inf{ext}", ("\n".join(rows + [sep.join(["1", "inf", "2"])]) + "\n").encode())
        add(f"{e}_two_columns{ext}", ("\n".join(sep.join(r.split(sep)[:2]) for r in rows) + "\n").encode())
        add(f"{e}_ragged{ext}", ("\n".join(rows[:5] + [sep.join(["1", "2"])] + rows[5:]) + "\n").encode())
        add(f"{e}_words{ext}", ("\n".join(rows[:5] + [sep.join(["one", "two", "three"])]) + "\n").encode())
        add(f"{e}_bad_utf8_row{ext}", ("\n".join(rows[:5]) + "\n").encode() + b"1\xff 2\xfe 3\n")
        add(f"{e}_comments_only{ext}", b"# unit mm\n# nothing else\n// x y z\n")
        add(f"{e}_header_only{ext}", f"x{sep}y{sep}z\n".encode())
        add(f"{e}_unknown_unit{ext}", b"# unit furlong\n" + ("\n".join(rows) + "\n").encode())
        add(f"{e}_one_long_line{ext}", (sep.join(["1.5"] * 300_000) + "\n").encode())
        add(f"{e}_header_mismatch{ext}", f"x{sep}y{sep}z{sep}w\n".encode() + ("\n".join(rows) + "\n").encode())
        add(f"{e}_nul_bytes{ext}", ("\n".join(rows[:5]) + "\n").encode() + b"\0\0\0\0\n1 2 3\n")
        add(f"{e}_huge_value{ext}", ("\n".join(rows[:5] + [sep.join(["1e999", "2", "3"])]) + "\n").encode())
        add(f"{e}_colour_negative{ext}", b"x y z red green blue\n1 2 3 -5 0 0\n4 5 6 0 0 0\n")
    # STL
    add("stl_excess_binary.stl", stl_binary(many, 10))
    add("stl_excess_one.stl", stl_binary(tri[:2], 1))
    add("stl_count_zero_with_data.stl", stl_binary(tri, 0))
    add("stl_truncated_binary.stl", stl_binary(tri)[:-10])
    add("stl_huge_count.stl", stl_binary(tri, 2**32 - 1))
    add("stl_solid_binary_mismatch.stl", stl_binary(many, 9, header=b"solid exported"))
    add("stl_nan_binary.stl", stl_binary(np.where(np.arange(36).reshape(4, 3, 3) == 4, np.nan, tri)))
    add("stl_inf_ascii.stl", stl_ascii(tri).replace(b"vertex 10.0 0.0 0.0", b"vertex inf 0.0 0.0", 1))
    add("stl_nan_ascii.stl", stl_ascii(tri).replace(b"vertex 10.0 0.0 0.0", b"vertex nan 0.0 0.0", 1))
    add("stl_ascii_truncated.stl", stl_ascii(tri)[:-120])
    add("stl_ascii_no_facets.stl", b"solid empty\nendsolid empty\n")
    add("stl_ascii_words.stl", stl_ascii(tri).replace(b"vertex 10.0 0.0 0.0", b"vertex ten zero zero", 1))
    add("stl_ascii_bad_utf8.stl", stl_ascii(tri).replace(b"vertex 10.0 0.0 0.0", b"vertex 1\xff 0\xfe 0", 1))
    add("stl_ascii_two_coords.stl", stl_ascii(tri).replace(b"vertex 10.0 0.0 0.0", b"vertex 10.0 0.0", 1))
    add("stl_header_only.stl", b"camcmm".ljust(80, b" ") + struct.pack("<I", 5))
    # OBJ
    add("obj_face_out_of_range.obj", obj(v, np.array([[0, 1, 99]])))
    add("obj_face_zero_index.obj", obj(v, f).replace(b"f 1 3 2", b"f 0 3 2"))
    add("obj_face_negative_too_far.obj", obj(v, f) + b"f -1 -2 -99\n")
    add("obj_face_two_corners.obj", obj(v, f) + b"f 1 2\n")
    add("obj_vertex_words.obj", obj(v, f).replace(b"v 10.0", b"v ten", 1))
    add("obj_vertex_two_coords.obj", b"v 1 2\n" + obj(v, f))
    add("obj_nan_vertex.obj", b"v nan 0 0\n" + obj(v, f))
    add("obj_inf_vertex.obj", obj(v, f) + b"v 0 inf 0\n")
    add("obj_no_vertices.obj", b"# nothing\nf 1 2 3\n")
    add("obj_bad_utf8.obj", obj(v, f) + b"v 1\xff 2 3\n")
    add("obj_normal_out_of_range.obj", obj(v, np.zeros((0, 3), int)) + b"vn 0 0 1\nf 1//5 2//5 3//5\n")
    add("obj_unknown_unit.obj", b"# unit furlong\n" + obj(v, f))
    add("obj_face_words.obj", obj(v, f) + b"f one two three\n")
    add("obj_huge_index.obj", obj(v, f) + b"f 1 2 99999999999999999999\n")
    # E57 (pye57 / libE57)
    add("e57_magic_only.e57", b"ASTM-E57" + b"\0" * 40)
    add("e57_magic_junk.e57", b"ASTM-E57" + _junk(4000, 3))
    add("e57_header_lies.e57", b"ASTM-E57" + struct.pack("<IIQQQ", 1, 0, 2**40, 48, 2**40) + _junk(2000, 4))
    e57 = _e57_bytes()
    add("e57_truncated_half.e57", e57[: len(e57) // 2])
    add("e57_truncated_last_page.e57", e57[:-1024])
    flipped = bytearray(e57)
    flipped[len(e57) // 2] ^= 0xFF
    add("e57_byte_flipped.e57", bytes(flipped))
    add("e57_appended_junk.e57", e57 + _junk(3000, 5))
    # images
    add("png_truncated.png", _encoded(".png")[:60])
    add("png_zero_width.png", png(0, 10, idat=zlib.compress(b"")))
    add("png_zero_height.png", png(10, 0, idat=zlib.compress(b"")))
    add("png_header_huge_no_data.png", png(60000, 60000, idat=zlib.compress(b"\0" * 100)))
    add("png_bomb_12000.png", png_bomb())
    add("png_bomb_rgb.png", png(20000, 20000, idat=zlib.compress(b"\0" * 1000), colour=2))
    add("png_max_dims.png", png(2**31 - 1, 2**31 - 1, idat=b""))
    add("png_bad_crc.png", _encoded(".png")[:-8] + b"\0\0\0\0IEND")
    add("jpg_truncated.jpg", _encoded(".jpg")[:200])
    add("jpg_bomb_header.jpg", jpeg_header(65000, 65000))
    add("jpg_zero_size.jpg", jpeg_header(0, 0))
    add("tif_truncated.tif", _encoded(".tif")[:100])
    add("tif_bomb.tif", tiff(100000, 100000, body=b"\0" * 64))
    add("tif_zero.tif", tiff(0, 0, body=b""))
    add("tif_ifd_loop.tif", b"II*\0" + struct.pack("<I", 4) + b"\0" * 64)
    add("bmp_truncated.bmp", bmp(64, 48)[:100])
    add("bmp_bomb.bmp", bmp(50000, 50000, body=b"\0" * 64))
    add("bmp_negative_width.bmp", bmp(-64, 48))
    add("bmp_zero.bmp", bmp(0, 0))
    add("bmp_topdown_bomb.bmp", bmp(30000, -30000, body=b"\0" * 64))
    cases = [
        Case(f"info-{name.replace('.', '-')}", ("info", name, "--json"), {name: data}, (name,))
        for name, data in out.items()
    ]
    # file-system oddities
    cases += [
        Case("info-missing", ("info", "missing.ply"), {}, ("missing.ply",)),
        Case("info-folder", ("info", "folder.ply"), {"folder.ply/": b""}, ("folder.ply",)),
        Case("info-fifo", ("info", "pipe.ply"), {"pipe.ply": b"<fifo>"}, ("pipe.ply",), timeout=20),
        Case("info-dev-zero", ("info", "zero.xyz"), {"zero.xyz": b"->/dev/zero"}, ("zero.xyz",), timeout=20),
        Case(
            "info-dev-urandom", ("info", "random.stl"), {"random.stl": b"->/dev/urandom"}, ("random.stl",), timeout=20
        ),
        Case("info-broken-link", ("info", "gone.ply"), {"gone.ply": b"->nowhere.ply"}, ("gone.ply",)),
        Case("info-unknown-ext", ("info", "scan.las"), {"scan.las": b"LASF"}, ("scan.las",)),
        Case("info-no-ext", ("info", "scan"), {"scan": b"1 2 3\n"}, ("scan",)),
        Case("info-bad-unit", ("info", "ok.xyz", "--unit", "furlong"), {"ok.xyz": _xyz_text(P)}, ("furlong",)),
        Case("info-empty-unit", ("info", "ok.xyz", "--unit", ""), {"ok.xyz": _xyz_text(P)}, ("unit", "''")),
        Case("info-nan-unit", ("info", "ok.xyz", "--unit", "nan"), {"ok.xyz": _xyz_text(P)}, ("nan",)),
        Case("info-no-file", ("info",), {}, ("file", "required")),
        Case("info-two-files", ("info", "a.xyz", "b.xyz"), {}, ("b.xyz", "unrecognized")),
        Case(
            "info-image-cap-env",
            ("info", "small.png", "--json"),
            {"small.png": _encoded(".png")},
            ("small.png",),
            env={"CAMCMM_MAX_IMAGE_PIXELS": "1000"},
        ),
        Case(
            "info-image-cap-env-bad",
            ("info", "small.png", "--json"),
            {"small.png": _encoded(".png")},
            ("CAMCMM_MAX_IMAGE_PIXELS",),
            env={"CAMCMM_MAX_IMAGE_PIXELS": "lots"},
        ),
        Case(
            "info-image-cap-env-negative",
            ("info", "small.png", "--json"),
            {"small.png": _encoded(".png")},
            ("CAMCMM_MAX_IMAGE_PIXELS",),
            env={"CAMCMM_MAX_IMAGE_PIXELS": "-5"},
        ),
    ]
    return cases


def _fit_cases() -> list[Case]:
    S = _sphere(300)
    good = {"s.xyz": _xyz_text(S)}
    line = np.column_stack([np.linspace(0, 10, 50), np.zeros(50), np.zeros(50)])
    same = np.tile([[1.0, 2.0, 3.0]], (50, 1))
    cases = []
    for el in ("line", "plane", "circle", "sphere", "cylinder", "cone", "torus"):
        cases += [
            Case(
                f"fit-{el}-two-points",
                ("fit", el, "two.xyz", "--json"),
                {"two.xyz": _xyz_text(S[:2])},
                ("two.xyz", "point"),
            ),
            Case(
                f"fit-{el}-identical-points",
                ("fit", el, "same.xyz", "--json"),
                {"same.xyz": _xyz_text(same)},
                ("same.xyz",),
            ),
            Case(
                f"fit-{el}-nan",
                ("fit", el, "nan.xyz", "--json"),
                {"nan.xyz": _xyz_text(S) + b"1 nan 2\n"},
                ("nan.xyz",),
            ),
            Case(
                f"fit-{el}-empty-ply",
                ("fit", el, "empty.ply", "--json"),
                {"empty.ply": ply_binary(S[:0])},
                ("empty.ply",),
            ),
            Case(
                f"fit-{el}-mesh-file",
                ("fit", el, "m.stl", "--json"),
                {"m.stl": stl_binary(_tetra()[0][_tetra()[1]])},
                ("m.stl",),
            ),
            Case(f"fit-{el}-image-file", ("fit", el, "i.png", "--json"), {"i.png": _encoded(".png")}, ("i.png",)),
        ]
    for el in ("plane", "circle", "sphere", "cylinder", "cone", "torus"):
        cases.append(
            Case(f"fit-{el}-collinear", ("fit", el, "line.xyz", "--json"), {"line.xyz": _xyz_text(line)}, ("line.xyz",))
        )
    for val in ("-10", "0", "nan", "inf", "-inf", "ten", "1e400"):
        cases.append(
            Case(
                f"fit-nominal-radius-{val}",
                ("fit", "sphere", "s.xyz", "--nominal-radius", val, "--json"),
                good,
                ("nominal", "radius", val),
            )
        )
    for rule in (
        "bogus",
        "percent:-5",
        "percent:150",
        "percent:abc",
        "sigma:0",
        "sigma:-1",
        "sigma:nan",
        "percent:",
        "sigma:inf",
        "percent:nan",
    ):
        cases.append(
            Case(
                f"fit-outliers-{rule.replace(':', '-') or 'empty'}",
                ("fit", "sphere", "s.xyz", "--outliers", rule, "--json"),
                good,
                ("outlier", rule),
            )
        )
    cases += [
        Case("fit-bad-method", ("fit", "sphere", "s.xyz", "--method", "magic"), good, ("magic",)),
        Case("fit-bad-element", ("fit", "cone", "s.xyz"), good, ("cone",)),
        Case("fit-bad-unit", ("fit", "sphere", "s.xyz", "--unit", "parsec"), good, ("parsec",)),
        Case("fit-minzone-line", ("fit", "line", "s.xyz", "--method", "minzone", "--json"), good, ("minzone", "line")),
        Case("fit-extract-plane", ("fit", "plane", "s.xyz", "--extract", "--json"), good, ("extract", "plane")),
        Case("fit-missing-file", ("fit", "sphere", "nothere.ply"), {}, ("nothere.ply",)),
        Case(
            "fit-extract-no-radius-junk",
            ("fit", "sphere", "j.xyz", "--extract", "--json"),
            {"j.xyz": _xyz_text(_rng(3).uniform(-50, 50, (300, 3)))},
            ("j.xyz", "sphere"),
        ),
    ]
    return cases


def _plan(measurements=None, **over) -> bytes:
    import yaml

    doc = {
        "standard": "vdi2634-2",
        "system": {"measuring_volume": [100, 100, 100]},
        "mpe": {"PF": 0.186, "PS": 0.143, "SD": 0.096, "F": 0.243},
        "artefacts": {
            "sphere": {"diameter": 20.0},
            "flat": {"length": 150, "width": 60},
            "ball_bar": {"length": 49.944, "uncertainty": 0.0008, "sphere_diameter": 20.0},
        },
        "measurements": measurements or {"sphere": ["s.ply"]},
    }
    doc.update(over)
    return yaml.safe_dump(doc, sort_keys=False).encode()


def _verify_cases() -> list[Case]:
    S = ply_binary(_sphere(2000))
    base = {"s.ply": S}
    cases = []

    def plan_case(cid, plan_bytes, names, extra=None, args=()):
        files = dict(base, **(extra or {}))
        files["plan.yaml"] = plan_bytes
        cases.append(Case(f"verify-{cid}", ("verify", "plan.yaml", "--json", *args), files, names))

    plan_case("empty", b"", ("plan.yaml",))
    plan_case("junk", _junk(2000), ("plan.yaml",))
    plan_case("bad-utf8", BAD_UTF8 * 10, ("plan.yaml",))
    plan_case("not-yaml", b"standard: [unclosed\n", ("plan.yaml",))
    plan_case("a-list", b"- 1\n- 2\n", ("plan.yaml",))
    plan_case("alias-bomb", ALIAS_BOMB, ("plan.yaml", "alias"))
    plan_case("duplicate-mpe", _plan() + b"mpe: {PF: 99, PS: 99, SD: 99, F: 99}\n", ("plan.yaml", "mpe", "duplicate"))
    plan_case("unknown-standard", _plan(standard="iso-9999"), ("plan.yaml", "iso-9999"))
    plan_case("mpe-negative", _plan(mpe={"PF": -1, "PS": 0.1, "SD": 0.1, "F": 0.2}), ("plan.yaml", "PF", "mpe"))
    plan_case("mpe-nan", _plan(mpe={"PF": float("nan"), "PS": 0.1, "SD": 0.1, "F": 0.2}), ("plan.yaml", "PF", "mpe"))
    plan_case("mpe-text", _plan(mpe={"PF": "small", "PS": 0.1, "SD": 0.1, "F": 0.2}), ("plan.yaml", "PF", "small"))
    plan_case("diameter-zero", _plan(artefacts={"sphere": {"diameter": 0}}), ("plan.yaml", "diameter"))
    plan_case("diameter-negative", _plan(artefacts={"sphere": {"diameter": -20}}), ("plan.yaml", "diameter"))
    plan_case("volume-zero", _plan(system={"measuring_volume": [0, 0, 0]}), ("plan.yaml", "measuring_volume"))
    plan_case("no-measurements", _plan(measurements={}), ("plan.yaml", "measurements"))
    plan_case("measurement-missing-file", _plan(measurements={"sphere": ["gone.ply"]}), ("gone.ply",))
    plan_case("measurement-junk-file", _plan(measurements={"sphere": ["j.ply"]}), ("j.ply",), {"j.ply": _junk(500)})
    plan_case(
        "measurement-nan-file",
        _plan(measurements={"sphere": ["n.xyz"]}),
        ("n.xyz",),
        {"n.xyz": _xyz_text(_sphere(300)) + b"nan 1 2\n"},
    )
    plan_case("measurement-outside", _plan(measurements={"sphere": ["/etc/passwd.ply"]}), ("passwd.ply",))
    plan_case("unknown-artefact", _plan(measurements={"cube": ["s.ply"]}), ("cube",))
    plan_case(
        "measurement-unit-bad", _plan(measurements={"sphere": [{"file": "s.ply", "unit": "furlong"}]}), ("furlong",)
    )
    plan_case(
        "measurement-excess-data",
        _plan(measurements={"sphere": ["x.ply"]}),
        ("x.ply",),
        {"x.ply": ply_binary(_sphere(2000), 100)},
    )
    plan_case("measurement-image", _plan(measurements={"sphere": ["i.png"]}), ("i.png",), {"i.png": _encoded(".png")})
    plan_case("huge-file", b"# " + b"x" * (20 << 20) + b"\n" + _plan(), ("plan.yaml",))
    for w in ("0", "-1", "abc", "1000000", "nan"):
        plan_case(f"workers-{w}", _plan(), ("workers", w), args=("--workers", w))
    plan_case("report-is-a-file", _plan(), ("report", "out.txt"), {"out.txt": b"x"}, args=("--report", "out.txt"))
    cases.append(Case("verify-missing-plan", ("verify", "none.yaml"), {}, ("none.yaml",)))
    return cases


def _inspect_cases() -> list[Case]:
    v, f = _tetra()
    rng = _rng(4)
    w = rng.dirichlet([1, 1, 1], 400)
    tri = v[f]
    pts = np.concatenate([w @ t for t in tri])
    base = {"c.xyz": _xyz_text(pts), "n.stl": stl_binary(tri)}
    cases = []

    def ic(cid, args, names, extra=None, cloud="c.xyz"):
        cases.append(
            Case(
                f"inspect-{cid}",
                ("inspect", cloud, "--nominal", "n.stl", "--json", *args),
                dict(base, **(extra or {})),
                names,
                timeout=40,
            )
        )

    for opt, vals in {
        "--tolerance": ("-1", "0", "nan", "inf"),
        "--max-distance": ("-1", "0", "nan"),
        "--inlier-distance": ("-1", "nan"),
        "--min-overlap": ("2", "-0.5", "nan"),
        "--coverage-distance": ("0", "-3", "nan"),
        "--seed": ("-1", "abc", "1e30"),
    }.items():
        for val in vals:
            ic(f"{opt[2:]}-{val}", (opt, val), (opt[2:].replace("-", "_"), opt[2:], val))
    ic("region-inverted", ("--region", "10", "10", "10", "0", "0", "0"), ("region",))
    ic("region-nan", ("--region", "nan", "0", "0", "1", "1", "1"), ("region", "nan"))
    ic("pairs-missing", ("--align", "pairs", "--pairs", "p.json"), ("p.json",))
    ic("pairs-junk", ("--align", "pairs", "--pairs", "p.json"), ("p.json",), {"p.json": _junk(300)})
    ic(
        "pairs-two",
        ("--align", "pairs", "--pairs", "p.json"),
        ("p.json", "pairs", "3"),
        {"p.json": json.dumps({"measured": [[0, 0, 0], [1, 0, 0]], "nominal": [[0, 0, 0], [1, 0, 0]]}).encode()},
    )
    ic(
        "pairs-nan",
        ("--align", "pairs", "--pairs", "p.json"),
        ("p.json", "nan", "NaN"),
        {"p.json": b'{"measured": [[0,0,0],[1,0,0],[0,1,0]], "nominal": [[0,0,0],[1,0,0],[0,NaN,0]]}'},
    )
    ic(
        "pairs-collinear",
        ("--align", "pairs", "--pairs", "p.json"),
        ("p.json", "collinear", "pairs"),
        {
            "p.json": json.dumps(
                {"measured": [[0, 0, 0], [1, 0, 0], [2, 0, 0]], "nominal": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]}
            ).encode()
        },
    )
    ic("pairs-no-file", ("--align", "pairs"), ("pairs",))
    ic("nominal-junk", (), ("n.stl",), {"n.stl": _junk(1000)})
    ic("nominal-excess", (), ("n.stl",), {"n.stl": stl_binary(np.repeat(tri, 5, axis=0), 4)})
    ic("nominal-nan-mesh", (), ("n.stl",), {"n.stl": stl_binary(np.full((4, 3, 3), np.nan))})
    ic("nominal-three-points", (), ("n.stl", "n.xyz", "nominal"), {"n.stl": b"", "n.xyz": _xyz_text(v[:3])})
    ic("cloud-nan", (), ("c.xyz",), {"c.xyz": _xyz_text(pts) + b"nan 0 0\n"})
    ic("cloud-excess", (), ("c.ply",), {"c.ply": ply_binary(pts, 100)}, cloud="c.ply")
    ic("cloud-truncated", (), ("c.ply",), {"c.ply": ply_binary(pts)[:-100]}, cloud="c.ply")
    ic("cloud-one-point", (), ("c.xyz", "point"), {"c.xyz": b"1 2 3\n"})
    ic("cloud-image", (), ("c.png",), {"c.png": _encoded(".png")}, cloud="c.png")
    ic("out-bad-ext", ("--out", "out.las"), ("out.las",))
    ic("out-missing-folder", ("--out", "nodir/out.ply"), ("out.ply", "nodir"))
    ic("bad-unit", ("--unit", "furlong"), ("furlong",))
    ic("bad-nominal-unit", ("--nominal-unit", "furlong"), ("furlong",))
    cases.append(Case("inspect-no-nominal", ("inspect", "c.xyz"), base, ("nominal",)))
    return cases


def _uncertainty_cases() -> list[Case]:
    cases = []
    budget_ok = (
        b"quantity: x\nunit: um\ncontributions:\n  - {name: a, u: 3.1, dof: inf}\n"
        b"  - {name: b, u: 1.2, c: 1.4, dof: 20, distribution: rectangular}\n"
    )

    def bc(cid, data, names, args=()):
        cases.append(
            Case(f"budget-{cid}", ("uncertainty", "budget", "b.yaml", "--json", *args), {"b.yaml": data}, names)
        )

    bc("empty", b"", ("b.yaml",))
    bc("junk", _junk(800), ("b.yaml",))
    bc("bad-utf8", BAD_UTF8, ("b.yaml",))
    bc("alias-bomb", ALIAS_BOMB, ("b.yaml", "alias"))
    bc("duplicate-key", budget_ok + b"unit: mm\n", ("b.yaml", "unit", "duplicate"))
    bc("no-contributions", b"quantity: x\nunit: um\n", ("b.yaml", "contributions"))
    bc("contributions-empty", b"quantity: x\nunit: um\ncontributions: []\n", ("b.yaml", "contributions"))
    bc("contributions-not-list", b"quantity: x\nunit: um\ncontributions: 5\n", ("b.yaml", "contributions"))
    for key, val in (
        ("u", "-1"),
        ("u", ".nan"),
        ("u", ".inf"),
        ("u", "abc"),
        ("dof", "0"),
        ("dof", "-3"),
        ("dof", ".nan"),
        ("c", ".nan"),
        ("c", ".inf"),
        ("distribution", "weird"),
    ):
        body = f"quantity: x\nunit: um\ncontributions:\n  - {{name: a, u: 3.1, dof: 10, {key}: {val}}}\n".encode()
        if key == "u":
            body = f"quantity: x\nunit: um\ncontributions:\n  - {{name: a, u: {val}, dof: 10}}\n".encode()
        bc(f"{key}-{val.strip('.')}", body, ("b.yaml", key, val.strip(".")))
    bc("all-zero", b"quantity: x\nunit: um\ncontributions:\n  - {name: a, u: 0, dof: 10}\n", ("b.yaml", "zero", "u"))
    for p in ("0", "1", "1.5", "-0.1", "nan", "abc"):
        bc(f"coverage-{p}", budget_ok, ("coverage", p), ("--coverage-probability", p))
    bc("coverage-in-file", budget_ok + b"coverage_probability: 2\n", ("b.yaml", "coverage_probability"))
    bc("dof-rounding-bad", budget_ok, ("dof-rounding", "sideways"), ("--dof-rounding", "sideways"))
    cases.append(Case("budget-missing", ("uncertainty", "budget", "none.yaml"), {}, ("none.yaml",)))

    iso_ok = b"calibrated_value: 4.999\nu_cal: 0.0002\nmeasurements: [4.993, 5.003, 5.001]\nu_w: 0.0\nk: 2\n"

    def ic(cid, data, names, args=()):
        cases.append(
            Case(f"iso15530-{cid}", ("uncertainty", "iso15530-3", "i.yaml", "--json", *args), {"i.yaml": data}, names)
        )

    ic("empty", b"", ("i.yaml",))
    ic("junk", _junk(600), ("i.yaml",))
    ic("bad-utf8", BAD_UTF8, ("i.yaml",))
    ic("alias-bomb", ALIAS_BOMB, ("i.yaml", "alias"))
    ic("duplicate-key", iso_ok + b"u_cal: 5\n", ("i.yaml", "u_cal", "duplicate"))
    ic("no-measurements", iso_ok.replace(b"measurements: [4.993, 5.003, 5.001]\n", b""), ("i.yaml", "measurements"))
    ic("one-measurement", iso_ok.replace(b"[4.993, 5.003, 5.001]", b"[4.993]"), ("i.yaml", "measurements"))
    ic("measurement-text", iso_ok.replace(b"5.003", b"five"), ("i.yaml", "measurements", "five"))
    ic("measurement-nan", iso_ok.replace(b"5.003", b".nan"), ("i.yaml", "measurements", "nan"))
    ic("u-cal-negative", iso_ok.replace(b"u_cal: 0.0002", b"u_cal: -1"), ("i.yaml", "u_cal"))
    ic("u-w-nan", iso_ok.replace(b"u_w: 0.0", b"u_w: .nan"), ("i.yaml", "u_w"))
    ic("k-zero", iso_ok.replace(b"k: 2", b"k: 0"), ("i.yaml", "k"))
    ic("k-negative", iso_ok.replace(b"k: 2", b"k: -2"), ("i.yaml", "k"))
    for k in ("0", "-1", "nan", "inf", "x"):
        ic(f"opt-k-{k}", iso_ok, ("k", k), ("--k", k))
    ic(
        "project-missing",
        iso_ok,
        ("nowhere", "project", "result"),
        ("--project", "nowhere", "--result", "1", "--path", "x"),
    )
    ic("result-without-project", iso_ok, ("project", "result"), ("--result", "3"))

    mc_ok = (
        b"unit: um\niterations: 200\nseed: 1\ncameras:\n"
        b"  - {focal_length: 16.74, pixel_pitch: 0.00185, image_size: [4024, 3036], k: [-0.135, 0.24, 0.0]}\n"
        b"  - {focal_length: 16.66, pixel_pitch: 0.00185, image_size: [4024, 3036], k: [-0.13, 0.17, 0.0]}\n"
        b"stereo: {baseline: 199.35, angle_deg: 38.64}\ngrid: {size: [60, 40, 40], n: [2, 2, 2]}\n"
        b"uncertainties:\n  feature_location: 0.1\n  focal_length: [0.82, 0.84]\n"
        b"  rotation: [1.84e-4, 1.52e-4, 0.71e-4]\n  translation: [0.013, 0.008, 0.027]\n"
        b"  radial_distortion: [0.001, 0.0362, 0.0]\n"
        b"dof: {focal_length: 2244, rotation: 14, translation: 14, radial_distortion: 2244}\n"
    )

    def mc(cid, data, names, args=(), timeout=40.0):
        cases.append(
            Case(
                f"montecarlo-{cid}",
                ("uncertainty", "montecarlo", "m.yaml", "--json", *args),
                {"m.yaml": data},
                names,
                timeout=timeout,
            )
        )

    mc("empty", b"", ("m.yaml",))
    mc("junk", _junk(700), ("m.yaml",))
    mc("bad-utf8", BAD_UTF8, ("m.yaml",))
    mc("alias-bomb", ALIAS_BOMB, ("m.yaml", "alias"))
    mc("duplicate-key", mc_ok + b"seed: 2\n", ("m.yaml", "seed", "duplicate"))
    for old, new, names in (
        (b"image_size: [4024, 3036], k: [-0.135", b"image_size: [0, 0], k: [-0.135", ("image_size",)),
        (b"focal_length: 16.74", b"focal_length: 0", ("focal_length",)),
        (b"focal_length: 16.74", b"focal_length: -16", ("focal_length",)),
        (b"focal_length: 16.74", b"focal_length: .nan", ("focal_length",)),
        (b"pixel_pitch: 0.00185, image_size: [4024", b"pixel_pitch: 0, image_size: [4024", ("pixel_pitch",)),
        (b"n: [2, 2, 2]", b"n: [0, 0, 0]", ("grid", "n")),
        (b"n: [2, 2, 2]", b"n: [3000, 3000, 3000]", ("grid", "n", "3000")),
        (b"n: [2, 2, 2]", b"n: [-2, 2, 2]", ("grid", "n")),
        (b"size: [60, 40, 40]", b"size: [.nan, 40, 40]", ("grid", "size")),
        (b"baseline: 199.35", b"baseline: 0", ("baseline",)),
        (b"baseline: 199.35", b"baseline: -5", ("baseline",)),
        (b"iterations: 200", b"iterations: 1000000000000", ("iterations",)),
        (b"iterations: 200", b"iterations: 0", ("iterations",)),
        (b"seed: 1", b"seed: -1", ("seed",)),
        (b"feature_location: 0.1", b"feature_location: -0.1", ("feature_location",)),
        (b"feature_location: 0.1", b"feature_location: .nan", ("feature_location",)),
        (b"unit: um", b"unit: furlong", ("furlong", "unit")),
        (b"angle_deg: 38.64", b"angle_deg: 720", ("angle",)),
        (b"cameras:\n", b"cameras: []\nx:\n", ("cameras",)),
    ):
        mc(
            f"file-{old.split(b':')[0].decode().strip()}-{new.split(b':')[-1].decode().strip(' []').split(',')[0]}".replace(  # noqa: E501
                " ", ""
            ).replace(".", ""),
            mc_ok.replace(old, new, 1),
            ("m.yaml", *names),
        )
    for it in ("0", "-1", "1000000000000", "abc", "1e3"):
        mc(f"iterations-{it}", mc_ok, ("iterations", it), ("--iterations", it))
    for seed in ("-1", "abc", "1e40"):
        mc(f"seed-{seed}", mc_ok, ("seed", seed), ("--seed", seed))
    mc("method-bad", mc_ok, ("method", "magic"), ("--method", "magic"))
    mc("studies-bad", mc_ok, ("studies", "everything"), ("--studies", "everything"))
    mc("scheduler-bad", mc_ok, ("scheduler", "bogus"), ("--scheduler", "bogus://x"))
    mc("out-is-file", mc_ok, ("out", "o.txt"), ("--out", "o.txt"))
    cases[-1].files["o.txt"] = b"x"
    return cases


def _calibration_cases() -> list[Case]:
    board = chessboard_png()
    blank = _encoded(".png", (240, 320))
    cases = []

    def cc(cid, args, files, names, timeout=40.0):
        cases.append(Case(f"calibrate-{cid}", ("calibrate", "camera", *args, "--json"), files, names, timeout=timeout))

    imgs = {f"b{i}.png": board for i in range(3)}
    names3 = tuple(imgs)
    for spec in (
        "bogus",
        "chessboard:0x0:25",
        "chessboard:9x6:-25",
        "chessboard:9x6:nan",
        "chessboard:9x6:0",
        "chessboard:100000x100000:1",
        "charuco:5x5:20:30",
        "circles:4x11",
        "chessboard:9x6:inf",
        "charuco:5x7:20:10:NODICT",
    ):
        cc(f"board-{spec.replace(':', '-')}", (*names3, "--board", spec), imgs, ("board", spec))
    cc("missing-image", ("gone.png", "--board", "chessboard:9x6:20"), {}, ("gone.png",))
    cc("junk-image", ("j.png", "--board", "chessboard:9x6:20"), {"j.png": _junk(3000)}, ("j.png",))
    cc("bomb-image", ("bomb.png", "--board", "chessboard:9x6:20"), {"bomb.png": png_bomb()}, ("bomb.png",))
    cc(
        "no-board-found",
        ("blank.png", "blank2.png", "--board", "chessboard:9x6:20"),
        {"blank.png": blank, "blank2.png": blank},
        ("board", "blank.png", "corners", "views"),
    )
    cc("cloud-as-image", ("c.ply", "--board", "chessboard:9x6:20"), {"c.ply": ply_binary(_sphere(10))}, ("c.ply",))
    cc(
        "mixed-sizes",
        ("b0.png", "small.png", "--board", "chessboard:9x6:20"),
        {"b0.png": board, "small.png": blank},
        ("size", "small.png", "board"),
    )
    for opt, vals in {
        "--distance": ("-1", "0", "nan"),
        "--subpix-window": ("0", "-1", "100000"),
        "--outlier-factor": ("-1", "nan"),
    }.items():
        for val in vals:
            cc(
                f"{opt[2:]}-{val}",
                (*names3, "--board", "chessboard:9x6:20", opt, val),
                imgs,
                (opt[2:], opt[2:].replace("-", "_"), val),
            )
    cc("out-bad-ext", (*names3, "--board", "chessboard:9x6:20", "--out", "cal.txt"), imgs, ("cal.txt",))
    cases.append(
        Case(
            "calibrate-stereo-count-mismatch",
            (
                "calibrate",
                "stereo",
                "--left",
                "b0.png",
                "b1.png",
                "--right",
                "b2.png",
                "--board",
                "chessboard:9x6:20",
                "--json",
            ),
            imgs,
            ("left", "right"),
        )
    )
    cases.append(
        Case(
            "calibrate-stereo-missing",
            ("calibrate", "stereo", "--left", "x.png", "--right", "y.png", "--board", "chessboard:9x6:20"),
            {},
            ("x.png", "y.png"),
        )
    )
    for cid, left, names in (
        ("junk", {"l.png": _junk(900)}, ("l.png",)),
        ("bomb", {"l.png": png_bomb()}, ("l.png",)),
        ("misnamed", {"l.png": _encoded(".jpg")}, ("l.png",)),
        ("empty", {"l.png": b""}, ("l.png",)),
    ):
        cases.append(
            Case(
                f"calibrate-stereo-left-{cid}",
                (
                    "calibrate",
                    "stereo",
                    "--left",
                    "l.png",
                    "--right",
                    "b1.png",
                    "--board",
                    "chessboard:9x6:20",
                    "--json",
                ),
                {**imgs, **left},
                names,
            )
        )
    for spec in ("chessboard:9x6", "acircles:0x0:5"):
        cases.append(
            Case(
                f"calibrate-stereo-board-{spec.replace(':', '-')}",
                ("calibrate", "stereo", "--left", "b0.png", "--right", "b1.png", "--board", spec, "--json"),
                imgs,
                ("board", spec),
            )
        )
    cases.append(
        Case("calibrate-no-images", ("calibrate", "camera", "--board", "chessboard:9x6:20"), {}, ("IMAGES", "required"))
    )
    return cases


def _cal_yaml(fx=1000.0, fy=1000.0, baseline=100.0, size=(64, 48)) -> bytes:
    return (
        f"%YAML 1.2\n---\nM1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        f"   data: [ {fx}, 0., 32., 0., {fy}, 24., 0., 0., 1. ]\n"
        "D1: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n"
        "M2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        "   data: [ 1000., 0., 640., 0., 1000., 400., 0., 0., 1. ]\n"
        "D2: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n"
        f"image_size1: !!opencv-matrix\n   rows: 1\n   cols: 2\n   dt: i\n   data: [ {size[0]}, {size[1]} ]\n"
        "image_size2: !!opencv-matrix\n   rows: 1\n   cols: 2\n   dt: i\n   data: [ 1280, 800 ]\n"
        "camera_name1: camera\n"
        "camera_name2: projector\n"
        "R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n"
        f"T: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ {-baseline}, 0., 0. ]\n"
    ).encode()


def _fringe_cases() -> list[Case]:
    seq_ok = (
        b"projector: {width: 1280, height: 800}\nbit_depth: 8\nframes:\n  - white\n  - black\n"
        b"  - {type: phase, direction: vertical, steps: 4, period: 32}\n"
        b"  - {type: gray, direction: vertical, period: 32}\n"
    )
    cases = []

    def pc(cid, data, names, timeout=30.0):
        cases.append(
            Case(
                f"fringe-patterns-{cid}",
                ("fringe", "patterns", "s.yaml", "--out", "out", "--json"),
                {"s.yaml": data},
                names,
                timeout=timeout,
            )
        )

    pc("empty", b"", ("s.yaml",))
    pc("junk", _junk(500), ("s.yaml",))
    pc("bad-utf8", BAD_UTF8, ("s.yaml",))
    pc("alias-bomb", ALIAS_BOMB, ("s.yaml", "alias"))
    pc("duplicate-key", seq_ok + b"bit_depth: 16\n", ("s.yaml", "bit_depth", "duplicate"))
    for old, new, names in (
        (b"width: 1280, height: 800", b"width: 200000, height: 200000", ("width", "200000", "projector")),
        (b"width: 1280, height: 800", b"width: 0, height: 0", ("width", "projector")),
        (b"width: 1280, height: 800", b"width: -1280, height: 800", ("width", "projector")),
        (b"width: 1280, height: 800", b"width: .nan, height: 800", ("width", "projector")),
        (b"width: 1280, height: 800", b"width: 12.5, height: 800", ("width", "projector")),
        (b"steps: 4", b"steps: 0", ("steps",)),
        (b"steps: 4", b"steps: 1", ("steps",)),
        (b"steps: 4", b"steps: 1000000", ("steps",)),
        (b"steps: 4", b"steps: -4", ("steps",)),
        (b"period: 32}\n  - {type: gray", b"period: 0}\n  - {type: gray", ("period",)),
        (b"period: 32}\n  - {type: gray", b"period: -32}\n  - {type: gray", ("period",)),
        (b"period: 32}\n  - {type: gray", b"period: .nan}\n  - {type: gray", ("period",)),
        (b"bit_depth: 8", b"bit_depth: 3", ("bit_depth",)),
        (b"direction: vertical, steps", b"direction: sideways, steps", ("direction", "sideways")),
        (b"  - white\n", b"  - {type: ignore, count: 10000000}\n", ("count", "10000000")),
        (b"  - white\n", b"  - {type: hologram}\n", ("hologram", "type")),
        (b"frames:\n", b"frames: []\nx:\n", ("frames",)),
    ):
        pc(
            f"{new.split(b':')[0].decode().strip(' -{')}-{new.split(b':')[1].decode().strip(' ').split(',')[0]}".replace(  # noqa: E501
                " ", ""
            )
            .replace("{", "")
            .replace("}", "")
            .replace("\n-", ""),
            seq_ok.replace(old, new, 1),
            ("s.yaml", *names),
        )
    cases.append(
        Case(
            "fringe-patterns-out-is-file",
            ("fringe", "patterns", "s.yaml", "--out", "o.txt", "--json"),
            {"s.yaml": seq_ok, "o.txt": b"x"},
            ("o.txt",),
        )
    )
    cases.append(Case("fringe-patterns-missing", ("fringe", "patterns", "none.yaml", "--out", "o"), {}, ("none.yaml",)))

    frames = {f"imgs/f{i:02d}.png": _encoded(".png") for i in range(12)}

    def rc(cid, files, names, args=(), cal="cal.yaml"):
        base = {"s.yaml": seq_ok, "cal.yaml": _cal_yaml(), **frames}
        base.update(files)
        cases.append(
            Case(
                f"fringe-reconstruct-{cid}",
                ("fringe", "reconstruct", "s.yaml", "--images", "imgs", "--calibration", cal, "--json", *args),
                base,
                names,
            )
        )

    rc("negative-focal", {"cal.yaml": _cal_yaml(fx=-1000.0)}, ("cal.yaml", "focal"))
    rc("zero-focal", {"cal.yaml": _cal_yaml(fx=0.0, fy=0.0)}, ("cal.yaml", "focal"))
    rc("nan-focal", {"cal.yaml": _cal_yaml(fx=float("nan"))}, ("cal.yaml", "focal"))
    rc("no-baseline", {"cal.yaml": _cal_yaml(baseline=0.0)}, ("cal.yaml", "baseline"))
    rc("cal-junk", {"cal.yaml": _junk(900)}, ("cal.yaml",))
    rc("cal-bad-utf8", {"cal.yaml": BAD_UTF8}, ("cal.yaml",))
    rc("cal-missing", {}, ("nocal.yaml",), cal="nocal.yaml")
    rc("images-missing", {}, ("noimgs", "images"), args=("--images", "noimgs"))
    rc("images-empty-dir", {"empty/": b""}, ("empty", "images", "frames"), args=("--images", "empty"))
    rc("images-junk", {f"imgs/f{i:02d}.png": _junk(300, i) for i in range(12)}, ("f00.png", "imgs"))
    rc("images-bomb", {"imgs/f00.png": png_bomb()}, ("f00.png",))
    rc(
        "images-too-few",
        {f"imgs/f{i:02d}.png": b"" for i in range(12)} | {"few/a.png": _encoded(".png")},
        ("few", "frames", "images"),
        args=("--images", "few"),
    )
    rc("images-size-mismatch", {"imgs/f03.png": _encoded(".png", (20, 20))}, ("f03.png", "size", "imgs"))
    for opt, val in (
        ("--black-threshold", "-5"),
        ("--black-threshold", "nan"),
        ("--modulation-threshold", "-1"),
        ("--white-threshold", "inf"),
        ("--saturation", "0"),
        ("--saturation", "-1"),
    ):
        rc(f"{opt[2:]}-{val}", {}, (opt[2:], opt[2:].replace("-", "_"), val), args=(opt, val))
    rc("method-bad", {}, ("method", "magic"), args=("--method", "magic"))
    rc("stereo-without-images2", {}, ("images2", "stereo"), args=("--method", "stereo"))
    return cases


def _simulate_cases() -> list[Case]:
    import yaml

    seq = yaml.safe_dump(
        {"projector": {"width": 1280, "height": 800}, "bit_depth": 8, "frames": ["white", "black"]}
    ).encode()

    def scene(**over):
        doc = {
            "name": "t",
            "seed": 3,
            "artefacts": [{"type": "sphere", "center": [0, 0, 0], "diameter": 20.0}],
            "rig": {"preset": "stereo_fringe", "image_size": [64, 48]},
            "render": {"supersample": 1},
            "sequence": "seq.yaml",
            "patterns": ["white"],
        }
        doc.update(over)
        return yaml.safe_dump(doc, sort_keys=False).encode()

    cases = []

    def sc(cid, data, names, extra=None, timeout=40.0):
        cases.append(
            Case(
                f"simulate-{cid}",
                ("simulate", "scene.yaml", "--out", "out", "--json"),
                {"scene.yaml": data, "seq.yaml": seq, **(extra or {})},
                names,
                timeout=timeout,
            )
        )

    sc("empty", b"", ("scene.yaml",))
    sc("junk", _junk(400), ("scene.yaml",))
    sc("bad-utf8", BAD_UTF8, ("scene.yaml",))
    sc("alias-bomb", ALIAS_BOMB, ("scene.yaml", "alias"))
    sc("duplicate-key", scene() + b"seed: 9\n", ("scene.yaml", "seed", "duplicate"))
    for d in (0, -20, float("nan"), float("inf")):
        sc(
            f"sphere-diameter-{d}",
            scene(artefacts=[{"type": "sphere", "center": [0, 0, 0], "diameter": d}]),
            ("scene.yaml", "diameter"),
        )
    sc(
        "sphere-center-nan",
        scene(artefacts=[{"type": "sphere", "center": [float("nan"), 0, 0], "diameter": 20}]),
        ("scene.yaml", "center"),
    )
    v, f = _tetra()
    for s in (0, -1, float("nan")):
        sc(
            f"mesh-scale-{s}",
            scene(artefacts=[{"type": "mesh", "file": "m.stl", "scale": s}]),
            ("scene.yaml", "scale"),
            {"m.stl": stl_binary(v[f])},
        )
    sc("mesh-missing", scene(artefacts=[{"type": "mesh", "file": "gone.stl"}]), ("gone.stl",))
    sc("mesh-junk", scene(artefacts=[{"type": "mesh", "file": "j.stl"}]), ("j.stl",), {"j.stl": _junk(1000)})
    sc(
        "mesh-excess",
        scene(artefacts=[{"type": "mesh", "file": "x.stl"}]),
        ("x.stl",),
        {"x.stl": stl_binary(np.repeat(v[f], 10, axis=0), 4)},
    )
    sc("image-size-zero", scene(rig={"preset": "stereo_fringe", "image_size": [0, 0]}), ("scene.yaml", "image_size"))
    sc(
        "image-size-huge",
        scene(rig={"preset": "stereo_fringe", "image_size": [200000, 200000]}),
        ("scene.yaml", "image_size"),
    )
    sc(
        "image-size-negative",
        scene(rig={"preset": "stereo_fringe", "image_size": [-64, 48]}),
        ("scene.yaml", "image_size"),
    )
    sc("rig-unknown", scene(rig={"preset": "hexapod"}), ("scene.yaml", "hexapod", "preset"))
    for ss in (0, -1, 1000):
        sc(f"supersample-{ss}", scene(render={"supersample": ss}), ("scene.yaml", "supersample"))
    sc("read-noise-negative", scene(sensor={"read_noise": -1.0}), ("scene.yaml", "read_noise"))
    sc("sensor-bits-bad", scene(sensor={"bits": 3}), ("scene.yaml", "bits"))
    sc("seed-negative", scene(seed=-1), ("scene.yaml", "seed"))
    sc("artefact-unknown", scene(artefacts=[{"type": "cone", "diameter": 5}]), ("scene.yaml", "cone"))
    sc("artefacts-empty", scene(artefacts=[]), ("scene.yaml", "artefacts"))
    sc("sequence-missing", scene(sequence="none.yaml"), ("none.yaml",))
    sc("sequence-junk", scene(sequence="j.yaml"), ("j.yaml",), {"j.yaml": _junk(300)})
    sc("pattern-unknown", scene(patterns=["plaid"]), ("scene.yaml", "plaid", "patterns"))
    sc("ambient-negative", scene(lighting={"ambient": -1}), ("scene.yaml", "ambient"))
    cases.append(
        Case(
            "simulate-out-is-file",
            ("simulate", "scene.yaml", "--out", "o.txt", "--json"),
            {"scene.yaml": scene(), "seq.yaml": seq, "o.txt": b"x"},
            ("o.txt",),
        )
    )
    cases.append(Case("simulate-missing", ("simulate", "none.yaml", "--out", "o"), {}, ("none.yaml",)))
    return cases


def _scale_gauge_cases() -> list[Case]:
    x = np.linspace(0, 100, 11)
    csv_ok = ("interferometer,camera\n" + "".join(f"{a},{a * 1.0001}\n" for a in x)).encode()
    cases = []

    def sc(cid, data, names, args=(), extra=None):
        cases.append(
            Case(
                f"scale-{cid}",
                ("scale", "--interferometer", "i.csv", "--json", *args),
                {"i.csv": data, **(extra or {})},
                names,
            )
        )

    sc("empty", b"", ("i.csv",))
    sc("junk", _junk(500), ("i.csv",))
    sc("bad-utf8", BAD_UTF8 * 5, ("i.csv",))
    sc("header-only", b"interferometer,camera\n", ("i.csv",))
    sc("one-row", b"interferometer,camera\n1,1\n", ("i.csv",))
    sc("no-interferometer-column", b"a,b\n1,2\n3,4\n", ("i.csv", "interferometer"))
    sc("nan-value", csv_ok.replace(b"50.0,", b"nan,"), ("i.csv", "nan"))
    sc("inf-value", csv_ok.replace(b"50.0,", b"inf,"), ("i.csv", "inf"))
    sc("text-value", csv_ok.replace(b"50.0,", b"fifty,"), ("i.csv", "fifty"))
    sc("all-same", b"interferometer,camera\n" + b"5,5\n" * 10, ("i.csv", "travel", "interferometer"))
    sc("huge-row", b"interferometer,camera\n" + b"1," * 200000 + b"1\n2,2\n", ("i.csv",))
    for opt, val in (
        ("--accuracy", "-1"),
        ("--accuracy", "nan"),
        ("--accuracy", "2"),
        ("--length", "0"),
        ("--length", "-5"),
        ("--length", "nan"),
    ):
        sc(f"{opt[2:]}-{val}", csv_ok, (opt[2:], val), (opt, val))
    sc("calibration-missing", csv_ok, ("none.yaml",), ("--calibration", "none.yaml", "--out", "new.yaml"))
    sc(
        "calibration-junk",
        csv_ok,
        ("c.yaml",),
        ("--calibration", "c.yaml", "--out", "new.yaml"),
        {"c.yaml": _junk(400)},
    )
    sc("out-without-calibration", csv_ok, ("out", "calibration"), ("--out", "new.yaml"))
    cases.append(Case("scale-missing", ("scale", "--interferometer", "none.csv"), {}, ("none.csv",)))

    rng = _rng(7)
    platen = np.column_stack([rng.uniform(-50, 50, 1500), rng.uniform(-30, 30, 1500), np.zeros(1500)])
    face = np.column_stack([rng.uniform(-5, 5, 400), rng.uniform(-15, 15, 400), np.full(400, 25.0)])
    gb = {"g.xyz": _xyz_text(np.vstack([platen, face]))}

    def gc(cid, args, names, files=None):
        cases.append(
            Case(f"gauge-{cid}", ("gauge-block", "g.xyz", "--json", *args), gb if files is None else files, names)
        )

    for val in ("0", "-10", "nan", "inf", "abc"):
        gc(f"nominal-{val}", ("--nominal", val), ("nominal", val))
    for val in ("0", "-1", "nan"):
        gc(f"ransac-{val}", ("--nominal", "25", "--ransac-threshold", val), ("ransac", val))
    gc("up-zero", ("--nominal", "25", "--up", "0", "0", "0"), ("up",))
    gc("up-nan", ("--nominal", "25", "--up", "nan", "0", "1"), ("up", "nan"))
    gc("flat-only", ("--nominal", "25"), ("g.xyz", "plane", "block"), {"g.xyz": _xyz_text(platen)})
    gc("nan-cloud", ("--nominal", "25"), ("g.xyz",), {"g.xyz": gb["g.xyz"] + b"nan 0 0\n"})
    gc("missing-cloud", ("--nominal", "25"), ("g.xyz",), {})
    return cases


def _run_cases() -> list[Case]:
    S = _sphere(500)
    good = {"c.ply": ply_binary(S)}
    cases = []

    def rc(cid, args, names, files=None, timeout=40.0):
        cases.append(
            Case(f"run-{cid}", ("run", *args, "--json"), good if files is None else files, names, timeout=timeout)
        )

    for val in ("0", "-1", "nan", "inf", "abc", "1e-300"):
        rc(f"downsample-voxel-{val}", ("cloud.downsample", "c.ply", "--voxel-size", val), ("voxel", val))
    for opt, val in (("--nb-neighbors", "0"), ("--nb-neighbors", "-5"), ("--std-ratio", "-1"), ("--std-ratio", "nan")):
        rc(f"denoise-{opt[2:]}-{val}", ("cloud.denoise", "c.ply", opt, val), (opt[2:].replace("-", "_"), val))
    for opt, val in (("--radius", "0"), ("--radius", "nan"), ("--max-nn", "0"), ("--max-nn", "-1")):
        rc(f"normals-{opt[2:]}-{val}", ("cloud.normals", "c.ply", opt, val), (opt[2:].replace("-", "_"), val))
    rc("unknown-plugin", ("cloud.nope", "c.ply"), ("cloud.nope",))
    rc("device-plugin", ("devices.stage.simulated",), ("devices.stage.simulated",))
    rc("missing-input", ("cloud.downsample",), ("cloud", "input"))
    rc("extra-input", ("cloud.downsample", "c.ply", "c.ply", "c.ply"), ("input", "c.ply"))
    rc("input-missing-file", ("cloud.downsample", "gone.ply", "--voxel-size", "1"), ("gone.ply",))
    rc("input-junk", ("cloud.downsample", "j.ply", "--voxel-size", "1"), ("j.ply",), {"j.ply": _junk(700)})
    rc("input-excess", ("cloud.downsample", "x.ply", "--voxel-size", "1"), ("x.ply",), {"x.ply": ply_binary(S, 10)})
    rc("unknown-option", ("cloud.downsample", "c.ply", "--voxl", "1"), ("voxl",))
    rc("fit-sphere-nan", ("fit.sphere", "n.xyz"), ("n.xyz",), {"n.xyz": _xyz_text(S) + b"nan 0 0\n"})
    rc("fit-sphere-mesh", ("fit.sphere", "m.stl"), ("m.stl",), {"m.stl": stl_binary(_tetra()[0][_tetra()[1]])})
    for opt, val in (
        ("--n-points", "1000000000000"),
        ("--n-points", "0"),
        ("--n-points", "-1"),
        ("--diameter", "-5"),
        ("--diameter", "0"),
        ("--diameter", "nan"),
        ("--noise", "-1"),
        ("--noise", "nan"),
        ("--seed", "-1"),
    ):
        rc(
            f"artefact-cloud-{opt[2:]}-{val}",
            ("virtuallab.artefact-cloud", "--artefact", "sphere", opt, val),
            (opt[2:].replace("-", "_"), val),
            {},
        )
    rc("artefact-cloud-unknown", ("virtuallab.artefact-cloud", "--artefact", "cone"), ("artefact", "cone"), {})
    rc("uncertainty-budget-junk", ("uncertainty.budget", "b.yaml"), ("b.yaml",), {"b.yaml": _junk(300)})
    rc(
        "acceptance-set-huge",
        ("virtuallab.acceptance-set", "--n-sphere", "1000000000000", "--directory", "d"),
        ("n_sphere", "1000000000000"),
        {},
    )
    rc(
        "fringe-patterns-huge",
        ("fringe.patterns", "s.yaml"),
        ("s.yaml", "width", "200000"),
        {"s.yaml": b"projector: {width: 200000, height: 200000}\nbit_depth: 8\nframes: [white]\n"},
    )
    rc(
        "project-is-file",
        ("cloud.downsample", "c.ply", "--voxel-size", "1", "--project", "p.txt"),
        ("p.txt", "project"),
        dict(good, **{"p.txt": b"x"}),
    )
    return cases


def _devices_cases() -> list[Case]:
    cases = [
        Case("devices-list-bogus", ("devices", "list", "--bogus"), {}, ("--bogus",)),
        Case("devices-unknown-sub", ("devices", "explode"), {}, ("explode",)),
    ]
    # a value the simulator accepts starts it serving until killed: keep these few and short
    for opt, val in (
        ("--axes", "0"),
        ("--axes", "abc"),
        ("--resolution", "0"),
        ("--resolution", "nan"),
        ("--speed", "-200"),
        ("--travel", "-5"),
        ("--address", "1000"),
        ("--tcp", "not-an-address"),
        ("--tcp", "127.0.0.1:99999"),
        ("--seed", "-1"),
    ):
        cases.append(
            Case(
                f"devices-simulate-stage-{opt[2:]}-{val}",
                ("devices", "simulate-stage", opt, val),
                {},
                (opt[2:], opt[2:].replace("-", "_"), val),
                timeout=6.0,
            )
        )
    return cases


def _top_cases() -> list[Case]:
    return [
        Case("top-unknown-command", ("explode",), {}, ("explode",)),
        Case("top-unknown-option", ("--explode",), {}, ("--explode",)),
        Case("uncertainty-no-sub", ("uncertainty", "nothing"), {}, ("nothing",)),
        Case("fringe-no-sub", ("fringe", "nothing"), {}, ("nothing",)),
        Case("calibrate-no-sub", ("calibrate", "nothing"), {}, ("nothing",)),
        Case("plugins-bogus", ("plugins", "--bogus"), {}, ("--bogus",)),
        Case("demo-into-file", ("demo", "f.txt", "--json"), {"f.txt": b"x"}, ("f.txt",)),
        Case("serve-bad-port", ("serve", "--port", "99999", "--project", "p"), {}, ("port", "99999"), timeout=90),
        Case("serve-port-text", ("serve", "--port", "http"), {}, ("port", "http"), timeout=60),
    ]


@functools.cache
def all_cases() -> dict[str, Case]:
    cases = (
        _reader_cases()
        + _fit_cases()
        + _verify_cases()
        + _inspect_cases()
        + _uncertainty_cases()
        + _calibration_cases()
        + _fringe_cases()
        + _simulate_cases()
        + _scale_gauge_cases()
        + _run_cases()
        + _devices_cases()
        + _top_cases()
    )
    from helpers import badcases  # the families of issue 26 (readers and commands added since)

    cases += badcases.cases()
    out: dict[str, Case] = {}
    for c in cases:
        assert c.id not in out, f"duplicate case id {c.id}"
        out[c.id] = c
    return out


# -- the verdict ---------------------------------------------------------------------------
def _has_warning(stdout: str, stderr: str) -> bool:
    if "warning" in stderr.lower():
        return True
    try:
        doc = json.loads(stdout)
    except ValueError:
        return "warning" in stdout.lower()

    def walk(x):
        if isinstance(x, dict):
            return any((k == "warnings" and bool(v)) or walk(v) for k, v in x.items())
        if isinstance(x, list):
            return any(walk(v) for v in x)
        return False

    return walk(doc)


def _names(needle: str, line: str) -> bool:
    """``needle`` in ``line`` (any case); a short one such as ``0`` or ``-1`` only as a
    token of its own, so that "100.0 %" does not count as naming the value 0."""
    if len(needle) > 3:
        return needle.lower() in line.lower()
    import re

    return re.search(r"(?<![\w.])" + re.escape(needle) + r"(?![\w.])", line, re.IGNORECASE) is not None


def verdict(case: Case, res: dict) -> str | None:
    """None when the case behaved (one-line error naming the culprit, or exit 0 with a
    warning, within time and memory); else what went wrong, in one line."""
    rc, out, err = res["rc"], res["stdout"], res["stderr"]
    if not isinstance(rc, int):
        return str(rc)
    if res["memory"] > MEMORY_LIMIT:
        return f"used {res['memory'] / 2**30:.1f} GB"
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if rc == 0:
        if _has_warning(out, err):
            return None
        return "exit 0 without a warning: " + (out.strip().replace("\n", " ")[:160] or "(no output)")
    if "Traceback" in err:
        return "traceback: " + " | ".join(lines[-3:])[:300]
    if len(lines) != 1:
        return f"{len(lines)} lines on stderr: " + " | ".join(lines[:4])[:300]
    line = lines[0]
    if "internal error" in line:
        return line[:300]
    if case.names and not any(_names(n, line) for n in case.names):
        return f"names none of {list(case.names)}: {line[:240]}"
    return None


# -- running ---------------------------------------------------------------------------------
def _materialise(case: Case, d: Path) -> None:
    for name, data in case.files.items():
        p = d / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if name.endswith("/"):
            p.mkdir(parents=True, exist_ok=True)
        elif data.startswith(b"->"):
            p.symlink_to(data[2:].decode())
        elif data == b"<fifo>":
            os.mkfifo(p)
        else:
            p.write_bytes(data)


def _selftest(argv) -> int:
    """Misbehaviours on purpose, to show the harness catches each (tests/test_bad_inputs.py)."""
    what = argv[1]
    if what == "segv":
        os.kill(os.getpid(), signal.SIGSEGV)
    if what == "hang":
        time.sleep(3600)
    if what == "alloc":
        block = np.ones(((MEMORY_LIMIT + (256 << 20)) // 8,))
        return 0 if block[-1] == 1 else 1
    if what == "traceback":
        import traceback

        try:
            return 1 // 0
        except ZeroDivisionError:
            traceback.print_exc()
            return 1
    if what == "two-lines":
        print("camcmm: error: x.ply: bad\nand more", file=sys.stderr)
        return 2
    if what == "silent":
        print("{}")
        return 0
    if what == "native-stderr":
        os.write(2, b"[ WARN:0] noise from a library\n")
        print("camcmm: error: x.ply: bad", file=sys.stderr)
        return 2
    return 0


def _rss() -> int:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _reset_peak() -> None:
    """Start this process's peak resident set (VmHWM) afresh (Linux >= 4.0), before a case."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


def _maxrss() -> int:
    """The peak resident set of this process since :func:`_reset_peak`, or of a child it waited
    for. VmHWM, not getrusage's ru_maxrss: Linux carries ru_maxrss over fork and exec, so a worker
    started by a 1.2 GB test process (late in a pytest-xdist worker) read 1.2 GB before its
    first case."""
    import resource

    own = 0
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                own = int(line.split()[1])
                break
    return max(own, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss) * 1024


def _run_in_worker(case: Case, root: Path) -> dict:
    import io
    import shutil
    import tempfile
    import warnings

    from camcmm.cli.main import main

    d = Path(tempfile.mkdtemp(prefix="".join(c if c.isalnum() else "-" for c in case.id[:40]) + "-", dir=root))
    _materialise(case, d)
    old_env = {k: os.environ.get(k) for k in case.env}
    os.environ.update(case.env)
    out_f, err_f = tempfile.TemporaryFile(dir=root), tempfile.TemporaryFile(dir=root)
    saved = os.dup(1), os.dup(2)
    sys.stdout.flush(), sys.stderr.flush()
    py_out, py_err = io.StringIO(), io.StringIO()
    real = sys.stdout, sys.stderr
    cwd = os.getcwd()
    rss0 = _rss()
    _reset_peak()
    t0 = time.perf_counter()
    os.dup2(out_f.fileno(), 1), os.dup2(err_f.fileno(), 2)
    sys.stdout, sys.stderr = py_out, py_err
    try:
        os.chdir(d)
        with warnings.catch_warnings():
            # as in a fresh process: each warning once (catch_warnings forgets which were
            # shown), the categories Python hides by default hidden
            warnings.simplefilter("default")
            for cat in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
                warnings.simplefilter("ignore", cat)
            try:
                rc = _selftest(case.argv) if case.argv[:1] == ("__selftest__",) else main(list(case.argv))
            except SystemExit as exc:  # argparse's --help and usage errors
                rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
                if not isinstance(exc.code, int) and exc.code is not None:
                    print(exc.code, file=sys.stderr)
            except BaseException as exc:  # main() let something through: that is the finding
                import traceback

                traceback.print_exc()
                rc = f"escaped {type(exc).__name__}"
    finally:
        sys.stdout.flush(), sys.stderr.flush()
        os.dup2(saved[0], 1), os.dup2(saved[1], 2)
        os.close(saved[0]), os.close(saved[1])
        sys.stdout, sys.stderr = real
        os.chdir(cwd)
        for k, val in old_env.items():
            if val is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = val
    seconds = time.perf_counter() - t0
    native = []
    for fh in (out_f, err_f):
        fh.seek(0)
        native.append(fh.read().decode("utf-8", "replace"))
        fh.close()
    shutil.rmtree(d, ignore_errors=True)
    return {
        "rc": rc,
        "stdout": py_out.getvalue() + native[0],
        "stderr": py_err.getvalue() + native[1],
        "seconds": seconds,
        "memory": _maxrss() - rss0,
    }


def worker_main() -> None:
    """Read pickled cases on stdin (4-byte length + pickle), answer one JSON line each."""
    import resource
    import tempfile

    import camcmm.cli.main  # noqa: F401 - the import cost is paid once, not per case

    # a case that allocates without bound must fail inside this worker, not take the
    # machine: address space capped well above what any case may legitimately use
    with open("/proc/self/statm") as fh:
        vm = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    cap = vm + (4 << 30)
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    inp = sys.stdin.buffer
    root = Path(tempfile.mkdtemp(prefix="camcmm-badinputs-"))
    proto.write(json.dumps({"ready": True}) + "\n")
    while True:
        head = inp.read(4)
        if len(head) < 4:
            return
        case = pickle.loads(inp.read(struct.unpack("<I", head)[0]))
        try:
            res = _run_in_worker(case, root)
        except BaseException as exc:  # the harness itself failed on this case
            res = {"rc": f"harness {type(exc).__name__}: {exc}", "stdout": "", "stderr": "", "seconds": 0, "memory": 0}
        proto.write(json.dumps(res, default=str) + "\n")


class Worker:
    """One long-lived worker process; ``run(case)`` returns its result dict, or a dict
    with ``rc`` "crash: ..." / "hang: ..." when the process died or overran."""

    def __init__(self):
        env = dict(
            os.environ,
            # tests/ too: the cases arrive pickled as helpers.badinputs.Case (the module as the
            # tests import it), which the worker (this file run as __main__) must import
            PYTHONPATH=os.pathsep.join([str(HERE.parent), str(HERE), os.environ.get("PYTHONPATH", "")]),
            PYTHONUNBUFFERED="1",
            OMP_NUM_THREADS="1",
            OPENBLAS_NUM_THREADS="1",
            VTK_DEFAULT_OPENGL_WINDOW=os.environ.get("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow"),
        )
        self.proc = subprocess.Popen(
            [sys.executable, str(HERE / "badinputs.py"), "--worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
        )
        line = self._line(120)
        if not line:
            raise RuntimeError("a bad-input worker did not start")

    def _line(self, timeout: float) -> bytes | None:
        deadline = time.monotonic() + timeout
        buf = b""
        fd = self.proc.stdout.fileno()
        while not buf.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([fd], [], [], left)
            if ready:
                chunk = os.read(fd, 1 << 20)
                if not chunk:
                    return b""
                buf += chunk
        return buf

    def run(self, case: Case) -> dict:
        blob = pickle.dumps(case)
        try:
            self.proc.stdin.write(struct.pack("<I", len(blob)) + blob)
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass
        t0 = time.monotonic()
        line = self._line(case.timeout)
        if line is None:
            self.kill()
            return {
                "rc": f"hang: no answer in {case.timeout:g} s",
                "stdout": "",
                "stderr": "",
                "seconds": case.timeout,
                "memory": 0,
            }
        if not line:
            code = self.proc.wait()
            how = f"signal {signal.Signals(-code).name}" if code < 0 else f"exit {code}"
            return {
                "rc": f"crash: the worker died ({how})",
                "stdout": "",
                "stderr": "",
                "seconds": time.monotonic() - t0,
                "memory": 0,
            }
        return json.loads(line)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def kill(self) -> None:
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait()

    def close(self) -> None:
        try:
            self.proc.stdin.close()
            self.proc.wait(10)
        except Exception:
            self.kill()


def run_cases(cases: list[Case], workers: int = 2) -> dict[str, dict]:
    """Run the cases on ``workers`` worker processes; case id -> result dict. A worker
    that crashed, hung or grew past :data:`MEMORY_LIMIT` is replaced before the next case."""
    results: dict[str, dict] = {}
    todo = list(cases)
    lock = threading.Lock()

    def loop():
        w = None
        try:
            while True:
                with lock:
                    if not todo:
                        return
                    case = todo.pop(0)
                try:
                    if w is None or not w.alive():
                        w = Worker()
                    res = w.run(case)
                except Exception as exc:  # the harness, not the case: still that case's failure
                    res = {
                        "rc": f"harness: {type(exc).__name__}: {exc}",
                        "stdout": "",
                        "stderr": "",
                        "seconds": 0,
                        "memory": 0,
                    }
                    if w is not None:
                        w.kill()
                    w = None
                results[case.id] = res
                if not w.alive() or (isinstance(res.get("memory"), int) and res["memory"] > MEMORY_LIMIT // 2):
                    w.kill()  # a fresh baseline for the next case
                    w = None
        finally:
            if w is not None:
                w.close()

    threads = [threading.Thread(target=loop, daemon=True) for _ in range(max(1, workers))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return results


if __name__ == "__main__":
    if sys.argv[1:] == ["--worker"]:
        worker_main()
    else:  # run some or all cases and print the verdicts: badinputs.py [substring ...]
        sel = [c for c in all_cases().values() if not sys.argv[1:] or any(s in c.id for s in sys.argv[1:])]
        t0 = time.time()
        res = run_cases(sel, int(os.environ.get("CAMCMM_BADINPUT_WORKERS", "2")))
        for c in sel:
            r = res[c.id]
            print(
                json.dumps(
                    {
                        "id": c.id,
                        "verdict": verdict(c, r),
                        "rc": r["rc"],
                        "s": round(r["seconds"], 2),
                        "mb": r["memory"] >> 20,
                        "err": r["stderr"].strip()[-300:],
                        "out": r["stdout"].strip()[:200] if r["rc"] == 0 else "",
                    }
                )
            )
        print(f"# {len(sel)} cases in {time.time() - t0:.0f} s", file=sys.stderr)
