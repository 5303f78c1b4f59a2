"""A drawing of the calibration board the form describes (SVG), so a person can hold
it beside the printed board: the squares (or circles), the points the calibration finds
(red dots: a chessboard's or ChArUco board's inner corners, the circles' centres), the
first point circled (the board frame's origin), the counts along each side, and one
square size (circle spacing) dimensioned with its value as entered — or "required" in
red while it is missing.

Layouts as OpenCV's detectors and ``camcmm_plugins.calibration.boards`` take them: a
chessboard of COLS x ROWS inner corners has (COLS + 1) x (ROWS + 1) squares; a ChArUco
board of COLS x ROWS squares has (COLS - 1) x (ROWS - 1) inner corners and a marker in
each white square; an asymmetric grid's centre (i, j) is at ((2 j + i mod 2) s, i s).
The drawing is to scale in itself (one square is one square), not to the printed size.
"""

from __future__ import annotations

import base64
import math
from typing import Any
from xml.sax.saxutils import escape

from .... import numbers
from .board import COUNTS, UNITS, size_label

#: the drawing's box in px, and its margins (room for the dimension and the counts)
WIDTH, HEIGHT = 340, 220
LEFT, TOP, RIGHT, BOTTOM = 30, 34, 10, 26
#: boards with more points than this get no dot per point (they would fill the squares)
MAX_DOTS = 2500
RED, INK = "#d32f2f", "#222"
MISSING = "required"


def _number(v: Any) -> float | None:
    try:
        f = float(str(v).strip().replace(",", "."))
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) and f > 0 else None


def _count(v: Any, default: int) -> int:
    f = _number(v)
    return int(f) if f is not None and f == int(f) and 1 <= f <= 200 else default


def size_text(form: dict[str, Any]) -> str:
    """The square size (circle spacing) as entered, with its unit and in mm when the
    unit is another; "required" when it is missing."""
    v, unit = _number(form.get("square")), str(form.get("unit") or "mm")
    if v is None or unit not in UNITS:
        return MISSING
    text = f"{numbers.significant(v, 6)} {unit}"
    return text if unit == "mm" else f"{text} = {numbers.significant(v * UNITS[unit], 6)} mm"


def points(form: dict[str, Any]) -> tuple[list[tuple[float, float]], tuple[float, float], str]:
    """(the points the calibration finds in units of one square / spacing, the board's
    extent (w, h) in the same units, what the points are)."""
    kind = str(form.get("kind") or "chessboard")
    c, r = _count(form.get("cols"), 9), _count(form.get("rows"), 6)
    if kind == "charuco":
        pts = [(j + 1.0, i + 1.0) for i in range(r - 1) for j in range(c - 1)]
        return pts, (float(c), float(r)), "inner corners"
    if kind == "acircles":
        pts = [(2.0 * j + i % 2 + 0.5, i + 0.5) for i in range(r) for j in range(c)]
        return pts, (2.0 * c, float(r)), "circles"
    if kind == "circles":
        return [(j + 0.5, i + 0.5) for i in range(r) for j in range(c)], (float(c), float(r)), "circles"
    return [(j + 1.0, i + 1.0) for i in range(r) for j in range(c)], (c + 1.0, r + 1.0), "inner corners"


def svg(form: dict[str, Any]) -> str:
    """The drawing of the board of ``form`` (the page's board form, see :mod:`.board`)."""
    kind = str(form.get("kind") or "chessboard")
    kind = kind if kind in COUNTS else "chessboard"
    c, r = _count(form.get("cols"), 9), _count(form.get("rows"), 6)
    pts, (bw, bh), what = points(form)
    s = min((WIDTH - LEFT - RIGHT) / bw, (HEIGHT - TOP - BOTTOM) / bh)  # px per square
    x0, y0 = LEFT, TOP
    X = lambda u: x0 + u * s  # noqa: E731
    Y = lambda v: y0 + v * s  # noqa: E731
    out = []
    if kind in ("chessboard", "charuco"):
        nx, ny = (c + 1, r + 1) if kind == "chessboard" else (c, r)
        out.append(f'<rect x="{x0}" y="{y0}" width="{nx * s:.2f}" height="{ny * s:.2f}" fill="#fff" stroke="{INK}"/>')
        marker = _number(form.get("marker")) if kind == "charuco" else None
        square = _number(form.get("square"))
        ratio = marker / square if marker and square and marker < square else 0.7
        for i in range(ny):
            for j in range(nx):
                if (i + j) % 2 == 0:
                    out.append(f'<rect x="{X(j):.2f}" y="{Y(i):.2f}" width="{s:.2f}" height="{s:.2f}" fill="{INK}"/>')
                elif kind == "charuco":  # the marker: a grey square in each white square
                    m = ratio * s
                    out.append(
                        f'<rect x="{X(j) + (s - m) / 2:.2f}" y="{Y(i) + (s - m) / 2:.2f}" width="{m:.2f}" '
                        f'height="{m:.2f}" fill="#9e9e9e"/>'
                    )
    else:
        rad = 0.3 * s
        out.append(f'<rect x="{x0}" y="{y0}" width="{bw * s:.2f}" height="{bh * s:.2f}" fill="#fff" stroke="{INK}"/>')
        for u, v in pts:
            out.append(f'<circle cx="{X(u):.2f}" cy="{Y(v):.2f}" r="{rad:.2f}" fill="{INK}"/>')
    if len(pts) <= MAX_DOTS:
        dot = max(1.0, min(3.0, 0.12 * s))
        for u, v in pts:
            out.append(f'<circle class="point" cx="{X(u):.2f}" cy="{Y(v):.2f}" r="{dot:.2f}" fill="{RED}"/>')
    if pts:  # the first point: the origin of the board frame
        u, v = pts[0]
        out.append(
            f'<circle cx="{X(u):.2f}" cy="{Y(v):.2f}" r="{max(4.0, 0.3 * s):.2f}" fill="none" '
            f'stroke="{RED}" stroke-width="1.5"/>'
        )
    out += _dimension(kind, pts, s, X, Y, size_text(form))
    counts = COUNTS[kind]
    out.append(
        f'<text x="{X(bw / 2):.2f}" y="{Y(bh) + 17:.2f}" text-anchor="middle" font-size="12" fill="{INK}">'
        f"{c} {escape(counts)} across</text>"
    )
    out.append(
        f'<text x="{x0 - 8}" y="{Y(bh / 2):.2f}" text-anchor="middle" font-size="12" fill="{INK}" '
        f'transform="rotate(-90 {x0 - 8} {Y(bh / 2):.2f})">{r} {escape(counts)} down</text>'
    )
    height = Y(bh) + BOTTOM
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height:.0f}" '
        f'viewBox="0 0 {WIDTH} {height:.0f}" font-family="sans-serif" data-points="{len(pts)}" '
        f'data-what="{what}">' + "".join(out) + "</svg>"
    )


def _dimension(kind: str, pts, s: float, X, Y, text: str) -> list[str]:
    """A dimension line over one square (circle spacing) at the top left, with its text."""
    if kind in ("circles", "acircles"):  # an asymmetric grid's rows are offset by s
        u0, u1 = 0.5, 1.5
    else:  # the first square
        u0, u1 = 0.0, 1.0
    y = TOP - 10
    colour = RED if text == MISSING else INK
    label = size_label(kind).lower()
    xa, xb = X(u0), X(u1)
    return [
        f'<line x1="{xa:.2f}" y1="{y}" x2="{xb:.2f}" y2="{y}" stroke="{colour}"/>',
        f'<line x1="{xa:.2f}" y1="{y - 5}" x2="{xa:.2f}" y2="{TOP}" stroke="{colour}"/>',
        f'<line x1="{xb:.2f}" y1="{y - 5}" x2="{xb:.2f}" y2="{TOP}" stroke="{colour}"/>',
        f'<text class="size" x="{xb + 6:.2f}" y="{y + 4}" font-size="12" fill="{colour}">'
        f"{escape(label)} {escape(text)}</text>",
    ]


def data_url(text: str) -> str:
    """An SVG as a ``data:`` URL for an <img> (no script of a page's own can run in it)."""
    return "data:image/svg+xml;base64," + base64.b64encode(text.encode("utf-8")).decode("ascii")
