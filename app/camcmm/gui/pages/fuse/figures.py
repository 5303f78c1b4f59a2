"""The Fuse page's plotly figures (plain JSON for trame-plotly, :mod:`camcmm.gui.plotly_json`):
the two grey images side by side with the inlier matches, the difference map, its
histogram, and its Abbott-Firestone curve with the 95 % band.

Each draws what the fusion plugin returned in its ``views`` output (the small grey
images, the inlier matches in their pixels, the difference grid, the histogram, the
material-ratio curve); nothing here computes them. Heights come in mm and are drawn in µm.
"""

from __future__ import annotations

import base64
import io
from typing import Any

import numpy as np

from .... import numbers
from ...plotly_json import LEGEND_TOP_RIGHT, empty, layout

UM = 1e3  # mm -> µm
#: largest side of the difference map as sent to the browser (a heatmap's JSON grows with its cells)
HEATMAP_SIDE = 256
MATCH_COLOUR = "#e8710a"
BAND_COLOUR = "rgba(59, 110, 165, 0.15)"


def png_uri(grey: Any) -> str:
    """A grey image ((h, w) numbers 0..255) as a PNG data URI (the figure's background)."""
    from PIL import Image

    a = np.clip(np.nan_to_num(np.asarray(grey, dtype=float)), 0, 255).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _grey(x: Any) -> np.ndarray | None:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        return None
    return a if a.ndim == 2 and min(a.shape) > 0 else None


def matches_figure(view: dict[str, Any]) -> dict[str, Any]:
    """The photogrammetry grey image (left) and the CSI's (right), the inlier matches as
    lines between them; y down as in the images. ``view``: one map's entry of ``views``."""
    photo, csi = _grey(view.get("photo_image")), _grey(view.get("csi_image"))
    if photo is None or csi is None:
        return empty("no grey images in this result")
    h1, w1 = photo.shape
    h2, w2 = csi.shape
    gap = 0.05 * (w1 + w2)
    off = w1 + gap
    m = view.get("matches") or {}
    a = np.asarray(m.get("photo") or [], dtype=float).reshape(-1, 2)
    b = np.asarray(m.get("csi") or [], dtype=float).reshape(-1, 2)
    n = min(len(a), len(b))
    a, b = a[:n], b[:n]
    xs, ys = [], []
    for (u1, v1), (u2, v2) in zip(a, b):
        xs += [float(u1), float(u2) + off, None]
        ys += [float(v1), float(v2), None]
    data = [
        {"type": "scatter", "x": xs, "y": ys, "mode": "lines", "name": f"{n} inlier matches",
         "line": {"color": MATCH_COLOUR, "width": 1}, "hoverinfo": "skip"},
        {"type": "scatter", "x": np.concatenate([a[:, 0], b[:, 0] + off]).tolist(),
         "y": np.concatenate([a[:, 1], b[:, 1]]).tolist(), "mode": "markers", "showlegend": False,
         "marker": {"color": MATCH_COLOUR, "size": 5, "symbol": "circle-open"}, "hoverinfo": "x+y"},
    ]  # fmt: skip
    lay = layout(
        f"Grey images: photogrammetry (left), CSI (right) — {n} inlier matches",
        "px",
        "px",
        legend=LEGEND_TOP_RIGHT,
        images=[
            {"source": png_uri(photo), "xref": "x", "yref": "y", "x": -0.5, "y": -0.5, "sizex": w1, "sizey": h1,
             "sizing": "stretch", "layer": "below", "xanchor": "left", "yanchor": "top"},
            {"source": png_uri(csi), "xref": "x", "yref": "y", "x": off - 0.5, "y": -0.5, "sizex": w2, "sizey": h2,
             "sizing": "stretch", "layer": "below", "xanchor": "left", "yanchor": "top"},
        ],
    )  # fmt: skip
    lay["xaxis"].update({"range": [-0.5, off + w2 - 0.5], "showgrid": False, "constrain": "domain"})
    # y down, and one px as long in y as in x: the images keep their shape
    lay["yaxis"].update({"range": [max(h1, h2) - 0.5, -0.5], "showgrid": False, "scaleanchor": "x", "scaleratio": 1})
    return {"data": data, "layout": lay}


def _difference_grid(diff: dict[str, Any]) -> tuple[np.ndarray, float, float, float, float] | None:
    z = np.asarray([[np.nan if v is None else v for v in row] for row in diff.get("grid") or []], dtype=float)
    if z.ndim != 2 or z.size == 0:
        return None
    dx = float(diff.get("dx") or 1.0)
    dy = float(diff.get("dy") or dx)
    return z, dx, dy, float(diff.get("x0") or 0.0), float(diff.get("y0") or 0.0)


def difference_figure(view: dict[str, Any]) -> dict[str, Any]:
    """The difference map CSI − photogrammetry (µm; plotly's RdBu: blue below 0, red above, white at 0)
    over the CSI footprint (mm); at most :data:`HEATMAP_SIDE` cells a side are sent."""
    got = _difference_grid(view.get("difference") or {})
    if got is None or not np.isfinite(got[0]).any():
        return empty("no difference map in this result")
    z, dx, dy, x0, y0 = got
    step = max(1, int(np.ceil(max(z.shape) / HEATMAP_SIDE)))
    zs = z[::step, ::step] * UM
    x = (x0 + dx * step * np.arange(zs.shape[1])).tolist()
    y = (y0 + dy * step * np.arange(zs.shape[0])).tolist()
    lim = float(np.nanpercentile(np.abs(zs), 99)) or 1.0
    data = [
        {"type": "heatmap", "x": x, "y": y, "z": [[None if v != v else round(float(v), 4) for v in row] for row in zs],
         "colorscale": "RdBu", "zmid": 0.0, "zmin": -lim, "zmax": lim,
         "colorbar": {"title": {"text": "µm", "side": "right"}, "thickness": 14, "tickformat": ".3~g"},
         "hovertemplate": "x %{x:.4g} mm, y %{y:.4g} mm: %{z:.3g} µm<extra></extra>"},
    ]  # fmt: skip
    lay = layout("Difference CSI − photogrammetry", "x in the map [mm]", "y in the map [mm]")
    lay["yaxis"].update({"scaleanchor": "x", "scaleratio": 1})
    return {"data": data, "layout": lay}


def histogram_figure(view: dict[str, Any]) -> dict[str, Any]:
    """The difference's histogram (µm), the 95 % band shaded."""
    hist = view.get("histogram") or {}
    edges = np.asarray(hist.get("edges") or [], dtype=float) * UM
    counts = np.asarray(hist.get("counts") or [], dtype=float)
    if len(edges) != len(counts) + 1 or not len(counts):
        return empty("no histogram in this result")
    data = [
        {"type": "bar", "x": (0.5 * (edges[1:] + edges[:-1])).tolist(), "y": counts.tolist(),
         "width": np.diff(edges).tolist(), "marker": {"color": "#3b6ea5"}, "name": "points",
         "hovertemplate": "%{x:.3g} µm: %{y} points<extra></extra>"},
    ]  # fmt: skip
    lay = layout("Histogram of the difference", "CSI − photogrammetry [µm]", "points", y_from_zero=True, bargap=0)
    shapes, notes = _band(view.get("abbott") or {}, axis="x")
    lay.update(shapes=shapes, annotations=notes)
    return {"data": data, "layout": lay}


def _band(ab: dict[str, Any], axis: str) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The 95 % band (2.5 … 97.5 % percentiles) as a shaded strip along ``axis`` and its label."""
    try:
        lo, hi = float(ab["p2_5"]) * UM, float(ab["p97_5"]) * UM
    except (KeyError, TypeError, ValueError):
        return [], []
    other = "y" if axis == "x" else "x"
    rect = {
        "type": "rect",
        f"{axis}ref": axis,
        f"{other}ref": "paper",
        f"{axis}0": lo,
        f"{axis}1": hi,
        f"{other}0": 0,
        f"{other}1": 1,
        "fillcolor": BAND_COLOUR,
        "line": {"width": 0},
        "layer": "below",
    }
    lines = [
        {"type": "line", f"{axis}ref": axis, f"{other}ref": "paper", f"{axis}0": v, f"{axis}1": v,
         f"{other}0": 0, f"{other}1": 1, "line": {"color": "#3b6ea5", "width": 1, "dash": "dash"}}
        for v in (lo, hi)
    ]  # fmt: skip
    text = f"95 %: {numbers.deviation(hi / UM)} / {numbers.deviation(lo / UM)}"  # the number rule
    note = {
        "text": text,
        "showarrow": False,
        "xref": "paper",
        "yref": "paper",
        "x": 0.98,
        "y": 0.96,
        "xanchor": "right",
        "font": {"size": 11, "color": "#3b6ea5"},
        "bgcolor": "rgba(255,255,255,0.8)",
    }
    return [rect, *lines], [note]


def abbott_figure(view: dict[str, Any]) -> dict[str, Any]:
    """The Abbott-Firestone (material-ratio) curve of the difference: height (µm) over
    the material ratio (%), the 95 % band (2.5 … 97.5 % of the points) shaded."""
    ab = view.get("abbott") or {}
    mr = np.asarray(ab.get("mr_percent") or [], dtype=float)
    hgt = np.asarray([np.nan if v is None else v for v in ab.get("height") or []], dtype=float) * UM
    if len(mr) != len(hgt) or not len(mr):
        return empty("no Abbott-Firestone curve in this result")
    data = [
        {"type": "scatter", "x": mr.tolist(), "y": hgt.tolist(), "mode": "lines", "name": "material ratio",
         "line": {"color": "#1f2d3d", "width": 2}, "hovertemplate": "%{x:.3g} %: %{y:.3g} µm<extra></extra>"},
    ]  # fmt: skip
    lay = layout("Abbott-Firestone curve of the difference", "material ratio [%]", "CSI − photogrammetry [µm]")
    lay["xaxis"]["range"] = [0, 100]
    shapes, notes = _band(ab, axis="y")
    lay.update(shapes=shapes, annotations=notes)
    return {"data": data, "layout": lay}


__all__ = ["abbott_figure", "difference_figure", "empty", "histogram_figure", "matches_figure", "png_uri"]
