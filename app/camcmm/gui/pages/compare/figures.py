"""The plotly figures of the "Compare with CAD" page: the histogram, the
Abbott-Firestone curve, a section, and an empty placeholder.

Each builds a plotly figure (as plain JSON for trame-plotly) from numbers the inspection
plugin returned (histogram bins, the material-ratio curve and its construction, a
section); nothing here computes them. Lengths come in mm; ``unit`` only chooses how
they are drawn.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from .... import numbers as num
from .tables import COLOURMAP, diverging_colours, fmt_len, interval_text


def _sig(x: float, digits: int) -> str:
    """``digits`` significant digits, never an exponent, a real minus (camcmm.numbers)."""
    return num.significant(x, digits)


def _hex_colours(values: np.ndarray, limit: float) -> list[str]:
    return ["#{:02x}{:02x}{:02x}".format(*c) for c in diverging_colours(values, limit)]


def _fig_json(fig: Any) -> dict[str, Any]:
    """A plotly figure as plain JSON (what the trame-plotly component binds to)."""
    import plotly.io as pio

    return json.loads(pio.to_json(fig, validate=True, engine="json"))


# The charts' top margin in two bands: the title at the top, the notes about the plot (the 95 %
# interval's text, the Abbott-Firestone parameters) in a band of their own just above the plot.
# Inside the plot or in the title's band they collided at 1366 px (issue 30): with the title when
# the interval lay left, with each other when it lay high.
TITLE_BAND = 24  # px
NOTE_LINE = 14  # px per line of a note (10 px font)


def _base_layout(title: str, xtitle: str, ytitle: str, note_lines: int = 0) -> dict[str, Any]:
    """The charts' common layout; ``note_lines`` lines of notes get a band above the plot."""
    top = TITLE_BAND + NOTE_LINE * note_lines + (4 if note_lines else 10)
    return {
        "title": {
            "text": title,
            "font": {"size": 13},
            "x": 0.02,
            "xanchor": "left",
            "yref": "container",
            "y": 1.0,
            "yanchor": "top",
            "pad": {"t": 6},
        },
        "margin": {"l": 56, "r": 14, "t": top, "b": 40},
        "xaxis": {"title": {"text": xtitle}, "zeroline": False},
        "yaxis": {"title": {"text": ytitle}, "zeroline": False},
        "showlegend": False,
        "paper_bgcolor": "white",
        "plot_bgcolor": "white",
        "hovermode": "closest",
        "font": {"family": "Roboto, DejaVu Sans, sans-serif", "size": 11},
    }


def _scale(unit: str) -> float:
    """The factor from mm to ``unit`` (µm or mm)."""
    return 1e3 if unit == "µm" else 1.0


def histogram_figure(
    hist: dict[str, Any], stats: dict[str, Any], unit: str, limit: float, tolerance: float | None = None
) -> dict[str, Any]:
    """Bars of the deviation histogram (coloured as the colour map), the 95 % interval
    shaded, ±tolerance as dashed lines; hover: the bin's range, count and share."""
    import plotly.graph_objects as go

    fig = go.Figure(_histogram_bars(hist, unit, limit))
    layout = _base_layout("Histogram of the deviations", f"deviation [{unit}]", "points", note_lines=1)
    shapes, notes = _histogram_interval(stats, unit)
    if tolerance:
        _histogram_tolerance(shapes, notes, tolerance, unit)
    layout.update({"shapes": shapes, "annotations": notes, "bargap": 0})
    fig.update_layout(**layout)
    return _fig_json(fig)


def _histogram_bars(hist: dict[str, Any], unit: str, limit: float) -> Any:
    """The histogram's bars, coloured as the colour map; hover: the bin's range, count and share."""
    import plotly.graph_objects as go

    f = _scale(unit)
    edges = np.asarray(hist["edges"], dtype=float)
    counts = np.asarray(hist["counts"], dtype=float)
    centres = 0.5 * (edges[1:] + edges[:-1])
    total = max(counts.sum(), 1.0)
    custom = np.column_stack([edges[:-1] * f, edges[1:] * f, 100.0 * counts / total])
    return go.Bar(
        x=(centres * f).tolist(),
        y=counts.tolist(),
        width=(np.diff(edges) * f).tolist(),
        marker={"color": _hex_colours(centres, limit), "line": {"width": 0}},
        customdata=custom.tolist(),
        hovertemplate=f"%{{customdata[0]:.4r}} … %{{customdata[1]:.4r}} {unit}<br>%{{y:,}} points "
        "(%{customdata[2]:.2f} %)<extra></extra>",
        name="deviations",
    )


def _histogram_interval(stats: dict[str, Any], unit: str) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The 95 % interval on the histogram: shaded, its bounds dotted, its text above (shapes, notes)."""
    f = _scale(unit)
    lo, hi = float(stats["p2_5"]) * f, float(stats["p97_5"]) * f
    shapes: list[dict[str, Any]] = [
        {
            "type": "rect",
            "xref": "x",
            "yref": "paper",
            "x0": lo,
            "x1": hi,
            "y0": 0,
            "y1": 1,
            "fillcolor": "rgba(46,125,50,0.10)",
            "line": {"width": 0},
            "layer": "below",
        }
    ]
    for x in (lo, hi):
        shapes.append(
            {
                "type": "line",
                "xref": "x",
                "yref": "paper",
                "x0": x,
                "x1": x,
                "y0": 0,
                "y1": 1,
                "line": {"color": "#2e7d32", "width": 1, "dash": "dot"},
            }
        )
    notes = [
        {
            "x": 0.5 * (lo + hi),
            "y": 1.0,
            "xref": "x",
            "yref": "paper",
            "yanchor": "bottom",
            "yshift": 2,
            "showarrow": False,
            "text": f"95 %: {interval_text(stats, unit)}",
            "font": {"size": 10, "color": "#2e7d32"},
        }
    ]
    return shapes, notes


def _histogram_tolerance(
    shapes: list[dict[str, Any]], notes: list[dict[str, Any]], tolerance: float, unit: str
) -> None:
    """±tolerance as dashed vertical lines, "±tolerance" written at the upper one (appended)."""
    f = _scale(unit)
    for s in (-1, 1):
        x = s * float(tolerance) * f
        shapes.append(
            {
                "type": "line",
                "xref": "x",
                "yref": "paper",
                "x0": x,
                "x1": x,
                "y0": 0,
                "y1": 0.92,
                "line": {"color": "#c62828", "width": 1.5, "dash": "dash"},
            }
        )
    notes.append(
        {
            "x": float(tolerance) * f,
            "y": 0.92,
            "xref": "x",
            "yref": "paper",
            "xanchor": "left",
            "showarrow": False,
            "text": f" ±{fmt_len(tolerance, unit)}",
            "font": {"size": 10, "color": "#c62828"},
        }
    )


def material_ratio_figure(
    mr: dict[str, Any], stats: dict[str, Any], unit: str, tolerance: float | None = None
) -> dict[str, Any]:
    """The Abbott-Firestone curve (material ratio % on x, deviation on y) with the
    ISO 13565-2 construction: the 40 % secant of least gradient, the equivalent
    straight line to 0 and 100 %, C1/C2 with Smr1/Smr2, the Spk and Svk triangles;
    the 95 % interval shaded and ±tolerance dashed. Hover gives the values."""
    import plotly.graph_objects as go

    f = _scale(unit)
    y = np.asarray(mr["curve"]["height"], dtype=float) * f
    C1, C2 = float(mr["C1"]) * f, float(mr["C2"]) * f
    spk, svk = float(mr["Spk"]) * f, float(mr["Svk"]) * f
    fig = go.Figure(_mr_construction(mr, unit) + _mr_curve(mr, unit))
    layout = _base_layout("Abbott-Firestone curve", "material ratio [%]", f"deviation [{unit}]", note_lines=3)
    shapes, notes = _mr_notes(mr, stats, unit)
    if tolerance:
        _mr_tolerance(shapes, notes, tolerance, unit)
    layout["xaxis"]["range"] = [0, 100]
    pad = 0.06 * ((y.max() - y.min()) or 1.0)
    layout["yaxis"]["range"] = [min(float(y.min()), C2 - svk) - pad, max(float(y.max()), C1 + spk) + pad]
    layout.update({"shapes": shapes, "annotations": notes})
    fig.update_layout(**layout)
    return _fig_json(fig)


def _mr_construction(mr: dict[str, Any], unit: str) -> list[Any]:
    """The Spk and Svk triangles and the equivalent straight line from C1 at 0 % to C2 at 100 %."""
    import plotly.graph_objects as go

    f, u = _scale(unit), unit
    C1, C2 = float(mr["C1"]) * f, float(mr["C2"]) * f
    s1, s2 = float(mr["Smr1"]), float(mr["Smr2"])
    spk, svk = float(mr["Spk"]) * f, float(mr["Svk"]) * f
    return [
        go.Scatter(
            x=[0, s1, s1, 0, 0],
            y=[C1, C1, C1, C1 + spk, C1],
            mode="lines",
            fill="toself",
            fillcolor="rgba(198,40,40,0.12)",
            line={"color": "#c62828", "width": 1},
            name="Spk triangle",
            hovertemplate=f"Spk {_sig(spk, 4)} {u} (equal area of the peaks above C1)<extra></extra>",
        ),
        go.Scatter(
            x=[100, s2, s2, 100, 100],
            y=[C2, C2, C2, C2 - svk, C2],
            mode="lines",
            fill="toself",
            fillcolor="rgba(21,101,192,0.12)",
            line={"color": "#1565c0", "width": 1},
            name="Svk triangle",
            hovertemplate=f"Svk {_sig(svk, 4)} {u} (equal area of the valleys below C2)<extra></extra>",
        ),
        go.Scatter(
            x=[0, 100],
            y=[C1, C2],
            mode="lines",
            line={"color": "#6a1b9a", "width": 1, "dash": "dash"},
            name="equivalent straight line",
            hovertemplate=(
                f"equivalent straight line: C1 {_sig(C1, 4)} {u} at 0 %, C2 {_sig(C2, 4)} {u} at 100 %<extra></extra>"
            ),
        ),
    ]


def _mr_curve(mr: dict[str, Any], unit: str) -> list[Any]:
    """C1/Smr1 and C2/Smr2 dotted, the material-ratio curve, and its 40 % secant of least gradient."""
    import plotly.graph_objects as go

    f, u = _scale(unit), unit
    x = np.asarray(mr["curve"]["mr_percent"], dtype=float)
    y = np.asarray(mr["curve"]["height"], dtype=float) * f
    a, b = float(mr["secant_start"]), float(mr["secant_end"])
    ya, yb = np.interp([a, b], x, y)
    traces = [
        go.Scatter(
            x=[0, s, s],
            y=[c, c, float(y.min())],
            mode="lines",
            line={"color": "#555", "width": 1, "dash": "dot"},
            name=f"{cn}, {sn}",
            hovertemplate=f"{cn} {_sig(c, 4)} {u}, {sn} {s:.2f} %<extra></extra>",
        )
        for cn, sn, c, s in (
            ("C1", "Smr1", float(mr["C1"]) * f, float(mr["Smr1"])),
            ("C2", "Smr2", float(mr["C2"]) * f, float(mr["Smr2"])),
        )
    ]
    return traces + [
        go.Scatter(
            x=x.tolist(),
            y=y.tolist(),
            mode="lines",
            line={"color": "#111", "width": 2},
            name="material-ratio curve",
            hovertemplate=f"material ratio %{{x:.1f}} %<br>deviation %{{y:.4r}} {u}<extra></extra>",
        ),
        go.Scatter(
            x=[a, b],
            y=[float(ya), float(yb)],
            mode="lines",
            line={"color": "#6a1b9a", "width": 4},
            name="40 % secant of least gradient",
            hovertemplate=f"40 % secant of least gradient: {a:.1f} … {b:.1f} %"
            f"<br>Sk {_sig(float(mr['Sk']) * f, 4)} {u}"
            "<extra></extra>",
        ),
    ]


def _mr_notes(
    mr: dict[str, Any], stats: dict[str, Any], unit: str
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The 95 % interval shaded with its text, and the box of Sk, Spk, Svk, Smr1, Smr2 (shapes, notes)."""
    f, u = _scale(unit), unit
    lo, hi = float(stats["p2_5"]) * f, float(stats["p97_5"]) * f
    shapes = [
        {
            "type": "rect",
            "xref": "paper",
            "yref": "y",
            "x0": 0,
            "x1": 1,
            "y0": lo,
            "y1": hi,
            "fillcolor": "rgba(46,125,50,0.10)",
            "line": {"width": 0},
            "layer": "below",
        }
    ]
    # above the plot (see TITLE_BAND): the parameters' two lines, then the interval's line
    notes = [
        {
            "x": 1.0,
            "y": 1.0,
            "xref": "paper",
            "yref": "paper",
            "xanchor": "right",
            "yanchor": "bottom",
            "yshift": 2,
            "showarrow": False,
            "text": f"95 % within {interval_text(stats, unit)}",
            "font": {"size": 10, "color": "#2e7d32"},
        },
        {
            "x": 1.0,
            "y": 1.0,
            "xref": "paper",
            "yref": "paper",
            "xanchor": "right",
            "yanchor": "bottom",
            "yshift": 2 + NOTE_LINE,
            "showarrow": False,
            "align": "right",
            "font": {"size": 10},
            "text": (
                f"Sk {_sig(float(mr['Sk']) * f, 3)} {u} · Spk {_sig(float(mr['Spk']) * f, 3)} {u} · "
                f"Svk {_sig(float(mr['Svk']) * f, 3)} {u}"
                f"<br>Smr1 {float(mr['Smr1']):.2f} % · Smr2 {float(mr['Smr2']):.2f} %"
            ),
        },
    ]
    return shapes, notes


def _mr_tolerance(shapes: list[dict[str, Any]], notes: list[dict[str, Any]], tolerance: float, unit: str) -> None:
    """±tolerance as dashed horizontal lines, "+tolerance" written at the upper one (appended)."""
    f = _scale(unit)
    for s in (-1, 1):
        yv = s * float(tolerance) * f
        shapes.append(
            {
                "type": "line",
                "xref": "paper",
                "yref": "y",
                "x0": 0,
                "x1": 1,
                "y0": yv,
                "y1": yv,
                "line": {"color": "#c62828", "width": 1.5, "dash": "dash"},
            }
        )
    notes.append(
        {
            "x": 0.01,
            "y": float(tolerance) * f,
            "xref": "paper",
            "yref": "y",
            "xanchor": "left",
            "yanchor": "bottom",
            "showarrow": False,
            "text": f"+{fmt_len(tolerance, unit)}",
            "font": {"size": 10, "color": "#c62828"},
        }
    )


def empty_figure(text: str = "") -> dict[str, Any]:
    return {
        "data": [],
        "layout": {
            "xaxis": {"visible": False},
            "yaxis": {"visible": False},
            "margin": {"l": 10, "r": 10, "t": 10, "b": 10},
            "annotations": [{"text": text, "showarrow": False, "xref": "paper", "yref": "paper", "x": 0.5, "y": 0.5}]
            if text
            else [],
        },
    }


def section_figure(sec: dict[str, Any], unit: str, limit: float) -> dict[str, Any]:
    """The section as a 2-D chart (equal axes, mm): the nominal in black, the
    measured points coloured by deviation on the colour map's scale."""
    import plotly.graph_objects as go

    whiskers = _section_whiskers(sec, unit, limit)
    traces = (whiskers or _section_measured(sec, unit, limit)) + _section_nominal(sec)
    fig = go.Figure(traces)
    fig.update_layout(**_section_layout(sec, bool(traces)))
    return _fig_json(fig)


def _section_measured(sec: dict[str, Any], unit: str, limit: float) -> list[Any]:
    """The measured points in the slab, coloured by deviation on the colour map's scale (none if empty)."""
    import plotly.graph_objects as go

    m = sec["measured"]
    if not len(m):
        return []
    f = _scale(unit)
    dev = np.asarray(sec["deviation"], dtype=float) * f
    lim = float(limit) * f
    return [
        go.Scatter(
            x=m[:, 0].tolist(),
            y=m[:, 1].tolist(),
            mode="markers",
            name="measured",
            marker={
                "color": np.nan_to_num(dev).tolist(),
                "colorscale": COLOURMAP,
                "cmin": -lim,
                "cmax": lim,
                "size": 4,
                "line": {"width": 0},
                "colorbar": {"title": {"text": f"[{unit}]", "side": "top"}, "thickness": 10, "len": 0.9},
            },
            customdata=np.nan_to_num(dev).tolist(),
            hovertemplate=(
                f"measured<br>{sec['u']} %{{x:.4f}} mm, {sec['v']} %{{y:.4f}} mm"
                f"<br>deviation %{{customdata:.4r}} {unit}<extra></extra>"
            ),
        )
    ]


def whisker_gain(sec: dict[str, Any], limit: float) -> float:
    """The drawing scale of the deviation whiskers: the colour limit (mm) drawn as a tenth
    of the outline's extent (presentation only, stated in the legend)."""
    lines = sec.get("nominal") or []
    if not lines:
        return 0.0
    P = np.concatenate([np.asarray(pl, dtype=float) for pl in lines])
    extent = float(np.ptp(P, axis=0).max()) if len(P) else 0.0
    return 0.1 * extent / float(limit) if limit and limit > 0 and extent > 0 else 0.0


def _section_whiskers(sec: dict[str, Any], unit: str, limit: float) -> list[Any]:
    """Deviation whiskers along the nominal outline: from each measured point's foot on
    the cut, along the outline's normal, deviation × gain long (red outward, blue
    inward), the tip coloured by the deviation. None without the plugin's feet."""
    import plotly.graph_objects as go

    foot = np.asarray(sec.get("foot", np.zeros((0, 2))), dtype=float)
    m = np.asarray(sec["measured"], dtype=float)
    gain = whisker_gain(sec, limit)
    if not len(foot) or len(foot) != len(m) or gain <= 0:
        return []
    dev = np.nan_to_num(np.asarray(sec["deviation"], dtype=float))
    tip = foot + gain * dev[:, None] * np.asarray(sec["normal"], dtype=float)
    f = _scale(unit)
    traces = []
    for name, sel, colour in (("above", dev > 0, "#c62828"), ("below", dev < 0, "#1565c0")):
        xs: list[float | None] = []
        ys: list[float | None] = []
        for a, b in zip(foot[sel], tip[sel]):
            xs += [float(a[0]), float(b[0]), None]
            ys += [float(a[1]), float(b[1]), None]
        traces.append(
            go.Scatter(
                x=xs, y=ys, mode="lines", line={"color": colour, "width": 1}, name=f"whiskers {name}", hoverinfo="skip"
            )
        )
    traces.append(
        go.Scatter(
            x=tip[:, 0].tolist(),
            y=tip[:, 1].tolist(),
            mode="markers",
            name=f"deviation × {_sig(gain, 3)}",
            marker={
                "color": (dev * f).tolist(),
                "colorscale": COLOURMAP,
                "cmin": -float(limit) * f,
                "cmax": float(limit) * f,
                "size": 3,
                "line": {"width": 0},
                "colorbar": {"title": {"text": f"[{unit}]", "side": "top"}, "thickness": 10, "len": 0.9},
            },
            customdata=np.column_stack([dev * f, m]).tolist(),
            hovertemplate=(
                f"measured {sec['u']} %{{customdata[1]:.4f}} mm, {sec['v']} %{{customdata[2]:.4f}} mm"
                f"<br>deviation %{{customdata[0]:.4r}} {unit}<extra></extra>"
            ),
        )
    )
    return traces


def _section_nominal(sec: dict[str, Any]) -> list[Any]:
    """The nominal: its points (a reference cloud) and its cut polylines (a mesh), in black."""
    import plotly.graph_objects as go

    traces = []
    if len(sec["nominal_points"]):
        q = sec["nominal_points"]
        traces.append(
            go.Scatter(
                x=q[:, 0].tolist(),
                y=q[:, 1].tolist(),
                mode="markers",
                name="nominal",
                marker={"color": "#424242", "size": 2},
                hovertemplate="nominal point<extra></extra>",
            )
        )
    if sec["nominal"]:
        xs: list[float | None] = []
        ys: list[float | None] = []
        for pl in sec["nominal"]:
            xs += pl[:, 0].tolist() + [None]
            ys += pl[:, 1].tolist() + [None]
        traces.append(
            go.Scatter(
                x=xs,
                y=ys,
                mode="lines",
                line={"color": "#212121", "width": 1.2},
                name="nominal",
                hovertemplate=(f"nominal<br>{sec['u']} %{{x:.4f}} mm, {sec['v']} %{{y:.4f}} mm<extra></extra>"),
            )
        )
    return traces


def _section_layout(sec: dict[str, Any], drawn: bool) -> dict[str, Any]:
    """The section's title and equal axes; "the plane misses the part" when nothing is ``drawn``."""
    title = (
        f"Section {sec['axis']} = {sec['position']:.3f} mm — {sec['n_in_slab']:,} measured points within "
        f"±{fmt_len(sec['half_width'], 'mm')}"
    ).replace(",", " ")
    layout = _base_layout(title, f"{sec['u']} [mm]", f"{sec['v']} [mm]")
    layout["yaxis"].update({"scaleanchor": "x", "scaleratio": 1})
    layout["title"]["font"] = {"size": 11}
    if not drawn:
        layout["annotations"] = [
            {
                "text": "the plane misses the part",
                "showarrow": False,
                "xref": "paper",
                "yref": "paper",
                "x": 0.5,
                "y": 0.5,
            }
        ]
    return layout
