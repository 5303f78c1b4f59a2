"""How the "Compare with CAD" page writes its numbers: deviations in µm (the number rule,
:mod:`camcmm.numbers`, as every page and the reports), the tolerance bands' legend and
colours, the statistics and alignment tables.

Presentation only, on the numbers the inspection plugin returned (its outputs, its band
counts): nothing here computes a statistic. Lengths come in mm; ``unit`` ("µm" from
:func:`display_unit`, or "mm" for a position) only chooses how they are written.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .... import numbers as num
from ...view import fmt_count

MINUS = num.MINUS  # a real minus sign: "-" reads as a hyphen next to µm
#: Tolerance bands: code -> (key, colour). NaN deviations get code 2 (grey).
BANDS = {-1: ("below", "#2166ac"), 0: ("within", "#1a9850"), 1: ("above", "#d7301f"), 2: ("invalid", "#9e9e9e")}
COLOURMAP = "RdBu_r"  # the plugin's and the report's diverging scale (blue below, red above)


# =============================================================================== units
def display_unit(limit_mm: Any = None) -> tuple[str, float]:
    """The unit deviations are written in and the factor mm -> unit: µm, whatever their
    size (the number rule: deviations in µm everywhere, so this page, the Series page and
    the reports agree). ``limit_mm`` is kept for the callers."""
    return num.MICRO, 1e3


def _num(v: float, digits: int = 3, signed: bool = False) -> str:
    """``v`` with ``digits`` significant digits, never in exponent notation; a real
    minus sign; ``0`` for a value that rounds to zero."""
    if v is None or not math.isfinite(v):
        return "—"
    text = num.plain(v, digits)
    return "+" + text if signed and text != "0" and not text.startswith(MINUS) else text


def fmt_len(x_mm: Any, unit: str = "mm", signed: bool = False, digits: int = 3) -> str:
    """A length given in mm, written in ``unit`` by the number rule (:func:`camcmm.numbers.length`:
    µm to 0.01 µm and three significant digits, mm to 0.1 µm): ``"+24.1 µm"``. ``digits``
    is kept for the callers."""
    if not num.finite(x_mm):
        return "—"
    return num.length(x_mm, unit=num.unit_text(unit) or "mm", signed=signed)


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
    steps = sorted((m * 10.0**e for e in range(e0 - 2, e0 + 1) for m in (1.0, 2.0, 2.5, 5.0)), reverse=True)
    for step in steps:
        k = math.floor(lim / step + 1e-9)
        if 2 * k + 1 >= n:
            return [round(i * step, 12) for i in range(-k, k + 1)]
    return [0.0]


# =============================================================================== bands
def band_legend(counts: dict[str, int], tolerance: float, unit: str) -> list[dict[str, Any]]:
    """Legend rows ``{key, label, colour, count, percent}`` for the tolerance bands."""
    total = max(sum(counts.values()), 1)
    t = fmt_len(tolerance, unit)
    labels = {
        "above": f"above +{t}",
        "within": f"within ±{t}",
        "below": f"below {MINUS}{t}",
        "invalid": "no deviation (NaN)",
    }
    rows = []
    for code in (1, 0, -1, 2):
        key, colour = BANDS[code]
        if key == "invalid" and not counts.get(key):
            continue
        c = int(counts.get(key, 0))
        rows.append(
            {
                "key": key,
                "label": labels[key],
                "colour": colour,
                "count": c,
                "percent": round(100.0 * c / total, 2),
                "text": f"{labels[key]}: {num.percent(c / total, 1)}",
            }
        )
    return rows


def _hex_to_rgb(h: str) -> list[int]:
    h = h.lstrip("#")
    return [int(h[i : i + 2], 16) for i in (0, 2, 4)]


def band_colours(codes: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 colours of the band codes (N,) the plugin gave (a colour lookup)."""
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


# =============================================================================== tables
def stats_rows(
    outputs: dict[str, Any], unit: str, tolerance: float | None = None, within: float | None = None
) -> list[dict[str, str]]:
    """The statistics table: ``{key, name, value}`` rows in ``unit``. With a
    ``tolerance``, the share ``within`` it (0..1, counted by the plugin's bands for the
    tolerance now in the field, else the run's own) is a row."""
    st = outputs.get("stats") or {}
    rows = [{"key": "n", "name": "points", "value": fmt_count(st.get("n", 0))}]
    for key, name, signed in (
        ("mean", "mean", True),
        ("std", "std dev", False),
        ("rms", "rms", False),
        ("min", "min", True),
        ("max", "max", True),
        ("p2_5", f"percentile {num.percentile_key('p2_5')}", True),
        ("p97_5", f"percentile {num.percentile_key('p97_5')}", True),
    ):
        rows.append({"key": key, "name": name, "value": fmt_len(st.get(key), unit, signed)})
    rows.append({"key": "interval95", "name": "95 % within", "value": interval_text(st, unit)})
    if tolerance is not None and tolerance > 0:
        share = within if within is not None else st.get("within_tolerance")
        if share is not None:
            rows.append(
                {
                    "key": "within",
                    "name": f"within ±{fmt_len(tolerance, unit)}",
                    "value": num.percent(float(share), 2),
                }
            )
    cov = outputs.get("coverage_info") or {}
    if outputs.get("coverage") is not None:
        rows.append({"key": "coverage", "name": "coverage (area)", "value": num.percent(float(outputs["coverage"]), 2)})
        if cov.get("distance"):
            rows.append(
                {"key": "coverage_distance", "name": "covered: a point within", "value": fmt_len(cov["distance"], "mm")}
            )
    return rows


def alignment_rows(outputs: dict[str, Any], unit: str) -> list[dict[str, str]]:
    """The alignment: method, converged (with the reason), rms, scale, rotation,
    translation, overlap."""
    a = outputs.get("alignment") or {}
    conv = bool(outputs.get("converged", a.get("converged")))
    reason = outputs.get("reason", a.get("reason")) or ""
    rows = [
        {"key": "method", "name": "method", "value": str(a.get("method", ""))},
        {
            "key": "converged",
            "name": "converged",
            "value": ("yes" if conv else "NO") + (f" — {reason}" if reason else ""),
        },
        {"key": "rms", "name": "rms", "value": fmt_len(outputs.get("rms", a.get("rms")), unit)},
    ]
    scale = outputs.get("scale", a.get("scale"))
    if scale is not None:
        rows.append({"key": "scale", "name": "scale", "value": f"{float(scale):.8f}"})
    if a.get("rotation_angle_deg") is not None:
        rows.append({"key": "rotation", "name": "rotation", "value": num.angle(a["rotation_angle_deg"], "deg")})
    t = outputs.get("translation", a.get("translation"))
    if t is not None:
        rows.append(
            {
                "key": "translation",
                "name": "translation",
                "value": num.vector(np.asarray(t, float).ravel()) + " mm",
            }
        )
    held = outputs.get("held_dofs", a.get("held_dofs")) or []
    if held:  # in words: what the part's symmetry left undetermined and the alignment held
        rows.append({"key": "held", "name": "held (symmetry)", "value": "; ".join(str(h) for h in held)})
    ov = outputs.get("overlap", a.get("overlap"))
    if ov is not None and isinstance(ov, (int, float)) and math.isfinite(ov):
        rows.append({"key": "overlap", "name": "overlap", "value": num.percent(float(ov), 1)})
    return rows
