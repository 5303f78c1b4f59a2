"""STL triangle meshes, binary and ascii.

Reading: triangles (F, 3, 3) -> shared vertices (V, 3) float64 in the file's unit
(identical corners merged) and faces (F, 3) int64. STL has no unit; ``unit mm`` /
``units=m`` in the 80-byte binary header or after ``solid`` is honoured, default mm.
Facet normals are not kept (they follow from the vertex order). A binary file is
recognised by its size (84 + 50 x triangles) even when its header starts with
"solid", as some exporters write.

Writing: binary by default (float32 corners: about 7 significant digits, so 0.1 µm
on a 1 m part) or ascii (shortest exact text of the doubles); facet normals computed
from the corners. Vertex normals and fields are not stored (STL has no place for them).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ._common import Raw, canonical_unit, fail

_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
_UNIT = re.compile(rb"\bunits?\s*[:= ]\s*([a-z\xb5]+)", re.IGNORECASE)
_VERTEX = re.compile(rb"vertex\s+([^\r\n]*)")


def read(path: Path, name: str) -> Raw:
    data = path.read_bytes()
    n = int(np.frombuffer(data, "<u4", 1, 80)[0]) if len(data) >= 84 else -1
    if n >= 0 and len(data) == 84 + 50 * n:
        return _binary(data, n, name)
    if data.lstrip()[:5].lower() == b"solid":
        return _ascii(data, name)
    if n < 0:
        raise fail(name, f"not an STL file: {len(data)} bytes, too short for a binary STL and not ascii 'solid'")
    if len(data) < 84 + 50 * n:
        raise fail(
            name,
            f"truncated binary STL: the header promises {n} triangles ({84 + 50 * n} bytes) "
            f"but the file has {len(data)} bytes",
        )
    extra = len(data) - 84 - 50 * n
    if extra >= 50:  # room for more triangles than the header counts: refuse rather than drop them
        raise fail(
            name,
            f"binary STL declares {n} triangles ({84 + 50 * n} bytes) but the file has {len(data)} "
            f"bytes, room for {extra // 50} more: the triangle count is wrong or data was appended",
        )
    # a few bytes of padding, which some exporters add, hold no triangle: nothing is lost
    return _binary(data, n, name)


def _unit(text: bytes) -> str | None:
    # free header text ("Unit conversion by ...") must not be taken for a declaration
    for m in _UNIT.finditer(text):
        word = m.group(1).decode("latin-1")
        if canonical_unit(word):
            return word
    return None


def _binary(data: bytes, n: int, name: str) -> Raw:
    tri = np.frombuffer(data, _RECORD, n, 84)["corners"].reshape(-1, 3)
    vertices, faces = _merge(tri)
    return Raw(vertices, faces=faces, unit=_unit(data[:80]), encoding="binary")


def _ascii(data: bytes, name: str) -> Raw:
    found = [v.decode("latin-1") for v in _VERTEX.findall(data)]
    if not found and b"\0" in data:
        raise fail(name, f"binary STL whose size ({len(data)} bytes) does not match its triangle count (truncated?)")
    if len(found) % 3:
        raise fail(name, f"ascii STL has {len(found)} vertex lines, not a multiple of 3 (truncated?)")
    corners: np.ndarray | None = np.zeros((0, 3))
    if found:
        try:
            corners = np.loadtxt(found, dtype=np.float64, ndmin=2, comments=None)
        except ValueError:
            corners = None
        if corners is None or corners.shape[1] != 3:
            bad = next(v for v in found if not _is_float_triple(v))
            raise fail(name, f"ascii STL vertex {bad.strip()[:60]!r} is not three numbers")
    first = data.lstrip().split(b"\n", 1)[0]
    assert corners is not None  # a failed parse raised above
    vertices, faces = _merge(corners)
    return Raw(vertices, faces=faces, unit=_unit(first), encoding="ascii")


def _is_float_triple(v: str) -> bool:
    try:
        return len([float(x) for x in v.split()]) == 3
    except ValueError:
        return False


def _merge(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corner list (3F, 3) -> vertices (V, 3) float64 in order of first appearance
    and faces (F, 3). Corners merge when their coordinates are bit-identical; sorting
    the raw bits is four times faster than ``np.unique(axis=0)``."""
    if len(corners) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    key = np.ascontiguousarray(corners + 0.0)  # + 0.0 turns -0.0 into 0.0 so the two merge
    bits = key.view(np.uint32 if key.dtype.itemsize == 4 else np.uint64).reshape(-1, 3)
    order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))  # stable: equal corners keep file order
    s = bits[order]
    new = np.empty(len(s), bool)
    new[0] = True
    new[1:] = (s[1:] != s[:-1]).any(axis=1)
    group = np.cumsum(new) - 1
    first = order[new]  # the earliest corner of each group
    rank = np.argsort(first, kind="stable")
    renumber = np.empty_like(rank)
    renumber[rank] = np.arange(len(rank))
    inverse = np.empty(len(s), np.int64)
    inverse[order] = renumber[group]
    return corners[first[rank]].astype(np.float64), inverse.reshape(-1, 3)


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    v = obj.vertices / factor if factor != 1.0 else obj.vertices
    tri = v[obj.faces]  # (F, 3, 3)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    with open(path, "wb") as fh:
        if binary:
            rec = np.zeros(len(tri), _RECORD)
            rec["normal"] = normal
            rec["corners"] = tri
            fh.write(f"camcmm binary STL, unit {unit}".encode("ascii").ljust(80, b" "))
            fh.write(np.uint32(len(tri)).astype("<u4").tobytes())
            rec.tofile(fh)
            return
        fh.write(f"solid camcmm unit {unit}\n".encode("ascii"))
        facet = (
            "facet normal %r %r %r\n outer loop\n  vertex %r %r %r\n  vertex %r %r %r\n"
            "  vertex %r %r %r\n endloop\nendfacet\n"
        )
        rows = np.hstack([normal, tri.reshape(-1, 9)])
        for start in range(0, len(rows), 100_000):
            fh.write("".join([facet % tuple(r) for r in rows[start : start + 100_000].tolist()]).encode("ascii"))
        fh.write(b"endsolid camcmm\n")
