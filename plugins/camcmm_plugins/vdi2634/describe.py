"""An evaluation in the operator's words: the fit in one line and as rows, and the side
from which its deviation colour map reads best. The standard adds these to every
evaluation (``fit_text``, ``fit``, ``view`` of :class:`camcmm.api.PositionEvaluation`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import numbers


def _mm(v: Any) -> str:
    """A length as the number rule writes it (0.1 µm: 4 decimals in mm, a real minus)."""
    return numbers.length(float(v))


def rule_words(rule: str) -> str:
    """An outlier rule of the plan (``vdi2634``, ``percent:5``, ``sigma:3``, ``none``) in words."""
    kind, _, arg = rule.partition(":")
    if kind == "vdi2634":
        return "VDI/VDE 2634 rule: at most 3 of every 1000 points"
    if kind == "percent":
        return f"the {arg} % farthest points"
    if kind == "sigma":
        return f"points beyond {arg} standard deviations"
    return "no outlier rule" if kind == "none" else rule


def fit_text(ev: dict[str, Any]) -> str:
    """One line on the fit: what was fitted, points used/removed."""
    parts = []
    if ev.get("diameter") is not None:
        parts.append(f"Ø {_mm(ev['diameter'])}")
    if ev.get("length") is not None:
        parts.append(f"L {_mm(ev['length'])}")
    if isinstance(ev.get("lengths"), list):
        parts.append("L " + ", ".join(numbers.mm(float(x)) for x in ev["lengths"]) + " mm")
    form = ev.get("form") if isinstance(ev.get("form"), dict) else None
    if form and form.get("std") is not None:
        parts.append(f"σ {numbers.deviation(float(form['std']), signed=False)}")
    if ev.get("n_points") is not None:
        used = ev.get("n_used")
        n = numbers.count(ev["n_points"])
        parts.append(f"{n} pts" if used is None else f"{numbers.count(used)} of {n} pts")
    if ev.get("n_removed"):
        parts.append(f"{ev['n_removed']} removed")
    return " · ".join(parts)


def fit_rows(ev: dict[str, Any]) -> list[dict[str, str]]:
    """Rows ``{name, value}`` on the fit (centre, size, form, points) for the detail panel."""
    rows: list[dict[str, str]] = []

    def add(name: str, value: str) -> None:
        rows.append({"name": name, "value": value})

    def xyz(v: Any) -> str:
        return numbers.vector([float(x) for x in v]) + " mm"

    if ev.get("center") is not None:
        add("centre", xyz(ev["center"]))
    if ev.get("diameter") is not None:
        cal = ev.get("diameter_calibrated")
        add("Ø", _mm(ev["diameter"]) + (f" (calibrated {_mm(cal)})" if cal is not None else ""))
    if ev.get("length") is not None:
        cal = ev.get("length_calibrated")
        add("length", _mm(ev["length"]) + (f" (calibrated {_mm(cal)})" if cal is not None else ""))
    for i, sph in enumerate(ev.get("spheres") or []):
        if isinstance(sph, dict) and sph.get("center") is not None:
            add(
                f"sphere {i + 1}",
                xyz(sph["center"]) + (f", Ø {_mm(sph['diameter'])}" if sph.get("diameter") is not None else ""),
            )
    if ev.get("normal") is not None:
        add("normal", numbers.direction([float(x) for x in ev["normal"]]))
    given = ev.get("form")
    form = given if isinstance(given, dict) else {}
    if form.get("std") is not None:
        add("form σ", numbers.deviation(float(form["std"]), signed=False))
    n, used, removed = ev.get("n_points"), ev.get("n_used"), ev.get("n_removed")
    if n is not None:
        text = f"{numbers.count(used)} of {numbers.count(n)} used" if used is not None else numbers.count(n)
        if removed:
            text += f", {numbers.count(removed)} removed"
        if ev.get("outliers"):
            text += f" ({rule_words(str(ev['outliers']))})"
        add("points", text)
    if isinstance(ev.get("scale"), (int, float)) and ev["scale"] != 1:
        add("scale", numbers.plain(float(ev["scale"]), 6))
    return rows


def view(ev: dict[str, Any]) -> dict[str, list[float]] | None:
    """``{"direction", "up"}`` (direction from the object to the camera) that shows the
    colour map well: a flat face-on (along its normal, from the sensor's side); a ball
    bar across its length, from above; a plate face-on; a sphere from the front and
    above, as the sensor saw it. None when the evaluation says nothing of its geometry."""
    z = np.array([0.0, 0.0, 1.0])
    if ev.get("normal") is not None:
        n = np.asarray(ev["normal"], float)
        n = n / (np.linalg.norm(n) or 1.0)
        if n @ z < 0:
            n = -n
        up = np.array([0.0, 1.0, 0.0]) if abs(n @ z) > 0.9 else z
        return {"direction": n.tolist(), "up": up.tolist()}
    centres = [s.get("center") for s in ev.get("spheres") or [] if isinstance(s, dict) and s.get("center")]
    if len(centres) >= 2:
        c = np.asarray(centres, float)
        d = c[1] - c[0]
        d = d / (np.linalg.norm(d) or 1.0)
        if len(c) >= 3:  # a plate: face-on
            n = np.cross(c[1] - c[0], c[2] - c[0])
            n = n / (np.linalg.norm(n) or 1.0)
            v = n if n @ z >= 0 else -n
        else:
            v = z - (z @ d) * d
            if np.linalg.norm(v) < 0.2:  # a (nearly) vertical bar: from the front
                v = np.array([0.0, -1.0, 0.0]) - d * d[1] * -1.0
            v = v / (np.linalg.norm(v) or 1.0)
            v = v + 0.4 * np.cross(d, v)
        v = v / np.linalg.norm(v)
        up = z if abs(v @ z) < 0.9 else np.array([0.0, 1.0, 0.0])
        return {"direction": v.tolist(), "up": up.tolist()}
    if ev.get("center") is not None:
        return {"direction": [0.3, -0.6, 1.0], "up": [0.0, 0.0, 1.0]}
    return None


def add_words(ev: dict[str, Any]) -> dict[str, Any]:
    """``ev`` with ``fit_text``, ``fit`` and ``view`` added (in place; returned)."""
    ev["fit_text"] = fit_text(ev)
    ev["fit"] = fit_rows(ev)
    look = view(ev)
    if look is not None:
        ev["view"] = look
    return ev
