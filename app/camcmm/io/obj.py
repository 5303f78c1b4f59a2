"""Wavefront OBJ triangle meshes.

Reading: ``v x y z`` -> vertices (V, 3) float64 in the file's unit (extra values on a
``v`` line, w or colours, are ignored); ``f`` lines (``i``, ``i/t``, ``i//n``,
``i/t/n``, negative indices relative to the vertices so far) -> faces (F, 3) int64,
polygons split into fans; ``vn`` referenced by the faces -> vertex normals.
Materials, texture coordinates, groups, lines and points are ignored. OBJ has no unit;
a ``# unit m`` comment is honoured, default mm.

Writing: ``# unit <unit>``, ``v`` lines (shortest exact text of the doubles), ``vn``
lines when the mesh has vertex normals, ``f`` lines with 1-based indices. Fields are
not stored (OBJ has no place for them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ._common import Raw, fail, text_rows, triangulate, unit_from_comment


def read(path: Path, name: str) -> Raw:
    text = path.read_bytes().decode("utf-8", errors="replace")
    verts: list[str] = []
    normals: list[str] = []
    linenos: dict[str, list[int]] = {"vertex": [], "normal": []}  # for messages only
    polys: list[list[int]] = []
    corner_normals: list[tuple[int, int]] = []  # (vertex index, normal index) pairs
    unit = None
    for lineno, line in enumerate(text.splitlines(), 1):
        tokens = line.split()
        if not tokens:
            continue
        key = tokens[0]
        try:
            if key == "v":
                if len(tokens) < 4:
                    raise ValueError
                verts.append(" ".join(tokens[1:4]))
                linenos["vertex"].append(lineno)
            elif key == "vn":
                normals.append(" ".join(tokens[1:4]))
                linenos["normal"].append(lineno)
            elif key == "f":
                poly = []
                for t in tokens[1:]:
                    parts = t.split("/")
                    i = int(parts[0])
                    i = i - 1 if i > 0 else len(verts) + i
                    poly.append(i)
                    if len(parts) == 3 and parts[2]:
                        k = int(parts[2])
                        corner_normals.append((i, k - 1 if k > 0 else len(normals) + k))
                polys.append(poly)
            elif key.startswith("#"):
                unit = unit or unit_from_comment(line.strip().lstrip("#").strip())
        except ValueError:
            raise InputError(
                f"{name} line {lineno}: cannot read {line.strip()[:60]!r} as an OBJ {key!r} line"
            ) from None
    if not verts:
        raise fail(name, "no vertices ('v' lines) found; is this an OBJ file?")
    vertices = _floats(verts, name, "vertex", linenos["vertex"])
    faces = triangulate([np.asarray(p) for p in polys], name) if polys else np.zeros((0, 3), np.int64)
    vertex_normals = None
    if normals and corner_normals:
        vn = _floats(normals, name, "normal", linenos["normal"])
        pairs = np.array(corner_normals, dtype=np.int64)
        if pairs[:, 1].min() < 0 or pairs[:, 1].max() >= len(vn):
            raise fail(name, f"a face refers to normal {pairs[:, 1].max() + 1} but there are {len(vn)} 'vn' lines")
        if pairs[:, 0].min() >= 0 and pairs[:, 0].max() < len(vertices):
            vertex_normals = np.zeros_like(vertices)
            vertex_normals[pairs[:, 0]] = vn[pairs[:, 1]]
    return Raw(vertices, normals=vertex_normals, faces=faces, unit=unit, encoding="ascii")


def _floats(rows: list[str], name: str, what: str, linenos: list[int]) -> np.ndarray:
    try:
        return np.array(" ".join(rows).split(), dtype=np.float64).reshape(-1, 3)
    except ValueError:
        for r, lineno in zip(rows, linenos):
            try:
                if len([float(x) for x in r.split()]) != 3:
                    raise ValueError
            except ValueError:
                raise InputError(f"{name} line {lineno}: {what} {r!r} is not three numbers") from None
        raise  # pragma: no cover - the loop above finds the culprit


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    v = obj.vertices / factor if factor != 1.0 else obj.vertices
    f = obj.faces + 1
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(f"# written by camcmm\n# unit {unit}\n")
        for chunk in text_rows([v[:, 0], v[:, 1], v[:, 2]], " ", "v "):
            fh.write(chunk)
        with_normals = obj.vertex_normals is not None
        if with_normals:
            n = obj.vertex_normals
            for chunk in text_rows([n[:, 0], n[:, 1], n[:, 2]], " ", "vn "):
                fh.write(chunk)
        # with normals each corner is "i//i": the normal has the vertex's index
        fmt = "f %d//%d %d//%d %d//%d\n" if with_normals else "f %d %d %d\n"
        corners = np.repeat(f, 2, axis=1) if with_normals else f
        for start in range(0, len(corners), 200_000):
            fh.write("".join([fmt % tuple(r) for r in corners[start : start + 200_000].tolist()]))
