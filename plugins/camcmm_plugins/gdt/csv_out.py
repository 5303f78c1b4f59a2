"""The characteristics of an evaluation as CSV rows, one per part and characteristic, for
spreadsheets and SPC tools (``camcmm gdt evaluate … --csv rows.csv``, ``camcmm gdt batch``).

Columns (:data:`COLUMNS`): ``part``, ``id``, ``type``, ``feature``, ``datums`` (``A|B|C``),
``value``, ``unit`` (mm), ``tolerance`` (a zone's width), ``lower``/``upper`` (a size's
deviations from its nominal), ``u`` (standard uncertainty, k = 1), ``U`` (= k·u), ``k``,
``verdict`` (simple) and ``verdict_guarded`` (ISO 14253-1 with the guard band U). A number
the evaluation has not (a characteristic not evaluated, a zone's lower/upper) is an empty
cell; numbers are written with ``repr`` (the shortest text that reads back to the same
float), so a spreadsheet gets the full precision.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from camcmm.api import InputError, checked_path

#: The columns, in order.
COLUMNS = (
    "part",
    "id",
    "type",
    "feature",
    "datums",
    "value",
    "unit",
    "tolerance",
    "lower",
    "upper",
    "u",
    "U",
    "k",
    "verdict",
    "verdict_guarded",
)


def rows(evaluation: Mapping[str, Any], part: str) -> list[dict[str, Any]]:
    """One row a characteristic of ``evaluation`` (the evaluate JSON), keyed by
    :data:`COLUMNS`; ``part`` names the measured part (a serial number, a file's stem)."""
    out = []
    for c in evaluation.get("characteristics") or []:
        row = {k: c.get(k) for k in COLUMNS}
        row["part"] = part
        row["datums"] = "|".join(c.get("datums") or ())
        row["unit"] = c.get("unit") or evaluation.get("unit") or "mm"
        out.append(row)
    return out


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_csv(table: Iterable[Mapping[str, Any]], path: str | Path) -> Path:
    """Write ``table`` (rows of :func:`rows`, possibly of many parts) to ``path`` as CSV
    (comma, header line, UTF-8). Returns the path."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p}: is a folder (--csv expects a file)")
    lines = [[_cell(r.get(k)) for k in COLUMNS] for r in table]
    try:
        with p.open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(COLUMNS)
            w.writerows(lines)
    except OSError as exc:
        raise InputError(f"{p}: cannot be written ({exc.strerror or exc})") from None
    return p


def check_output(value: str | Path, flag: str) -> Path:
    """An output file named by ``flag`` (``--qif``, ``--csv``), checked before any work:
    resolved (and confined in a confined run, :func:`camcmm.api.checked_path`), not a
    folder, its folder existing. Refused with one line naming the file and the flag."""
    p = checked_path(Path(value), flag)
    if p.is_dir():
        raise InputError(f"{value}: is a folder ({flag} expects a file)")
    if not p.parent.is_dir():
        raise InputError(f"{value}: its folder does not exist ({flag})")
    return p
