"""Point files read in chunks, never whole: binary PLY, ``.npy`` and plain text (``.xyz``).

:func:`open_source` returns a :class:`Source` whose :meth:`Source.chunks` yields
``(points, fields)`` pieces in file order: ``points`` (m, 3) float64 in mm (the file's
unit times its factor to mm), ``fields`` name -> (m,) array in the file's own dtype. At
most ``chunk`` rows are held at a time, so a cloud bigger than the memory can be indexed
(:mod:`camcmm.bigcloud.store`).

* **Binary PLY** (little or big endian): the ``vertex`` element with fixed-size rows
  (``x, y, z`` and any scalar properties, which become fields: ``red``, ``intensity``,
  ``deviation`` ...). Elements before it must have fixed-size rows too (their bytes are
  skipped); a ``face`` element after it is ignored. Unit: ``comment unit m`` as
  :mod:`camcmm.io.ply` reads it, or the caller's ``unit``. ASCII PLY is refused (convert
  it to binary, or to ``.xyz``).
* **.npy**: an (N, >=3) float array (columns 4.. become fields ``col4`` ...) or a
  structured array with fields ``x, y, z`` (the others become fields). Read through a
  memory map.
* **Text** (``.xyz``, ``.txt``, ``.csv``): numbers separated by spaces, tabs, ``,`` or
  ``;`` (no decimal commas); ``#`` comments, ``# unit m`` states the unit; an optional
  header line names the columns (x, y, z first), else columns 4.. are ``col4`` ...

Every problem is one line naming the file (:class:`camcmm.errors.InputError`).
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io._common import canonical_unit, fail, unit_from_comment
from ..io.ply import read_header as ply_header
from ..units import to_mm_factor

#: Rows read per chunk by default (1 M points: 24 MB of float64 coordinates).
CHUNK = 1_000_000

_EXT_PLY, _EXT_NPY, _EXT_TEXT = (".ply",), (".npy",), (".xyz", ".txt", ".csv", ".pts")


@dataclass
class Source:
    """A point file opened for chunked reading.

    ``n`` rows (None for text until read through), ``fields`` name -> numpy dtype string,
    ``unit`` the file's length unit and ``factor`` its factor to mm, ``stated`` whether
    the file or the caller said so (else mm is assumed), ``format`` a word.
    """

    path: Path
    format: str
    n: int | None
    unit: str
    factor: float
    fields: dict[str, str] = field(default_factory=dict)
    stated: bool = False
    _ply: tuple | None = None  # (offset, row dtype) of the vertex element
    _text: tuple | None = None  # (lines to skip, delimiter, column names)

    @property
    def name(self) -> str:
        return self.path.name

    def chunks(self, chunk: int = CHUNK) -> Iterator[tuple[np.ndarray, dict[str, np.ndarray]]]:
        """``(points mm (m, 3) float64, fields)`` pieces of at most ``chunk`` rows, in file order."""
        if self.format == "ply":
            yield from self._ply_chunks(chunk)
        elif self.format == "npy":
            yield from self._npy_chunks(chunk)
        else:
            yield from self._text_chunks(chunk)

    def _mm(self, x, y, z) -> np.ndarray:
        p = np.empty((len(x), 3))
        p[:, 0], p[:, 1], p[:, 2] = x, y, z
        if self.factor != 1.0:
            p *= self.factor
        return p

    def _ply_chunks(self, chunk: int):
        assert self._ply is not None
        offset, dt = self._ply
        with open(self.path, "rb") as fh:
            fh.seek(offset)
            left = int(self.n or 0)
            while left > 0:
                m = min(chunk, left)
                rows = np.fromfile(fh, dt, m)
                if len(rows) < m:
                    raise fail(self.name, f"binary PLY ends inside the vertex rows ({left - len(rows)} missing)")
                left -= m
                fields = {k: rows[k].astype(rows[k].dtype.newbyteorder("=")) for k in self.fields}
                yield self._mm(rows["x"], rows["y"], rows["z"]), fields

    def _npy_chunks(self, chunk: int):
        a = np.load(self.path, mmap_mode="r")
        for s in range(0, len(a), chunk):
            block = np.asarray(a[s : s + chunk])
            if block.dtype.names:
                pts = self._mm(block["x"], block["y"], block["z"])
                fields = {k: np.asarray(block[k]) for k in self.fields}
            else:
                pts = self._mm(block[:, 0], block[:, 1], block[:, 2])
                fields = {k: np.asarray(block[:, int(k[3:]) - 1]) for k in self.fields}
            yield pts, fields

    def _text_chunks(self, chunk: int):
        assert self._text is not None
        skip, delim, names = self._text
        with open(self.path, encoding="utf-8-sig", errors="replace") as fh:
            lines = (ln for ln in itertools.islice(fh, skip, None) if ln.strip() and not ln.lstrip().startswith("#"))
            row0 = skip
            while True:
                block = list(itertools.islice(lines, chunk))
                if not block:
                    return
                try:
                    a = np.loadtxt(block, delimiter=delim, ndmin=2, dtype=float)
                except ValueError as exc:
                    msg = " ".join(str(exc).split())[:120]
                    raise fail(self.name, f"bad number in the data lines after line {row0}: {msg}") from None
                if a.shape[1] != len(names):
                    raise fail(
                        self.name, f"{a.shape[1]} columns after line {row0}, the first data line has {len(names)}"
                    )
                row0 += len(block)
                yield self._mm(a[:, 0], a[:, 1], a[:, 2]), {k: a[:, names.index(k)] for k in self.fields}


def open_source(path: str | Path, unit: str | None = None) -> Source:
    """Open ``path`` for chunked reading (see the module docstring); ``unit`` overrides
    the file's own (default mm)."""
    p = Path(path)
    name = p.name
    if not p.exists():
        raise InputError(f"{path}: no such file")
    if not p.is_file():
        raise InputError(f"{path}: not a regular file")
    ext = p.suffix.lower()
    if ext in _EXT_PLY:
        src = _open_ply(p, name)
    elif ext in _EXT_NPY:
        src = _open_npy(p, name)
    elif ext in _EXT_TEXT:
        src = _open_text(p, name)
    else:
        raise fail(name, f"extension {ext!r}: a big cloud is read from .ply (binary), .npy or .xyz/.txt/.csv")
    if unit is not None:
        src.unit, src.stated = unit, True
    key = canonical_unit(src.unit) if src.unit else None
    if key is None:
        raise fail(name, f"unit {src.unit!r} is not a length unit (m, cm, mm, um, in)")
    src.unit, src.factor = key, to_mm_factor(key)
    return src


def _open_ply(p: Path, name: str) -> Source:
    size = p.stat().st_size
    with open(p, "rb") as fh:
        hdr = ply_header(fh, name)
    if hdr.encoding == "ascii":
        raise fail(name, "ASCII PLY: a big cloud is read from binary PLY (or .xyz); convert it first")
    bo = "<" if hdr.encoding == "binary_little_endian" else ">"
    offset = hdr.size
    for el in hdr.elements:
        if el.name == "vertex":
            break
        if not el.fixed:
            raise fail(name, f"PLY element {el.name!r} before the vertices has list properties; cannot skip it")
        offset += el.count * np.dtype([(q.name, bo + q.dtype) for q in el.props]).itemsize
    else:
        raise fail(name, "PLY has no vertex element")
    if not el.fixed:
        raise fail(name, "PLY vertex element has list properties; a big cloud needs fixed-size vertex rows")
    names = [q.name for q in el.props]
    missing = [c for c in "xyz" if c not in names]
    if missing:
        raise fail(name, f"PLY vertex element has no {'/'.join(missing)} property")
    dt = np.dtype([(q.name, bo + q.dtype) for q in el.props])
    if offset + el.count * dt.itemsize > size:
        raise fail(
            name,
            f"truncated binary PLY: the header promises {el.count} vertex rows, which need "
            f"{offset + el.count * dt.itemsize} bytes, but the file has {size} bytes",
        )
    unit = next((u for c in hdr.comments if (u := unit_from_comment(c))), None)
    fields = {q.name: np.dtype(q.dtype).str[1:] for q in el.props if q.name not in ("x", "y", "z")}
    return Source(p, "ply", el.count, unit or "mm", 1.0, fields, unit is not None, _ply=(offset, dt))


def _open_npy(p: Path, name: str) -> Source:
    try:
        a = np.load(p, mmap_mode="r")
    except Exception as exc:  # noqa: BLE001 - numpy's reasons are many; one line names the file
        raise fail(
            name, f"not a readable .npy array ({type(exc).__name__}: {' '.join(str(exc).split())[:100]})"
        ) from None
    if a.dtype.names:
        missing = [c for c in "xyz" if c not in a.dtype.names]
        if missing or a.ndim != 1:
            raise fail(name, f"structured .npy needs 1-D records with fields x, y, z (missing {missing or 'none'})")
        fields = {k: a.dtype[k].str[1:] for k in a.dtype.names if k not in ("x", "y", "z")}
    else:
        if a.ndim != 2 or a.shape[1] < 3 or a.dtype.kind not in "fiu":
            raise fail(name, f"array of shape {a.shape} and dtype {a.dtype}: expected (N, >=3) numbers")
        fields = {f"col{j + 1}": a.dtype.str[1:] for j in range(3, a.shape[1])}
    return Source(p, "npy", int(a.shape[0]), "mm", 1.0, fields)


_NUM = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def _open_text(p: Path, name: str) -> Source:
    unit: str | None = None
    skip = 0
    header: list[str] | None = None
    delim: str | None = None
    with open(p, encoding="utf-8-sig", errors="replace") as fh:
        for line in fh:
            s = line.strip()
            if not s or s.startswith("#") or s.startswith("//"):
                u = unit_from_comment(s.lstrip("#/ ").strip())
                unit = u or unit
                if s.startswith("//") and s[2:].strip():  # CloudCompare's //X,Y,Z header
                    header = _tokens(s[2:], _delim(s[2:]))
                skip += 1
                continue
            delim = _delim(s)
            tokens = _tokens(s, delim)
            if not all(_NUM.match(t) for t in tokens):
                if header is not None:
                    raise fail(name, f"line {skip + 1} {s[:40]!r} is not a row of numbers")
                header = tokens
                skip += 1
                continue
            n_cols = len(tokens)
            break
        else:
            raise fail(name, "no data lines")
    if n_cols < 3:
        raise fail(name, f"line {skip + 1}: {n_cols} columns; a point needs x y z")
    names = [h.lower() for h in header] if header and len(header) == n_cols else []
    if names and names[:3] != ["x", "y", "z"]:
        raise fail(name, f"header {header!r}: the first three columns must be x y z")
    if not names:
        names = ["x", "y", "z"] + [f"col{j + 1}" for j in range(3, n_cols)]
    fields = {k: "f8" for k in names[3:]}
    return Source(p, "text", None, unit or "mm", 1.0, fields, unit is not None, _text=(skip, delim, names))


def _delim(line: str) -> str | None:
    for d in (";", ",", "\t"):
        if d in line:
            return d
    return None


def _tokens(line: str, delim: str | None) -> list[str]:
    return [t.strip().strip('"') for t in (line.split(delim) if delim else line.split())]
