"""Camera images: PNG, JPEG, TIFF, BMP through OpenCV (imported only when needed).

Reading keeps the stored depth and channels (``IMREAD_UNCHANGED``): ``data`` is
(H, W) for grey, (H, W, 3) or (H, W, 4) in OpenCV's **BGR(A)** order, uint8 or
uint16 (16-bit PNG/TIFF from machine-vision cameras) or float32 (TIFF). Only the first
page of a multi-page TIFF is read. The bytes are read by Python and decoded from
memory, so paths with non-ASCII characters work on every platform.

Decompression bombs: a few kB of PNG can hold 20000 x 20000 px, gigabytes once
decoded. The width and height are read from the file's header first and an image of
more than ``CAMCMM_MAX_IMAGE_PIXELS`` pixels (environment variable, default
100 million, about a 10000 x 10000 camera frame) is refused before OpenCV decodes it.
OpenCV has no header-only read and its own limit (``OPENCV_IO_MAX_IMAGE_PIXELS``) is
read once per process, so the few header bytes are parsed here. A file whose size cannot
be read from its header (not a PNG, JPEG, TIFF or BMP, or a header cut short or
malformed) is refused, not decoded: the cap must not depend on the parser giving up
(a JPEG with one stray byte before its SOF0 used to be decoded at 2.4 GB). The JPEG
scan follows libjpeg's ``next_marker`` (stray bytes and 0xFF fill bytes between
segments are skipped), so whatever libjpeg decodes is measured first.

This is the one image reader of the project: every image camcmm decodes (plugins
through ``camcmm.api.read``) passes the cap here.

Writing encodes ``Image.data`` unchanged (BGR order) with the extension's codec.
"""

from __future__ import annotations

import os
import re
import struct
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..model import Image
from ._common import fail

#: Default of ``CAMCMM_MAX_IMAGE_PIXELS``: width x height above this is refused.
MAX_IMAGE_PIXELS = 100_000_000


def max_image_pixels() -> int:
    """The pixel cap: ``CAMCMM_MAX_IMAGE_PIXELS`` if set (a positive integer), else
    :data:`MAX_IMAGE_PIXELS`."""
    text = os.environ.get("CAMCMM_MAX_IMAGE_PIXELS", "").strip()
    if not text:
        return MAX_IMAGE_PIXELS
    try:
        number = float(text)
        value = int(number) if number.is_integer() else 0
    except (ValueError, OverflowError):
        value = 0
    if value <= 0:
        raise ParameterError(f"CAMCMM_MAX_IMAGE_PIXELS={text[:40]!r} is not a positive whole number of pixels")
    return value


#: Bytes a pixel of the largest uncompressed image (16-bit RGBA) and room for headers and
#: metadata: a file larger than the cap allows is refused before it is read into memory.
_MAX_BYTES_PER_PIXEL, _HEADER_ROOM = 8, 16 << 20


def load_bytes(path: Path, name: str) -> np.ndarray:
    """The file's bytes (uint8), refused from its size before it is read when it is
    larger than any image under the pixel cap can be."""
    size, cap = path.stat().st_size, max_image_pixels()
    if size > cap * _MAX_BYTES_PER_PIXEL + _HEADER_ROOM:
        raise fail(
            name,
            f"{size / 1e6:.0f} MB, more than any image of at most {cap / 1e6:g} Mpx takes "
            "(set CAMCMM_MAX_IMAGE_PIXELS to allow more); not read",
        )
    return np.fromfile(path, np.uint8)


def read(path: Path, name: str) -> Image:
    buf = load_bytes(path, name)
    measure(buf, path.suffix, name)
    import cv2

    error: str | None
    with _native_stderr() as said:
        try:
            data = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
        except cv2.error as exc:
            data, error = None, " ".join(str(exc).split())[:160]
        else:
            error = None
    if data is None:
        why = error or _reason(said[0])
        raise fail(
            name,
            f"cannot decode the image: not a valid {path.suffix.lstrip('.').upper()} file"
            + (f" ({why})" if why else ""),
        )
    if said[0].strip():
        # a decoder's complaint about an image it could still read (libjpeg: "Corrupt JPEG
        # data: 3 extraneous bytes before marker"): one explicit warning line, not raw noise
        os.write(2, f"camcmm: warning: {name}: {_reason(said[0])}\n".encode())
    if data.size == 0:
        raise fail(name, f"the image has no pixels ({data.shape[1] if data.ndim > 1 else 0} x {data.shape[0]})")
    meta = {"file": name, "channel_order": "BGR" if data.ndim == 3 else "grey"}
    return Image(data, name=name, metadata=meta)


def measure(buf: np.ndarray, suffix: str, name: str) -> tuple[int, int]:
    """(width, height) of the encoded image ``buf`` (the whole file's bytes), checked
    before any pixel is decoded: its content is the format its extension ``suffix``
    names, its size is read from its header and is within the pixel cap. Every decode of
    an image file in camcmm passes here first (:func:`read`; the GUI's thumbnails);
    otherwise a one-line InputError naming ``name``."""
    head = memoryview(buf.data)  # the whole file: a TIFF may keep its IFD at the end
    kind, expected = image_kind(head), _KIND_OF_EXT.get(suffix.lower())
    if kind is not None and expected is not None and kind != expected:
        raise fail(
            name,
            f"the file holds a {kind} image, not {expected} as its extension says; rename it to {_EXT_OF_KIND[kind]}",
        )
    size = image_size(head)
    if size is None:
        # refused, not left to OpenCV: an image whose size is unknown might be any size
        if kind is None:
            raise fail(name, "not a PNG, JPEG, TIFF or BMP image (unknown header); not decoded")
        raise fail(name, f"cannot read the image size from its {kind} header; not decoded")
    check_image_size(size, name)
    return size


_KIND_OF_EXT = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".tif": "TIFF", ".tiff": "TIFF", ".bmp": "BMP"}
_EXT_OF_KIND = {"PNG": ".png", "JPEG": ".jpg", "TIFF": ".tif", "BMP": ".bmp"}
_STDERR_LOCK = threading.Lock()
_LOG_PREFIX = re.compile(r"^\[\s*\w+:\d+@[\d.]+\]\s+global\s+\S+\s+(\S+\s+)?")


def image_kind(head: bytes | memoryview) -> str | None:
    """ "PNG", "JPEG", "TIFF" or "BMP" from the file's first bytes, None for anything else."""
    if bytes(head[:8]) == b"\x89PNG\r\n\x1a\n":
        return "PNG"
    if bytes(head[:3]) == b"\xff\xd8\xff":
        return "JPEG"
    if bytes(head[:4]) in (b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"):
        return "TIFF"
    if bytes(head[:2]) == b"BM":
        return "BMP"
    return None


@contextmanager
def _native_stderr():
    """Collect what native decoders print on file descriptor 2 while they run (libpng
    and libtiff print there, OpenCV logs there): a corrupt image then gives one error
    line that carries their reason, not a second line from the library. Yields a list
    that holds the text afterwards."""
    said: list[str] = []
    with _STDERR_LOCK:
        try:
            saved = os.dup(2)
        except OSError:  # no stderr to redirect
            said.append("")
            yield said
            return
        with tempfile.TemporaryFile() as tmp:
            os.dup2(tmp.fileno(), 2)
            try:
                yield said
            finally:
                os.dup2(saved, 2)
                os.close(saved)
                tmp.seek(0)
                said.append(tmp.read(65536).decode("utf-8", "replace"))


def _reason(text: str) -> str:
    """The last line a decoder printed, without OpenCV's log prefix."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    if not lines:
        return ""
    return " ".join(_LOG_PREFIX.sub("", lines[-1]).split())[:160]


def check_image_size(size: tuple[int, int], name: str) -> None:
    """Refuse a (width, height) that is empty or above the pixel cap, naming the file."""
    w, h = size
    if w <= 0 or h <= 0:
        raise fail(name, f"the image header declares {w} x {h} px; an image needs at least 1 x 1")
    cap = max_image_pixels()
    if w * h > cap:
        raise fail(
            name,
            f"the image header declares {w} x {h} px ({w * h / 1e6:.0f} Mpx), more than the "
            f"{cap / 1e6:g} Mpx camcmm decodes (set CAMCMM_MAX_IMAGE_PIXELS to allow more)",
        )


def image_size(head: bytes | memoryview) -> tuple[int, int] | None:
    """(width, height) from the header of a PNG, JPEG, BMP or TIFF file, or None
    when the header is not one of those or is cut short or malformed (:func:`read`
    then refuses the file rather than decode an image of unknown size)."""
    try:
        if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
            return struct.unpack(">II", head[16:24])
        if head[:2] == b"BM" and len(head) >= 26:
            hsize = struct.unpack("<I", head[14:18])[0]
            if hsize == 12:  # OS/2 BITMAPCOREHEADER
                return struct.unpack("<HH", head[18:22])
            w, h = struct.unpack("<ii", head[18:26])
            return w, abs(h)  # a negative height means top-down rows
        if head[:2] == b"\xff\xd8":
            return _jpeg_size(head)
        if head[:4] in (b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"):
            return _tiff_size(head)
    except (struct.error, IndexError):
        return None
    return None


_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def _jpeg_size(head) -> tuple[int, int] | None:
    """(width, height) of the first frame header (SOFn) of a JPEG, found as libjpeg's
    ``next_marker`` finds markers: bytes that are not 0xFF between segments (stray bytes,
    which libjpeg skips with a warning) and 0xFF fill bytes are skipped, 0xFF00 is no
    marker; segments with a length are stepped over. None when the scan data (SOS) or
    the end (EOI) comes before any frame header, or the file ends first."""
    data = bytes(head)  # bytes.find: a linear scan in C, not byte by byte in Python
    n, i = len(data), 2
    while True:
        i = data.find(b"\xff", i)
        if i < 0:
            return None
        while i < n and data[i] == 0xFF:  # the marker's 0xFF and any fill bytes
            i += 1
        if i >= n:
            return None
        marker = data[i]
        i += 1
        if marker == 0x00 or marker == 0x01 or 0xD0 <= marker <= 0xD8:  # stuffed byte, TEM, RSTn, SOI: no length
            continue
        if marker in (0xD9, 0xDA):  # end of image or scan data before any frame header
            return None
        if i + 2 > n:
            return None
        length = struct.unpack(">H", data[i : i + 2])[0]
        if marker in _SOF:
            if i + 7 > n:
                return None
            h, w = struct.unpack(">HH", data[i + 3 : i + 7])
            return w, h
        if length < 2:
            return None
        i += length


def _tiff_size(head) -> tuple[int, int] | None:
    bo = "<" if head[:2] == b"II" else ">"
    big = head[2:4] in (b"+\0", b"\0+")
    if big:
        offset = struct.unpack(bo + "Q", head[8:16])[0]
        count = struct.unpack(bo + "Q", head[offset : offset + 8])[0]
        entry, first, value_at = 20, offset + 8, 12
    else:
        offset = struct.unpack(bo + "I", head[4:8])[0]
        count = struct.unpack(bo + "H", head[offset : offset + 2])[0]
        entry, first, value_at = 12, offset + 2, 8
    found: dict[int, int] = {}
    for k in range(min(count, 4096)):
        e = head[first + k * entry : first + (k + 1) * entry]
        if len(e) < entry:
            break
        tag, typ = struct.unpack(bo + "HH", e[:4])
        if tag in (256, 257):
            code = {3: "H", 4: "I", 16: "Q"}.get(typ)
            if code is None:
                return None
            found[tag] = struct.unpack(bo + code, e[value_at : value_at + struct.calcsize(code)])[0]
    if 256 in found and 257 in found:
        return found[256], found[257]
    return None


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    import cv2

    try:
        ok, encoded = cv2.imencode(path.suffix.lower(), np.asarray(obj.data))
    except cv2.error as exc:
        raise fail(name, f"cannot encode the image ({' '.join(str(exc).split())[:160]})") from exc
    if not ok:
        raise fail(name, f"OpenCV cannot encode a {obj.data.dtype} {obj.data.shape} image as {path.suffix}")
    encoded.tofile(path)
