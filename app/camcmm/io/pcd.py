"""PCD (Point Cloud Library): ``DATA ascii``, ``binary`` and ``binary_compressed``.

Reading: ``x y z`` -> points (N, 3) float64 in the file's unit (PCD has no unit; a
``# unit m`` comment line, as camcmm writes, is honoured, default mm); ``rgb`` /
``rgba`` (packed 0x00RRGGBB, stored as U or F) -> colours (N, 3) uint8;
``normal_x/y/z`` -> normals; every other field -> a per-point field (a field with
COUNT k > 1 becomes ``name_0`` .. ``name_{k-1}``; PCL's ``_`` padding is dropped).
Points whose x, y or z is NaN (PCL's marker for "no return" in organised clouds) are
refused, like NaN in any other format: the message says how many there are.
``binary_compressed`` is LZF-decompressed here in pure Python, fine for clouds up to a
few million points.

Writing: ``DATA binary`` (or ``ascii``); x y z and normals as float (F 4), because
PCL only maps F 4 fields onto its point types and Open3D's reader turns binary F 8
coordinates into zeros; that rounds coordinates to float32 (about 30 nm at 1 m, in
mm). Use PLY to keep every digit. Colours as packed ``rgb`` U 4 (as Open3D writes
it), fields in their own type.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._common import (
    Raw,
    check_name,
    cloud_columns,
    fail,
    field_unit_comments,
    field_unit_from_comment,
    text_rows,
    unit_from_comment,
)

_CODES = {
    ("F", 4): "f4",
    ("F", 8): "f8",
    ("I", 1): "i1",
    ("I", 2): "i2",
    ("I", 4): "i4",
    ("I", 8): "i8",
    ("U", 1): "u1",
    ("U", 2): "u2",
    ("U", 4): "u4",
    ("U", 8): "u8",
}
_TYPES = {v: k for k, v in _CODES.items()}
_NORMALS = ("normal_x", "normal_y", "normal_z")
_MAX_HEADER_LINES = 1000


def read(path: Path, name: str) -> Raw:
    size = path.stat().st_size
    with open(path, "rb") as fh:
        hdr, comments, offset = _header(fh, name)
    unit = next((u for u in map(unit_from_comment, comments) if u), None)
    field_units = dict(fu for fu in map(field_unit_from_comment, comments) if fu)
    fields, types, sizes, counts = hdr["FIELDS"], hdr["TYPE"], hdr["SIZE"], hdr["COUNT"]
    n = hdr["POINTS"]
    cols = []
    for j, (f, t, s, c) in enumerate(zip(fields, types, sizes, counts)):
        code = _CODES.get((t, s))
        if code is None:
            raise fail(name, f"PCD field {f!r} has TYPE {t} SIZE {s}, which PCD does not define")
        cols.append((f if f != "_" else f"_pad{j}", "<" + code, (c,)))
    if len({c[0] for c in cols}) != len(cols):
        raise fail(name, f"PCD header names a field twice: {' '.join(fields)}")
    dt = np.dtype(cols)
    data = hdr["DATA"]
    if data == "ascii":
        table = _ascii(path, offset, sum(counts), n, name)
        arrays, k = {}, 0
        for (f, code, (c,)), _t in zip(cols, types):
            block = table[:, k : k + c]
            k += c
            arrays[f] = _ascii_rgb(block) if f in ("rgb", "rgba") else block.astype(code)
    elif data == "binary":
        if offset + n * dt.itemsize > size:
            raise fail(
                name,
                f"truncated PCD: the header promises {n} points of {dt.itemsize} bytes "
                f"({offset + n * dt.itemsize} bytes in all) but the file has {size}",
            )
        extra = size - offset - n * dt.itemsize
        if dt.itemsize and extra >= dt.itemsize:
            raise fail(
                name,
                f"PCD declares {n} points of {dt.itemsize} bytes but the file has {extra} bytes more, "
                f"room for {extra // dt.itemsize} more points: POINTS is wrong or data was appended",
            )
        arr = np.fromfile(path, dt, n, offset=offset) if n else np.zeros(0, dt)
        arrays = {f: arr[f].reshape(n, c) for f, _, (c,) in cols}
    elif data == "binary_compressed":
        arrays = _compressed(path, offset, cols, n, name)
    else:
        raise fail(name, f"PCD DATA {data!r} is not ascii, binary or binary_compressed")
    raw = _interpret(arrays, n, unit, data, name)
    raw.field_units = {k: u for k, u in field_units.items() if k in raw.fields}
    return raw


def _header(fh, name: str) -> tuple[dict, list[str], int]:
    hdr: dict = {}
    comments = []
    for lineno in range(1, _MAX_HEADER_LINES):
        raw = fh.readline(4096)
        if not raw:
            raise fail(name, "PCD header has no DATA line (the file ends inside the header)")
        try:
            line = raw.decode("ascii").strip()
        except UnicodeDecodeError:
            raise fail(name, f"not a PCD file: header line {lineno} is not ASCII text") from None
        if not line:
            continue
        if line.startswith("#"):
            comments.append(line.lstrip("#").strip())
            continue
        word, *values = line.split()
        key = word.upper()
        if key not in ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"):
            raise fail(name, f"not a PCD file: header line {lineno} starts with {word[:40]!r}")
        hdr[key] = values
        if key == "DATA":
            break
    else:
        raise fail(name, f"PCD header has no DATA line in its first {_MAX_HEADER_LINES} lines")
    try:
        nf = len(hdr["FIELDS"])
        out = {
            "FIELDS": hdr["FIELDS"],
            "SIZE": [int(v) for v in hdr["SIZE"]],
            "TYPE": [v.upper() for v in hdr["TYPE"]],
            "COUNT": [int(v) for v in hdr.get("COUNT", ["1"] * nf)],
            "DATA": hdr["DATA"][0].lower(),
        }
        width = int(hdr.get("WIDTH", ["0"])[0])
        height = int(hdr.get("HEIGHT", ["1"])[0])
        out["POINTS"] = int(hdr["POINTS"][0]) if "POINTS" in hdr else width * height
    except (KeyError, IndexError, ValueError) as exc:
        raise fail(name, f"bad PCD header: missing or malformed {exc}") from None
    if min(out["POINTS"], width, height, *out["SIZE"], *out["COUNT"]) < 0:
        raise fail(name, "bad PCD header: negative POINTS, WIDTH, HEIGHT, SIZE or COUNT")
    if "POINTS" in hdr and "WIDTH" in hdr and width * height != out["POINTS"]:
        raise fail(name, f"bad PCD header: POINTS {out['POINTS']} but WIDTH x HEIGHT = {width} x {height}")
    if not all(len(out[k]) == nf for k in ("SIZE", "TYPE", "COUNT")):
        raise fail(name, "bad PCD header: FIELDS, SIZE, TYPE and COUNT have different lengths")
    return out, comments, fh.tell()


def _ascii(path: Path, offset: int, ncols: int, n: int, name: str) -> np.ndarray:
    with open(path, "rb") as fh:
        fh.seek(offset)
        lines = [ln for ln in fh.read().decode("latin-1").splitlines() if ln.strip()]
    if len(lines) < n:
        raise fail(name, f"truncated PCD: the header promises {n} points but the file has {len(lines)} lines")
    if len(lines) > n:
        raise fail(
            name,
            f"PCD declares {n} points but the file has {len(lines)} data lines: POINTS is wrong or data was appended",
        )
    try:
        table = np.loadtxt(lines, dtype=np.float64, ndmin=2, comments=None) if n else np.zeros((0, ncols))
    except ValueError:
        table = None
    if table is None or table.shape[1] != ncols:
        for i, line in enumerate(lines):
            tokens = line.split()
            bad = len(tokens) != ncols
            for t in tokens:
                try:
                    float(t)
                except ValueError:
                    bad = True
            if bad:
                raise fail(name, f"PCD point {i}: expected {ncols} numbers, found {line[:60]!r}")
    if table is None:  # every line looked right, yet numpy refused them together
        raise fail(name, "PCD points cannot be read as a table of numbers")
    return table


def _ascii_rgb(block: np.ndarray) -> np.ndarray:
    """Packed colours written as text: PCL and Open3D write the 32-bit pattern as an
    integer, older writers print the float that has the same bits."""
    v = block[:, 0]
    integral = (v == np.round(v)) & (v >= 0) & (v < 2**32)
    out = np.where(integral, v, 0).astype(np.uint32)
    if not integral.all():
        out[~integral] = v[~integral].astype(np.float32).view(np.uint32)
    return out.reshape(-1, 1)


def _compressed(path: Path, offset: int, cols, n: int, name: str) -> dict:
    with open(path, "rb") as fh:
        fh.seek(offset)
        sizes = fh.read(8)
        if len(sizes) < 8:
            raise fail(name, "truncated PCD: no compressed block after DATA binary_compressed")
        csize, usize = (int(v) for v in np.frombuffer(sizes, "<u4"))
        need = n * sum(np.dtype(code).itemsize * c for _, code, (c,) in cols)
        if usize != need:
            raise fail(name, f"PCD compressed block unpacks to {usize} bytes, but {n} points need {need}")
        blob = fh.read(csize)
    if len(blob) < csize:
        raise fail(name, f"truncated PCD: the compressed block should have {csize} bytes, the file has {len(blob)}")
    raw = _lzf_decompress(blob, int(usize), name)
    arrays, pos = {}, 0
    for f, code, (c,) in cols:
        # binary_compressed stores the data field by field, not point by point
        item = np.dtype(code)
        nbytes = n * c * item.itemsize
        if pos + nbytes > len(raw):
            raise fail(name, f"PCD compressed data holds {len(raw)} bytes, fewer than the header needs")
        arrays[f] = np.frombuffer(raw, item, n * c, pos).reshape(n, c)
        pos += nbytes
    return arrays


def _lzf_decompress(data: bytes, size: int, name: str) -> bytes:
    out = bytearray()
    ip, end = 0, len(data)
    try:
        while ip < end:
            ctrl = data[ip]
            ip += 1
            if ctrl < 32:  # a literal run of ctrl + 1 bytes
                if len(out) + ctrl + 1 > size:
                    raise ValueError(f"more than the declared {size} bytes")
                out += data[ip : ip + ctrl + 1]
                ip += ctrl + 1
                continue
            length = ctrl >> 5
            if length == 7:
                length += data[ip]
                ip += 1
            ref = len(out) - ((ctrl & 0x1F) << 8) - data[ip] - 1
            ip += 1
            length += 2
            if len(out) + length > size:  # more than the header says: stop before it grows
                raise ValueError(f"more than the declared {size} bytes")
            if ref < 0:
                raise ValueError("back reference before the start")
            if ref + length <= len(out):
                out += out[ref : ref + length]
            else:  # the copy overlaps what it writes: a repeated pattern
                pattern = bytes(out[ref:])
                out += (pattern * (length // len(pattern) + 1))[:length]
    except (IndexError, ValueError) as exc:
        raise fail(name, f"PCD compressed data is corrupt ({exc})") from None
    if len(out) != size:
        raise fail(name, f"PCD compressed data unpacks to {len(out)} bytes, the header says {size}")
    return bytes(out)


def _interpret(arrays: dict, n: int, unit: str | None, encoding: str, name: str) -> Raw:
    missing = [c for c in "xyz" if c not in arrays]
    if missing:
        raise fail(name, f"PCD file has no {'/'.join(missing)} field")
    points = np.empty((n, 3))
    for j, c in enumerate("xyz"):
        points[:, j] = arrays[c][:, 0]
    colors = normals = None
    used = {"x", "y", "z"}
    for key in ("rgb", "rgba"):
        if key in arrays:
            packed = np.ascontiguousarray(arrays[key][:, 0]).view(np.uint32)
            colors = np.column_stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255]).astype(np.uint8)
            used.add(key)
            break
    if all(k in arrays for k in _NORMALS):
        normals = np.column_stack([arrays[k][:, 0] for k in _NORMALS]).astype(np.float64)
        used.update(_NORMALS)
    fields = {}
    for k, a in arrays.items():
        if k in used or k.startswith("_pad"):
            continue
        if a.shape[1] == 1:
            fields[k] = np.ascontiguousarray(a[:, 0])
        else:
            fields.update({f"{k}_{i}": np.ascontiguousarray(a[:, i]) for i in range(a.shape[1])})
    return Raw(points, colors, normals, fields, {}, None, unit, encoding)


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    pts, colors, normals, fields = cloud_columns(obj, factor)
    pts = pts.astype(np.float32)
    cols: list[tuple[str, np.ndarray]] = [("x", pts[:, 0]), ("y", pts[:, 1]), ("z", pts[:, 2])]
    if normals is not None:
        cols += [(k, normals[:, j].astype(np.float32)) for j, k in enumerate(_NORMALS)]
    if colors is not None:
        c = colors.astype(np.uint32)
        cols.append(("rgb", (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]))
    taken = {k for k, _ in cols}
    for k, a in fields.items():
        check_name(k, name)
        a = np.asarray(a)
        if a.dtype == np.bool_:
            a = a.astype(np.uint8)
        if a.ndim != 1 or a.dtype.str[1:] not in _TYPES:
            raise fail(name, f"cannot write field {k!r} ({a.dtype}, shape {a.shape}) to PCD")
        if k in taken:
            raise fail(name, f"cannot write field {k!r}: the name is taken by the coordinates, normals or colours")
        cols.append((k, a))
    types = [_TYPES[a.dtype.str[1:]] for _, a in cols]
    head = [
        "# .PCD v0.7 - Point Cloud Data file format",
        f"# unit {unit}",
        *(f"# {c}" for c in field_unit_comments(obj, fields)),
        "VERSION 0.7",
        "FIELDS " + " ".join(k for k, _ in cols),
        "SIZE " + " ".join(str(s) for _, s in types),
        "TYPE " + " ".join(t for t, _ in types),
        "COUNT " + " ".join("1" for _ in cols),
        f"WIDTH {len(pts)}",
        "HEIGHT 1",
        "VIEWPOINT 0 0 0 1 0 0 0",
        f"POINTS {len(pts)}",
        f"DATA {'binary' if binary else 'ascii'}",
    ]
    with open(path, "wb") as fh:
        fh.write(("\n".join(head) + "\n").encode("ascii"))
        if binary:
            rec = np.empty(len(pts), [(k, a.dtype.newbyteorder("<")) for k, a in cols])
            for k, a in cols:
                rec[k] = a
            rec.tofile(fh)
        else:
            for chunk in text_rows([a for _, a in cols]):
                fh.write(chunk.encode("ascii"))
