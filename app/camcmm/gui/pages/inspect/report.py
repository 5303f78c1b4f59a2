"""A plugin's result as a report reads: the rows a metrologist looks for, from what the
plugin declares.

Only the outputs the plugin's manifest declares are reported, in its order; their
declared ``unit`` and ``type`` decide how they read (:mod:`.numbers`):

* a length (unit mm) to the decimals its standard uncertainty resolves, with ``u``
  beside it; a ``radius`` also gives the diameter (``d = 2r``, ``u(d) = 2u(r)``);
* a vector in mm as ``(x, y, z) mm``; a vector without unit as a direction;
* a JSON mapping of lengths (``form``, unit mm) as one row per member, in µm;
* the output named ``std_uncertainty`` (a mapping of output name -> standard
  uncertainty, in that output's unit) is not a row of its own: it gives the ``u``
  column of the others;
* a cloud or mesh output names the item it became.

Everything else (undeclared outputs such as indices, long arrays) is left to the
"all outputs" table (:func:`.results.result_rows`). Nothing here computes a result.
"""

from __future__ import annotations

from typing import Any

from ....conformity import verdict_words
from . import numbers as fmt

UNCERTAINTY = "std_uncertainty"
#: what ``u`` is when the plugin's ``std_uncertainty`` output does not say (its ``help``):
#: the least-squares fits give the covariance of their estimate from the residuals
U_SOURCE = (
    "from the fit's residuals: the covariance s²(JᵀJ)⁻¹ of the least-squares estimate, "
    "s² = Σr²/(n − p) (the points' noise and form only; not the scanner's calibration)"
)
#: Labels for output names many plugins share (the words a report uses); any other
#: name reads with its underscores as spaces.
LABELS = {
    "n_points": "points",
    "n_used": "points used",
    "n_removed": "points removed by the outlier rule",
    "n_points_raw": "points in the raw scan",
    "n_extracted_away": "points removed by the extraction (not on the sphere)",
    "radius_deviation": f"radius {fmt.MINUS} nominal",
    "center": "centre",
    # an acceptance test's verdicts (standard plugins, ISO 14253-1)
    "verdict": "verdict",
    "verdict_guarded": "verdict with the test uncertainty (guarded)",
}


def label(name: str) -> str:
    return LABELS.get(name, name.replace("_", " "))


def _port(p: Any) -> dict[str, str]:
    if isinstance(p, dict):
        return {k: str(p.get(k) or "") for k in ("name", "type", "unit", "help")}
    return {k: str(getattr(p, k, "") or "") for k in ("name", "type", "unit", "help")}


def _row(name: str, value: str, unit: str = "", u: str = "", u_unit: str = "", help: str = "") -> dict[str, str]:
    uu = f"{u} {u_unit}".strip() if u else ""
    return {"name": name, "label": label(name), "value": value, "unit": unit, "u": uu, "help": help}


def _length(name: str, v: Any, u: Any, help: str) -> list[dict[str, str]]:
    ut, uu = fmt.uncertainty_parts(u) if fmt.finite(u) else ("", "")
    if not fmt.finite(u) and fmt.finite(v) and abs(float(v)) < 0.1:  # a small length (a deviation) reads in µm
        return [_row(name, fmt.micro(v, signed=True), fmt.MICRO, help=help)]
    rows = [_row(name, fmt.mm(v, u), "mm", ut, uu, help)]
    if name == "radius" and fmt.finite(v):
        u2 = 2 * float(u) if fmt.finite(u) else None
        dt, du = fmt.uncertainty_parts(u2) if u2 is not None else ("", "")
        rows.insert(0, _row("diameter", fmt.mm(2 * float(v), u2), "mm", dt, du, "twice the radius"))
    return rows


def _form(name: str, value: dict, help: str) -> list[dict[str, str]]:
    rows = []
    for key, v in value.items():
        if fmt.finite(v):
            signed = key in ("min", "max")
            rows.append(_row(f"{name}_{key}", fmt.micro(v, signed), fmt.MICRO, help=help))
            rows[-1]["label"] = f"{label(name)} {key}"
    return rows


def _one(port: dict[str, str], value: Any, u: Any, items: dict[str, str]) -> list[dict[str, str]]:
    name, typ, unit, help = port["name"], port["type"], port["unit"], port["help"]
    if typ in ("pointcloud", "mesh"):
        made = items.get(name)
        if made:
            return [_row(name, f"item '{made}' (coloured in the view)", help=help)]
        d = value if isinstance(value, dict) else {}  # to_jsonable's summary of a cloud or mesh
        n = d.get("n_points", d.get("n_faces"))
        kind = "point cloud" if typ == "pointcloud" else typ
        what = f"{kind} '{d.get('name', name)}'" + (f", {fmt.count(n)} points" if "n_points" in d else "")
        return [_row(name, what if n is not None else kind, help=help)]
    if isinstance(value, bool) or value is None:
        return [_row(name, "yes" if value else ("no" if value is False else "not defined"), help=help)]
    if isinstance(value, (int, float)):
        if unit == "mm":
            return _length(name, value, u, help)
        if isinstance(value, int) and not unit:
            return [_row(name, fmt.count(value), help=help)]
        return [_row(name, fmt.significant(value), unit, help=help)]
    if isinstance(value, (list, tuple)) and value and all(fmt.finite(x) for x in value) and len(value) <= 4:
        if unit == "mm":
            ut, uu = fmt.uncertainty_vector(u) if isinstance(u, (list, tuple)) else ("", "")
            return [_row(name, fmt.vector(value, u if isinstance(u, (list, tuple)) else None), "mm", ut, uu, help)]
        return [_row(name, fmt.direction(value), unit, help=help)]
    if isinstance(value, dict) and unit == "mm" and any(fmt.finite(v) for v in value.values()):
        return _form(name, value, help)
    if isinstance(value, str):
        words = verdict_words(value) if name in ("verdict", "verdict_guarded") else value
        return [_row(name, words, unit, help=help)]
    return []  # long lists, nested JSON: the "all outputs" table shows them


def report_rows(outputs: dict[str, Any], ports: list[Any], items: dict[str, str] | None = None) -> list[dict]:
    """Rows ``{name, label, value, unit, u, help}`` of the declared outputs present in
    ``outputs`` (JSON data: a live result passed through ``to_jsonable``, or a stored one).
    ``items``: output name -> name of the item it became. No declared output: no rows
    (the caller shows all outputs instead)."""
    uncert: dict[str, Any] = outputs[UNCERTAINTY] if isinstance(outputs.get(UNCERTAINTY), dict) else {}
    declared = [_port(p) for p in ports]
    source = next((p["help"] for p in declared if p["name"] == UNCERTAINTY and p["help"]), U_SOURCE)
    rows: list[dict[str, str]] = []
    for p in declared:
        name = p["name"]
        if name == UNCERTAINTY or (name not in outputs and name not in (items or {})):
            continue
        rows += _one(p, outputs.get(name), uncert.get(name), dict(items or {}))
    for row in rows:  # "u" says what it is: a standard uncertainty, k = 1, and where it comes from
        row["u_what"] = f"standard uncertainty u (k = 1) {source}" if row.get("u") else ""
    return rows


def parameters_line(params: dict[str, Any], declared: list[Any]) -> str:
    """``"outliers none · method ls · nominal radius 10 mm · extract on"``: the
    parameters a run used, with their declared units (unset ones left out)."""
    units = {getattr(p, "name", ""): getattr(p, "unit", "") or "" for p in declared}
    parts = []
    for k, v in params.items():
        if v is None or v == "":
            continue
        if isinstance(v, bool):
            text = "on" if v else "off"
        elif isinstance(v, float):
            text = fmt.significant(v)
        elif isinstance(v, (list, tuple)):
            text = "(" + ", ".join(fmt.significant(x) if fmt.finite(x) else str(x) for x in v) + ")"
        else:
            text = str(v)
        parts.append(f"{k.replace('_', ' ')} {text}" + (f" {units[k]}" if units.get(k) else ""))
    return " · ".join(parts)
