"""A study's outputs as the page's tables ``{key, title, header, rows}`` (cells as text)
and key-value rows ``{name, label, value}``: table 6.3 and fig. 6.16's fit for the
light-field study, tables 6.1, 6.2 and the area coverage for the speckle study.
Values the run did not give are shown as "—", never made up."""

from __future__ import annotations

import math
import re
from typing import Any

from .... import numbers as num

DASH = "—"
CONDITIONS = (("off", "non-speckle"), ("on", "speckle"))
#: The study file's artefact and material keys (virtual lab, thesis ch. 6.2) as a person
#: writes them; the page imports no plugin, so the words are kept here (issue 30: no keys
#: on screen). Any other key reads with its underscores as spaces.
WORDS = {
    "am_pyramid": "AM pyramid",
    "am_recess": "AM recess",
    "am_sphere": "AM sphere",
    "am_pillars": "AM pillars",
    "nylon12": "nylon 12",
    "abs": "ABS",
    "ti6al4v": "Ti-6Al-4V",
}


def words(key: Any) -> str:
    """``"ti6al4v"`` -> ``"Ti-6Al-4V"``, ``"am_pyramid"`` -> ``"AM pyramid"``."""
    return WORDS.get(str(key), num.words(str(key)))


def _f(x: Any, fmt: str) -> str:
    """``x`` in the format spec ``fmt`` by the number rule (camcmm.numbers): a ``g`` spec
    as that many significant digits without an exponent, counts grouped by a space, a real
    minus, ``0`` for a value that rounds to zero."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return DASH
    if not math.isfinite(v):
        return DASH
    if fmt.endswith("g"):
        m = re.search(r"\.(\d+)", fmt)
        text = num.significant(v, int(m.group(1)) if m else 6)
        return "+" + text if "+" in fmt and v > 0 and text != "0" else text
    text = format(v, fmt).replace(",", " ")
    if not any(c in "123456789" for c in text):
        return "0"
    return text.replace("-", num.MINUS)


def table_63(t: dict[str, Any]) -> dict[str, Any]:
    """Table 6.3: gradient (mm/λ) per artefact × set, each set's sample std (µm/λ), mean, focal length."""
    sets = [str(s) for s in t.get("sets") or []]
    grads = zip(t.get("artefacts") or [], t.get("gradients") or [])
    rows = [[str(a), *[_f(g, ".4f") for g in row]] for a, row in grads]
    std_um = [_f(None if s is None else 1000 * s, ".1f") for s in t.get("std") or []]
    rows.append(["Standard deviation / µm λ⁻¹", *std_um])
    rows.append(["Mean / mm λ⁻¹", *[_f(m, ".4f") for m in t.get("mean") or []]])
    rows.append(["Focal length / mm", *[_f(f, ".2f") for f in t.get("focal_length_mm") or []]])
    return {"key": "t63", "title": "Gradient data (table 6.3), mm λ⁻¹", "header": ["Artefact", *sets], "rows": rows}


def focal_rows(f: dict[str, Any] | None, truth: dict[str, Any] | None = None) -> list[dict[str, str]]:
    """Fig. 6.16's first-order fit, the prediction with its u, and the truth when known."""
    if not f:
        return [{"name": "fit", "label": "Gradient vs focal length", "value": "needs two or more focal lengths"}]
    cov = f.get("cov") or [[None, None], [None, None]]
    u = [math.sqrt(c) if isinstance(c, (int, float)) and c >= 0 else None for c in (cov[0][0], cov[1][1])]
    rows = [
        ("slope", "Slope", num.value_u(f.get("slope"), u[0], "mm λ⁻¹ per mm")),
        ("intercept", "Intercept", num.value_u(f.get("intercept"), u[1], "mm λ⁻¹")),
        ("r2", "r²", _f(f.get("r2"), ".6f")),
        ("residual_std", "Residual std", f"{_f(f.get('residual_std'), '.3g')} mm λ⁻¹"),
    ]
    p = f.get("predicted")
    if p:
        rows.append(
            (
                "predicted",
                f"Predicted at {_f(p.get('focal_length'), 'g')} mm",
                f"{_f(p.get('gradient_mm_per_lambda'), '.5f')} mm λ⁻¹, u {_f(p.get('u'), '.2g')} (line), "
                f"{_f(p.get('u_new_set'), '.2g')} (a new set)",
            )
        )
    for s in (truth or {}).get("sets") or []:
        rows.append(
            (
                f"truth-{s.get('set')}",
                f"{s.get('set')}: true / measured",
                f"{_f(s.get('true'), '.4f')} / {_f(s.get('mean'), '.4f')} (Δ {_f(s.get('difference'), '+.2g')})",
            )
        )
    return [{"name": n, "label": label, "value": v} for n, label, v in rows]


def _grid(cases: list[dict[str, Any]]) -> tuple[list[str], list[str], dict[tuple, dict[str, Any]]]:
    arts = list(dict.fromkeys(str(c.get("artefact")) for c in cases))
    mats = list(dict.fromkeys(str(c.get("material")) for c in cases))
    by = {(str(c.get("artefact")), str(c.get("material")), str(c.get("condition"))): c for c in cases}
    return arts, mats, by


def speckle_tables(cases: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Tables 6.1 (std of the deviations, µm) and 6.2 (points), the area coverage per case."""
    arts, mats, by = _grid(cases)
    header = ["Artefact"] + [f"{words(m)} {label}" for m in mats for _, label in CONDITIONS]
    out = []
    for key, title, fmt in (("std_um", "Deviation from CAD, std / µm (table 6.1)", ".0f"),
                            ("n_points", "Points (table 6.2)", ",.0f")):  # fmt: skip
        rows = []
        for a in arts:
            row = [words(a)]
            for m in mats:
                for cond, _ in CONDITIONS:
                    c = by.get((a, m, cond))
                    row.append("failed" if c is not None and "error" in c else _f((c or {}).get(key), fmt))
            rows.append(row)
        out.append({"key": key, "title": title, "header": header, "rows": rows})
    classes = ("top", "side", "curved")
    rows = []
    for c in cases:
        if "coverage_area_fraction" not in c:
            continue
        f = c.get("coverage_by_face") or {}
        pct = [_f(None if f.get(k) is None else 100 * f[k], ".1f") for k in classes]
        case = (
            " · ".join(words(c.get(k)) for k in ("artefact", "material"))
            + f" · {dict(CONDITIONS).get(str(c.get('condition')), str(c.get('condition')))}"
        )
        rows.append([case, _f(100 * float(c["coverage_area_fraction"]), ".1f"), *pct])
    out.append(
        {
            "key": "coverage",
            "title": "Coverage by area of the CAD surface / %",
            "header": ["Case", "covered", *classes],
            "rows": rows,
        }
    )
    return out


def summary_rows(summary: dict[str, Any]) -> list[dict[str, str]]:
    """The study's summary per material: the mean change with speckle."""
    rows = []
    for m, s in (summary or {}).items():
        if not isinstance(s, dict):
            continue
        cov = s.get("coverage_area_fraction_change")
        value = (
            f"std {_f(s.get('std_um_change'), '+.0f')} µm, points {_f(s.get('n_points_change'), '+,.0f')}, "
            f"coverage {_f(None if cov is None else 100 * cov, '+.1f')} %"
        )
        rows.append({"name": f"summary-{m}", "label": f"{words(m)}: change with speckle", "value": value})
    return rows


def pairs(cases: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The artefact × material pairs (the choices of the side-by-side maps)."""
    seen = dict.fromkeys((str(c.get("artefact")), str(c.get("material"))) for c in cases)
    return [{"title": f"{words(a)} · {words(m)}", "value": f"{a}|{m}"} for a, m in seen]


def case_id(cases: list[dict[str, Any]], pair: str, condition: str) -> str | None:
    a, _, m = str(pair).partition("|")
    for c in cases:
        if str(c.get("artefact")) == a and str(c.get("material")) == m and str(c.get("condition")) == condition:
            return str(c.get("id"))
    return None
