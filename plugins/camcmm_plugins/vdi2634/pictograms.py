"""Pictograms of the VDI/VDE 2634 positions: where the standard wants the artefact, as
inline SVG for the position cards of the GUI's acceptance page (which asks the standard
for them: ``Standard.pictograms(requirements, plan)``).

The measuring volume is drawn as a box in cabinet projection (x to the right, y away
from the operator, z up; origin in the centre, as the standard plugin gives its
positions) with the artefact where the standard wants it — the sphere as a shaded
ball with its shadow and a drop line to the floor (the other positions faint), the
ball bar as a bar between two balls, the flat as a plate with its measured face's
normal, the ball plate as a triangle of balls, a camera position as a camera looking
at the sphere. Written as SVG text by hand rather than rendered as images: the browser
scales it crisply and it needs no plotting library, nor trame, nor a browser (tests
read the SVG).
"""

from __future__ import annotations

import html as _html
import math
from typing import Any

import numpy as np

_K, _ANGLE = 0.5, math.radians(30.0)  # cabinet projection: depth halved, receding at 30 deg
_EDGE = "#78909c"
_HIDDEN = "#b0bec5"
_FLOOR = "#eceff1"
_BLUE = "#1565c0"
_SCALE = 100.0  # the longest edge of the volume is drawn 100 units long


def _proj(p: Any) -> tuple[float, float]:
    x, y, z = (float(c) for c in p)
    return x + _K * y * math.cos(_ANGLE), -(z + _K * y * math.sin(_ANGLE))


class _Svg:
    def __init__(self, uid: str):
        self.uid = uid
        self.parts: list[str] = []
        self.xs: list[float] = []
        self.ys: list[float] = []
        self.defs: list[str] = []

    def _pt(self, p: Any) -> tuple[float, float]:
        x, y = _proj(p)
        self.xs.append(x)
        self.ys.append(y)
        return x, y

    def line(self, a: Any, b: Any, color: str = _EDGE, width: float = 1.0, dash: str = "", cap: str = "round") -> None:
        (x1, y1), (x2, y2) = self._pt(a), self._pt(b)
        d = f' stroke-dasharray="{dash}"' if dash else ""
        self.parts.append(
            f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" stroke="{color}" '
            f'stroke-width="{width:.2f}" stroke-linecap="{cap}"{d}/>'
        )

    def poly(self, pts: list[Any], fill: str, stroke: str = "none", width: float = 1.0, opacity: float = 1.0) -> None:
        xy = [self._pt(p) for p in pts]
        s = " ".join(f"{x:.1f},{y:.1f}" for x, y in xy)
        self.parts.append(
            f'<polygon points="{s}" fill="{fill}" fill-opacity="{opacity:.2f}" stroke="{stroke}" '
            f'stroke-width="{width:.2f}" stroke-linejoin="round"/>'
        )

    def ball(self, c: Any, r: float, color: str = _BLUE, faint: bool = False) -> None:
        x, y = self._pt(c)
        self.xs += [x - r, x + r]
        self.ys += [y - r, y + r]
        if faint:
            self.parts.append(
                f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" fill="#cfd8dc" stroke="#b0bec5" stroke-width="0.6"/>'
            )
            return
        gid = f"g-{self.uid}"
        if not self.defs:
            self.defs.append(
                f'<radialGradient id="{gid}" cx="0.35" cy="0.3" r="0.75">'
                f'<stop offset="0" stop-color="#ffffff"/><stop offset="0.35" stop-color="#64b5f6"/>'
                f'<stop offset="1" stop-color="{color}"/></radialGradient>'
            )
        self.parts.append(
            f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" fill="url(#{gid})" stroke="#0d47a1" stroke-width="0.8"/>'
        )

    def text(self, p: Any, s: str, size: float = 9.0, color: str = "#78909c", anchor: str = "middle") -> None:
        x, y = self._pt(p)
        self.parts.append(
            f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size:.1f}" fill="{color}" '
            f'text-anchor="{anchor}" font-family="sans-serif">{_html.escape(s)}</text>'
        )

    def render(self, title: str, pad: float = 6.0) -> str:
        x0, x1 = min(self.xs) - pad, max(self.xs) + pad
        y0, y1 = min(self.ys) - pad, max(self.ys) + pad
        defs = f"<defs>{''.join(self.defs)}</defs>" if self.defs else ""
        return (
            f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0:.1f} {y0:.1f} {x1 - x0:.1f} {y1 - y0:.1f}" '
            f'width="100%" height="100%" preserveAspectRatio="xMidYMid meet" role="img" '
            f'aria-label="{_html.escape(title)}"><title>{_html.escape(title)}</title>{defs}'
            + "".join(self.parts)
            + "</svg>"
        )


def _unit(v: Any, default=(1.0, 0.0, 0.0)) -> np.ndarray:
    a = np.asarray(v if v is not None else default, dtype=float)
    n = float(np.linalg.norm(a))
    return a / n if n > 0 else np.asarray(default, dtype=float)


def _box(svg: _Svg, h: np.ndarray, back: bool) -> None:
    """The measuring volume: back=True draws the floor and the hidden edges (before the
    artefact), back=False the visible edges (after it)."""
    hx, hy, hz = h
    c = {(sx, sy, sz): (sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)}
    hidden = (-1, 1, -1)  # back, bottom, left: behind the box in this view
    edges = [(a, b) for a in c for b in c if a < b and sum(x != y for x, y in zip(a, b)) == 1]
    if back:
        svg.poly([c[(-1, -1, -1)], c[(1, -1, -1)], c[(1, 1, -1)], c[(-1, 1, -1)]], _FLOOR)
        for a, b in edges:
            if hidden in (a, b):
                svg.line(c[a], c[b], _HIDDEN, 0.8, "3 2")
    else:
        for a, b in edges:
            if hidden not in (a, b):
                svg.line(c[a], c[b], _EDGE, 1.0)
        svg.text((hx + 6, -hy, -hz), "x", anchor="start")
        svg.text((-hx - 4, -hy, hz + 2), "z", anchor="end")
        svg.text((-hx - 3, hy, -hz - 3), "y", anchor="end")


def _shadow_disc(svg: _Svg, c: np.ndarray, r: float, floor: float) -> None:
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    pts = [(c[0] + r * math.cos(a), c[1] + r * math.sin(a), floor) for a in t]
    svg.poly(pts, "#90a4ae", opacity=0.35)


def _drop(svg: _Svg, c: np.ndarray, floor: float) -> None:
    svg.line(c, (c[0], c[1], floor), "#90a4ae", 0.7, "2 2")


def pictogram(
    test: str,
    position: dict[str, Any],
    volume: Any,
    artefact: dict[str, Any] | None = None,
    others: list[dict[str, Any]] | None = None,
    uid: str = "p",
) -> str:
    """An inline SVG of one position of a test in the measuring volume (mm).

    ``position`` is a position of ``std.requirements()`` (``where`` as fractions of the
    volume, ``direction``, ``normal``, ``rotation``/``tilt``, ``camera``); ``artefact``
    the plan's artefact entry (sizes, drawn to scale but never smaller than visible);
    ``others`` the test's other positions (drawn faint for the sphere)."""
    vol = np.asarray(volume, dtype=float)
    s = _SCALE / float(vol.max())
    h = vol * s / 2
    a = artefact or {}
    floor = -h[2]
    where = np.asarray(position.get("where") or [0, 0, 0], dtype=float) * vol * s
    svg = _Svg(uid)
    title = f"{position.get('label') or position.get('id', '')}: {position.get('hint', '')}".strip(": ")
    _box(svg, h, back=True)
    min_r = 3.0
    cam = position.get("camera") if isinstance(position.get("camera"), dict) else None

    if test == "sphere" and cam is not None:  # part 3: the camera moves around the sphere
        r = max(float(a.get("diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        el = math.radians(float(cam.get("elevation", 45.0)))
        dist = 0.95 * float(np.linalg.norm(h))
        for o in others or []:
            oc = o.get("camera") if isinstance(o.get("camera"), dict) else None
            if oc is None or o.get("id") == position.get("id"):
                continue
            az = math.radians(float(oc.get("azimuth", 0.0)))
            p = where + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
            svg.ball(p, 2.0, faint=True)
        _shadow_disc(svg, where, r, floor)
        _drop(svg, where, floor)
        svg.ball(where, r)
        az = math.radians(float(cam.get("azimuth", 0.0)))
        p = where + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        svg.line(p, where, "#ef6c00", 0.9, "3 2")
        x, y = svg._pt(p)
        svg.xs += [x - 8, x + 8]
        svg.ys += [y - 6, y + 6]
        svg.parts.append(
            f'<g transform="translate({x:.1f},{y:.1f})"><rect x="-7" y="-5" width="14" height="10" rx="2" '
            'fill="#ef6c00"/><circle cx="0" cy="0" r="3.2" fill="#fff3e0" stroke="#bf360c" '
            'stroke-width="0.8"/><rect x="-4" y="-7.5" width="6" height="2.5" fill="#ef6c00"/></g>'
        )
    elif test == "sphere":
        r = max(float(a.get("diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        for o in others or []:
            if o.get("id") == position.get("id"):
                continue
            oc = np.asarray(o.get("where") or [0, 0, 0], dtype=float) * vol * s
            svg.ball(oc, 2.2, faint=True)
        _shadow_disc(svg, where, r, floor)
        _drop(svg, where, floor)
        svg.ball(where, r)
    elif test == "ball_bar":
        d = _unit(position.get("direction"))
        length = float(a.get("length") or 0.5 * vol.max()) * s
        r = max(float(a.get("sphere_diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        ends = [where - d * length / 2, where + d * length / 2]
        svg.line((ends[0][0], ends[0][1], floor), (ends[1][0], ends[1][1], floor), "#b0bec5", 2.5)
        for e in ends:
            _shadow_disc(svg, e, r, floor)
            _drop(svg, e, floor)
        ends.sort(key=lambda e: -e[1])  # far ball first
        svg.line(ends[0], ends[1], "#455a64", 2.6)
        for e in ends:
            svg.ball(e, r)
    elif test == "flat":
        u = _unit(position.get("direction"))
        n = _unit(position.get("normal"), (0.0, 0.0, 1.0))
        w = np.cross(n, u)
        w = w / (np.linalg.norm(w) or 1.0)
        length = float(a.get("length") or 0.8 * vol.max()) * s
        width = float(a.get("width") or 0.3 * vol.max()) * s
        corners = [where + su * u * length / 2 + sw * w * width / 2 for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        svg.poly([(c[0], c[1], floor) for c in corners], "#90a4ae", opacity=0.35)
        svg.poly(corners, "#42a5f5", "#0d47a1", 1.0, 0.55)
        tip = where + n * 0.28 * _SCALE
        svg.line(where, tip, "#c62828", 1.4)
        x, y = svg._pt(tip)
        svg.parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2.2" fill="#c62828"/>')
    elif test == "ball_plate":
        lengths = [float(x) for x in (a.get("lengths") or [6.0, 8.0, 10.0])][:3]
        l1, l2, l3 = lengths
        x3 = (l1**2 + l3**2 - l2**2) / (2 * l1)
        y3 = math.sqrt(max(l3**2 - x3**2, 0.0))
        tri = np.array([[0.0, 0.0, 0.0], [l1, 0.0, 0.0], [x3, y3, 0.0]])
        tri -= tri.mean(axis=0)
        rot = math.radians(float(position.get("rotation") or 0.0))
        tilt = math.radians(float(position.get("tilt") or 0.0))
        rz = np.array([[math.cos(rot), -math.sin(rot), 0], [math.sin(rot), math.cos(rot), 0], [0, 0, 1]])
        rx = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
        pts = (rx @ rz @ tri.T).T * s + where
        r = max(float(a.get("sphere_diameter") or 0.1 * vol.max()) / 2 * s, min_r)
        plate = pts + (pts - pts.mean(axis=0)) * 0.45
        svg.poly([(p[0], p[1], floor) for p in plate], "#90a4ae", opacity=0.3)
        svg.poly(list(plate), "#cfd8dc", "#78909c", 0.9, 0.9)
        svg.line(pts[0], pts[1], "#ef6c00", 1.0)  # edge 1 (L1): the arrow the rotation is measured from
        for p in sorted(pts, key=lambda p: -p[1]):
            svg.ball(p, r)
    else:  # a test this page does not know: the volume and a marker at the position
        svg.ball(where, min_r)
    _box(svg, h, back=False)
    return svg.render(title)


def pictograms(requirements: list[dict[str, Any]], plan: dict[str, Any]) -> dict[str, str]:
    """``{"test/position": svg}`` for every position of a test's requirements."""
    vol = (plan.get("system") or {}).get("measuring_volume") or [100, 100, 100]
    arts = plan.get("artefacts") or {}
    out = {}
    for r in requirements:
        for p in r["positions"]:
            uid = f"{r['test']}-{p['id']}".replace("_", "-")
            out[f"{r['test']}/{p['id']}"] = pictogram(r["test"], p, vol, arts.get(r["test"]), r["positions"], uid)
    return out
