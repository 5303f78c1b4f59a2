"""The Studies page's plotly figures (plain JSON, :mod:`camcmm.gui.plotly_json`): one
view's depth against lambda with its fitted line (fig. 6.15), each set's mean gradient
against the focal length with the first-order fit and error bars (fig. 6.16), and one
case's deviation map seen from above (figs. 6.10-6.13, two side by side).

Each draws what the study plugin returned (the scatter, the fit's slope and intercept,
the deviation clouds decimated by :mod:`.run`); nothing here fits or computes them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...plotly_json import LEGEND_TOP_RIGHT, empty, layout

UM = 1e3  # mm -> µm
LINE = "#d62728"
POINTS = "#1f77b4"
LEFT_OUT = "#bbbbbb"

__all__ = ["deviation_figure", "empty", "focal_figure", "scatter_figure"]


def scatter_figure(view: dict[str, Any] | None, title: str = "") -> dict[str, Any]:
    """Photogrammetric depth (mm) against lambda of one view: the pixels in the fit, those
    left out (the band about λ = 0, rejected residuals) in grey, and the fitted line."""
    if not view:
        return empty("run a light-field study: the depth-vs-λ scatter of a view appears here")
    lam = np.asarray(view.get("lambda") or [], float)
    d = np.asarray(view.get("depth") or [], float)
    used = np.asarray(view.get("used") or [True] * len(lam), bool)
    if not len(lam) or len(d) != len(lam) or len(used) != len(lam):
        return empty("no scatter for this view")
    g, c = float(view.get("gradient_mm_per_lambda") or np.nan), float(view.get("intercept") or np.nan)
    x = [float(lam.min()), float(lam.max())]
    data = [
        {"type": "scattergl", "mode": "markers", "x": lam[~used].tolist(), "y": d[~used].tolist(), "name": "left out",
         "marker": {"size": 3, "color": LEFT_OUT}},
        {"type": "scattergl", "mode": "markers", "x": lam[used].tolist(), "y": d[used].tolist(), "name": "fitted",
         "marker": {"size": 3, "color": POINTS}},
        {"type": "scatter", "mode": "lines", "x": x, "y": [g * v + c for v in x], "name": f"{g:.4f} mm/λ",
         "line": {"color": LINE, "width": 2}},
    ]  # fmt: skip
    name = str(view.get("image") or "").rsplit("/", 1)[-1]
    title = title or f"Depth vs λ (fig. 6.15): {name}"
    lay = layout(title, "λ (eq. 6.5)", "photogrammetric depth [mm]", LEGEND_TOP_RIGHT)
    return {"data": data, "layout": lay}


def focal_figure(f: dict[str, Any] | None) -> dict[str, Any]:
    """Each set's mean gradient (± its standard deviation) against the calibrated focal
    length, the first-order fit, and the predicted gradient with its u when there is one."""
    pts = (f or {}).get("points") or []
    if not f or not pts:
        return empty("the gradient-vs-focal-length fit needs two or more focal lengths")
    x = np.array([float(p["focal_length_mm"]) for p in pts])
    y = np.array([float(p["mean"]) for p in pts])
    e = np.array([float(p.get("std") or 0.0) for p in pts])
    a, b = float(f["slope"]), float(f["intercept"])
    pred = f.get("predicted") or {}
    xs = [float(x.min()), float(x.max())]
    if pred.get("focal_length") is not None:
        xs = [min(xs[0], float(pred["focal_length"])), max(xs[1], float(pred["focal_length"]))]
    data = [
        {"type": "scatter", "mode": "markers", "x": x.tolist(), "y": y.tolist(), "name": "set mean ± std",
         "text": [str(p.get("set")) for p in pts], "marker": {"size": 8, "color": POINTS},
         "error_y": {"type": "data", "array": e.tolist(), "visible": True, "thickness": 1.5},
         "hovertemplate": "%{text}: f %{x:.4r} mm, %{y:.5r} mm/λ<extra></extra>"},
        {"type": "scatter", "mode": "lines", "x": xs, "y": [a * v + b for v in xs],
         "name": f"fit {a:.5f} f {b:+.4f}", "line": {"color": LINE, "width": 2}},
    ]  # fmt: skip
    if pred.get("gradient_mm_per_lambda") is not None:
        u = pred.get("u_new_set") if pred.get("u_new_set") is not None else pred.get("u")
        data.append(
            {"type": "scatter", "mode": "markers", "x": [float(pred["focal_length"])],
             "y": [float(pred["gradient_mm_per_lambda"])], "name": "predicted ± u (a new set)",
             "marker": {"size": 10, "symbol": "diamond-open", "color": "#2ca02c"},
             "error_y": {"type": "data", "array": [float(u or 0.0)], "visible": True}}
        )  # fmt: skip
    lay = layout("Gradient vs focal length (fig. 6.16)", "focal length [mm]", "gradient [mm/λ]", LEGEND_TOP_RIGHT)
    return {"data": data, "layout": lay}


def deviation_figure(m: dict[str, Any] | None, title: str, lim_um: float | None = None) -> dict[str, Any]:
    """A deviation cloud seen from above (x, y in CAD coordinates, mm), coloured by the
    signed deviation in µm (plotly's RdBu: red above the CAD, blue below, grey at 0;
    ``lim_um`` the colour range, shared by a pair)."""
    if not m or not m.get("x"):
        return empty(f"{title}: no deviation cloud")
    d = np.asarray(m["d"], float) * UM
    lim = lim_um or float(np.nanpercentile(np.abs(d), 98)) or 1.0
    order = np.argsort(np.asarray(m["z"], float))  # the top surfaces drawn last, over the walls
    data = [
        {"type": "scattergl", "mode": "markers", "x": np.asarray(m["x"])[order].tolist(),
         "y": np.asarray(m["y"])[order].tolist(),
         "marker": {"size": 3, "color": d[order].round(2).tolist(), "colorscale": "RdBu",
                    "cmin": -lim, "cmax": lim, "colorbar": {"title": {"text": "µm"}, "thickness": 12}},
         "hovertemplate": "x %{x:.1f}, y %{y:.1f} mm: %{marker.color:.3r} µm<extra></extra>"},
    ]  # fmt: skip
    lay = layout(title, "x [mm]", "y [mm]")
    lay["yaxis"].update({"scaleanchor": "x", "scaleratio": 1})
    return {"data": data, "layout": lay}


def shared_limit(*maps: dict[str, Any] | None) -> float | None:
    """The colour range (µm) two maps side by side share: the 98th percentile of both."""
    d = [np.abs(np.asarray(m["d"], float)) * UM for m in maps if m and m.get("d")]
    return float(np.nanpercentile(np.concatenate(d), 98)) or None if d else None
