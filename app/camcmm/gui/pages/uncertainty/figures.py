"""Charts of the Uncertainty page as plain plotly JSON, and the same charts as PNG.

Plain dicts, not ``plotly.graph_objects``: the trame-plotly component binds to JSON,
and the PNG export draws the very same dict with matplotlib (already a dependency
for reports; plotly's own static export needs Kaleido and a browser), so what the
operator sees and what they download cannot drift apart.

Inputs are the outputs of the plugins providing ``uncertainty-budget`` and
``monte-carlo-uncertainty`` (camcmm's own: ``camcmm_plugins.uncertainty``); values in
the result's unit (µm by default). Presentation only: every number drawn is one the
plugin returned.
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

from .... import numbers as num
from ...plotly_json import LEGEND_BELOW, empty, layout

AXES = ("x", "y", "z")
AXIS_COLOURS = {"x": "#1f77b4", "y": "#2ca02c", "z": "#d62728"}
FACTOR_TITLES = {
    "feature_location": "feature location",
    "focal_length": "focal length",
    "principal_point": "principal point",
    "radial_distortion": "radial distortion",
    "tangential_distortion": "tangential distortion",
    "rotation": "rotation (camera 2)",
    "translation": "translation (camera 2)",
    "joint": "all factors at once",
}
PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")


def shown_unit(unit: str | None) -> str:
    """Units as files write them (``um``, ``urad``) and as people read them (``µm``, ``µrad``)."""
    return num.unit_text(unit)


def factor_title(name: str) -> str:
    return FACTOR_TITLES.get(name, name.replace("_", " "))


def fmt(x: Any, digits: int = 4) -> str:
    """A plain number as the tables show it (a coverage factor, degrees of freedom):
    ``digits`` significant digits, never an exponent; None and inf as ∞ (an infinite
    number of degrees of freedom)."""
    if x is None:
        return "∞"
    x = float(x)
    return "∞" if math.isinf(x) else num.significant(x, digits)  # dof 14, not 14.00


def u_text(x: Any) -> str:
    """An uncertainty in the result's unit with two significant digits (GUM 7.2.6, the
    number rule); ``0`` for zero."""
    if x is None or not num.finite(x):
        return num.UNDEFINED
    return num.plain(abs(float(x)), 2)


def _layout(title: str, xtitle: str, ytitle: str, legend: bool = True, **extra: Any) -> dict[str, Any]:
    return layout(title, xtitle, ytitle, LEGEND_BELOW if legend else None, y_from_zero=True, **extra)


#: what the budget's bars and percentages are (one thing, said in the chart's title and the table)
SHARE_MEANING = "share of the variance u_c² = Σ (c·u)², in %"


def budget_figure(result: dict[str, Any]) -> dict[str, Any]:
    """Horizontal bars: each contribution's share of the combined variance u_c²,
    (c·u)² / u_c² in % (the GUM's convention for a budget's percentages). Bar and label
    are the same number; |c·u| is in the hover."""
    rows = list(result.get("contributions") or [])
    unit = shown_unit(result.get("unit"))
    if not rows:
        return empty("the budget's contributions appear here")
    names = [str(r.get("name")) for r in rows][::-1]
    shares = [100.0 * float(r.get("share", 0.0)) for r in rows][::-1]
    cu = [u_text(r.get("contribution", 0.0)) for r in rows][::-1]
    bar = {
        "type": "bar",
        "orientation": "h",
        "y": names,
        "x": shares,
        "marker": {"color": "#1f77b4"},
        "text": [num.percent(s / 100.0) for s in shares],
        "textposition": "auto",
        "customdata": cu,
        "hovertemplate": "%{y}<br>share of u_c² %{text}<br>|c·u| = %{customdata} " + unit + "<extra></extra>",
    }
    return {
        "data": [bar],
        "layout": _layout(
            "Contributions: " + SHARE_MEANING,
            "share of u_c² / %",
            "",
            legend=False,
            yaxis={"automargin": True},
        ),
    }


def contributions_figure(mc: dict[str, Any]) -> dict[str, Any]:
    """Grouped bars per influence factor in x, y and z (the form of thesis table 3.2)."""
    contrib = mc.get("contributions") or {}
    unit = shown_unit(mc.get("unit", "um"))
    if not contrib:
        return empty("run the Monte Carlo simulation to see the contributions")
    names = [factor_title(f) for f in contrib]
    data = [
        {
            "type": "bar",
            "name": a,
            "x": names,
            "y": [float(v[i]) for v in contrib.values()],
            "marker": {"color": AXIS_COLOURS[a]},
            "hovertemplate": "%{x}<br>u_" + a + " = %{y:.2r} " + unit + "<extra></extra>",
        }
        for i, a in enumerate(AXES)
    ]
    comb = mc.get("combined") or [0, 0, 0]
    title = (
        "Contributions per factor; combined " + ", ".join(f"u_{a} {u_text(c)}" for a, c in zip(AXES, comb)) + f" {unit}"
    )
    return {
        "data": data,
        "layout": _layout(title, "influence factor", f"standard uncertainty / {unit}", barmode="group"),
    }


def convergence_figure(conv: dict[str, Any], unit: str, axis: str = "x") -> dict[str, Any]:
    """Thesis fig. 3.3: each factor's running standard uncertainty against the number
    of iterations, on one axis."""
    if not conv:
        return empty("tick 'convergence' under Studies and run to see the convergence")
    i = AXES.index(axis)
    unit = shown_unit(unit)
    data = []
    for j, (f, c) in enumerate(conv.items()):
        u = np.asarray(c["u"], float).reshape(-1, 3)
        data.append(
            {
                "type": "scatter",
                "mode": "lines",
                "name": factor_title(f),
                "x": np.asarray(c["iterations"]).tolist(),
                "y": u[:, i].tolist(),
                "line": {"color": PALETTE[j % len(PALETTE)], "width": 1.6},
                "hovertemplate": factor_title(f) + "<br>N = %{x}<br>u = %{y:.2r} " + unit + "<extra></extra>",
            }
        )
    lay = _layout(f"Convergence in {axis}", "iterations", f"u_{axis} / {unit}")
    lay["xaxis"]["type"] = "log"
    return {"data": data, "layout": lay}


def _xyz_lines(x: Any, xyz: Any) -> list[dict[str, Any]]:
    """One line per axis: ``xyz`` (N, 3) against ``x`` (N,), coloured as every x/y/z chart here."""
    x = np.asarray(x, float).tolist()
    xyz = np.asarray(xyz, float).reshape(-1, 3)
    return [
        {
            "type": "scatter",
            "mode": "lines+markers",
            "name": a,
            "x": x,
            "y": xyz[:, i].tolist(),
            "line": {"color": AXIS_COLOURS[a]},
        }
        for i, a in enumerate(AXES)
    ]


def sweep_figure(sweep: dict[str, Any], unit: str) -> dict[str, Any]:
    """Thesis fig. 3.4: the feature-location contribution for sigma 0..1 px."""
    if not sweep:
        return empty("tick 'sweep' under Studies and run to see the feature-location sweep")
    data = _xyz_lines(sweep["sigma_px"], sweep["u"])
    unit = shown_unit(unit)
    return {
        "data": data,
        "layout": _layout("Feature-location sweep", "σ of the feature location / px", f"standard uncertainty / {unit}"),
    }


def spatial_figure(spatial: dict[str, Any], unit: str) -> dict[str, Any]:
    """Thesis fig. 3.9: per-point standard deviation along a line through the volume."""
    if not spatial:
        return empty("tick 'spatial' under Studies and run to see the variation along an axis")
    data = _xyz_lines(spatial["position"], spatial["std"])
    unit = shown_unit(unit)
    return {
        "data": data,
        "layout": _layout(
            f"Spatial variation along {spatial.get('axis', 'x')} (all factors)",
            f"{spatial.get('axis', 'x')} / mm",
            f"standard deviation / {unit}",
        ),
    }


def figure_png(fig: dict[str, Any], width_px: int = 900, height_px: int = 520) -> bytes:
    """The plotly dict drawn with matplotlib (bars, grouped bars, lines) as PNG."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    dpi = 100
    f = Figure(figsize=(width_px / dpi, height_px / dpi), dpi=dpi)
    ax = f.add_subplot(111)
    lay = fig.get("layout", {})
    traces = fig.get("data", [])
    bars = [t for t in traces if t.get("type") == "bar"]
    if bars and bars[0].get("orientation") == "h":
        t = bars[0]
        ax.barh(t["y"], t["x"], color=t.get("marker", {}).get("color", "#1f77b4"))
    elif bars:
        labels = list(bars[0]["x"])
        w = 0.8 / len(bars)
        x = np.arange(len(labels))
        for k, t in enumerate(bars):
            ax.bar(
                x + (k - (len(bars) - 1) / 2) * w,
                t["y"],
                w,
                label=t.get("name"),
                color=t.get("marker", {}).get("color"),
            )
        ax.set_xticks(x, labels, rotation=20, ha="right")
    for t in traces:
        if t.get("type") == "scatter":
            ax.plot(
                t["x"],
                t["y"],
                marker="o" if "markers" in t.get("mode", "") else None,
                ms=3,
                label=t.get("name"),
                color=(t.get("line") or {}).get("color"),
            )
    if lay.get("xaxis", {}).get("type") == "log":
        ax.set_xscale("log")
    ax.set_title(lay.get("title", {}).get("text", ""), loc="left", fontsize=10)
    ax.set_xlabel(lay.get("xaxis", {}).get("title", {}).get("text", ""))
    ax.set_ylabel(lay.get("yaxis", {}).get("title", {}).get("text", ""))
    ax.grid(True, alpha=0.3)
    if lay.get("showlegend", False) and len(traces) > 1:
        ax.legend(fontsize=8)
    f.tight_layout()
    buf = io.BytesIO()
    f.savefig(buf, format="png")
    return buf.getvalue()
