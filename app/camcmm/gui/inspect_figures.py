"""Numbers and charts of the "Compare with CAD" page: lengths in the unit that reads
well, tolerance bands and their colours, the statistics and alignment tables, and the
plotly figures (histogram, Abbott-Firestone curve, section, empty).

Plain functions on numpy arrays and dicts (the plugin's outputs); nothing here touches
trame, VTK or the project, so each can be tested alone. Lengths come in mm; ``unit``
("mm" or "µm", from :func:`display_unit`) only chooses how they are written.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from .view import fmt_count

MINUS = "\u2212"  # a real minus sign: "-" reads as a hyphen next to µm
#: Tolerance bands: code -> (key, colour). NaN deviations get code 2 (grey).
BANDS = {-1: ("below", "#2166ac"), 0: ("within", "#1a9850"), 1: ("above", "#d7301f"), 2: ("invalid", "#9e9e9e")}
COLOURMAP = "RdBu_r"  # the plugin's and the report's diverging scale (blue below, red above)


# =============================================================================== units
def display_unit(limit_mm: Any) -> tuple[str, float]:
    """The unit numbers of this size read well in, and the factor mm -> unit: below
    0.1 mm µm (0.05 mm reads 50 µm), else mm (the report's rule)."""
    try:
        a = abs(float(limit_mm))
    except (TypeError, ValueError):
        a = 0.0
    if math.isfinite(a) and 0 < a < 0.1:
        return "µm", 1e3
    return "mm", 1.0


def _num(v: float, digits: int = 3, signed: bool = False) -> str:
    """``v`` with ``digits`` significant digits, never in exponent notation; a real
    minus sign."""
    if v is None or not math.isfinite(v):
        return "—"
    if v == 0:
        decimals = max(digits - 1, 0)
    else:
        decimals = min(max(digits - 1 - int(math.floor(math.log10(abs(v)))), 0), 9)
    text = f"{v:+.{decimals}f}" if signed else f"{v:.{decimals}f}"
    return text.replace("-", MINUS)


def fmt_len(x_mm: Any, unit: str = "mm", signed: bool = False, digits: int = 3) -> str:
    """A length given in mm, written in ``unit`` (mm or µm): ``"+24.1 µm"``."""
    try:
        x = float(x_mm)
    except (TypeError, ValueError):
        return "—"
    if not math.isfinite(x):
        return "—"
    f = 1e3 if unit == "µm" else 1.0
    return f"{_num(x * f, digits, signed)} {unit}"


def interval_text(stats: dict[str, Any], unit: str) -> str:
    """The central 95 % of the deviations as the thesis writes it: ``"+24 µm / −33 µm"``
    (upper bound first)."""
    return f"{fmt_len(stats.get('p97_5'), unit, True)} / {fmt_len(stats.get('p2_5'), unit, True)}"


def legend_title(unit: str) -> str:
    return f"deviation [{unit}]"


def nice_ticks(limit: float, n: int = 5) -> list[float]:
    """Round tick values on a symmetric scale ±limit, 0 among them, at least ``n`` of
    them with the largest round step (1, 2, 2.5, 5 × 10^k): 19.7 gives −15 … 15 in steps
    of 5, not −19.7, −9.83, 0 …"""
    lim = abs(float(limit))
    if not math.isfinite(lim) or lim == 0:
        return [0.0]
    e0 = math.floor(math.log10(lim))
    steps = sorted((m * 10.0 ** e for e in range(e0 - 2, e0 + 1) for m in (1.0, 2.0, 2.5, 5.0)), reverse=True)
    for step in steps:
        k = math.floor(lim / step + 1e-9)
        if 2 * k + 1 >= n:
            return [round(i * step, 12) for i in range(-k, k + 1)]
    return [0.0]


# =============================================================================== bands
def band_codes(dev: Any, tolerance: float) -> np.ndarray:
    """Per point: -1 below −tolerance, 0 within ±tolerance (inclusive, as the
    statistics count it), +1 above, 2 not a number."""
    d = np.asarray(dev, dtype=float)
    t = abs(float(tolerance))
    codes = np.zeros(d.shape, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        codes[d > t] = 1
        codes[d < -t] = -1
    codes[~np.isfinite(d)] = 2
    return codes


def band_counts(dev: Any, tolerance: float) -> dict[str, int]:
    """Points below, within and above ±tolerance (and not a number)."""
    codes = band_codes(dev, tolerance)
    n = np.bincount((codes + 1).astype(np.intp), minlength=4)
    return {"below": int(n[0]), "within": int(n[1]), "above": int(n[2]), "invalid": int(n[3])}


def band_legend(counts: dict[str, int], tolerance: float, unit: str) -> list[dict[str, Any]]:
    """Legend rows ``{key, label, colour, count, percent}`` for the tolerance bands."""
    total = max(sum(counts.values()), 1)
    t = fmt_len(tolerance, unit)
    labels = {"above": f"above +{t}", "within": f"within ±{t}", "below": f"below {MINUS}{t}",
              "invalid": "no deviation (NaN)"}
    rows = []
    for code in (1, 0, -1, 2):
        key, colour = BANDS[code]
        if key == "invalid" and not counts.get(key):
            continue
        c = int(counts.get(key, 0))
        rows.append({"key": key, "label": labels[key], "colour": colour, "count": c,
                     "percent": round(100.0 * c / total, 2), "text": f"{labels[key]}: {100.0 * c / total:.1f} %"})
    return rows


def _hex_to_rgb(h: str) -> list[int]:
    h = h.lstrip("#")
    return [int(h[i:i + 2], 16) for i in (0, 2, 4)]


def band_colours(codes: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 colours of the band codes."""
    lut = np.zeros((4, 3), dtype=np.uint8)
    for code, (_, colour) in BANDS.items():
        lut[code + 1] = _hex_to_rgb(colour)
    return lut[(np.asarray(codes) + 1).astype(np.intp)]


def diverging_colours(dev: Any, limit: float) -> np.ndarray:
    """(N, 3) uint8 colours of the deviations on the diverging map over ±limit."""
    from matplotlib import colormaps

    lim = float(limit) if limit and limit > 0 else 1.0
    u = np.clip(0.5 + 0.5 * np.nan_to_num(np.asarray(dev, dtype=float)) / lim, 0.0, 1.0)
    return np.round(colormaps[COLOURMAP](u)[:, :3] * 255).astype(np.uint8)


def _hex_colours(values: np.ndarray, limit: float) -> list[str]:
    return ["#%02x%02x%02x" % tuple(c) for c in diverging_colours(values, limit)]


# =============================================================================== tables
def stats_rows(outputs: dict[str, Any], unit: str, tolerance: float | None = None,
               dev: np.ndarray | None = None) -> list[dict[str, str]]:
    """The statistics table: ``{key, name, value}`` rows in ``unit``. With a
    ``tolerance`` (and the deviations) the share within it is counted here, so it
    follows the tolerance field after the run."""
    st = outputs.get("stats") or {}
    rows = [{"key": "n", "name": "points", "value": fmt_count(st.get("n", 0))}]
    for key, name, signed in (("mean", "mean", True), ("std", "std dev", False),
                              ("rms", "rms", False), ("min", "min", True), ("max", "max", True),
                              ("p2_5", "p2.5", True), ("p97_5", "p97.5", True)):
        rows.append({"key": key, "name": name, "value": fmt_len(st.get(key), unit, signed)})
    rows.append({"key": "interval95", "name": "95 % within", "value": interval_text(st, unit)})
    if tolerance is not None and tolerance > 0:
        if dev is not None:
            c = band_counts(dev, tolerance)
            total = max(sum(c.values()) - c["invalid"], 1)
            share = c["within"] / total
        else:
            share = st.get("within_tolerance")
        if share is not None:
            rows.append({"key": "within", "name": f"within ±{fmt_len(tolerance, unit)}",
                         "value": f"{100.0 * float(share):.2f} %"})
    cov = outputs.get("coverage_info") or {}
    if outputs.get("coverage") is not None:
        rows.append({"key": "coverage", "name": "coverage (area)", "value": f"{100.0 * float(outputs['coverage']):.2f} %"})
        if cov.get("distance"):
            rows.append({"key": "coverage_distance", "name": "covered: a point within", "value": fmt_len(cov["distance"], "mm")})
    return rows


def alignment_rows(outputs: dict[str, Any], unit: str) -> list[dict[str, str]]:
    """The alignment: method, converged (with the reason), rms, scale, rotation,
    translation, overlap."""
    a = outputs.get("alignment") or {}
    conv = bool(outputs.get("converged", a.get("converged")))
    reason = outputs.get("reason", a.get("reason")) or ""
    rows = [{"key": "method", "name": "method", "value": str(a.get("method", ""))},
            {"key": "converged", "name": "converged",
             "value": ("yes" if conv else "NO") + (f" — {reason}" if reason else "")},
            {"key": "rms", "name": "rms", "value": fmt_len(outputs.get("rms", a.get("rms")), unit)}]
    scale = outputs.get("scale", a.get("scale"))
    if scale is not None:
        rows.append({"key": "scale", "name": "scale", "value": f"{float(scale):.8f}"})
    if a.get("rotation_angle_deg") is not None:
        rows.append({"key": "rotation", "name": "rotation", "value": f"{float(a['rotation_angle_deg']):.4f}°"})
    t = outputs.get("translation", a.get("translation"))
    if t is not None:
        rows.append({"key": "translation", "name": "translation",
                     "value": "(" + ", ".join(_num(float(x), 4) for x in np.asarray(t, float).ravel()) + ") mm"})
    ov = outputs.get("overlap", a.get("overlap"))
    if ov is not None and isinstance(ov, (int, float)) and math.isfinite(ov):
        rows.append({"key": "overlap", "name": "overlap", "value": f"{100.0 * float(ov):.1f} %"})
    return rows


# =============================================================================== figures
def _fig_json(fig: Any) -> dict[str, Any]:
    """A plotly figure as plain JSON (what the trame-plotly component binds to)."""
    import plotly.io as pio

    return json.loads(pio.to_json(fig, validate=True, engine="json"))


def _base_layout(title: str, xtitle: str, ytitle: str) -> dict[str, Any]:
    return {"title": {"text": title, "font": {"size": 13}, "x": 0.02, "xanchor": "left"},
            "margin": {"l": 56, "r": 14, "t": 34, "b": 40}, "xaxis": {"title": {"text": xtitle}, "zeroline": False},
            "yaxis": {"title": {"text": ytitle}, "zeroline": False}, "showlegend": False,
            "paper_bgcolor": "white", "plot_bgcolor": "white", "hovermode": "closest",
            "font": {"family": "Roboto, DejaVu Sans, sans-serif", "size": 11}}


def histogram_figure(hist: dict[str, Any], stats: dict[str, Any], unit: str, limit: float,
                     tolerance: float | None = None) -> dict[str, Any]:
    """Bars of the deviation histogram (coloured as the colour map), the 95 % interval
    shaded, ±tolerance as dashed lines; hover: the bin's range, count and share."""
    import plotly.graph_objects as go

    f = 1e3 if unit == "µm" else 1.0
    edges = np.asarray(hist["edges"], dtype=float)
    counts = np.asarray(hist["counts"], dtype=float)
    centres = 0.5 * (edges[1:] + edges[:-1])
    total = max(counts.sum(), 1.0)
    custom = np.column_stack([edges[:-1] * f, edges[1:] * f, 100.0 * counts / total])
    fig = go.Figure(go.Bar(
        x=(centres * f).tolist(), y=counts.tolist(), width=(np.diff(edges) * f).tolist(),
        marker={"color": _hex_colours(centres, limit), "line": {"width": 0}}, customdata=custom.tolist(),
        hovertemplate=f"%{{customdata[0]:.4g}} … %{{customdata[1]:.4g}} {unit}<br>%{{y:,}} points "
                      "(%{customdata[2]:.2f} %)<extra></extra>", name="deviations"))
    layout = _base_layout("Histogram of the deviations", f"deviation [{unit}]", "points")
    lo, hi = float(stats["p2_5"]) * f, float(stats["p97_5"]) * f
    shapes = [{"type": "rect", "xref": "x", "yref": "paper", "x0": lo, "x1": hi, "y0": 0, "y1": 1,
               "fillcolor": "rgba(46,125,50,0.10)", "line": {"width": 0}, "layer": "below"},
              {"type": "line", "xref": "x", "yref": "paper", "x0": lo, "x1": lo, "y0": 0, "y1": 1,
               "line": {"color": "#2e7d32", "width": 1, "dash": "dot"}},
              {"type": "line", "xref": "x", "yref": "paper", "x0": hi, "x1": hi, "y0": 0, "y1": 1,
               "line": {"color": "#2e7d32", "width": 1, "dash": "dot"}}]
    notes = [{"x": 0.5 * (lo + hi), "y": 1.0, "xref": "x", "yref": "paper", "yanchor": "bottom", "showarrow": False,
              "text": f"95 %: {interval_text(stats, unit)}", "font": {"size": 10, "color": "#2e7d32"}}]
    if tolerance:
        for s in (-1, 1):
            x = s * float(tolerance) * f
            shapes.append({"type": "line", "xref": "x", "yref": "paper", "x0": x, "x1": x, "y0": 0, "y1": 0.92,
                           "line": {"color": "#c62828", "width": 1.5, "dash": "dash"}})
        notes.append({"x": float(tolerance) * f, "y": 0.92, "xref": "x", "yref": "paper", "xanchor": "left",
                      "showarrow": False, "text": f" ±{fmt_len(tolerance, unit)}", "font": {"size": 10, "color": "#c62828"}})
    layout.update({"shapes": shapes, "annotations": notes, "bargap": 0})
    fig.update_layout(**layout)
    return _fig_json(fig)


def material_ratio_figure(mr: dict[str, Any], stats: dict[str, Any], unit: str,
                          tolerance: float | None = None) -> dict[str, Any]:
    """The Abbott-Firestone curve (material ratio % on x, deviation on y) with the
    ISO 13565-2 construction: the 40 % secant of least gradient, the equivalent
    straight line to 0 and 100 %, C1/C2 with Smr1/Smr2, the Spk and Svk triangles;
    the 95 % interval shaded and ±tolerance dashed. Hover gives the values."""
    import plotly.graph_objects as go

    f = 1e3 if unit == "µm" else 1.0
    x = np.asarray(mr["curve"]["mr_percent"], dtype=float)
    y = np.asarray(mr["curve"]["height"], dtype=float) * f
    C1, C2 = float(mr["C1"]) * f, float(mr["C2"]) * f
    s1, s2 = float(mr["Smr1"]), float(mr["Smr2"])
    spk, svk = float(mr["Spk"]) * f, float(mr["Svk"]) * f
    a, b = float(mr["secant_start"]), float(mr["secant_end"])
    ya, yb = np.interp([a, b], x, y)
    u = unit
    traces = [
        go.Scatter(x=[0, s1, s1, 0, 0], y=[C1, C1, C1, C1 + spk, C1], mode="lines", fill="toself",
                   fillcolor="rgba(198,40,40,0.12)", line={"color": "#c62828", "width": 1},
                   name="Spk triangle", hovertemplate=f"Spk {spk:.4g} {u} (equal area of the peaks above C1)<extra></extra>"),
        go.Scatter(x=[100, s2, s2, 100, 100], y=[C2, C2, C2, C2 - svk, C2], mode="lines", fill="toself",
                   fillcolor="rgba(21,101,192,0.12)", line={"color": "#1565c0", "width": 1},
                   name="Svk triangle", hovertemplate=f"Svk {svk:.4g} {u} (equal area of the valleys below C2)<extra></extra>"),
        go.Scatter(x=[0, 100], y=[C1, C2], mode="lines", line={"color": "#6a1b9a", "width": 1, "dash": "dash"},
                   name="equivalent straight line",
                   hovertemplate=f"equivalent straight line: C1 {C1:.4g} {u} at 0 %, C2 {C2:.4g} {u} at 100 %<extra></extra>"),
        go.Scatter(x=[0, s1, s1], y=[C1, C1, float(y.min())], mode="lines",
                   line={"color": "#555", "width": 1, "dash": "dot"}, name="C1, Smr1",
                   hovertemplate=f"C1 {C1:.4g} {u}, Smr1 {s1:.2f} %<extra></extra>"),
        go.Scatter(x=[0, s2, s2], y=[C2, C2, float(y.min())], mode="lines",
                   line={"color": "#555", "width": 1, "dash": "dot"}, name="C2, Smr2",
                   hovertemplate=f"C2 {C2:.4g} {u}, Smr2 {s2:.2f} %<extra></extra>"),
        go.Scatter(x=x.tolist(), y=y.tolist(), mode="lines", line={"color": "#111", "width": 2},
                   name="material-ratio curve",
                   hovertemplate=f"material ratio %{{x:.1f}} %<br>deviation %{{y:.4g}} {u}<extra></extra>"),
        go.Scatter(x=[a, b], y=[float(ya), float(yb)], mode="lines", line={"color": "#6a1b9a", "width": 4},
                   name="40 % secant of least gradient",
                   hovertemplate=f"40 % secant of least gradient: {a:.1f} … {b:.1f} %<br>Sk {float(mr['Sk']) * f:.4g} {u}"
                                 "<extra></extra>"),
    ]
    fig = go.Figure(traces)
    layout = _base_layout("Abbott-Firestone curve", "material ratio [%]", f"deviation [{unit}]")
    lo, hi = float(stats["p2_5"]) * f, float(stats["p97_5"]) * f
    shapes = [{"type": "rect", "xref": "paper", "yref": "y", "x0": 0, "x1": 1, "y0": lo, "y1": hi,
               "fillcolor": "rgba(46,125,50,0.10)", "line": {"width": 0}, "layer": "below"}]
    notes = [{"x": 50, "y": hi, "xref": "x", "yref": "y", "yanchor": "bottom", "showarrow": False,
              "text": f"95 % within {interval_text(stats, unit)}", "font": {"size": 10, "color": "#2e7d32"}},
             {"x": 0.99, "y": 0.98, "xref": "paper", "yref": "paper", "xanchor": "right", "yanchor": "top",
              "showarrow": False, "align": "right", "bgcolor": "rgba(255,255,255,0.85)", "bordercolor": "#ccc",
              "borderwidth": 1, "font": {"size": 10},
              "text": (f"Sk {float(mr['Sk']) * f:.3g} {u} · Spk {spk:.3g} {u} · Svk {svk:.3g} {u}"
                       f"<br>Smr1 {s1:.2f} % · Smr2 {s2:.2f} %")}]
    if tolerance:
        for s in (-1, 1):
            yv = s * float(tolerance) * f
            shapes.append({"type": "line", "xref": "paper", "yref": "y", "x0": 0, "x1": 1, "y0": yv, "y1": yv,
                           "line": {"color": "#c62828", "width": 1.5, "dash": "dash"}})
        notes.append({"x": 0.01, "y": float(tolerance) * f, "xref": "paper", "yref": "y", "xanchor": "left",
                      "yanchor": "bottom", "showarrow": False, "text": f"+{fmt_len(tolerance, unit)}",
                      "font": {"size": 10, "color": "#c62828"}})
    layout["xaxis"]["range"] = [0, 100]
    pad = 0.06 * ((y.max() - y.min()) or 1.0)
    layout["yaxis"]["range"] = [min(float(y.min()), C2 - svk) - pad, max(float(y.max()), C1 + spk) + pad]
    layout.update({"shapes": shapes, "annotations": notes})
    fig.update_layout(**layout)
    return _fig_json(fig)


def empty_figure(text: str = "") -> dict[str, Any]:
    return {"data": [], "layout": {"xaxis": {"visible": False}, "yaxis": {"visible": False},
                                   "margin": {"l": 10, "r": 10, "t": 10, "b": 10},
                                   "annotations": [{"text": text, "showarrow": False, "xref": "paper",
                                                    "yref": "paper", "x": 0.5, "y": 0.5}] if text else []}}


def section_figure(sec: dict[str, Any], unit: str, limit: float) -> dict[str, Any]:
    """The section as a 2-D chart (equal axes, mm): the nominal in black, the
    measured points coloured by deviation on the colour map's scale."""
    import plotly.graph_objects as go

    f = 1e3 if unit == "µm" else 1.0
    traces = []
    m = sec["measured"]
    if len(m):
        dev = np.asarray(sec["deviation"], dtype=float) * f
        lim = float(limit) * f
        traces.append(go.Scatter(
            x=m[:, 0].tolist(), y=m[:, 1].tolist(), mode="markers", name="measured",
            marker={"color": np.nan_to_num(dev).tolist(), "colorscale": COLOURMAP, "cmin": -lim, "cmax": lim,
                    "size": 4, "line": {"width": 0},
                    "colorbar": {"title": {"text": f"[{unit}]", "side": "top"}, "thickness": 10, "len": 0.9}},
            customdata=np.nan_to_num(dev).tolist(),
            hovertemplate=(f"measured<br>{sec['u']} %{{x:.4f}} mm, {sec['v']} %{{y:.4f}} mm"
                           f"<br>deviation %{{customdata:.4g}} {unit}<extra></extra>")))
    if len(sec["nominal_points"]):
        q = sec["nominal_points"]
        traces.append(go.Scatter(x=q[:, 0].tolist(), y=q[:, 1].tolist(), mode="markers", name="nominal",
                                 marker={"color": "#424242", "size": 2},
                                 hovertemplate="nominal point<extra></extra>"))
    if sec["nominal"]:
        xs: list[float | None] = []
        ys: list[float | None] = []
        for pl in sec["nominal"]:
            xs += pl[:, 0].tolist() + [None]
            ys += pl[:, 1].tolist() + [None]
        traces.append(go.Scatter(x=xs, y=ys, mode="lines", line={"color": "#212121", "width": 1.2}, name="nominal",
                                 hovertemplate=f"nominal<br>{sec['u']} %{{x:.4f}} mm, {sec['v']} %{{y:.4f}} mm<extra></extra>"))
    fig = go.Figure(traces)
    title = (f"Section {sec['axis']} = {sec['position']:.3f} mm — {sec['n_in_slab']:,} measured points within "
             f"±{fmt_len(sec['half_width'], 'mm')}").replace(",", " ")
    layout = _base_layout(title, f"{sec['u']} [mm]", f"{sec['v']} [mm]")
    layout["yaxis"].update({"scaleanchor": "x", "scaleratio": 1})
    layout["title"]["font"] = {"size": 11}
    if not traces:
        layout["annotations"] = [{"text": "the plane misses the part", "showarrow": False, "xref": "paper",
                                  "yref": "paper", "x": 0.5, "y": 0.5}]
    fig.update_layout(**layout)
    return _fig_json(fig)
