"""The Calibration page's board form: the fields a person fills in, and the board spec
string the calibration plugins, the CLI and the saved files take (the contract).

A board spec (lengths in mm; see ``camcmm_plugins.calibration.boards``)::

    chessboard:COLSxROWS:SQUARE              inner corners:      chessboard:9x6:25
    charuco:COLSxROWS:SQUARE:MARKER:DICT     squares, marker:    charuco:11x8:15:11:DICT_5X5_100
    circles:COLSxROWS:SPACING                circle centres:     circles:7x6:20
    acircles:COLSxROWS:SPACING               OpenCV's asymmetric grid: acircles:4x11:10

The form (:data:`FIELDS`) holds the kind, the columns and rows, the square size (circle
spacing) and the ChArUco marker side in a unit of the person's choice (:data:`UNITS`),
and the ArUco dictionary. :func:`compose` makes the spec from the form (square size
REQUIRED: it sets the scale of every length the calibration gives, so it is never
assumed); :func:`parse` makes the form from a spec (unit mm), so
``compose(parse(spec)) == spec`` for every spec :func:`compose` writes.
:func:`detection_spec` is the spec the board check on the first image uses: the size of
the squares does not change which points are found, so the check runs before the size is
entered. :func:`describe` says a spec in words.
"""

from __future__ import annotations

import math
import re
from typing import Any

from ....errors import InputError

#: the form's fields: state variable of the page -> key of the form dict
FIELDS = {
    "kind": "cal_board_kind",
    "cols": "cal_board_cols",
    "rows": "cal_board_rows",
    "square": "cal_board_square",
    "unit": "cal_board_unit",
    "marker": "cal_board_marker",
    "dictionary": "cal_board_dict",
}
#: a unit's length in mm (a board printed in inches is common: 1 in = 25.4 mm exactly)
UNITS = {"mm": 1.0, "cm": 10.0, "in": 25.4}
KINDS = [
    {"title": "Chessboard", "value": "chessboard"},
    {"title": "ChArUco (chessboard with markers)", "value": "charuco"},
    {"title": "Circle grid, symmetric", "value": "circles"},
    {"title": "Circle grid, asymmetric (OpenCV)", "value": "acircles"},
]
#: each kind in words, inside a sentence
NAMES = {
    "chessboard": "chessboard",
    "charuco": "ChArUco board",
    "circles": "symmetric circle grid",
    "acircles": "asymmetric circle grid",
}
#: the ArUco dictionaries OpenCV predefines (value: OpenCV's name, as the board generators
#: print it and the board spec keeps it), in words: the marker's bits and how many markers
DICTIONARIES = [
    *[
        {"title": f"{n} × {n} bits, {k} markers", "value": f"DICT_{n}X{n}_{k}"}
        for n in (4, 5, 6, 7)
        for k in (50, 100, 250, 1000)
    ],
    {"title": "original ArUco, 5 × 5 bits, 1024 markers", "value": "DICT_ARUCO_ORIGINAL"},
    {"title": "AprilTag 16h5, 4 × 4 bits, 30 markers", "value": "DICT_APRILTAG_16H5"},
    {"title": "AprilTag 25h9, 5 × 5 bits, 35 markers", "value": "DICT_APRILTAG_25H9"},
    {"title": "AprilTag 36h10, 6 × 6 bits, 2320 markers", "value": "DICT_APRILTAG_36H10"},
    {"title": "AprilTag 36h11, 6 × 6 bits, 587 markers", "value": "DICT_APRILTAG_36H11"},
]
DEFAULT_DICT = "DICT_5X5_100"
#: what COLS x ROWS counts, per kind (the labels of the two fields say it)
COUNTS = {
    "chessboard": "inner corners",
    "charuco": "squares",
    "circles": "circles",
    "acircles": "circles",
}
_SIZE = re.compile(r"^(\d+)\s*[x×X]\s*(\d+)$")


def blank() -> dict[str, Any]:
    """A new form: OpenCV's sample board's 9 x 6 corners, and NO square size."""
    return {"kind": "chessboard", "cols": 9, "rows": 6, "square": "", "unit": "mm", "marker": "",
            "dictionary": DEFAULT_DICT}  # fmt: skip


def _whole(form: dict[str, Any], key: str, label: str) -> int:
    v = form.get(key)
    try:
        f = float(str(v).strip())
    except (TypeError, ValueError):
        raise InputError(f"board {label}: {v!r} is not a whole number") from None
    if not (math.isfinite(f) and f == int(f) and f >= 1):
        raise InputError(f"board {label}: {v!r} is not a whole number of at least 1")
    return int(f)


def _length(form: dict[str, Any], key: str, label: str) -> float:
    """A length of the form in mm; InputError naming the field when empty or not > 0."""
    v = form.get(key)
    unit = str(form.get("unit") or "mm")
    if unit not in UNITS:
        raise InputError(f"board unit: {unit!r} is not one of {', '.join(UNITS)}")
    if v is None or str(v).strip() == "":
        raise InputError(f"board {label}: enter it (in {unit}); it sets the scale of every length measured")
    try:
        f = float(str(v).strip().replace(",", "."))
    except ValueError:
        raise InputError(f"board {label}: {v!r} is not a number") from None
    if not (math.isfinite(f) and f > 0):
        raise InputError(f"board {label}: {v!r} must be a positive length")
    return f * UNITS[unit]


def _mm(v: float) -> str:
    """A length in mm for the spec: up to 10 significant digits (1/16 in = 1.5875 mm
    exactly), no exponent."""
    text = f"{v:.10f}".rstrip("0").rstrip(".")
    return text or "0"


def size_label(kind: str) -> str:
    """What the size field is called for a kind."""
    return "Circle spacing" if kind in ("circles", "acircles") else "Square size"


def compose(form: dict[str, Any]) -> str:
    """The board spec of a form (lengths converted to mm); InputError naming the field
    that is missing or wrong. The plugin judges the rest (board too small, markers more
    than the dictionary holds, …) when it parses the spec."""
    kind = str(form.get("kind") or "").strip().lower()
    if kind not in COUNTS:
        raise InputError(f"board type: {kind!r} is not one of {', '.join(COUNTS)}")
    what = COUNTS[kind]
    cols = _whole(form, "cols", f"{what} across")
    rows = _whole(form, "rows", f"{what} down")
    square = _length(form, "square", size_label(kind).lower())
    spec = f"{kind}:{cols}x{rows}:{_mm(square)}"
    if kind == "charuco":
        marker = _length(form, "marker", "marker size")
        if marker >= square:
            raise InputError(f"board marker size: {_mm(marker)} mm must be smaller than the square ({_mm(square)} mm)")
        d = str(form.get("dictionary") or DEFAULT_DICT).strip().upper()
        spec += f":{_mm(marker)}:{d}"
    return spec


def parse(spec: str) -> dict[str, Any]:
    """The form of a board spec (lengths in mm); InputError naming the spec when it does
    not read as one (see the module docstring)."""
    parts = [p.strip() for p in str(spec or "").split(":")]
    kind = parts[0].lower()
    if kind not in COUNTS:
        raise InputError(f"board {spec!r}: unknown kind {parts[0]!r}; use one of {', '.join(COUNTS)}")
    n = 4 if kind == "charuco" else 3
    if not (len(parts) == n or (kind == "charuco" and len(parts) == n + 1)):
        raise InputError(f"board {spec!r}: expected {kind}:COLSxROWS:{'SQUARE:MARKER[:DICT]' if n == 4 else 'SIZE'}")
    m = _SIZE.match(parts[1])
    if not m:
        raise InputError(f"board {spec!r}: size {parts[1]!r} must read COLSxROWS, e.g. 9x6")
    form = blank()
    form.update(kind=kind, cols=int(m.group(1)), rows=int(m.group(2)), unit="mm")
    try:
        form["square"] = float(parts[2])
        if kind == "charuco":
            form["marker"] = float(parts[3])
    except ValueError:
        raise InputError(f"board {spec!r}: the lengths must be numbers (mm)") from None
    if kind == "charuco" and len(parts) == 5:
        form["dictionary"] = parts[4].upper()
    return form


def detection_spec(form: dict[str, Any]) -> str:
    """The spec the board check uses: the form's, with a square of 1 mm (and a ChArUco
    marker in the form's proportion, else 0.75 of the square) where no size is entered
    yet — which points are found does not depend on the scale."""
    try:
        return compose(form)
    except InputError:
        pass
    probe = dict(form, unit="mm", square=1)
    if str(form.get("kind")) == "charuco":
        try:
            ratio = _length(form, "marker", "marker") / _length(form, "square", "square")
        except InputError:
            ratio = 0.75
        probe["marker"] = ratio if 0 < ratio < 1 else 0.75
    return compose(probe)


def describe(spec: str) -> str:
    """A spec in words, e.g. "chessboard, 9 × 6 inner corners, 25 mm squares"."""
    try:
        f = parse(spec)
    except InputError:
        return str(spec)
    text = f"{NAMES[f['kind']]}, {f['cols']} × {f['rows']} {COUNTS[f['kind']]}, "
    if f["kind"] in ("circles", "acircles"):
        return text + f"spacing {_mm(f['square'])} mm"
    text += f"{_mm(f['square'])} mm squares"
    if f["kind"] == "charuco":
        text += f", {_mm(f['marker'])} mm markers ({dictionary_words(f['dictionary'])})"
    return text


def dictionary_words(name: str) -> str:
    """An ArUco dictionary in words ("5 × 5 bits, 100 markers"); an unknown name as given."""
    return next((d["title"] for d in DICTIONARIES if d["value"] == str(name).upper()), str(name))
