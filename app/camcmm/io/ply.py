"""PLY (Stanford polygon file): ascii, binary little-endian and binary big-endian.

Reading
    ``vertex`` element: ``x, y, z`` -> points (N, 3) float64 in the file's unit (the
    caller scales to mm); ``red/green/blue`` (also ``r/g/b``, ``diffuse_*``) -> colours
    (N, 3) uint8; ``nx/ny/nz`` (also ``normal_x``...) -> normals (N, 3); every other
    scalar property -> a per-point field with its dtype kept (``deviation``, ``alpha``,
    ``intensity`` ...).
    ``face`` element with a ``vertex_indices`` / ``vertex_index`` list -> triangles
    (F, 3) int64; polygons are split into fans. No face element, or one with zero
    rows, gives a point cloud.
    Unit: ``comment unit m`` or ``comment units: meters`` (also as ``obj_info``);
    ``comment field_unit deviation mm`` sets a field's unit. Default: mm.

Binary bodies are read by numpy, one ``fromfile`` per element (no Python loop per
vertex); only files whose lists change length from row to row (mixed polygons) go
through plyfile. The header is parsed here so that truncated or garbage files get a
precise message.

Writing: x, y, z as double, normals as double, colours as uchar, fields in their own
type; ``comment unit <unit>`` and one ``comment field_unit <name> <unit>`` per field.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ._common import (
    Raw,
    check_name,
    cloud_columns,
    colors_to_uint8,
    fail,
    field_unit_comments,
    field_unit_from_comment,
    text_rows,
    triangulate,
    unit_from_comment,
)

_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}
_NAMES = {
    "i1": "char",
    "u1": "uchar",
    "i2": "short",
    "u2": "ushort",
    "i4": "int",
    "u4": "uint",
    "f4": "float",
    "f8": "double",
}
_ENCODINGS = ("ascii", "binary_little_endian", "binary_big_endian")
_COLORS = (("red", "green", "blue"), ("r", "g", "b"), ("diffuse_red", "diffuse_green", "diffuse_blue"))
_NORMALS = (("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z"))
_FACE_LISTS = ("vertex_indices", "vertex_index")
_MAX_HEADER_LINES = 10_000


@dataclass
class _Prop:
    name: str
    dtype: str  # numpy code without byte order, e.g. "f4"
    count: str | None = None  # numpy code of a list's length, None for a scalar


@dataclass
class _Element:
    name: str
    count: int
    props: list[_Prop] = field(default_factory=list)

    @property
    def fixed(self) -> bool:
        return all(p.count is None for p in self.props)


@dataclass
class _Header:
    encoding: str
    elements: list[_Element]
    comments: list[str]
    size: int  # bytes up to and including the end_header line


# -- reading --------------------------------------------------------------------------
def read(path: Path, name: str) -> Raw:
    size = path.stat().st_size
    with open(path, "rb") as fh:
        hdr = read_header(fh, name)
    if hdr.encoding == "ascii":
        elements = _read_ascii(path, hdr, name)
    else:
        elements = _read_binary(path, hdr, name, size)
        if elements is None:
            elements = _read_with_plyfile(path, hdr, name, size)
    return _interpret(elements, hdr, name)


def read_header(fh, name: str) -> _Header:
    """The header of the PLY file open as ``fh`` (binary), checked; one-line refusals name ``name``."""
    magic = fh.readline(64)
    if magic.rstrip(b"\r\n") != b"ply":
        raise fail(name, f"not a PLY file: it starts with {magic[:20]!r}, expected 'ply'")
    encoding, elements, comments = None, [], []
    for lineno in range(2, _MAX_HEADER_LINES):
        raw = fh.readline(4096)
        if not raw:
            raise fail(name, "PLY header has no end_header line (the file ends inside the header)")

        def bad(why: str) -> Exception:
            return fail(name, f"bad PLY header line {lineno} {raw[:60]!r}: {why}")

        if not raw.endswith(b"\n"):
            raise bad("line too long or file ends inside the header")
        try:
            line = raw.decode("ascii").strip()
        except UnicodeDecodeError:
            raise bad("not ASCII text") from None
        tokens = line.split()
        if not tokens:
            continue
        word = tokens[0]
        if word == "end_header":
            break
        if word in ("comment", "obj_info"):
            comments.append(line[len(word) :].strip())
        elif word == "format":
            if len(tokens) != 3 or tokens[1] not in _ENCODINGS:
                raise bad(f"expected 'format <{'|'.join(_ENCODINGS)}> 1.0'")
            encoding = tokens[1]
        elif word == "element":
            if len(tokens) != 3 or not tokens[2].isdigit():
                raise bad("expected 'element <name> <count>'")
            elements.append(_Element(tokens[1], int(tokens[2])))
        elif word == "property":
            if not elements:
                raise bad("property before any element")
            if len(tokens) == 3 and tokens[1] in _TYPES:
                prop = _Prop(tokens[2], _TYPES[tokens[1]])
            elif (
                len(tokens) == 5
                and tokens[1] == "list"
                and tokens[3] in _TYPES
                and _TYPES.get(tokens[2], "f")[0] in "iu"
            ):
                prop = _Prop(tokens[4], _TYPES[tokens[3]], _TYPES[tokens[2]])
            else:
                raise bad("expected 'property <type> <name>' or 'property list <int type> <type> <name>'")
            if any(p.name == prop.name for p in elements[-1].props):
                raise bad(f"property {prop.name!r} appears twice in element {elements[-1].name!r}")
            elements[-1].props.append(prop)
        else:
            raise bad(f"unknown keyword {word!r}")
    else:
        raise fail(name, f"PLY header has no end_header line in its first {_MAX_HEADER_LINES} lines")
    if encoding is None:
        raise fail(name, "PLY header has no format line")
    for el in elements:
        if el.count and not el.props:  # rows of nothing: a header that cannot be right
            raise fail(name, f"PLY element {el.name!r} declares {el.count} rows but no properties")
    return _Header(encoding, elements, comments, fh.tell())


def _truncated(name: str, el: _Element, need: int, size: int) -> Exception:
    return fail(
        name,
        f"truncated binary PLY: the header promises {el.count} {el.name} rows, "
        f"which need {need} bytes, but the file has {size} bytes",
    )


def _read_binary(path: Path, hdr: _Header, name: str, size: int):
    """Element name -> {property -> array}; list properties as (rows, k) arrays.
    None when a list changes length between rows (the caller falls back to plyfile)."""
    bo = "<" if hdr.encoding == "binary_little_endian" else ">"
    offset, out = hdr.size, {}
    last: tuple[_Element, int] | None = None
    with open(path, "rb") as fh:
        for el in hdr.elements:
            if el.fixed:
                dt, lists = np.dtype([(p.name, bo + p.dtype) for p in el.props]), {}
            else:
                dt, lists = _constant_list_dtype(fh, el, bo, offset, size, name)
            need = offset + el.count * dt.itemsize
            if need > size:
                if lists:  # ragged lists longer than the first row, or truncated: plyfile tells
                    return None
                raise _truncated(name, el, need, size)
            fh.seek(offset)
            arr = np.fromfile(fh, dt, el.count) if el.count and dt.itemsize else np.zeros(el.count, dt)
            for count_name, k in lists.items():
                if el.count and not (arr[count_name] == k).all():
                    return None
            out[el.name] = {p.name: _native(arr[p.name]) for p in el.props}
            offset = need
            last = (el, dt.itemsize)
    if hdr.elements and last is not None and size > offset:
        _excess_binary(name, hdr, last, size - offset, size)
    return out


def _excess_binary(name: str, hdr: _Header, last: tuple[_Element, int], extra: int, size: int) -> None:
    """Bytes after the last element: a header that undercounts its rows (a writer that
    patched the count wrongly, a concatenation) would silently lose data, so refuse
    as soon as the bytes could hold one more row. Fewer bytes than a row (a closing
    newline some writers add) lose nothing."""
    el, row = last
    if row and extra >= row:
        counts = ", ".join(f"{e.count} {e.name}" for e in hdr.elements)
        room = f"{'up to ' if not el.fixed else ''}{extra // row}"
        raise fail(
            name,
            f"binary PLY has {extra} bytes after the rows its header declares ({counts}); "
            f"that is room for {room} more {el.name} rows: the header's counts are wrong "
            f"or data was appended ({size} bytes in all)",
        )


def _native(a: np.ndarray) -> np.ndarray:
    """Big-endian columns in the machine's order: fields must compute without surprises."""
    return a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("="))


def _constant_list_dtype(fh, el: _Element, bo: str, offset: int, size: int, name: str):
    """The row dtype of an element with list properties, assuming every row has the
    list lengths of the first row (true for triangle meshes); checked after reading."""
    fields: list[tuple] = []
    lists: dict[str, int] = {}
    fh.seek(offset)
    for j, p in enumerate(el.props):
        item = np.dtype(bo + p.dtype)
        if p.count is None:
            fields.append((p.name, item))
            fh.seek(item.itemsize, 1)
            continue
        cdt = np.dtype(bo + p.count)
        b = fh.read(cdt.itemsize) if el.count else b"\0" * cdt.itemsize
        if len(b) < cdt.itemsize:
            raise _truncated(name, el, fh.tell() + cdt.itemsize, size)
        k = int(np.frombuffer(b, cdt)[0])
        fields += [(f"__n{j}", cdt), (p.name, item, (k,))]
        lists[f"__n{j}"] = k
        fh.seek(k * item.itemsize, 1)
    return np.dtype(fields), lists


def _read_with_plyfile(path: Path, hdr: _Header, name: str, size: int) -> dict:
    import plyfile  # only for ragged lists, which the numpy path cannot read in one go

    try:
        with open(path, "rb") as fh:
            data = plyfile.PlyData.read(fh)
            end = fh.tell()  # plyfile stops where the declared rows end
    except Exception as exc:
        reason = " ".join(str(exc).split())
        if "end-of-file" in reason:
            raise fail(name, f"truncated binary PLY ({reason})") from exc
        raise fail(name, f"cannot read the PLY body ({reason})") from exc
    if hdr.elements and size > end:
        last = hdr.elements[-1]
        # the shortest row the last element can have: its scalars, its lists empty but
        # a face's corners, which are at least three
        row = sum(
            np.dtype(p.dtype).itemsize * (3 if p.name in _FACE_LISTS else 0) + np.dtype(p.count).itemsize
            if p.count
            else np.dtype(p.dtype).itemsize
            for p in last.props
        )
        _excess_binary(name, hdr, (last, row), size - end, size)
    return {
        el.name: {
            p.name: (list(el.data[p.name]) if isinstance(p, plyfile.PlyListProperty) else el.data[p.name])
            for p in el.properties
        }
        for el in data.elements
    }


def _read_ascii(path: Path, hdr: _Header, name: str) -> dict:
    with open(path, "rb") as fh:
        fh.seek(hdr.size)
        body = fh.read().decode("latin-1")
    lines = [ln for ln in body.splitlines() if ln.strip()]
    pos, out = 0, {}
    for el in hdr.elements:
        block = lines[pos : pos + el.count]
        if len(block) < el.count:
            raise fail(
                name,
                f"truncated PLY: the header promises {el.count} {el.name} lines but the file has only {len(block)}",
            )
        pos += el.count
        out[el.name] = _ascii_element(block, el, name)
    if len(lines) > pos:
        counts = ", ".join(f"{e.count} {e.name}" for e in hdr.elements)
        raise fail(
            name,
            f"ascii PLY has {len(lines) - pos} more lines than its header declares ({counts}; "
            f"{len(lines)} data lines): the header's counts are wrong or data was appended",
        )
    return out


def _ascii_element(block: list[str], el: _Element, name: str) -> dict:
    n_scalar = len(el.props)
    if el.fixed:
        numbers = _numbers(block, n_scalar, el.name, name)
        return {p.name: _as_type(numbers[:, j], p.dtype, el.name, p.name, name) for j, p in enumerate(el.props)}
    # Lists: when every row has the same number of values (triangles) the rows form a
    # table; otherwise walk the tokens row by row.
    first = block[0].split() if block else []
    table: np.ndarray | None = None
    if block:
        try:
            table = np.loadtxt(block, dtype=np.float64, ndmin=2, comments=None)
        except ValueError:
            table = None
    if table is not None and table.shape[1] == len(first):
        cols, j, ok = {}, 0, True
        for p in el.props:
            if p.count is None:
                cols[p.name] = table[:, j]
                j += 1
                continue
            k = int(table[0, j]) if j < table.shape[1] else -1
            if k < 0 or j + 1 + k > table.shape[1] or not (table[:, j] == k).all():
                ok = False
                break
            cols[p.name] = table[:, j + 1 : j + 1 + k]
            j += 1 + k
        if ok and j == table.shape[1]:
            return {p.name: _as_type(cols[p.name], p.dtype, el.name, p.name, name) for p in el.props}
    values: dict[str, list] = {p.name: [] for p in el.props}
    for i, line in enumerate(block):
        tokens, j = line.split(), 0
        try:
            for p in el.props:
                if p.count is None:
                    values[p.name].append(float(tokens[j]))
                    j += 1
                else:
                    k = int(tokens[j])
                    conv = int if p.dtype[0] in "iu" else float
                    values[p.name].append([conv(t) for t in tokens[j + 1 : j + 1 + k]])
                    if len(values[p.name][-1]) != k:
                        raise IndexError
                    j += 1 + k
            if j != len(tokens):
                raise IndexError
        except (IndexError, ValueError):
            raise fail(
                name, f"{el.name} {i}: cannot parse {line[:60]!r} as {' '.join(p.name for p in el.props)}"
            ) from None
    return {
        p.name: (values[p.name] if p.count else _as_type(np.array(values[p.name]), p.dtype, el.name, p.name, name))
        for p in el.props
    }


def _numbers(block: list[str], ncols: int, what: str, name: str) -> np.ndarray:
    """(rows, ncols) float64 of whitespace-separated ascii rows, or a message naming
    the first bad row."""
    if not block:
        return np.zeros((0, ncols))
    try:
        table = np.loadtxt(block, dtype=np.float64, ndmin=2, comments=None)
        if table.shape[1] == ncols:
            return table
    except ValueError:
        pass
    for i, line in enumerate(block):
        tokens = line.split()
        if len(tokens) != ncols:
            raise fail(name, f"{what} {i}: expected {ncols} values, found {len(tokens)} in {line[:60]!r}")
        for t in tokens:
            try:
                float(t)
            except ValueError:
                raise fail(name, f"{what} {i}: {t!r} is not a number") from None
    raise fail(name, f"cannot parse the {what} rows")  # pragma: no cover - loadtxt agreed above


def _as_type(col: np.ndarray, code: str, el: str, prop: str, name: str) -> np.ndarray:
    if code[0] in "iu":
        if col.size and not (col == np.round(col)).all():
            raise fail(name, f"{el} property {prop!r} is declared integer but holds fractions")
    return col.astype(code)


def _interpret(elements: dict, hdr: _Header, name: str) -> Raw:
    if "vertex" not in elements:
        raise fail(name, "PLY file has no vertex element")
    v = elements["vertex"]
    missing = [c for c in "xyz" if c not in v]
    if missing:
        raise fail(name, f"PLY vertex element has no {'/'.join(missing)} property")
    n = len(v["x"])
    points = np.empty((n, 3))
    for j, c in enumerate("xyz"):
        points[:, j] = v[c]
    used = {"x", "y", "z"}
    colors = normals = None
    for trio in _COLORS:
        if all(c in v for c in trio):
            colors = colors_to_uint8(np.column_stack([v[c] for c in trio]), name)
            used.update(trio)
            break
    for trio in _NORMALS:
        if all(c in v for c in trio):
            normals = np.column_stack([v[c] for c in trio]).astype(np.float64)
            used.update(trio)
            break
    fields = {k: a for k, a in v.items() if k not in used and isinstance(a, np.ndarray) and a.ndim == 1}
    unit, field_units = None, {}
    for c in hdr.comments:
        unit = unit or unit_from_comment(c)
        fu = field_unit_from_comment(c)
        if fu and fu[0] in fields:
            field_units[fu[0]] = fu[1]
    faces = None
    face_el = elements.get("face")
    if face_el is not None and len(next(iter(face_el.values()), [])) > 0:
        key = next((k for k in _FACE_LISTS if k in face_el), None)
        if key is None:
            raise fail(name, f"PLY face element has no {' or '.join(_FACE_LISTS)} list")
        faces = triangulate(face_el[key], name)
    return Raw(points, colors, normals, fields, field_units, faces, unit, hdr.encoding)


# -- writing --------------------------------------------------------------------------
def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    pts, colors, normals, fields = cloud_columns(obj, factor)
    cols: list[tuple[str, np.ndarray]] = [("x", pts[:, 0]), ("y", pts[:, 1]), ("z", pts[:, 2])]
    if normals is not None:
        cols += [(k, normals[:, j]) for j, k in enumerate(("nx", "ny", "nz"))]
    if colors is not None:
        cols += [(k, colors[:, j]) for j, k in enumerate(("red", "green", "blue"))]
    taken = {k for k, _ in cols}
    for k, a in fields.items():
        check_name(k, name)
        if k in taken:
            raise fail(name, f"cannot write field {k!r}: the name is taken by the coordinates, normals or colours")
        cols.append((k, _ply_array(a, k, name)))
    faces = getattr(obj, "faces", None)
    head = [
        "ply",
        f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
        f"comment written by camcmm {__version__}",
        f"comment unit {unit}",
    ]
    head += [f"comment {c}" for c in field_unit_comments(obj, fields)]
    head.append(f"element vertex {len(pts)}")
    head += [f"property {_NAMES[a.dtype.str[1:]]} {k}" for k, a in cols]
    if faces is not None:
        head += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    head.append("end_header")
    with open(path, "wb") as fh:
        fh.write(("\n".join(head) + "\n").encode("ascii"))
        if binary:
            vert = np.empty(len(pts), [(k, a.dtype.newbyteorder("<")) for k, a in cols])
            for k, a in cols:
                vert[k] = a
            vert.tofile(fh)
            if faces is not None:
                tri = np.empty(len(faces), [("n", "u1"), ("v", "<i4", (3,))])
                tri["n"] = 3
                tri["v"] = faces
                tri.tofile(fh)
        else:
            for chunk in text_rows([a for _, a in cols]):
                fh.write(chunk.encode("ascii"))
            if faces is not None:
                three = np.full(len(faces), 3, np.uint8)
                for chunk in text_rows([three, faces[:, 0], faces[:, 1], faces[:, 2]]):
                    fh.write(chunk.encode("ascii"))


def _ply_array(a: np.ndarray, key: str, name: str) -> np.ndarray:
    """A field as a 1-D array of a type PLY has (int64 -> int32 when it fits, else double)."""
    a = np.asarray(a)
    if a.ndim != 1:
        raise fail(name, f"cannot write field {key!r} of shape {a.shape}: PLY holds one value per vertex")
    if a.dtype == np.bool_:
        return a.astype(np.uint8)
    if a.dtype.kind == "f" and a.dtype.itemsize < 4:
        return a.astype(np.float32)
    if a.dtype.kind in "iu" and a.dtype.itemsize == 8:
        fits = a.size == 0 or (a.min() >= np.iinfo(np.int32).min and a.max() <= np.iinfo(np.int32).max)
        return a.astype(np.int32) if fits else a.astype(np.float64)
    if a.dtype.kind == "f" and a.dtype.itemsize > 8:
        return a.astype(np.float64)
    if a.dtype.str[1:] not in _NAMES:
        raise fail(name, f"cannot write field {key!r} of type {a.dtype} to PLY")
    return a
