"""The Series page's plotly figures (plain JSON, :mod:`camcmm.gui.plotly_json`): the run
chart of one characteristic across the parts — each value coloured by its verdict, the
tolerance limits, the mean and the control limits — and one part's labels: its
characteristics' flags at their anchors on the part, with the decisive points, in the
plan's coordinates. They draw the series' numbers (camcmm.tasks.series.chart); nothing
here computes them."""

from __future__ import annotations

from typing import Any

from .... import numbers as num
from ....tasks.gdt import SIZES
from ....tasks.series import VERDICT_COLOURS
from ...plotly_json import LEGEND_BELOW, empty, layout

__all__ = ["empty", "labels_figure", "run_chart"]

#: Verdicts from the worst: the colour of a flag holding several characteristics.
WORST = ("not conform", "undecided", "not evaluated", "conform")


def _hline(y: float, name: str, colour: str, dash: str, n: int) -> dict[str, Any]:
    return {
        "type": "scatter",
        "mode": "lines",
        "x": [-0.5, n - 0.5],
        "y": [y, y],
        "name": name,
        "line": {"color": colour, "dash": dash, "width": 1.5},
        "hoverinfo": "name+y",
    }


def run_chart(c: dict[str, Any] | None) -> dict[str, Any]:
    """Values of characteristic ``c`` (:func:`camcmm.tasks.series.chart`) part by part."""
    if not c or not c.get("parts"):
        return empty("run a series, then click a cell: the run chart of its characteristic appears here")
    n = len(c["parts"])
    x = list(range(n))
    # a size in mm, a zone (form, orientation, location) in µm: as the table and the Compare page
    unit, f = ("mm", 1.0) if c.get("type") in SIZES else (num.MICRO, 1000.0)
    data: list[dict[str, Any]] = [
        {
            "type": "scatter",
            "mode": "lines+markers",
            "x": x,
            "y": [None if v is None else float(v) * f for v in c["values"]],
            "text": [
                f"{p}: {num.characteristic(v, unit == 'mm')}, {verdict}"
                for p, v, verdict in zip(c["parts"], c["values"], c["verdicts"], strict=True)
            ],
            "name": "value",
            "line": {"color": "#90a4ae", "width": 1},
            "marker": {"size": 10, "color": [VERDICT_COLOURS.get(v, "#9e9e9e") for v in c["verdicts"]]},
            "hoverinfo": "text",
        }
    ]
    for key, name, colour, dash in (
        ("usl", "upper tolerance limit", "#d7301f", "solid"),
        ("lsl", "lower tolerance limit", "#d7301f", "solid"),
        ("mean", "mean", "#1565c0", "dot"),
        ("ucl", "upper control limit", "#6a1b9a", "dash"),
        ("lcl", "lower control limit", "#6a1b9a", "dash"),
    ):
        if c.get(key) is not None:
            data.append(_hline(float(c[key]) * f, name, colour, dash, n))
    lay = layout(f"{c['id']} across the parts", "part", f"value [{unit}]", legend=LEGEND_BELOW)
    lay["xaxis"].update({"tickmode": "array", "tickvals": x, "ticktext": c["parts"], "range": [-0.5, n - 0.5]})
    return {"data": data, "layout": lay}


def labels_figure(part: str, evaluation: dict[str, Any] | None, points: Any = None) -> dict[str, Any]:
    """The flags of one part: its aligned cloud (``points``, plan coordinates, grey; None:
    not drawn), each characteristic's anchor (its id, value and verdict as text, in the
    verdict's colour) and its decisive points, plan coordinates (mm)."""
    labels = list((evaluation or {}).get("labels") or [])
    if not labels:
        return empty(f"{part}: no labels (the part was not evaluated)")
    rows = {c["id"]: c for c in (evaluation or {}).get("characteristics") or []}
    data: list[dict[str, Any]] = []
    if points is not None and len(points):
        data.append({
            "type": "scatter3d", "mode": "markers", "name": "the part, aligned", "hoverinfo": "skip",
            "x": points[:, 0].tolist(), "y": points[:, 1].tolist(), "z": points[:, 2].tolist(),
            "marker": {"size": 1.5, "color": "#b0bec5"}, "showlegend": False,
        })  # fmt: skip
    anchors: dict[tuple[float, ...], list[tuple[str, str]]] = {}
    for lab in labels:
        c = rows.get(lab.get("id"), {})
        verdict = str(c.get("verdict_guarded") or lab.get("verdict") or "not evaluated")
        colour = VERDICT_COLOURS.get(verdict, "#9e9e9e")
        dec = lab.get("decisive") or []
        if dec:
            data.append({
                "type": "scatter3d", "mode": "markers", "name": f"{lab['id']} decisive points",
                "x": [p[0] for p in dec], "y": [p[1] for p in dec], "z": [p[2] for p in dec],
                "marker": {"size": 3, "color": colour}, "showlegend": False,
            })  # fmt: skip
        a = tuple(round(float(v), 6) for v in (lab.get("anchor") or [0.0, 0.0, 0.0]))
        value = c.get("value")
        shown = "—" if value is None else num.characteristic(value, c.get("type") in SIZES)
        anchors.setdefault(a, []).append((f"{lab['id']}: {shown}, {verdict}", verdict))
    for a, flags in anchors.items():  # a feature's characteristics share one flag, the worst verdict its colour
        worst = min((v for _, v in flags), key=lambda v: WORST.index(v) if v in WORST else len(WORST))
        text = "<br>".join(t for t, _ in flags)
        data.append({
            "type": "scatter3d", "mode": "markers+text", "name": text, "x": [a[0]], "y": [a[1]], "z": [a[2]],
            "text": [text], "textposition": "top center", "textfont": {"color": "#212121", "size": 11},
            "marker": {"size": 7, "color": VERDICT_COLOURS.get(worst, "#9e9e9e"), "symbol": "diamond"},
        })  # fmt: skip
    lay = layout(f"{part}: its characteristics' labels", "", "", legend=None)
    lay["scene"] = {
        "aspectmode": "data",
        "xaxis": {"title": "x mm"},
        "yaxis": {"title": "y mm"},
        "zaxis": {"title": "z mm"},
    }
    lay["margin"] = {"l": 0, "r": 0, "t": 36, "b": 0}
    return {"data": data, "layout": lay}
