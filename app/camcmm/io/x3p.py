"""ISO 25178-72 X3P height maps (XML 3D surface profile), read and written here.

An X3P file is a zip holding ``main.xml`` (axes, grid size, instrument, data link) and
the heights as little-endian binary (``bindata/data.bin``, x fastest: row by row).
X3P lengths are metres by definition; camcmm converts to mm and records
``source_unit = "m"``. Written by hand (zipfile and ElementTree) rather than through
SurfaceTopography: the format is small, the writer must keep camcmm's metadata, and
reading a 4 M-point map stays one numpy view of the zip member.

Reading: incremental x/y axes (AxisType I) with their increments and offsets (the map's
origin), the z axis as I/L/F/D with z = value * increment + offset, invalid points from
NaN, infinity (older openGPS versions) or the optional validity bitmap
(``ValidPointsLink``, least-significant bit first, as openGPS's ValidBuffer writes it;
SurfaceTopography 1.25 writes it so too but reads it most-significant bit first), the
MD5 of the point data checked when given, Record2 (date, instrument, probing system,
comment) kept in ``meta``.
Limits (issue 26; :mod:`camcmm.io._maps`): the zip's declared sizes within the memory
limit and no member inflating like a bomb (> 100:1 and > 256 MB), main.xml at most 4 MB
and without a DTD or entities (billion laughs, external entities), each member read in
1 MB chunks no further than the grid main.xml declares (its declared size must be the
grid's, its inflated size is checked while reading), so reading holds the raw data and
their float64 heights and no more; increments and offsets refused when 0, negative,
non-finite or implausible (a map wider than 5000 mm, heights beyond it).
Writing: float64 values in mm with the z increment 1e-3 (z in metres = value *
increment, as the standard defines it), NaN for invalid points (allowed for floating
types, so no validity bitmap), increments and offsets written as the exact decimal of
the mm value times 1e-3 and read back in decimal, so a map comes back bit for bit; the
md5 checksum file; Record2 from ``meta`` (``instrument``, ``date``, ``comment``).
Besides the standard's members, camcmm writes the intensity channel and the whole
``meta`` as ``camcmm/intensity.bin`` and ``camcmm/meta.json``, which other readers
ignore, so X3P is camcmm's lossless store of a height map.
"""

from __future__ import annotations

import hashlib
import json
import xml.etree.ElementTree as ET
import zipfile
from datetime import UTC, datetime
from decimal import Decimal
from pathlib import Path
from typing import Any
from xml.parsers import expat

import numpy as np

from .. import __version__
from ..jsonable import to_jsonable
from ..model import HeightMap
from ._common import fail
from ._maps import MIN_Z_FACTOR_MM, check_grid, check_heights, check_plausible, check_zip, factor, read_member

_NS = "http://www.opengps.eu/2008/ISO5436_2"
_DTYPES = {"I": "<u2", "L": "<u4", "F": "<f4", "D": "<f8"}
#: camcmm's own members, outside the standard's links (other readers ignore them): the
#: intensity channel (float64, the heights' order) and the full metadata as JSON, so a
#: map stored in a project comes back whole.
_INTENSITY, _META = "camcmm/intensity.bin", "camcmm/meta.json"
#: main.xml (and camcmm/meta.json) larger than this is refused before it is read: a
#: header of axes, sizes and a record of the instrument is a few kB.
MAX_XML = 4 << 20


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _tree(elem: ET.Element, depth: int = 0) -> Any:
    """The element as nested dicts of local names -> text (namespaces dropped); X3P nests
    four levels, so deeper nesting is cut off (no recursion limit reached on a hostile file)."""
    if len(elem) == 0 or depth > 16:
        return (elem.text or "").strip()
    return {_local(child.tag): _tree(child, depth + 1) for child in elem}


def _mm(d: dict, key: str, name: str, default: float | None = None, axis: str = "") -> float:
    """The value (metres in the file) in mm, scaled in decimal: what :func:`write` wrote
    as the decimal of ``repr(mm)`` shifted by 1e-3 comes back as the same float64, bit for bit."""
    text = d.get(key)
    label = f"X3P {axis} {key}".replace("  ", " ")
    if text in (None, ""):
        if default is None:
            raise fail(name, f"X3P main.xml has no {axis} {key}".replace("  ", " "))
        return default
    if not isinstance(text, str):
        raise fail(name, f"{label} is not a number (it has child elements)")
    try:
        v = float(Decimal(text.strip()) * 1000)
    except (ArithmeticError, ValueError):  # InvalidOperation, Overflow of the decimal context
        raise fail(name, f"{label} {text[:40]!r} is not a number (or is out of range)") from None
    if not np.isfinite(v):
        raise fail(name, f"{label} {text[:40]!r} is not a finite number")
    return v


def _count(d: dict, key: str, name: str) -> int:
    text = _text(d, key)
    if not (text.isascii() and text.isdigit()) or len(text) > 12:
        raise fail(name, f"X3P {key} {text[:40]!r} is not a whole number of points")
    return int(text)


def _text(d: dict, key: str) -> str:
    """A leaf's text ('' when missing or when it has children)."""
    v = d.get(key)
    return v if isinstance(v, str) else ""


def _metres(mm: float) -> str:
    return str(Decimal(repr(float(mm))).scaleb(-3))


def _xml(zf: zipfile.ZipFile, name: str) -> ET.Element:
    """main.xml parsed, refused when it declares more than :data:`MAX_XML` bytes (before
    reading; zipfile stops at the declared size) or carries a document type declaration:
    X3P's schema needs none, and entities are how an XML bomb (billion laughs) expands a
    few kB into gigabytes. Checked by expat itself, so no encoding hides it."""
    try:
        info = zf.getinfo("main.xml")
    except KeyError:
        raise fail(name, "not an X3P file (the zip has no main.xml)") from None
    if info.file_size > MAX_XML:
        raise fail(name, f"X3P main.xml declares {info.file_size} bytes; more than {MAX_XML} is not a header")
    data = read_member(zf, "main.xml", name, info.file_size, "X3P")

    def refuse(*_: Any) -> None:
        raise fail(name, "X3P main.xml declares a DTD or entities, which X3P does not use (refused: entity expansion)")

    check = expat.ParserCreate()
    check.StartDoctypeDeclHandler = refuse
    check.EntityDeclHandler = refuse
    try:
        check.Parse(bytes(data), True)
        return ET.fromstring(bytes(data))
    except (expat.ExpatError, ET.ParseError, LookupError) as exc:  # LookupError: an unknown encoding
        raise fail(name, f"X3P main.xml is not valid XML ({str(exc)[:100]})") from None


def read(path: Path, name: str) -> HeightMap:
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError, EOFError):
        raise fail(name, "not an X3P file (not a zip archive)") from None
    with zf:
        check_zip(zf, name, "X3P zip")
        doc = _tree(_xml(zf, name))
        rec1, rec3 = doc.get("Record1"), doc.get("Record3")
        if not isinstance(rec1, dict) or not isinstance(rec3, dict):
            raise fail(name, "X3P main.xml lacks Record1 or Record3")
        if _text(rec1, "FeatureType") != "SUR":
            raise fail(name, f"X3P feature type {_text(rec1, 'FeatureType')[:40]!r} is not a surface (SUR)")
        axes = rec1.get("Axes") or {}
        cx, cy, cz = (_dict(axes.get(k)) for k in ("CX", "CY", "CZ"))
        if _text(cx, "AxisType") != "I" or _text(cy, "AxisType") != "I":
            raise fail(name, "X3P with absolute x/y axes is a point list, not a height map on a grid")
        dims = _dict(rec3.get("MatrixDimension"))
        nx, ny, nz = (_count(dims, k, name) for k in ("SizeX", "SizeY", "SizeZ"))
        if nz != 1 or nx < 1 or ny < 1:
            raise fail(name, f"X3P grid {nx} x {ny} x {nz} is not one layer of points")
        dtype = _DTYPES.get(_text(cz, "DataType"))
        if dtype is None:
            raise fail(name, f"X3P z data type {_text(cz, 'DataType')[:40]!r} is not one of I, L, F, D")
        # the header fields that scale the data, checked before any data are read
        dx = _mm(cx, "Increment", name, axis="CX")
        dy = _mm(cy, "Increment", name, axis="CY")
        origin = (_mm(cx, "Offset", name, 0.0, "CX"), _mm(cy, "Offset", name, 0.0, "CY"))
        check_plausible(name, nx, ny, dx, dy, origin, fields=" (X3P CX/CY Increment)")
        inc, off = _mm(cz, "Increment", name, 1000.0, "CZ"), _mm(cz, "Offset", name, 0.0, "CZ")
        factor(name, f"X3P CZ Increment {_text(cz, 'Increment')[:40]!r}", inc, MIN_Z_FACTOR_MM)
        link = _dict(rec3.get("DataLink"))
        member = _text(link, "PointDataLink")
        if not member:
            raise fail(name, "X3P main.xml has no PointDataLink (data inside the XML are not supported)")
        n, size = nx * ny, nx * ny * np.dtype(dtype).itemsize
        # the raw data, their float64 heights, the validity bits and the intensity
        check_grid(name, nx, ny, np.dtype(dtype).itemsize + 8 + 8 + 1, "X3P grid")
        blob = read_member(zf, member, name, size, "X3P data")
        expected = _text(link, "MD5ChecksumPointData")
        if expected and hashlib.md5(blob).hexdigest().upper() != expected.upper():
            raise fail(name, f"X3P data {member!r} do not match their MD5 checksum (a damaged file)")
        raw = np.frombuffer(blob, dtype=dtype).reshape(ny, nx)
        # z = value * increment + offset (metres), taken to mm in one factor each
        z = raw.astype(np.float64)
        del raw, blob
        if inc != 1.0:
            z *= inc
        if off != 0.0:
            z += off
        if dtype in ("<f4", "<f8"):  # openGPS marked invalid float points with +inf before NaN
            z[np.isinf(z)] = np.nan
        valid_member = _text(link, "ValidPointsLink")
        if valid_member:
            # whole bytes, least-significant bit first; a writer may pad to a word
            bits = np.frombuffer(
                read_member(zf, valid_member, name, (n + 7) // 8, "X3P validity data", slack=8), dtype=np.uint8
            )
            valid = np.unpackbits(bits, count=n, bitorder="little").reshape(ny, nx).astype(bool)
            z[~valid] = np.nan
        check_heights(name, z, " (X3P CZ Increment and Offset)")
        meta = _record2(doc.get("Record2"))
        meta["format"] = "ISO 25178-72 X3P"
        names = set(zf.namelist())
        intensity = None
        if _INTENSITY in names:
            intensity = np.frombuffer(read_member(zf, _INTENSITY, name, n * 8, "X3P"), dtype="<f8").reshape(ny, nx)
        if _META in names:
            size = zf.getinfo(_META).file_size
            if size > MAX_XML:
                raise fail(name, f"X3P {_META} declares {size} bytes; more than {MAX_XML} is not metadata")
            try:
                kept = json.loads(bytes(read_member(zf, _META, name, size, "X3P")))
            except (ValueError, RecursionError) as exc:  # RecursionError: nesting beyond Python's stack
                raise fail(name, f"X3P {_META} is not JSON ({str(exc)[:100]})") from None
            if isinstance(kept, dict):
                if kept.get("format") not in (None, meta["format"]):
                    kept["source_format"] = kept["format"]  # the instrument file it came from
                meta.update(kept, format=meta["format"])
    return HeightMap(z, dx, dy, intensity=intensity, origin=origin, name=name, source_unit="m", meta=meta)


def _dict(v: Any) -> dict:
    """An element of main.xml that must hold children (a leaf or a missing one: empty)."""
    return v if isinstance(v, dict) else {}


def _record2(rec2: Any) -> dict[str, Any]:
    if not isinstance(rec2, dict):
        return {}
    meta: dict[str, Any] = {}
    inst = rec2.get("Instrument")
    if isinstance(inst, dict):
        meta["instrument"] = {k.lower(): v for k, v in inst.items() if v and v not in ("unknown", "not available")}
    for key, out in (("Date", "date"), ("Creator", "creator"), ("CalibrationDate", "calibration_date")):
        if rec2.get(key):
            meta[out] = rec2[key]
    probe = rec2.get("ProbingSystem")
    if isinstance(probe, dict) and probe:
        meta["probing_system"] = {k.lower(): v for k, v in probe.items() if v}
    if rec2.get("Comment"):
        meta["comment"] = rec2["Comment"]
    return meta


def _sub(parent: ET.Element, tag: str, text: str | None = None) -> ET.Element:
    e = ET.SubElement(parent, tag)
    if text is not None:
        e.text = text
    return e


def _axis(parent: ET.Element, tag: str, kind: str, dtype: str, inc_mm: float, off_mm: float) -> None:
    ax = _sub(parent, tag)
    _sub(ax, "AxisType", kind)
    _sub(ax, "DataType", dtype)
    _sub(ax, "Increment", _metres(inc_mm))
    _sub(ax, "Offset", _metres(off_mm))


def write(obj: Any, path: Path, *, name: str, **_: Any) -> None:
    """Write ``obj`` (a HeightMap) as X3P at ``path``: float64 values in mm with the z
    increment 1e-3 (so z in metres is value * increment, as the standard defines, and
    the heights come back bit for bit), NaN = invalid."""
    hm: HeightMap = obj
    data = np.ascontiguousarray(hm.heights, dtype="<f8").tobytes()
    md5 = hashlib.md5(data).hexdigest().upper()
    root = ET.Element("p:ISO5436_2", {"xmlns:p": _NS})
    rec1 = _sub(root, "Record1")
    _sub(rec1, "Revision", "ISO5436 - 2000")
    _sub(rec1, "FeatureType", "SUR")
    axes = _sub(rec1, "Axes")
    _axis(axes, "CX", "I", "D", hm.dx, hm.origin[0])
    _axis(axes, "CY", "I", "D", hm.dy, hm.origin[1])
    _axis(axes, "CZ", "A", "D", 1.0, 0.0)
    rec2 = _sub(root, "Record2")
    meta = hm.meta or {}
    _sub(rec2, "Date", str(meta.get("date") or datetime.now(UTC).isoformat(timespec="seconds")))
    _sub(rec2, "Creator", str(meta.get("creator") or "camcmm"))
    inst: dict[str, Any] = meta["instrument"] if isinstance(meta.get("instrument"), dict) else {}
    ins = _sub(rec2, "Instrument")
    _sub(ins, "Manufacturer", str(inst.get("manufacturer") or inst.get("vendor") or "unknown"))
    _sub(ins, "Model", str(inst.get("model") or inst.get("name") or "unknown"))
    _sub(ins, "Serial", str(inst.get("serial") or "not available"))
    _sub(ins, "Version", str(inst.get("version") or f"camcmm {__version__}"))
    _sub(rec2, "CalibrationDate", str(meta.get("calibration_date") or meta.get("date") or "unknown"))
    probe = _sub(rec2, "ProbingSystem")
    _sub(probe, "Type", "NonContacting")
    _sub(probe, "Identification", str((meta.get("probing_system") or {}).get("identification") or "unknown"))
    _sub(rec2, "Comment", str(meta.get("comment") or hm.name))
    rec3 = _sub(root, "Record3")
    dims = _sub(rec3, "MatrixDimension")
    ny, nx = hm.shape
    for tag, v in (("SizeX", nx), ("SizeY", ny), ("SizeZ", 1)):
        _sub(dims, tag, str(v))
    link = _sub(rec3, "DataLink")
    _sub(link, "PointDataLink", "bindata/data.bin")
    _sub(link, "MD5ChecksumPointData", md5)
    _sub(_sub(root, "Record4"), "ChecksumFile", "md5checksum.hex")
    xml = b'<?xml version="1.0" encoding="UTF-8" standalone="no" ?>\n' + ET.tostring(root, encoding="utf-8")
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        zf.writestr("main.xml", xml)
        # stored, not deflated: float64 measurement noise barely compresses (a 4 M-point map
        # shrinks ~5 %) while deflating it takes seconds, inflating it a third of the read
        zf.writestr("bindata/data.bin", data, compress_type=zipfile.ZIP_STORED)
        zf.writestr("md5checksum.hex", f"{hashlib.md5(xml).hexdigest().upper()} *main.xml\n")
        if hm.intensity is not None:
            zf.writestr(_INTENSITY, np.ascontiguousarray(hm.intensity, dtype="<f8").tobytes())
        if hm.meta:
            zf.writestr(_META, json.dumps(to_jsonable(hm.meta)))
