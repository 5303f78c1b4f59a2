"""How a plugin's result reads on the Inspect page: the table rows, the JSON shown
(long arrays cut), and the outputs that become new items. Presentation only: values
are formatted and per-point arrays a plugin returned are attached to a copy of the
cloud as colour fields; nothing is computed from them."""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from ....host import RunResult, to_jsonable
from ...session import kind_of
from ...view import fmt_count

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
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.6g}" if np.isfinite(v) else "not defined"
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


def result_rows(outputs: dict[str, Any], units: dict[str, str]) -> list[dict[str, str]]:
    """Rows ``{name, value, unit}`` for the result table. Units come from the plugin's
    declared outputs, or from a ``units`` mapping (or ``unit`` text) inside the outputs;
    one level of nested dicts is shown with dotted names."""
    extra: dict[str, Any] = outputs["units"] if isinstance(outputs.get("units"), dict) else {}
    rows = []
    for name, value in outputs.items():
        if name == "units":
            continue
        unit = str(units.get(name) or extra.get(name, "") or "")
        if not isinstance(value, dict):
            rows.append({"name": name, "value": fmt_value(value), "unit": unit})
            continue
        sub_units: dict[str, Any] = value["units"] if isinstance(value.get("units"), dict) else {}
        for k, v in value.items():
            if k in ("units", "unit"):
                continue
            u = sub_units.get(k) or (value.get("unit") if isinstance(value.get("unit"), str) else "") or unit
            rows.append({"name": f"{name}.{k}", "value": fmt_value(v), "unit": str(u or "")})
    return rows


def _with_fields(spec: Any, result: RunResult, base: Any) -> Any | None:
    """A copy of the cloud ``base`` with each per-point numeric output (length
    ``base.n_points``) as a colour field in its declared unit; None if there is none."""
    from ....model import PointCloud

    units = {p.name: p.unit for p in spec.outputs}
    fields, field_units = dict(base.fields), dict(base.field_units)
    for name, value in result.outputs.items():
        if (
            isinstance(value, np.ndarray)
            and value.ndim == 1
            and len(value) == base.n_points
            and value.dtype.kind in "iuf"
        ):
            fields[name] = value.astype(float)
            field_units[name] = units.get(name, "")
    if len(fields) == len(base.fields):
        return None
    return PointCloud(base.points, base.colors, base.normals, fields, field_units, base.name, base.source_unit)


def derived_name(own: str, in_name: str, fallback: str, taken: set[str]) -> str:
    """The name of an item a run made: the output's own name unless it only repeats the
    input's, with a word the input's name already ends in said once ("ball deviations"
    fitted again gives "ball deviations", not "ball deviations deviations"), and a
    number when the project already has that name ("ball deviations (2)")."""
    name = own if own and own != in_name and own not in ("cloud", "mesh") else fallback
    name = re.sub(r"\b(\w+)(?: \1\b)+", r"\1", " ".join(name.split()))
    base, n = name, 2
    while name in taken:
        name, n = f"{base} ({n})", n + 1
    return name


def new_items(
    spec: Any, result: RunResult, inputs: dict[str, Any], taken: set[str] | None = None
) -> list[tuple[str, str, Any]]:
    """``[(output label, item name, object)]``: the clouds and meshes among the outputs (one level
    into dicts), or else a coloured copy of the input cloud (a deviation map). ``taken``:
    the names the project's items have (a new name does not repeat one)."""
    found: list[tuple[str, Any]] = []
    for name, value in result.outputs.items():
        if kind_of(value) in ("pointcloud", "mesh"):
            found.append((name, value))
        elif isinstance(value, dict):
            found += [(f"{name}.{k}", v) for k, v in value.items() if kind_of(v) in ("pointcloud", "mesh")]
    base = next((o for o in inputs.values() if kind_of(o) == "pointcloud"), None)
    if not found and base is not None:
        coloured = _with_fields(spec, result, base)
        if coloured is not None:
            found.append(("fields", coloured))
    in_name = next((getattr(o, "name", "") for o in inputs.values() if getattr(o, "name", "")), "")
    out, names = [], set(taken or ())
    for label, obj in found:
        fallback = f"{spec.id} {label}" + (f" of {in_name}" if in_name else "")
        name = derived_name(str(getattr(obj, "name", "") or ""), in_name, fallback, names)
        names.add(name)
        out.append((label, name, obj))
    return out


def residual_fields(obj: Any, inputs: dict[str, Any]) -> dict[str, str]:
    """The length fields (unit mm) a run added to a cloud, i.e. not on its input cloud
    (a fit's residuals, a comparison's deviations), each with the unit the view shows
    it in: µm when every value lies within ±1 mm, else mm. First the one to colour by."""
    if not hasattr(obj, "fields"):
        return {}
    had = set()
    for o in inputs.values():
        had |= set(getattr(o, "fields", {}) or {})
    out = {}
    for name, values in obj.fields.items():
        if name in had or (obj.field_units or {}).get(name) != "mm":
            continue
        a = np.asarray(values, dtype=float)
        finite = a[np.isfinite(a)]
        out[name] = "µm" if finite.size and float(np.abs(finite).max()) < 1.0 else "mm"
    return out
