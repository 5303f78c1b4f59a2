"""Pieces the format modules share: the raw read result, units, colours, polygon
triangulation, text formatting of columns and atomic writes.

A format reader returns a :class:`Raw` with coordinates in the *file's* unit; the
package front (``camcmm.io.read``) scales them to mm and builds the model object, so
the unit rules live in one place.
"""

from __future__ import annotations

import os
import re
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

#: Words files use for their length unit -> camcmm unit keys (see camcmm.units).
_UNIT_WORDS = {
    "m": "m",
    "meter": "m",
    "meters": "m",
    "metre": "m",
    "metres": "m",
    "mm": "mm",
    "millimeter": "mm",
    "millimeters": "mm",
    "millimetre": "mm",
    "millimetres": "mm",
    "cm": "cm",
    "centimeter": "cm",
    "centimeters": "cm",
    "centimetre": "cm",
    "centimetres": "cm",
    "um": "um",
    "µm": "um",
    "micron": "um",
    "microns": "um",
    "micrometer": "um",
    "micrometers": "um",
    "micrometre": "um",
    "micrometres": "um",
    "nm": "nm",
    "nanometer": "nm",
    "nanometers": "nm",
    "nanometre": "nm",
    "nanometres": "nm",
    "in": "in",
    "inch": "in",
    "inches": "in",
}

_UNIT_COMMENT = re.compile(r"^\s*(?:length[ _]?)?units?\s*[:=]?\s*([a-zµ]+)\s*$", re.IGNORECASE)
_FIELD_UNIT = re.compile(r"^\s*field_units?\s+(\S+)\s+(\S+)\s*$", re.IGNORECASE)


@dataclass
class Raw:
    """What a point/mesh reader found, before unit conversion.

    points : (N, 3) float64 in the file's unit; colors : (N, 3) uint8 or None;
    normals : (N, 3) or None; fields : name -> (N,) array; faces : (F, 3) int64 or
    None for a point cloud (an empty (0, 3) array for a mesh file without faces);
    unit : the unit word the file declares, or None; encoding : e.g. "ascii".
    """

    points: np.ndarray
    colors: np.ndarray | None = None
    normals: np.ndarray | None = None
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    field_units: dict[str, str] = field(default_factory=dict)
    faces: np.ndarray | None = None
    unit: str | None = None
    encoding: str = ""


def unit_from_comment(text: str) -> str | None:
    """The unit word of a comment such as ``unit m`` or ``units: meters``, else None."""
    m = _UNIT_COMMENT.match(text)
    return m.group(1) if m else None


def field_unit_from_comment(text: str) -> tuple[str, str] | None:
    """(field, unit) of a comment such as ``field_unit deviation mm``, else None."""
    m = _FIELD_UNIT.match(text)
    return (m.group(1), m.group(2)) if m else None


def field_unit_comments(obj, fields: dict) -> list[str]:
    """``field_unit <name> <unit>`` comment texts for the written fields that have one."""
    return [
        f"field_unit {k} {u}"
        for k, u in getattr(obj, "field_units", {}).items()
        if k in fields and u and not any(ch.isspace() for ch in u)
    ]


def canonical_unit(word: str) -> str | None:
    """``"meters"`` -> ``"m"``; None for a word that is not a known length unit."""
    return _UNIT_WORDS.get(word.strip().lower())


def fail(name: str, problem: str) -> InputError:
    return InputError(f"{name}: {problem}")


def colors_to_uint8(c: np.ndarray, name: str) -> np.ndarray:
    """(N, 3) colours of any common encoding -> uint8 0..255.

    Floats with a maximum of at most 1 are taken as 0..1 (Open3D, PCL), larger floats
    and integers as 0..255, integers above 255 as 16-bit (0..65535).
    """
    c = np.asarray(c)
    if c.dtype == np.uint8:
        return c
    if c.size == 0:
        return c.astype(np.uint8)
    lo, hi = float(np.min(c)), float(np.max(c))
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo < 0:
        raise fail(name, f"colour values must be finite and >= 0, found {lo:g}..{hi:g}")
    if c.dtype.kind == "f" and hi <= 1.0:
        return np.clip(np.round(c * 255.0), 0, 255).astype(np.uint8)
    if hi <= 255:
        return np.round(c).astype(np.uint8)
    if hi <= 65535:
        return np.round(c / 257.0).astype(np.uint8)
    raise fail(name, f"colour values run up to {hi:g}; expected 0..1, 0..255 or 0..65535")


def triangulate(polys: list[np.ndarray] | np.ndarray, name: str) -> np.ndarray:
    """Polygons (a 2-D array of equal-length rows, or a list of index arrays) -> (F, 3)
    int64 triangles. Polygons with more than three corners are split as fans, which is
    right for the convex faces scanners and CAD exporters write."""
    if isinstance(polys, np.ndarray) and polys.ndim == 2:
        groups = [polys]
    else:
        if len(polys) == 0:
            return np.zeros((0, 3), np.int64)
        lengths = np.fromiter((len(p) for p in polys), np.int64, len(polys))
        groups = []
        for k in np.unique(lengths):
            idx = np.flatnonzero(lengths == k)
            if k < 3:
                raise fail(name, f"face {int(idx[0])} has {int(k)} vertices; a face needs 3 or more")
            groups.append(np.array([polys[i] for i in idx], dtype=np.int64).reshape(len(idx), k))
    out = []
    for g in groups:
        k = g.shape[1]
        if len(g) and k < 3:
            raise fail(name, f"faces have {k} vertices; a face needs 3 or more")
        for i in range(1, k - 1):
            out.append(np.column_stack([g[:, 0], g[:, i], g[:, i + 1]]))
    return np.vstack(out).astype(np.int64) if out else np.zeros((0, 3), np.int64)


def cloud_columns(obj, factor: float) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, dict]:
    """(points scaled to the output unit, colors, normals, fields) of a cloud or mesh.

    ``factor`` converts the output unit to mm, so points are divided by it."""
    pts = obj.points if hasattr(obj, "points") else obj.vertices
    if factor != 1.0:
        pts = pts / factor
    colors = getattr(obj, "colors", None)
    normals = obj.normals if hasattr(obj, "normals") else obj.vertex_normals
    return pts, colors, normals, dict(obj.fields)


_CHUNK = 200_000


def _fmt(dtype: np.dtype) -> str:
    # repr gives the shortest text that reads back to the same double; 9 significant
    # digits do the same for float32
    if dtype.kind == "f":
        return "%.9g" if dtype.itemsize <= 4 else "%r"
    if dtype.kind in "iub":
        return "%d"
    raise TypeError(f"cannot write values of type {dtype} as text")


def text_rows(columns: list[np.ndarray], delimiter: str = " ", prefix: str = "") -> Iterator[str]:
    """Text lines (``prefix`` + values joined by ``delimiter``), in chunks, for equally
    long 1-D columns; floats are written so that they read back exactly."""
    if not columns:
        return
    fmt = prefix + delimiter.join(_fmt(np.asarray(c).dtype) for c in columns) + "\n"
    n = len(columns[0])
    for start in range(0, n, _CHUNK):
        cols = [np.asarray(c[start : start + _CHUNK]).tolist() for c in columns]
        yield "".join([fmt % row for row in zip(*cols)])


def check_name(name: str, file: str, forbidden: str = " \t\r\n") -> None:
    """Field names end up in headers; one with a separator in it would shift columns."""
    bad = [c for c in forbidden if c in name]
    if not name or bad:
        why = "it is empty" if not name else f"it contains {bad[0]!r}, which separates columns"
        raise InputError(f"{file}: cannot write field name {name!r}: {why}")


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` (same extension, so libraries that pick
    the format from it still work); on success it replaces ``path`` in one step, so a
    crash leaves either the old file or none, never a half-written one."""
    tmp = path.with_name(f".{path.stem}.{os.getpid()}-{secrets.token_hex(4)}.tmp{path.suffix}")
    try:
        yield tmp
        # flush to disk before the rename: after a power cut the name must not point
        # at a file whose blocks were never written
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        try:
            tmp.unlink()
        except FileNotFoundError:
            pass
