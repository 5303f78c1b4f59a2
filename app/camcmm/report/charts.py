"""Charts for reports, drawn with matplotlib's Agg backend and returned as PNG bytes.

Each function returns a :class:`ChartPNG` — plain PNG ``bytes`` with an ``info`` dict
saying what was drawn (projection, colour range, unit, point counts). ``Section.figure``
copies ``info`` into the report's JSON, so a reader of the JSON knows, for instance,
which colour range a deviation map used.

matplotlib is imported inside the functions (importing camcmm.report stays cheap) and
only through ``matplotlib.figure.Figure`` with an Agg canvas — never pyplot — so no
display, no global figure registry and no backend switching are involved; this is safe
on a headless server and in worker threads.

Units: inputs are in ``unit`` (mm by default). Deviation maps and histograms pick a
display unit in which the numbers read well (mm, µm or nm) and say it on the axis;
bar charts keep the unit they are given, so they match the table beside them.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import numbers
from ..errors import CamcmmError, InputError

#: Most points a deviation map draws; more only cost time and look the same.
MAX_DRAWN = 50_000
DPI = 150
_MM = 1 / 25.4  # inches per mm

_UNIT_TO_MM = {"mm": 1.0, "µm": 1e-3, "um": 1e-3, "\u03bcm": 1e-3, "nm": 1e-6, "m": 1e3}
_COLOURS = {"ok": "#4f8f63", "bad": "#c62828", "plain": "#4a6fa5", "limit": "#b71c1c", "missing": "#9ca3af"}
_CMAP = "RdBu_r"  # diverging: blue = below nominal (material missing), red = above


class ChartPNG(bytes):
    """PNG bytes that also carry ``info``: what the chart shows, as JSON data."""

    info: dict

    def __new__(cls, png: bytes, info: dict) -> ChartPNG:
        obj = super().__new__(cls, png)
        obj.info = info
        return obj


# --------------------------------------------------------------------------- helpers
def _factor(unit: str) -> float:
    try:
        return _UNIT_TO_MM[unit]
    except KeyError:
        raise InputError(f"chart unit {unit!r}: use one of mm, µm, nm, m") from None


def _display_unit(max_abs_mm: float) -> str:
    """µm: deviations are written in µm whatever their size (the number rule,
    :mod:`camcmm.numbers`, as every page); ``display_unit=`` still chooses another."""
    return "µm"


def _values(values: Any, what: str, allow_missing: bool = False) -> np.ndarray:
    try:
        a = np.asarray(
            [np.nan if v is None else v for v in values] if allow_missing else values, dtype=np.float64
        ).ravel()
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what}: values must be numbers ({exc})") from None
    if a.size == 0:
        raise InputError(f"{what}: no values to draw (empty input)")
    if not allow_missing:
        bad = ~np.isfinite(a)
        if bad.any():
            raise InputError(
                f"{what}: {int(bad.sum())} of {a.size} values are NaN or Inf "
                f"(first at index {int(np.flatnonzero(bad)[0])}); remove them first"
            )
    return a


def _new_figure(width_mm: float, height_mm: float):
    """An Agg-backed Figure of the given printed size (no pyplot, so no display)."""
    import matplotlib as mpl
    from matplotlib.figure import Figure

    rc: dict[str, Any] = {
        "font.size": 7.5,
        "axes.titlesize": 8.5,
        "axes.labelsize": 7.5,
        "xtick.labelsize": 7,
        "ytick.labelsize": 7,
        "legend.fontsize": 7,
        "axes.linewidth": 0.6,
        "xtick.major.width": 0.6,
        "ytick.major.width": 0.6,
        "svg.fonttype": "none",
    }
    with mpl.rc_context(rc):  # type: ignore[arg-type]  # matplotlib types the keys as literals
        fig = Figure(figsize=(width_mm * _MM, height_mm * _MM), dpi=DPI)
    return fig, rc


def _axes(fig, width_mm: float, height_mm: float, left: float, bottom: float, right: float, top: float):
    """Axes placed by margins in mm.

    Fixed margins instead of matplotlib's constrained layout: the layout solver costs
    ~0.1 s per chart (half the time of a report with 25 maps), and fixed margins also
    give every chart of a kind the same plot area, so a page of maps lines up.
    """
    ax = fig.add_axes(
        (left / width_mm, bottom / height_mm, 1 - (left + right) / width_mm, 1 - (bottom + top) / height_mm)
    )
    # the number rule on the axes too: no "1e-5" offset or exponent above a tick column
    ax.ticklabel_format(style="plain", useOffset=False)
    return ax


def _heading(fig, height_mm: float, title: str | None, stats: str) -> None:
    """Title (if any) and a line of statistics at the top left of the figure."""
    y = 1 - 1.2 / height_mm
    if title:
        fig.text(0.012, y, title, ha="left", va="top", fontsize=8, fontweight="bold")
        y -= 4.2 / height_mm
    fig.text(0.012, y, stats, ha="left", va="top", fontsize=6.5, color="#333")


def _top_mm(title: str | None) -> float:
    return 5.5 + (4.2 if title else 0.0)


def _num(x: float, unit: str = "") -> str:
    """A chart's number by the number rule: in µm the deviations' 0.01 µm and three
    significant digits, else three significant digits; never an exponent, a true minus,
    ``0`` for a value that rounds to zero."""
    if unit == "µm":
        return numbers.micro(x / 1000.0)
    return numbers.significant(x, 3)


def _png(fig, dpi: float) -> bytes:
    """Render with Agg and encode as an RGB PNG carrying its dpi.

    RGB, not matplotlib's default RGBA: the charts are opaque, and an alpha channel
    only makes the HTML larger and the PDF carry a soft mask per image. No time
    stamp goes into the file, so the same chart gives the same SHA-256 every time.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image  # a dependency of matplotlib

    fig.set_dpi(dpi)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    rgb = np.asarray(canvas.buffer_rgba())[..., :3]
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb)).save(buf, format="PNG", dpi=(dpi, dpi), compress_level=3)
    return buf.getvalue()


# --------------------------------------------------------------------------- bar chart
def bar_chart(
    labels: Sequence[Any],
    values: Sequence[float | None],
    limit: float | Sequence[float] | None = None,
    unit: str = "mm",
    title: str | None = None,
    ylabel: str | None = None,
    errors: Sequence[float] | None = None,
    width_mm: float = 160,
    height_mm: float = 65,
    dpi: float = DPI,
) -> ChartPNG:
    """Per-position values as bars, with the limit (e.g. the MPE) as dashed lines at ±limit.

    ``limit`` is one number or one per position (an MPE that grows with length);
    bars beyond it are red, the others green. ``errors`` draws ±U error bars. Missing
    values (None/NaN: a position not measured) get an "n/a" mark instead of a bar. The
    −limit line is drawn only if some value is negative, so a chart of non-negative
    errors (probing form) does not waste half its height. Values keep ``unit``, so the
    chart matches the table beside it.
    """
    import matplotlib as mpl

    what = "bar chart" + (f" {title!r}" if title else "")
    labels = [str(x) for x in labels]
    v = _values(values, what, allow_missing=True)
    if len(labels) != v.size:
        raise InputError(f"{what}: {len(labels)} labels for {v.size} values")
    if np.isinf(v).any():
        raise InputError(f"{what}: value at {labels[int(np.flatnonzero(np.isinf(v))[0])]!r} is infinite")
    ok = np.isfinite(v)
    if not ok.any():
        raise InputError(f"{what}: every value is missing")
    lim = None
    if limit is not None:
        lim_in = _values(np.atleast_1d(np.asarray(limit, dtype=float)), what)
        if lim_in.size not in (1, v.size):
            raise InputError(f"{what}: {lim_in.size} limits for {v.size} values (give one or one each)")
        lim = np.abs(np.broadcast_to(lim_in, v.shape)).astype(float)
    err = None if errors is None else _values(errors, what)
    if err is not None and err.size != v.size:
        raise InputError(f"{what}: {err.size} error bars for {v.size} values")

    heights = np.where(ok, v, 0.0)
    beyond = np.zeros(v.size, bool) if lim is None else ok & (np.abs(heights) > lim)
    negative = bool((v[ok] < 0).any())
    long_labels = max(len(s_) for s_ in labels) > 6 or v.size > 14
    bottom = 6 + (0.9 * min(max(len(s_) for s_ in labels), 14) if long_labels else 3)
    fig, rc = _new_figure(width_mm, height_mm)
    with mpl.rc_context(rc):  # type: ignore[arg-type]  # matplotlib types the keys as literals
        ax = _axes(fig, width_mm, height_mm, left=14, bottom=bottom, right=3, top=_top_mm(title))
        x = np.arange(v.size)
        colours = np.where(beyond, _COLOURS["bad"], _COLOURS["ok"] if lim is not None else _COLOURS["plain"])
        ax.bar(
            x[ok],
            heights[ok],
            color=colours[ok],
            width=0.65,
            zorder=2,
            yerr=None if err is None else err[ok],
            error_kw={"elinewidth": 0.7, "capsize": 2, "ecolor": "#333"},
        )
        ax.axhline(0, color="#333", lw=0.6, zorder=3)
        if lim is not None:
            xs = np.concatenate([[x[0] - 0.5], x + 0.5])
            steps = np.concatenate([lim[:1], lim])
            ax.step(xs, steps, where="pre", color=_COLOURS["limit"], ls="--", lw=0.9, zorder=4)
            if negative:
                ax.step(xs, -steps, where="pre", color=_COLOURS["limit"], ls="--", lw=0.9, zorder=4)
        # y range: every bar, error bar and limit line visible
        reach = np.abs(heights[ok]) + (0 if err is None else err[ok])
        top = float(max(reach.max(), 0 if lim is None else lim.max()))
        top = top if top > 0 else 1.0
        ax.set_ylim(-1.15 * top if negative else 0.0, 1.15 * top)
        for xi in x[~ok]:
            ax.text(xi, 0.03 * top, "n/a", ha="center", va="bottom", fontsize=6.5, color=_COLOURS["missing"])
        if v.size <= 16:  # value labels only where they do not crowd each other
            for xi, h in zip(x[ok], heights[ok]):
                ax.text(
                    xi,
                    h + (0.02 if h >= 0 else -0.02) * top,
                    _num(h, unit),
                    ha="center",
                    va="bottom" if h >= 0 else "top",
                    fontsize=6,
                    color="#333",
                    zorder=5,
                )
        ax.set_xticks(x)
        ax.set_xticklabels(
            labels, rotation=45 if long_labels else 0, ha="right" if long_labels else "center", rotation_mode="anchor"
        )
        ax.set_xlim(-0.6, v.size - 0.4)
        ax.set_ylabel(ylabel or f"value [{unit}]")
        ax.grid(axis="y", color="#e3e6ea", lw=0.5, zorder=0)
        ax.spines[["top", "right"]].set_visible(False)
        ax.tick_params(length=2)
        stats = f"{v.size} values"
        if (~ok).any():
            stats += f", {int((~ok).sum())} missing"
        if lim is not None:
            lim_txt = (
                _num(lim[0], unit)
                if np.all(lim == lim[0])
                else f"{_num(lim.min(), unit)} \u2026 {_num(lim.max(), unit)}"
            )
            stats += f"   dashed: \u00b1limit {lim_txt} {unit}   beyond limit: {int(beyond.sum())}"
        _heading(fig, height_mm, title, stats)
        png = _png(fig, dpi)
    info = {
        "chart": "bar",
        "unit": unit,
        "n": int(v.size),
        "n_missing": int((~ok).sum()),
        "limit": None if lim is None else [float(l) for l in lim],
        "n_beyond_limit": None if lim is None else int(beyond.sum()),
    }
    return ChartPNG(png, info)


# --------------------------------------------------------------------------- geometry
def _fitted(element: str, p: np.ndarray) -> dict[str, Any]:
    """The outputs of the installed plugin that provides ``<element>-fit`` ("sphere" or
    "plane"; camcmm's fit.sphere / fit.plane, or a lab's own) for the points p (N, 3) mm.

    Only used to place a map when the caller gives no centre or normal: charts draw,
    they do not fit. The deviations drawn are the caller's, from whatever (certified)
    fit the standard chose.
    """
    from ..host import default_host  # lazy: a chart made without a fit never needs the host
    from ..model import PointCloud

    host = default_host()
    return host.run(host.provider(f"{element}-fit").id, {"cloud": PointCloud(p, name="chart points")}).outputs


def _guess_kind(p: np.ndarray) -> str:
    """ "sphere" or "plane" for points with no centre or normal given.

    Both are fitted by the plugins; a sphere is chosen only if its form RMS is less than
    half the plane's and its radius is not huge against the patch (a nearly flat patch
    is fitted by an enormous sphere just as well as by a plane).
    """
    if len(p) < 5:
        return "plane"
    plane_rms = float(_fitted("plane", p)["form"]["rms"])
    try:
        sphere = _fitted("sphere", p)
    except CamcmmError:  # no sphere through these points (does not converge, degenerate)
        return "plane"
    r, sphere_rms = float(sphere["radius"]), float(sphere["form"]["rms"])
    if not math.isfinite(r) or not math.isfinite(sphere_rms):
        return "plane"
    extent = float(np.ptp(p, axis=0).max())
    return "sphere" if sphere_rms < 0.5 * plane_rms and r < 10 * max(extent, 1e-12) else "plane"


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    if not n > 0:
        raise InputError("deviation map: normal vector has zero length")
    return v / n


def _sphere_xy(p: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Map coordinates for points on a sphere.

    Most spheres are seen from one side, so the default is a Lambert azimuthal
    equal-area projection centred on the mean direction of the points: the measured
    cap appears as a disc, areas are true (in mm² of sphere surface, R·√2 at 90°), and
    a cluster of bad points is as large on the map as on the ball. If the points wrap
    round more than ~150° from that direction (near-complete spheres), the azimuthal
    map would tear the far side apart, so a cylindrical equal-area map (azimuth against
    sine of elevation about the z axis) is used instead.
    """
    d = p - centre
    rad = np.linalg.norm(d, axis=1)
    if not (rad > 0).all():
        raise InputError("deviation map: a point coincides with the sphere centre")
    u = d / rad[:, None]
    R = float(np.median(rad))
    mean = u.mean(axis=0)
    if np.linalg.norm(mean) > 1e-6:
        m = mean / np.linalg.norm(mean)
        cosc = np.clip(u @ m, -1, 1)
        max_angle = float(np.degrees(np.arccos(cosc.min())))
    else:
        max_angle = 180.0
    if max_angle <= 150.0:
        # "up" on the map is the global +z projected on the tangent plane (+y if m ∥ z)
        up = np.array([0.0, 0.0, 1.0])
        if abs(up @ m) > 0.95:
            up = np.array([0.0, 1.0, 0.0])
        e2 = up - (up @ m) * m
        e2 /= np.linalg.norm(e2)
        e1 = np.cross(e2, m)
        k = np.sqrt(2.0 / (1.0 + np.maximum(cosc, -1 + 1e-12)))
        x, y = R * k * (u @ e1), R * k * (u @ e2)
        info = {
            "projection": "Lambert azimuthal equal-area",
            "view_direction": m.tolist(),
            "max_angle_deg": round(max_angle, 2),
            "radius": R,
            "xlabel": "x on map [mm] (equal-area)",
            "ylabel": "y on map [mm] (equal-area)",
        }
    else:
        az = np.degrees(np.arctan2(u[:, 1], u[:, 0]))
        x, y = az, np.clip(u[:, 2], -1, 1)
        info = {
            "projection": "cylindrical equal-area (azimuth, sin elevation about z)",
            "radius": R,
            "xlabel": "azimuth [°]",
            "ylabel": "elevation [°]",
        }
    return x, y, info


def _plane_xy(
    p: np.ndarray, centre: np.ndarray | None, normal: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, dict]:
    """In-plane coordinates: origin at ``centre`` (default the fitted plane's point), the u axis
    along the longest extent of the points, so a long flat lies across the page.

    Singular vectors have no sign, so signs are fixed by convention (a fitted normal
    points to +z, or else along its largest component; u along its largest component):
    the same flat measured twice is drawn the same way round, not mirrored.
    """
    if normal is None or centre is None:
        plane = _fitted("plane", p)
    c = np.asarray(plane["point"], dtype=float) if centre is None else centre
    if normal is None:
        n = np.asarray(plane["normal"], dtype=float)
        if n[2] < 0 or (abs(n[2]) < 1e-9 and n[np.argmax(np.abs(n))] < 0):
            n = -n
    else:
        n = _unit(np.asarray(normal, dtype=float).reshape(3))
    q = p - c
    q_in = q - np.outer(q @ n, n)
    # the principal direction of the drawing: which way the map lies on the page
    _, _, vt2 = np.linalg.svd(q_in - q_in.mean(axis=0), full_matrices=False)
    u = vt2[0] - (vt2[0] @ n) * n
    u /= np.linalg.norm(u)
    if u[np.argmax(np.abs(u))] < 0:
        u = -u
    v = np.cross(n, u)
    return (
        q @ u,
        q @ v,
        {
            "projection": "in-plane coordinates",
            "centre": c.tolist(),
            "normal": n.tolist(),
            "u_axis": u.tolist(),
            "v_axis": v.tolist(),
            "xlabel": "u [mm]",
            "ylabel": "v [mm]",
        },
    )


def _subsample(dev: np.ndarray, max_points: int) -> np.ndarray:
    """Indices of at most ``max_points`` points to draw, sorted by |deviation|.

    The largest |deviations| are always kept (they decide a form error and must be
    visible); the rest is a seeded random sample, so the same data give the same
    picture. Drawing in order of |deviation| puts the extremes on top.
    """
    n = dev.size
    order = np.argsort(np.abs(dev), kind="stable")
    if n > max_points:
        n_top = max_points // 10
        top = order[n - n_top :]
        rest = np.random.default_rng(0).choice(order[: n - n_top], max_points - n_top, replace=False)
        idx = np.concatenate([rest, top])
        return idx[np.argsort(np.abs(dev[idx]), kind="stable")]
    return order


# --------------------------------------------------------------------------- deviation map
def deviation_map(
    points: Any,
    deviations: Any,
    kind: str = "auto",
    center: Sequence[float] | None = None,
    normal: Sequence[float] | None = None,
    unit: str = "mm",
    limit: float | None = None,
    title: str | None = None,
    display_unit: str | None = None,
    max_points: int = MAX_DRAWN,
    width_mm: float | None = None,
    height_mm: float | None = None,
    dpi: float = DPI,
) -> ChartPNG:
    """The deviation colour map of a sphere or a flat.

    ``points`` (N, 3) in mm, ``deviations`` (N,) signed, in ``unit``: radial for a
    sphere (outside positive), normal distance for a plane. ``kind`` "sphere", "plane"
    or "auto" (a given ``center`` means sphere, a given ``normal`` plane, otherwise
    decided from the points). Pass the centre/normal of the standard's own fit when
    there is one; without them the fitting plugin (task ``sphere-fit`` / ``plane-fit``)
    places the map.

    A sphere is drawn in an equal-area projection (see ``_sphere_xy``), a flat over its
    in-plane coordinates. The colour map is diverging and centred on zero; its range
    is ±``limit`` when given (points beyond saturate and the colour bar gets arrows),
    else ±max|deviation|. The colour bar reads "deviation [mm]", "[µm]" or "[nm]",
    whichever makes the numbers read well (``display_unit`` forces one). At most
    ``max_points`` points are drawn, always including the largest deviations. The
    size defaults to 82 mm wide (two side by side on A4), or the full text width for
    a long flat; the height follows the map's aspect ratio.
    """
    import matplotlib as mpl

    what = "deviation map" + (f" {title!r}" if title else "")
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{what}: points must be an (N, 3) array of numbers") from None
    if p.size == 0:
        raise InputError(f"{what}: no points to draw (empty input)")
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"{what}: points must have shape (N, 3), got {p.shape}")
    bad = ~np.isfinite(p).all(axis=1)
    if bad.any():
        raise InputError(
            f"{what}: {int(bad.sum())} of {len(p)} points have NaN or Inf coordinates "
            f"(first at index {int(np.flatnonzero(bad)[0])}); remove them first"
        )
    dev = _values(deviations, what)
    if dev.size != len(p):
        raise InputError(f"{what}: {dev.size} deviations for {len(p)} points")
    if kind not in ("auto", "sphere", "plane"):
        raise InputError(f"{what}: kind {kind!r} must be 'sphere', 'plane' or 'auto'")
    if len(p) < 3:
        raise InputError(f"{what}: {len(p)} points are too few for a map (need at least 3)")
    if max_points < 100:
        raise InputError(f"{what}: max_points {max_points} is too small (at least 100)")
    to_mm = _factor(unit)
    if kind == "auto":
        kind = "sphere" if center is not None else "plane" if normal is not None else _guess_kind(p)

    c: np.ndarray | None
    if kind == "sphere":
        if center is None:
            try:
                c = np.asarray(_fitted("sphere", p)["center"], dtype=float)
            except CamcmmError:
                c = np.full(3, np.nan)
            if not np.isfinite(c).all():
                raise InputError(f"{what}: the points do not define a sphere; give center=")
        else:
            c = np.asarray(center, dtype=float).reshape(3)
        x, y, geo = _sphere_xy(p, c)
        geo["centre"] = c.tolist()
    else:
        c = None if center is None else np.asarray(center, dtype=float).reshape(3)
        x, y, geo = _plane_xy(p, c, None if normal is None else np.asarray(normal, dtype=float))
    cylindrical = geo["projection"].startswith("cylindrical")

    # colour range: symmetric about zero, in a unit that reads well
    dev_mm = dev * to_mm
    max_abs = float(np.abs(dev_mm).max())
    lim_mm = None if limit is None else abs(float(limit)) * to_mm
    du = display_unit or _display_unit(max(max_abs, lim_mm or 0.0))
    scale = 1.0 / _factor(du)
    d = dev_mm * scale
    vmax = (lim_mm if lim_mm else max_abs) * scale
    if not vmax > 0:
        vmax = 1.0  # all deviations zero: any symmetric range shows them as white
    vmin = -vmax
    over, under = bool(d.max() > vmax * (1 + 1e-12)), bool(d.min() < vmin * (1 + 1e-12))
    extend = "both" if over and under else "max" if over else "min" if under else "neither"

    # size: the plot area follows the data's aspect ratio, so no paper is wasted
    left, right, bottom, top = 13.0, 19.0, 10.0, _top_mm(title)
    xr = (float(x.min()), float(x.max()))
    yr = (float(y.min()), float(y.max()))
    if cylindrical:
        aspect = 0.6
    elif kind == "sphere":
        r90 = geo["radius"] * math.sqrt(2)
        half = max(abs(v_) for v_ in (*xr, *yr)) * 1.04
        half = min(max(half, 1e-9), r90 * 1.04)  # never wider than the 90° rim needs
        xr, yr = (-half, half), (-half, half)
        aspect = 1.0
    else:
        pad_x, pad_y = 0.03 * (xr[1] - xr[0]) + 1e-9, 0.03 * (yr[1] - yr[0]) + 1e-9
        xr, yr = (xr[0] - pad_x, xr[1] + pad_x), (yr[0] - pad_y, yr[1] + pad_y)
        aspect = (yr[1] - yr[0]) / (xr[1] - xr[0])
    if width_mm is None:
        width_mm = 170.0 if (kind == "plane" and aspect < 0.45) else 82.0
    plot_w = width_mm - left - right
    if height_mm is None:
        height_mm = float(np.clip(plot_w * aspect, 25.0, 110.0)) + bottom + top

    idx = _subsample(d, max_points)
    fig, rc = _new_figure(width_mm, height_mm)
    with mpl.rc_context(rc):  # type: ignore[arg-type]  # matplotlib types the keys as literals
        ax = _axes(fig, width_mm, height_mm, left, bottom, right, top)
        # marker area (pt²) such that the drawn points roughly tile the plot area
        plot_h = height_mm - bottom - top
        area_pt2 = (plot_w / 25.4 * 72) * (plot_h / 25.4 * 72)
        fill = 0.5 if kind == "sphere" and not cylindrical else 0.8  # the cap covers part of the square
        s = float(np.clip(1.6 * fill * area_pt2 / max(idx.size, 1), 0.1, 25.0))
        # dense clouds: squares, which tile like the pixels of a map and draw ~30 % faster
        # than discs; sparse ones: discs, which read as individual points
        marker = "s" if idx.size > 5000 else "o"
        sc = ax.scatter(x[idx], y[idx], c=d[idx], s=s, marker=marker, cmap=_CMAP, vmin=vmin, vmax=vmax, linewidths=0)
        if cylindrical:
            ticks = np.array([-90, -45, -20, 0, 20, 45, 90])  # evenly spread in sin(elevation)
            ax.set_yticks(np.sin(np.radians(ticks)), [f"{t}" for t in ticks])
            ax.set_ylim(-1.03, 1.03)
            ax.set_xlim(-183, 183)
            ax.set_xticks([-180, -90, 0, 90, 180])
        else:
            ax.set_xlim(*xr)
            ax.set_ylim(*yr)
            ax.set_aspect("equal", adjustable="box")
            if kind == "sphere":  # the 90° circle: the sphere's rim seen from the view direction
                t = np.linspace(0, 2 * np.pi, 200)
                r90 = geo["radius"] * math.sqrt(2)
                ax.plot(r90 * np.cos(t), r90 * np.sin(t), color="#9ca3af", lw=0.5, ls=":", zorder=0)
        ax.set_xlabel(geo["xlabel"])
        ax.set_ylabel(geo["ylabel"])
        ax.tick_params(length=2)
        ax.set_facecolor("#fbfbfc")
        # colour bar beside the plot area, as tall as the drawn box
        ax.apply_aspect()  # shrink the box to the equal aspect now, so the bar can follow it
        box = ax.get_position()
        cax = fig.add_axes((box.x1 + 2.0 / width_mm, box.y0, 2.6 / width_mm, box.height))
        cb = fig.colorbar(sc, cax=cax, extend=extend)
        cb.set_label(f"deviation [{du}]")
        cb.ax.tick_params(length=2)
        rms = float(np.sqrt(np.mean(d * d)))
        n_txt = f"n = {len(p):,}".replace(",", "\u2009")
        if idx.size < len(p):
            n_txt += f" ({idx.size:,} drawn)".replace(",", "\u2009")
        _heading(
            fig,
            height_mm,
            title,
            f"{n_txt}  min {_num(d.min(), du)}  max {_num(d.max(), du)}  RMS {_num(rms, du)} {du}",
        )
        png = _png(fig, dpi)
    info = {
        "chart": "deviation_map",
        "kind": kind,
        **{k: v for k, v in geo.items() if k not in ("xlabel", "ylabel")},
        "display_unit": du,
        "vmin": vmin,
        "vmax": vmax,
        "colormap": _CMAP,
        "n_points": int(len(p)),
        "n_drawn": int(idx.size),
        "min": float(d.min()),
        "max": float(d.max()),
        "rms": rms,
        "limit": None if lim_mm is None else lim_mm * scale,
    }
    return ChartPNG(png, info)


# --------------------------------------------------------------------------- histogram
def histogram(
    values: Any,
    unit: str = "mm",
    bins: int | str = "auto",
    limit: float | None = None,
    title: str | None = None,
    xlabel: str = "deviation",
    display_unit: str | None = None,
    width_mm: float = 82,
    height_mm: float = 58,
    dpi: float = DPI,
) -> ChartPNG:
    """Histogram of (signed) values, bars coloured with the deviation maps' colour scale
    (same range rule: ±limit or ±max|value|), so it doubles as the map's legend.

    The display unit follows the same rule as :func:`deviation_map`; the x axis is
    symmetric about zero, dashed lines mark ±limit, the solid line the mean.
    """
    import matplotlib as mpl

    what = "histogram" + (f" {title!r}" if title else "")
    v_mm = _values(values, what) * _factor(unit)
    lim_mm = None if limit is None else abs(float(limit)) * _factor(unit)
    max_abs = float(np.abs(v_mm).max())
    du = display_unit or _display_unit(max(max_abs, lim_mm or 0.0))
    v = v_mm / _factor(du)
    vmax = (lim_mm / _factor(du)) if lim_mm else max_abs / _factor(du)
    vmax = vmax if vmax > 0 else 1.0
    edges = np.histogram_bin_edges(v, bins=bins)
    if edges.size > 101:  # 'auto' on millions of points: more bars than pixels
        edges = np.histogram_bin_edges(v, bins=100)
    counts, edges = np.histogram(v, bins=edges)
    mean = float(v.mean())
    sd = float(v.std(ddof=1)) if v.size > 1 else 0.0

    fig, rc = _new_figure(width_mm, height_mm)
    with mpl.rc_context(rc):  # type: ignore[arg-type]  # matplotlib types the keys as literals
        from matplotlib import colormaps
        from matplotlib.colors import Normalize

        ax = _axes(fig, width_mm, height_mm, left=13, bottom=10, right=3, top=_top_mm(title))
        centres = 0.5 * (edges[:-1] + edges[1:])
        colours = colormaps[_CMAP](Normalize(-vmax, vmax)(centres))
        ax.bar(centres, counts, width=np.diff(edges), color=colours, edgecolor="#666", linewidth=0.25, zorder=2)
        if lim_mm:
            for sign in (-1, 1):
                ax.axvline(sign * vmax, color=_COLOURS["limit"], ls="--", lw=0.9, zorder=3)
        ax.axvline(mean, color="#111", lw=0.8, zorder=3)
        half = 1.05 * max(vmax, float(np.abs(edges).max()))
        ax.set_xlim(-half, half)
        ax.set_xlabel(f"{xlabel} [{du}]")
        ax.set_ylabel("count")
        ax.grid(axis="y", color="#e3e6ea", lw=0.5, zorder=0)
        ax.spines[["top", "right"]].set_visible(False)
        ax.tick_params(length=2)
        stats = f"n = {v.size:,}".replace(",", "\u2009") + f"  mean {_num(mean, du)} {du}  s {_num(sd, du)} {du}"
        if lim_mm:
            stats += f"  dashed: \u00b1limit {_num(vmax, du)} {du}"
        _heading(fig, height_mm, title, stats)
        png = _png(fig, dpi)
    info = {
        "chart": "histogram",
        "display_unit": du,
        "n": int(v.size),
        "bins": int(counts.size),
        "mean": mean,
        "std": sd,
        "min": float(v.min()),
        "max": float(v.max()),
        "limit": None if lim_mm is None else lim_mm / _factor(du),
    }
    return ChartPNG(png, info)
