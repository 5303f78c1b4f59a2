"""Point lists as text: ``.xyz``, ``.txt``, ``.csv`` (photogrammetry and scanner exports).

One point per line: x y z, then optionally colours (0-255 integers or 0-1 floats),
normals and extra columns. Columns are separated by ``,``, ``;``, a tab or spaces; the
separator is detected from the first data line and must stay the same on every line
(European ``1,5;2,0;3,1`` with decimal commas is understood too). Lines starting with
``#`` or ``//`` are comments; a comment such as ``# unit m`` gives the length unit
(default mm). An optional header line names the columns:

* with a header, ``x/y/z``, ``r/g/b`` or ``red/green/blue`` and ``nx/ny/nz`` are found
  by name (any case, CloudCompare's ``//X,Y,Z`` too); other columns become fields
  under their header names;
* without one, columns 1-3 are x, y, z; columns 4-6 are colours when they are all
  0..255 integers or all 0..1 floats, normals when every row is a unit vector; the
  next three columns are checked the same way; the rest become fields ``col4``,
  ``col5`` ... (named by their 1-based column number).

A first line holding just the point count (the PTS convention) is skipped.

Writing: a ``# unit <unit>`` comment, a header line, then x y z [nx ny nz]
[red green blue] [fields] per point; ``,`` for .csv, a space otherwise. Floats are
written with the shortest text that reads back to the same number.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._common import (
    Raw,
    check_name,
    cloud_columns,
    colors_to_uint8,
    fail,
    field_unit_comments,
    field_unit_from_comment,
    text_rows,
    unit_from_comment,
)

_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf|infinity)$", re.IGNORECASE)
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+$")
#: More columns than this on a line is no point list (a matrix, an image as text...).
MAX_COLUMNS = 1000
_DELIM_NAMES = {",": "','", ";": "';'", "\t": "tab", None: "spaces"}
_COLOR_NAMES = (("red", "green", "blue"), ("r", "g", "b"), ("diffuse_red", "diffuse_green", "diffuse_blue"))
_NORMAL_NAMES = (("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z"), ("normalx", "normaly", "normalz"))


def _split(line: str, delim: str | None) -> list[str]:
    tokens = line.split(delim) if delim else line.split()
    return [t.strip().strip('"') for t in tokens]


def _delimiter(line: str) -> str | None:
    # ';' first: a line with both is ';'-separated with decimal commas
    for d in (";", ",", "\t"):
        if d in line:
            return d
    return None


def _is_number(token: str) -> bool:
    return bool(_NUMBER.match(token))


def _open(path: Path):
    return open(path, encoding="utf-8-sig", errors="replace")


def read(path: Path, name: str) -> Raw:
    # Only the lines before the data are kept as strings: a plain numeric table is then
    # parsed by numpy straight from the file, in chunks (a list of one Python string per
    # line costs ~10x the file: a 315 MB .xyz took 5.5 GB). Decimal commas, quoted values
    # and a bad line take the slower path over every line, which names the line.
    head: list[str] = []
    with _open(path) as fh:
        for line in fh:
            head.append(line.rstrip("\r\n"))
            if _data_starts(head):
                break
    unit, header, header_is_comment, count_seen, start = None, None, False, False, None
    field_units: dict[str, str] = {}
    for i, line in enumerate(head):
        s = line.strip()
        if not s:
            continue
        if s.startswith(("#", "//")):
            body = s.lstrip("#/").strip()
            declared = unit_from_comment(body)
            unit = unit or declared
            fu = field_unit_from_comment(body)
            if fu:
                field_units[fu[0]] = fu[1]
                continue
            # CloudCompare writes its header as a comment: //X,Y,Z,R,G,B
            if s.startswith("//") and not declared and header is None:
                tokens = _split(body, _delimiter(body))
                if len(tokens) >= 3 and not any(_is_number(t) for t in tokens):
                    header, header_is_comment = (i, body), True
            continue
        tokens = _split(s, _delimiter(s))
        numeric = all(_is_number(t) or _DECIMAL_COMMA.match(t) for t in tokens)
        if not numeric and (header is None or header_is_comment):
            header, header_is_comment = (i, s), False
            continue
        if numeric and len(tokens) == 1 and tokens[0].isdigit() and not count_seen:
            count_seen = True  # a PTS-style point count
            continue
        start = i
        break
    if start is None:
        raise fail(name, "no data lines (the file holds only comments or a header)")
    first = head[start].strip()
    delim = _delimiter(first)
    decimal_comma = delim == ";" and "," in first
    ncol = len(_split(first.replace(",", ".") if decimal_comma else first, delim))
    if ncol > MAX_COLUMNS:
        raise InputError(
            f"{name} line {start + 1}: {ncol} columns, more than the {MAX_COLUMNS} a point list "
            f"may have; is this a point list (x y z per line)?"
        )
    table = None
    if not decimal_comma and '"' not in first and ncol >= 3:
        table = _parse_file(path, start, delim, ncol)
    if table is None:
        lines = [ln.rstrip("\r\n") for ln in _open(path)]
        data = lines[start:]
        if decimal_comma:
            data = [ln.replace(",", ".") for ln in data]
        table = _parse(data, delim, ncol, start, name, lines)
    names = None
    if header is not None:
        text = header[1]
        names = [t.strip("\"' ") for t in _split(text, delim if (delim and delim in text) else _delimiter(text))]
        if len(names) != table.shape[1]:
            raise InputError(
                f"{name} line {header[0] + 1}: the header names {len(names)} columns "
                f"but the data lines have {table.shape[1]}"
            )
    raw = _columns(table, names, unit, name)
    raw.field_units = {k: u for k, u in field_units.items() if k in raw.fields}
    return raw


def _data_starts(head: list[str]) -> bool:
    """Is the last line of ``head`` the first data line (numeric, not a lone PTS count
    right at the start)? The full rule is applied by :func:`read` on these lines."""
    s = head[-1].strip()
    if not s or s.startswith(("#", "//")):
        return False
    tokens = _split(s, _delimiter(s))
    if not all(_is_number(t) or _DECIMAL_COMMA.match(t) for t in tokens):
        return False
    if len(tokens) == 1 and tokens[0].isdigit():  # the first lone count is the PTS header
        return any(h.strip().isdigit() for h in head[:-1])
    return True


def _parse_file(path: Path, start: int, delim: str | None, ncol: int) -> np.ndarray | None:
    """(N, ncol) float64 read by numpy from the file after its first ``start`` lines, or
    None when a line does not parse (the caller then finds and names it)."""
    try:
        with _open(path) as fh:
            table = np.loadtxt(fh, dtype=np.float64, delimiter=delim, ndmin=2, comments=("#", "//"), skiprows=start)
    except ValueError:
        return None
    return table if table.shape[1] == ncol else None


def _parse(data: list[str], delim: str | None, ncol: int, start: int, name: str, lines: list[str]) -> np.ndarray:
    """(N, ncol) float64; on failure an InputError naming the first bad line."""
    if ncol >= 3:
        try:
            # numpy takes quoted values only with a single one-character comment marker
            quoted = bool(delim) and '"' in data[0]
            table = np.loadtxt(
                data,
                dtype=np.float64,
                delimiter=delim,
                ndmin=2,
                comments="#" if quoted else ("#", "//"),
                quotechar='"' if quoted else None,
            )
            if table.shape[1] == ncol:
                return table
        except ValueError:
            pass
    want = f"{ncol} numeric columns" if ncol >= 3 else "3 or more numeric columns"
    sep = _DELIM_NAMES[delim]
    bad = start
    for k, line in enumerate(data):
        s = line.strip()
        if not s or s.startswith(("#", "//")):
            continue
        tokens = _split(s, delim)
        if len(tokens) != max(ncol, 3) or not all(_is_number(t) for t in tokens):
            bad = start + k
            break
    raise InputError(f"{name} line {bad + 1}: expected {want} separated by {sep} but found {lines[bad].strip()[:80]!r}")


def _find(names_lower: list[str], options) -> list[int] | None:
    for trio in options:
        if all(t in names_lower for t in trio):
            return [names_lower.index(t) for t in trio]
    return None


def _unit_vectors(block: np.ndarray) -> bool:
    return block.size > 0 and bool(np.all(np.abs(np.linalg.norm(block, axis=1) - 1.0) < 1e-3))


def _color_like(block: np.ndarray) -> bool:
    if block.size == 0 or not np.isfinite(block).all() or block.min() < 0:
        return False
    hi = block.max()
    integral = bool((block == np.round(block)).all())
    return (integral and 1 < hi <= 255) or hi <= 1.0


def _columns(table: np.ndarray, names: list[str] | None, unit: str | None, name: str) -> Raw:
    n, ncol = table.shape
    colors = normals = None
    used: set[int] = set()
    labels = [f"col{j + 1}" for j in range(ncol)]
    if names is not None:
        lower = [s.lower().lstrip("/").strip() for s in names]
        xyz = _find(lower, (("x", "y", "z"),)) or [0, 1, 2]
        c_idx = _find(lower, _COLOR_NAMES)
        n_idx = _find(lower, _NORMAL_NAMES)
        if c_idx:
            colors = colors_to_uint8(table[:, c_idx], name)
            used.update(c_idx)
        if n_idx:
            normals = table[:, n_idx]
            used.update(n_idx)
        labels = [s.lstrip("/").strip() or f"col{j + 1}" for j, s in enumerate(names)]
    else:
        xyz = [0, 1, 2]
        for lo in (3, 6):
            block = table[:, lo : lo + 3]
            if block.shape[1] < 3:
                break
            if colors is None and _color_like(block) and not (block.max() <= 1.0 and _unit_vectors(block)):
                colors = colors_to_uint8(block, name)
            elif normals is None and _unit_vectors(block):
                normals = block.copy()
            else:
                break
            used.update(range(lo, lo + 3))
    used.update(xyz)
    points = np.ascontiguousarray(table[:, xyz])
    fields: dict[str, np.ndarray] = {}
    for j in range(ncol):
        if j not in used:
            key, k = labels[j], 2
            while key in fields:
                key, k = f"{labels[j]}_{k}", k + 1
            fields[key] = np.ascontiguousarray(table[:, j])
    return Raw(points, colors, normals, fields, {}, None, unit, "text")


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    delim = "," if path.suffix.lower() == ".csv" else " "
    pts, colors, normals, fields = cloud_columns(obj, factor)
    names, cols = ["x", "y", "z"], [pts[:, 0], pts[:, 1], pts[:, 2]]
    if normals is not None:
        names += ["nx", "ny", "nz"]
        cols += [normals[:, 0], normals[:, 1], normals[:, 2]]
    if colors is not None:
        names += ["red", "green", "blue"]
        cols += [colors[:, 0], colors[:, 1], colors[:, 2]]
    for k, a in fields.items():
        check_name(k, name, " \t\r\n,;#")
        a = np.asarray(a)
        if a.ndim != 1:
            raise fail(name, f"cannot write field {k!r} of shape {a.shape}: one value per point only")
        if k.lower() in names:
            raise fail(name, f"cannot write field {k!r}: the name is taken by the coordinates, normals or colours")
        names.append(k)
        # text has no types: float32 is written as the double it equals, so it reads back equal
        cols.append(a.astype(np.uint8) if a.dtype == np.bool_ else a.astype(np.float64) if a.dtype.kind == "f" else a)
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(f"# unit {unit}\n")
        fh.writelines(f"# {c}\n" for c in field_unit_comments(obj, fields))
        fh.write(delim.join(names) + "\n")
        for chunk in text_rows(cols, delim):
            fh.write(chunk)
