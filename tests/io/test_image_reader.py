"""The one image reader (issue 26): every image camcmm decodes is sized from its header
and capped first; what cannot be sized is refused, not decoded. The JPEG scan follows
libjpeg's marker reader, so a stray byte before SOF0 no longer hides a 20000 x 20000 px
frame, while a camera JPEG with fill or stray bytes still reads."""

from __future__ import annotations

import re
import struct
from pathlib import Path

import cv2
import numpy as np
import pytest

import camcmm.io as cio
from camcmm.errors import InputError
from camcmm.io.image import image_size, measure
from helpers.badinputs import bmp, jpeg_header, png, tiff

REPO = Path(__file__).resolve().parents[2]


def _jpeg_bomb(before_sof: bytes) -> bytes:
    """20000 x 20000 px: SOI, APP0, ``before_sof``, SOF0, EOI."""
    h = jpeg_header(20000, 20000)
    app0 = b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0"
    return h[:2] + app0 + before_sof + h[2:]


@pytest.fixture
def no_decode(monkeypatch):
    """cv2.imdecode fails the test if called: a refusal must come before any decode."""

    def boom(*a, **k):
        raise AssertionError("cv2.imdecode was called")

    monkeypatch.setattr(cv2, "imdecode", boom)


def _refused(path: Path, *needles: str) -> str:
    with pytest.raises(InputError) as err:
        cio.read(path)
    msg = str(err.value)
    assert "\n" not in msg and path.name in msg, msg
    for n in needles:
        assert n in msg, msg
    return msg


@pytest.mark.parametrize("junk", [b"\x00", b"stray bytes" * 9, b"\xff" * 5, b"\xff\x00\x01\xd0"])
def test_a_jpeg_bomb_behind_stray_bytes_is_measured_and_refused(tmp_path, no_decode, junk):
    data = _jpeg_bomb(junk)
    assert image_size(data) == (20000, 20000)
    p = tmp_path / "bomb.jpg"
    p.write_bytes(data)
    _refused(p, "20000 x 20000 px", "more than the 100 Mpx")


def _camera_jpeg() -> bytes:
    img = (np.indices((48, 64)).sum(axis=0) * 3 % 256).astype(np.uint8)
    return cv2.imencode(".jpg", np.dstack([img, img[::-1], 255 - img]), [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes()


@pytest.mark.parametrize(
    "where, extra",
    [(20, b"abc"), (20, b"\xff\xff\xff"), (2, b"\xff\xff")],  # stray bytes and fill bytes between segments
)
def test_a_jpeg_with_fill_or_stray_bytes_between_segments_still_reads(tmp_path, capfd, where, extra):
    clean = _camera_jpeg()
    assert clean[where] == 0xFF  # a marker starts there
    p = tmp_path / "cam.jpg"
    p.write_bytes(clean[:where] + extra + clean[where:])
    want = cv2.imdecode(np.frombuffer(clean, np.uint8), cv2.IMREAD_UNCHANGED)
    img = cio.read(p)
    assert img.data.shape == (48, 64, 3) and np.array_equal(img.data, want)
    err = capfd.readouterr().err
    # libjpeg's complaint about the stray bytes is passed on as one explicit warning line
    assert err == "" or (err.count("\n") == 1 and err.startswith("camcmm: warning: cam.jpg: ")), err


@pytest.mark.parametrize(
    "name, data",
    [
        ("sos.jpg", b"\xff\xd8\xff\xda\x00\x02" + b"\0" * 64),  # scan data before any frame header
        ("eoi.jpg", b"\xff\xd8\xff\xd9"),
        ("cut.jpg", jpeg_header(640, 480)[:8]),
        ("badlen.jpg", b"\xff\xd8\xff\xe0\x00\x01" + b"\0" * 32),
        ("noihdr.png", b"\x89PNG\r\n\x1a\n" + b"\0" * 40),
        ("cut.png", png(64, 48)[:20]),
        ("nosize.tif", tiff(8, 8).replace(struct.pack("<HHI", 256, 4, 1), struct.pack("<HHI", 300, 4, 1), 1)),
        ("farifd.tif", b"II*\0" + struct.pack("<I", 10**9) + b"\0" * 16),
        ("short.bmp", b"BM" + b"\0" * 12),
    ],
)
def test_an_image_whose_size_cannot_be_read_is_refused_not_decoded(tmp_path, no_decode, name, data):
    p = tmp_path / name
    p.write_bytes(data)
    _refused(p, "cannot read the image size from its", "not decoded")


def test_an_unknown_header_is_refused_not_decoded(tmp_path, no_decode):
    p = tmp_path / "gif.png"
    p.write_bytes(b"GIF89a" + b"\0" * 40)
    _refused(p, "not a PNG, JPEG, TIFF or BMP image", "not decoded")


@pytest.mark.parametrize(
    "name, data",
    [("png.png", png(20000, 20000)), ("t.tif", tiff(20000, 20000, b"")), ("b.bmp", bmp(20000, 20000, b""))],
)
def test_bombs_of_every_format_are_refused_from_the_header(tmp_path, no_decode, name, data):
    p = tmp_path / name
    p.write_bytes(data)
    _refused(p, "20000 x 20000 px")


def test_a_65535_square_png_header_is_one_line_even_above_opencvs_own_limit(tmp_path, monkeypatch):
    p = tmp_path / "huge.png"
    p.write_bytes(png(65535, 65535, idat=b"x"))
    _refused(p, "65535 x 65535 px")
    # with camcmm's cap raised beyond OpenCV's CV_IO_MAX_IMAGE_PIXELS (2^30), OpenCV's own
    # refusal is folded into the one line, not raised as cv2.error
    monkeypatch.setenv("CAMCMM_MAX_IMAGE_PIXELS", str(10**10))
    _refused(p, "cannot decode the image")


def _repo_images() -> list[Path]:
    exts = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"}
    roots = [REPO / "tests", REPO / "docs", REPO / "app", REPO / "plugins"]
    return sorted(p for r in roots if r.is_dir() for p in r.rglob("*") if p.suffix.lower() in exts and p.is_file())


def test_every_valid_image_of_the_repository_still_reads_at_its_size():
    """The calibration images and every other image kept in the repository: measured from
    the header exactly as OpenCV decodes them, and read."""
    files = _repo_images()
    assert len(files) >= 50, files  # tests/data's chessboard and kamino410 series at least
    for p in files:
        buf = np.fromfile(p, np.uint8)
        want = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
        if want is None:  # not an image OpenCV reads either (none today)
            continue
        assert measure(buf, p.suffix, p.name) == (want.shape[1], want.shape[0]), p
    for p in files[:: max(1, len(files) // 20)]:  # and a sample through the public reader
        assert cio.read(p).data.size > 0


def test_the_gui_thumbnail_of_a_bomb_is_empty_without_decoding(tmp_path, no_decode):
    from camcmm.gui.pages.photogrammetry.inputs import thumbnail

    p = tmp_path / "bomb.jpg"
    p.write_bytes(_jpeg_bomb(b"\x00"))
    assert thumbnail(p) == ""


_READERS = re.compile(
    r"cv2\.imread\b|cv2\.imdecode\b|\bImage\.open\b|imageio|tifffile|skimage\.io|\.read_image\b|cv2\.imreadmulti"
)


def test_every_image_read_of_the_project_goes_through_the_one_reader():
    """No other module of app/ or plugins/ decodes image files: they call camcmm.api.read
    (plugins) or camcmm.io.image (app). The GUI's thumbnails decode reduced, after
    camcmm.io.image.measure has sized and capped the file."""
    allowed = {
        "app/camcmm/io/image.py": "cv2.imdecode",
        "app/camcmm/gui/pages/photogrammetry/inputs.py": "cv2.imdecode",
    }
    found = []
    for root in ("app", "plugins"):
        for f in (REPO / root).rglob("*.py"):
            rel = f.relative_to(REPO).as_posix()
            for m in _READERS.finditer(f.read_text(encoding="utf-8")):
                if allowed.get(rel) != m.group(0):
                    found.append(f"{rel}: {m.group(0)}")
    assert not found, found
    thumbs = (REPO / "app/camcmm/gui/pages/photogrammetry/inputs.py").read_text(encoding="utf-8")
    assert thumbs.index("measure(buf") < thumbs.index("cv2.imdecode(")


def test_a_file_larger_than_any_image_under_the_cap_is_not_read(tmp_path, monkeypatch):
    """Above cap x 8 bytes (16-bit RGBA) + 16 MB of header room a file is refused from its
    size alone, before a byte is read: with a cap of 1 px, a sparse 20 MB 'PNG'."""
    p = tmp_path / "huge.png"
    with open(p, "wb") as fh:
        fh.write(png(8, 8))
        fh.truncate(20 << 20)  # sparse: no 20 MB written
    monkeypatch.setenv("CAMCMM_MAX_IMAGE_PIXELS", "1")
    monkeypatch.setattr(np, "fromfile", lambda *a, **k: pytest.fail("the file was read"))
    _refused(p, "21 MB, more than any image of at most 1e-06 Mpx", "not read")
