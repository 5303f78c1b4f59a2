"""ISO 25178-71 SDF height maps (Surface Data File), ASCII (``aISO-1.0``) and binary
(``bISO-1.0``), read and written here.

The header gives NumPoints (x) and NumProfiles (y), the steps Xscale, Yscale and the
height factor Zscale, all in metres by the standard; camcmm converts to mm and records
``source_unit = "m"``. Data types 5 (int16), 6 (int32) and 7 (float64); heights are
value * Zscale. Invalid points: ``BAD`` in ASCII files, NaN in float data, the type's
minimum (-2^15, -2^31) in integer data. Binary files hold an 81-byte little-endian
header (8-byte magic, ManufacID 10 s, CreateDate and ModDate 12 s each, NumPoints and
NumProfiles uint16, Xscale, Yscale, Zscale, Zresolution float64, Compression, DataType,
CheckType uint8), then the points x fastest. Written by hand because the layout is
fixed and short; SurfaceTopography reads what this writes (tests check it).

Checked before the points are read (issue 26; :mod:`camcmm.io._maps`): the grid within
the memory limit, the steps and Zscale positive, finite and plausible (a map wider than
5000 mm is a wrong header), a binary file exactly as long as its header and points
(trailing bytes refused with the counts), an ASCII file no longer than its values can
take (40 bytes each, plus a 64 kB trailer), read line by line.

Writing: data type 7 (float64 values in mm, Zscale 1e-3 so heights come back bit for
bit; steps as mm / 1000, in ASCII as the exact decimal), binary by default, ASCII with ``binary=False``
(``BAD`` for invalid points, one profile per line). The uint16 sizes cap a grid at
65535 x 65535 points.
"""

from __future__ import annotations

import io
import struct
from datetime import datetime
from decimal import Decimal
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..model import HeightMap
from ._common import fail
from ._maps import MIN_Z_FACTOR_MM, check_grid, check_heights, check_plausible, factor

_HEAD = struct.Struct("<8s10s12s12sHHddddBBB")
_TYPES = {5: "<i2", 6: "<i4", 7: "<f8"}
_M_TO_MM = 1000.0
_KEYS = ("NumPoints", "NumProfiles", "Xscale", "Yscale", "Zscale", "DataType")


def read(path: Path, name: str) -> HeightMap:
    size = path.stat().st_size
    with open(path, "rb") as fh:
        magic = fh.read(8)
        if magic == b"bISO-1.0":
            header, raw = _binary(fh, size, name)
            encoding = "binary"
        elif magic == b"aISO-1.0":
            header, raw = _ascii(fh, size, name)
            encoding = "ascii"
        else:
            raise fail(name, f"not an ISO 25178-71 SDF file (starts {magic!r}, expected b'aISO-1.0' or b'bISO-1.0')")
    dtype = header["DataType"]
    z = raw.astype(np.float64)
    if dtype in (5, 6):
        z[raw == np.iinfo(_TYPES[dtype]).min] = np.nan
    del raw
    if header["k"] != 1.0:
        z *= header["k"]
    check_heights(name, z, f" (SDF Zscale {header['Zscale']})")
    meta: dict[str, Any] = {"format": f"ISO 25178-71 SDF ({encoding})"}
    for key in ("ManufacID", "CreateDate"):
        v = header.get(key)
        v = v.decode("latin-1") if isinstance(v, bytes) else v
        if v and str(v).strip("\x00 "):
            meta[key.lower()] = str(v).strip("\x00 ")
    return HeightMap(z, header["dx"], header["dy"], name=name, source_unit="m", meta=meta)


def _scales(header: dict[str, Any], name: str) -> None:
    """Check the grid and the header fields that scale the data before the data are
    read; adds the steps ``dx``, ``dy`` and the height factor ``k`` in mm."""
    nx, ny = header["NumPoints"], header["NumProfiles"]
    check_grid(name, nx, ny, np.dtype(_TYPES[header["DataType"]]).itemsize + 8, "SDF grid")
    try:
        dx, dy, k = (_mm(header[key]) for key in ("Xscale", "Yscale", "Zscale"))
    except ArithmeticError:  # a decimal beyond the context's exponent range
        raise fail(name, "SDF Xscale, Yscale or Zscale is out of range") from None
    check_plausible(name, nx, ny, dx, dy, fields=f" (SDF Xscale {header['Xscale']}, Yscale {header['Yscale']})")
    header["dx"], header["dy"] = dx, dy
    header["k"] = factor(name, f"SDF Zscale {header['Zscale']}", k, MIN_Z_FACTOR_MM)


def _binary(fh: BinaryIO, size: int, name: str) -> tuple[dict[str, Any], np.ndarray]:
    """The binary header and the points, the file's length checked against the grid
    before the points are read: short is cut, longer holds bytes no field accounts for."""
    head = b"bISO-1.0" + fh.read(_HEAD.size - 8)
    if len(head) < _HEAD.size:
        raise fail(name, f"SDF header is cut short ({len(head)} bytes)")
    _, manuf, created, _mod, nx, ny, xs, ys, zs, _zres, comp, dtype, _chk = _HEAD.unpack(head)
    if comp != 0:
        raise fail(name, f"SDF compression {comp} is not supported (only 0, none)")
    if dtype not in _TYPES:
        raise fail(name, f"SDF data type {dtype} is not one of 5 (int16), 6 (int32), 7 (float64)")
    header = {"ManufacID": manuf, "CreateDate": created, "NumPoints": nx, "NumProfiles": ny}
    header.update(Xscale=xs, Yscale=ys, Zscale=zs, DataType=dtype)
    _scales(header, name)
    need = nx * ny * np.dtype(_TYPES[dtype]).itemsize
    if size - _HEAD.size < need:
        raise fail(name, f"SDF data are cut short: {size - _HEAD.size} bytes for {nx} x {ny} points ({need} bytes)")
    if size - _HEAD.size > need:
        raise fail(
            name,
            f"SDF holds {size - _HEAD.size} bytes of data; its {nx} x {ny} points of data type {dtype} "
            f"need {need}: {size - _HEAD.size - need} trailing bytes (a damaged or wrongly sized file)",
        )
    raw = np.fromfile(fh, dtype=_TYPES[dtype], count=nx * ny).reshape(ny, nx)
    return header, raw


def _mm(metres: float | str) -> float:
    """Metres to mm in decimal (on the text, or the shortest repr of a binary value): a
    step written as the decimal of its mm value shifted by 1e-3 in ASCII comes back as the same float64, one written as
    mm / 1000 in binary within a unit of the last place."""
    if isinstance(metres, str):
        return float(Decimal(metres) * 1000)
    return float(Decimal(repr(float(metres))) * 1000) if np.isfinite(metres) else float(metres)


#: An ASCII value takes at most this many bytes with its separator (a float64's repr is
#: at most 24 characters): a longer file holds something else, refused before parsing.
_ASCII_BYTES_PER_VALUE = 40
_ASCII_HEADER_BYTES = 1 << 16
#: ... and the optional trailer after the data's closing '*' line is a few lines of text.
_ASCII_TRAILER_BYTES = 1 << 16


def _ascii(fh: BinaryIO, size: int, name: str) -> tuple[dict[str, Any], np.ndarray]:
    fh.seek(0)
    head_blob = fh.read(_ASCII_HEADER_BYTES)
    head, sep, _ = head_blob.decode("latin-1").partition("\n*")
    if not sep:
        raise fail(name, "SDF header does not end with a '*' line (within 64 kB)")
    header: dict[str, Any] = {}
    for line in head.splitlines()[1:]:
        key, eq, value = line.partition("=")
        if eq:
            header[key.strip()] = value.strip()
    missing = [k for k in _KEYS if k not in header]
    if missing:
        raise fail(name, f"SDF header lacks {', '.join(missing)}")
    try:
        for k in ("NumPoints", "NumProfiles", "DataType"):
            text = header[k]
            if not (text.isascii() and text.lstrip("+-").isdigit()) or len(text) > 12:
                raise ValueError(f"{k} = {text[:40]}")
            header[k] = int(text)
        for k in ("Xscale", "Yscale", "Zscale"):
            if not np.isfinite(float(header[k])):  # kept as text: _mm scales it in decimal
                raise ValueError(f"{k} = {header[k][:40]}")
    except ValueError as exc:
        raise fail(name, f"SDF header value is not a number ({exc})") from None
    if header["DataType"] not in _TYPES:
        raise fail(name, f"SDF data type {header['DataType']} is not one of 5, 6, 7")
    _scales(header, name)
    n = header["NumPoints"] * header["NumProfiles"]
    if size > len(head) + _ASCII_TRAILER_BYTES + n * _ASCII_BYTES_PER_VALUE:
        raise fail(
            name,
            f"SDF is {size} bytes; {header['NumPoints']} x {header['NumProfiles']} values take at most "
            f"{n * _ASCII_BYTES_PER_VALUE} (trailing data or a wrong NumPoints/NumProfiles)",
        )
    fh.seek(0)
    text = fh.read().decode("latin-1")
    rest = text.partition("\n*")[2]
    del text
    body = rest.split("\n", 1)[1] if "\n" in rest else ""
    body = body.partition("\n*")[0]  # an optional trailer follows a second '*' line
    # line by line into the grid: a list of every value as Python objects would take ~10
    # times the grid's memory
    values = np.empty(n, dtype=np.float64)
    got = 0
    for line in io.StringIO(body):
        words = ["nan" if w.upper() == "BAD" else w for w in line.split()]
        if got + len(words) > n:
            raise fail(
                name, f"SDF holds more than {n} values for {header['NumPoints']} x {header['NumProfiles']} points"
            )
        try:
            values[got : got + len(words)] = np.array(words, dtype=np.float64)
        except ValueError as exc:
            raise fail(name, f"SDF data value is not a number ({str(exc)[:80]})") from None
        got += len(words)
    if got != n:
        raise fail(name, f"SDF holds {got} values for {header['NumPoints']} x {header['NumProfiles']} points")
    if np.isinf(values).any():
        raise fail(name, "SDF data hold an infinite value (invalid points are BAD)")
    return header, values.reshape(header["NumProfiles"], header["NumPoints"])


def write(obj: Any, path: Path, *, binary: bool = True, name: str, **_: Any) -> None:
    """Write ``obj`` (a HeightMap) as SDF (metres, data type 7, float64)."""
    hm: HeightMap = obj
    ny, nx = hm.shape
    if nx > 65535 or ny > 65535:
        raise fail(name, f"SDF holds at most 65535 x 65535 points; the map has {nx} x {ny}")
    z = hm.heights  # mm, with Zscale 1e-3: heights come back bit for bit
    stamp = datetime.now().strftime("%d%m%Y%H%M")
    dx, dy = hm.dx / _M_TO_MM, hm.dy / _M_TO_MM
    with open(path, "wb") as fh:
        if binary:
            fh.write(
                _HEAD.pack(b"bISO-1.0", b"camcmm", stamp.encode(), stamp.encode(), nx, ny, dx, dy, 1e-3, -1.0, 0, 7, 0)
            )
            fh.write(np.ascontiguousarray(z, dtype="<f8").tobytes())
            return
        lines = [
            "aISO-1.0",
            "ManufacID   = camcmm",
            f"CreateDate  = {stamp}",
            f"ModDate     = {stamp}",
            f"NumPoints   = {nx}",
            f"NumProfiles = {ny}",
            f"Xscale      = {Decimal(repr(hm.dx)).scaleb(-3)}",
            f"Yscale      = {Decimal(repr(hm.dy)).scaleb(-3)}",
            "Zscale      = 1e-3",
            "Zresolution = -1",
            "Compression = 0",
            "DataType    = 7",
            "CheckType   = 0",
            "*",
        ]
        fh.write(("\n".join(lines) + "\n").encode("ascii"))
        for row in z:
            # repr round-trips a float64 exactly
            fh.write((" ".join("BAD" if v != v else repr(float(v)) for v in row) + "\n").encode("ascii"))
        fh.write(b"*\n")
