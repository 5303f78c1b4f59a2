"""How a plugin's result reads on the Inspect page: the table rows and the JSON shown
(long arrays cut). Presentation only: values are formatted, nothing is computed from
them. Which outputs become new items (``new_items``, ``derived_name``,
``residual_fields``) is the task's (:mod:`camcmm.tasks.plugin_run`), re-exported here."""

from __future__ import annotations

from typing import Any

import numpy as np

from .... import numbers as num
from ....host import to_jsonable
from ....tasks.plugin_run import derived_name, new_items, residual_fields
from ...view import fmt_count

__all__ = ["derived_name", "fmt_value", "new_items", "residual_fields", "result_rows", "summarize_json"]

MAX_LIST = 12  # longer arrays are summarised in the result panel


def _numeric_array(v: Any) -> np.ndarray | None:
    """``v`` as a numeric array if it is an array or a (nested) list of numbers."""
    if isinstance(v, np.ndarray):
        return v
    if isinstance(v, (list, tuple)) and v:
        try:
            return np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            return None
    return None


def fmt_value(v: Any) -> str:
    """A result value as text: 6 significant digits, short arrays inline, long ones
    as shape and range."""
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, (list, tuple)) and v and all(isinstance(x, str) for x in v):
        return ", ".join(output_words(x) for x in v)  # names (covariance_names ...) in words, not a repr
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        # never an exponent (issue 30: "1.88976e-05" where a person reads it)
        return num.significant(float(v), 6) if np.isfinite(v) else "not defined"
    a = _numeric_array(v)
    if a is not None:
        if a.dtype.kind not in "iufb" or a.size == 0:
            return f"array {tuple(a.shape)}"
        if a.size <= MAX_LIST:
            rows = a.reshape(1, -1) if a.ndim <= 1 else a.reshape(a.shape[0], -1)
            return "[" + "; ".join(", ".join(fmt_value(x.item()) for x in row) for row in rows) + "]"
        return f"array {tuple(a.shape)}, {fmt_value(float(np.nanmin(a)))} … {fmt_value(float(np.nanmax(a)))}"
    if hasattr(v, "n_points"):
        return f"point cloud '{v.name}', {fmt_count(v.n_points)} points"
    if hasattr(v, "n_faces"):
        return f"mesh '{v.name}', {fmt_count(v.n_faces)} faces"
    return str(v)


def summarize_json(x: Any, limit: int = MAX_LIST) -> Any:
    """``to_jsonable`` with lists longer than ``limit`` cut to their shape and first three
    values (the panel must not carry 2 million numbers)."""
    if isinstance(x, dict):
        return {k: summarize_json(v, limit) for k, v in x.items()}
    if isinstance(x, (np.ndarray, list, tuple)):
        a = x if isinstance(x, np.ndarray) else None
        n = a.size if a is not None else len(x)
        if n > limit:
            shape = list(a.shape) if a is not None else [len(x)]
            return {"array_shape": shape, "first": to_jsonable(list(np.ravel(x)[:3]) if a is not None else list(x[:3]))}
        return [summarize_json(v, limit) for v in (a.tolist() if a is not None else x)]
    return to_jsonable(x)


def output_words(name: str) -> str:
    """An output's key as the table shows it: ``std_uncertainty.center`` -> "std uncertainty ·
    center" (the key stays the row's ``name``, for scripts and tests; issue 30)."""
    return " · ".join(part.replace("_", " ") for part in name.split("."))


def result_rows(outputs: dict[str, Any], units: dict[str, str]) -> list[dict[str, str]]:
    """Rows ``{name, label, value, unit}`` for the result table (``label``: the name in words,
    :func:`output_words`). Units come from the plugin's declared outputs, or from a ``units``
    mapping (or ``unit`` text) inside the outputs; one level of nested dicts is shown with
    dotted names."""
    extra: dict[str, Any] = outputs["units"] if isinstance(outputs.get("units"), dict) else {}
    rows = []
    for name, value in outputs.items():
        if name == "units":
            continue
        unit = str(units.get(name) or extra.get(name, "") or "")
        if not isinstance(value, dict):
            shown = {"label": output_words(name), "value": fmt_value(value), "unit": num.unit_text(unit)}
            rows.append({"name": name, **shown})
            continue
        sub_units: dict[str, Any] = value["units"] if isinstance(value.get("units"), dict) else {}
        for k, v in value.items():
            if k in ("units", "unit"):
                continue
            u = sub_units.get(k) or (value.get("unit") if isinstance(value.get("unit"), str) else "") or unit
            key = f"{name}.{k}"
            rows.append({"name": key, "label": output_words(key), "value": fmt_value(v), "unit": num.unit_text(u)})
    return rows
