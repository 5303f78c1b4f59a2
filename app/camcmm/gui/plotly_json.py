"""Plotly figures as plain JSON, the look every page's charts share.

The trame-plotly component binds to a figure's JSON; building the dict directly keeps
the pages free of ``plotly.graph_objects`` and lets the PNG exports draw the very same
dict with matplotlib.
"""

from __future__ import annotations

from typing import Any

FONT = {"family": "Roboto, DejaVu Sans, sans-serif", "size": 11}
LEGEND_BELOW = {"orientation": "h", "y": -0.25}
LEGEND_TOP_RIGHT = {
    "orientation": "h",
    "y": 1.0,
    "yanchor": "bottom",
    "x": 1,
    "xanchor": "right",
    "bgcolor": "rgba(0,0,0,0)",
}


def layout(
    title: str, xtitle: str, ytitle: str, legend: dict[str, Any] | None = None, y_from_zero: bool = False, **extra: Any
) -> dict[str, Any]:
    """A figure layout: title at the left, axis titles, white background. ``legend``
    places the legend (``LEGEND_BELOW``, ``LEGEND_TOP_RIGHT``); None hides it."""
    yaxis = {"title": {"text": ytitle}, "zeroline": False, "automargin": True}
    if y_from_zero:
        yaxis["rangemode"] = "tozero"
    lay = {
        "title": {"text": title, "font": {"size": 13}, "x": 0.02, "xanchor": "left"},
        "margin": {"l": 58, "r": 14, "t": 36, "b": 44},
        "xaxis": {"title": {"text": xtitle}, "zeroline": False, "automargin": True},
        "yaxis": yaxis,
        "showlegend": legend is not None,
        "paper_bgcolor": "white",
        "plot_bgcolor": "white",
        "hovermode": "closest",
        "font": FONT,
    }
    if legend is not None:
        lay["legend"] = legend
    lay.update(extra)
    return lay


def empty(text: str) -> dict[str, Any]:
    """A blank figure that says what will appear there."""
    lay = layout("", "", "")
    lay["xaxis"] = {"visible": False}
    lay["yaxis"] = {"visible": False}
    lay["annotations"] = [
        {
            "text": text,
            "showarrow": False,
            "font": {"size": 12, "color": "#777"},
            "xref": "paper",
            "yref": "paper",
            "x": 0.5,
            "y": 0.5,
        }
    ]
    return {"data": [], "layout": lay}
