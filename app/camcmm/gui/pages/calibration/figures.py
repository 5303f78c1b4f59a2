"""Charts of the Calibration page as plain plotly JSON, and the same charts as PNG.

Plain dicts (the trame-plotly component binds to JSON); the PNG export draws the same
numbers with matplotlib (plotly's static export needs Kaleido and a browser), as the
Uncertainty page does. Inputs are the rows of :mod:`.results` and the
output of the projection-uncertainty plugin (map (rows, columns) px, u, v, min, max):
the numbers are the plugins'; this module only draws them.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .... import numbers
from ...plotly_json import LEGEND_TOP_RIGHT, empty, layout

USED, LEFT_OUT, NOT_FOUND = "#1f77b4", "#d62728", "#7f7f7f"


def _layout(title: str, xtitle: str, ytitle: str, showlegend: bool = True, **extra: Any) -> dict[str, Any]:
    return layout(title, xtitle, ytitle, LEGEND_TOP_RIGHT if showlegend else None, **extra)


def views_figure(rows: list[dict[str, Any]], rms: float | None, title: str) -> dict[str, Any]:
    """Bars of each view's RMS reprojection error: used views blue, views left out as
    outliers red (at the RMS they had), images without a board as grey crosses at 0;
    the overall RMS as a dashed line."""
    if not rows:
        return empty("run a calibration to see each view's reprojection error")
    names = [r["name"] for r in rows]
    data: list[dict[str, Any]] = []
    for status, colour, label in (("used", USED, "used"), ("left out", LEFT_OUT, "left out")):
        sel = [r for r in rows if r["status"] == status and r["rms"] is not None]
        if sel:
            data.append(
                {
                    "type": "bar",
                    "name": label,
                    "x": [r["name"] for r in sel],
                    "y": [r["rms"] for r in sel],
                    "marker": {"color": colour},
                    "customdata": [r["reason"] for r in sel],
                    "hovertemplate": "%{x}<br>RMS %{y:.3r} px<br>%{customdata}<extra>" + label + "</extra>",
                }
            )
    missing = [r for r in rows if r["rms"] is None]
    if missing:
        data.append(
            {
                "type": "scatter",
                "mode": "markers",
                "name": "no board / not used",
                "x": [r["name"] for r in missing],
                "y": [0.0] * len(missing),
                "customdata": [r["reason"] for r in missing],
                "cliponaxis": False,
                "marker": {"symbol": "x", "size": 11, "color": LEFT_OUT, "line": {"width": 1}},
                "hovertemplate": "%{x}<br>%{customdata}<extra></extra>",
            }
        )
    lay = _layout(title, "", "RMS reprojection error / px", barmode="overlay")
    lay["xaxis"].update({"type": "category", "categoryorder": "array", "categoryarray": names, "tickangle": -45})
    top = max([r["rms"] for r in rows if r["rms"] is not None] + [float(rms or 0.0)])
    lay["yaxis"]["range"] = [0, 1.18 * top if top > 0 else 1.0]  # headroom for the RMS label
    if rms is not None and math.isfinite(float(rms)):
        lay["shapes"] = [
            {
                "type": "line",
                "xref": "paper",
                "x0": 0,
                "x1": 1,
                "y0": float(rms),
                "y1": float(rms),
                "line": {"color": "#444", "dash": "dash", "width": 1},
            }
        ]
        lay["annotations"] = [
            {
                "text": f"overall RMS {numbers.plain(rms, 3)} px",
                "xref": "paper",
                "x": 1,
                "xanchor": "right",
                "y": float(rms),
                "yanchor": "bottom",
                "showarrow": False,
                "font": {"size": 10},
                "bgcolor": "rgba(255,255,255,0.8)",
            }
        ]
    return {"data": data, "layout": lay}


def _log_ticks(lo: float, hi: float) -> tuple[list[float], list[str]]:
    vals = [
        m * 10.0**e for e in range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1) for m in (1, 2, 5)
    ]
    vals = [v for v in vals if lo <= v <= hi] or [lo, hi]
    return [math.log10(v) for v in vals], [numbers.significant(v, 3) for v in vals]


def heatmap_figure(
    pu: dict[str, Any] | None, corners: np.ndarray | None, image_size: Sequence[int], title: str
) -> dict[str, Any]:
    """The projection-uncertainty map over the image (px), with the corners the
    calibration used as dots. Colour on a log scale when the map spans more than a
    factor 20 (it grows fast towards corners the boards never reached); hover gives σ."""
    if not pu or pu.get("map") is None:
        return empty("run a calibration to see the projection uncertainty across the image")
    z = np.asarray(pu["map"], float)
    lo, hi = float(pu["min"]), float(pu["max"])  # the plugin's range of the map
    log = lo > 0 and hi / lo > 20
    colour = np.log10(z) if log else z
    bar = {"title": {"text": "σ / px", "side": "right"}, "thickness": 14}
    if log:
        tv, tt = _log_ticks(lo, hi)
        bar.update(tickvals=tv, ticktext=tt)
    heat = {
        "type": "heatmap",
        "x": np.asarray(pu["u"], float).tolist(),
        "y": np.asarray(pu["v"], float).tolist(),
        "z": colour.tolist(),
        "customdata": z.tolist(),
        "colorscale": "Viridis",
        "zsmooth": "best",
        "colorbar": bar,
        "name": "σ",
        "hovertemplate": "u %{x:.0f} px, v %{y:.0f} px<br>σ = %{customdata:.3r} px<extra></extra>",
    }
    data = [heat]
    if corners is not None and len(corners):
        c = np.asarray(corners, float).reshape(-1, 2)
        step = max(1, len(c) // 3000)
        data.append(
            {
                "type": "scattergl",
                "mode": "markers",
                "name": "board corners used",
                "x": c[::step, 0].tolist(),
                "y": c[::step, 1].tolist(),
                "marker": {"size": 3, "color": "rgba(255,255,255,0.75)"},
                "hoverinfo": "skip",
            }
        )
    w, h = (int(image_size[0]), int(image_size[1])) if len(image_size) == 2 else (0, 0)
    lay = _layout(title, "u / px", "v / px", showlegend=False)
    lay["xaxis"].update({"range": [0, w or None], "constrain": "domain", "showgrid": False})
    lay["yaxis"].update(
        {"range": [h or None, 0], "scaleanchor": "x", "scaleratio": 1, "constrain": "domain", "showgrid": False}
    )
    return {"data": data, "layout": lay}


def _png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def _figure(width_px: int, height_px: int):
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    return Figure(figsize=(width_px / 100, height_px / 100), dpi=100)


def views_png(
    rows: list[dict[str, Any]], rms: float | None, title: str, width_px: int = 900, height_px: int = 480
) -> bytes:
    """The per-view error chart as PNG (same colours as :func:`views_figure`)."""
    f = _figure(width_px, height_px)
    ax = f.add_subplot(111)
    x = np.arange(len(rows))
    colours = [USED if r["status"] == "used" else LEFT_OUT for r in rows]
    ax.bar(x, [r["rms"] or 0.0 for r in rows], color=colours)
    for i, r in enumerate(rows):
        if r["rms"] is None:
            ax.plot(i, 0, "x", color=LEFT_OUT, ms=8, clip_on=False)
    if rms is not None:
        ax.axhline(float(rms), ls="--", lw=1, color="#444", label=f"overall RMS {numbers.plain(rms, 3)} px")
        ax.legend(fontsize=8)
    ax.set_xticks(x, [r["name"] for r in rows], rotation=45, ha="right", fontsize=8)
    ax.set_ylabel("RMS reprojection error / px")
    ax.set_title(title, loc="left", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    return _png(f)


def heatmap_png(
    pu: dict[str, Any],
    corners: np.ndarray | None,
    image_size: Sequence[int],
    title: str,
    width_px: int = 900,
    height_px: int = 640,
) -> bytes:
    """The projection-uncertainty map as PNG (log colour when it spans a factor > 20)."""
    from matplotlib.colors import LogNorm

    f = _figure(width_px, height_px)
    ax = f.add_subplot(111)
    z = np.asarray(pu["map"], float)
    u, v = np.asarray(pu["u"], float), np.asarray(pu["v"], float)
    lo, hi = float(pu["min"]), float(pu["max"])
    norm = LogNorm(lo, hi) if lo > 0 and hi / lo > 20 else None
    im = ax.imshow(
        z, extent=(u[0], u[-1], v[-1], v[0]), cmap="viridis", norm=norm, interpolation="bilinear", aspect="equal"
    )
    if corners is not None and len(corners):
        c = np.asarray(corners, float).reshape(-1, 2)
        ax.plot(c[:, 0], c[:, 1], ".", ms=1.5, color="white", alpha=0.7)
    w, h = image_size
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    f.colorbar(im, ax=ax, label="σ / px", shrink=0.85)
    ax.set_xlabel("u / px")
    ax.set_ylabel("v / px")
    ax.set_title(title, loc="left", fontsize=10)
    return _png(f)
