"""ISO 15530-3: task-specific uncertainty with a calibrated workpiece (thesis ch. 4.4, eq. 4.1).

The calibrated workpiece is measured ``n`` times as the real workpieces are; then

* ``u_cal``  standard uncertainty of the calibration (certificate ``U_cal / k_cal``),
* ``u_p``    standard deviation of the ``n`` repeated results (one future measurement
  is as scattered as one of these, so it is *not* divided by √n),
* ``b = mean − calibrated value`` the systematic error, corrected on later results,
* ``u_b``    standard uncertainty of that correction: given in the file, or by default
  the standard error of the mean ``u_p/√n`` (set ``u_b: 0`` where, as in the thesis,
  the reconstruction is scaled with the workpiece itself so the bias vanishes by design),
* ``u_w``    variations between calibrated and measured workpiece (material,
  manufacturing, thermal expansion): a number, or the quadrature sum of
  ``u_w_material``, ``u_w_manufacturing`` and the thermal term
  ``L·sqrt(((T − 20 °C)·u(α))² + (α·u(T))²)`` from a ``thermal`` block,

    U = k · sqrt(u_cal² + u_p² + u_b² + u_w²)                        (eq. 4.1)

and, when the bias is left uncorrected, ISO 15530-3:2004's
``U_uncorrected = k · sqrt(u_cal² + u_p² + u_w²) + |b|``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, project_values


def _num(
    doc: Mapping[str, Any], key: str, default: float | None = None, minimum: float | None = 0.0, strict: bool = False
) -> float | None:
    v = doc.get(key, default)
    if v is None:
        return None
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{key}: {v!r} is not a number") from None
    if not math.isfinite(x):
        raise InputError(f"{key}: {v!r} must be finite")
    if minimum is not None and (x <= minimum if strict else x < minimum):
        raise InputError(f"{key} = {x:g} must be {'>' if strict else '>='} {minimum:g}")
    return x


def _given(
    doc: Mapping[str, Any], key: str, default: float | None = None, minimum: float | None = 0.0, strict: bool = False
) -> float:
    """:func:`_num` of a value that is there (the caller checked) or has a default: a float."""
    x = _num(doc, key, default, minimum, strict)
    if x is None:  # given as null: said as the evaluation said it before the check moved here
        bound = "" if minimum is None else f" {'>' if strict else '>='} {minimum:g}"
        raise InputError(f"{key} = None must be a finite number{bound}" if key in doc else f"{key}: missing")
    return x


def read_measurements(path: str | Path) -> list[float]:
    """Repeated results from a text/CSV file: every number in it, in order (one per line,
    or comma/whitespace separated); lines starting with ``#`` and a non-numeric header
    line are skipped."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"measurements file {p}: not found")
    values: list[float] = []
    for lineno, line in enumerate(p.read_text().splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = [f for f in line.replace(",", " ").replace(";", " ").split() if f]
        try:
            values.extend(float(f) for f in fields)
        except ValueError:
            if values:  # a header before the first number is skipped
                raise InputError(f"measurements file {p}: line {lineno} is not numeric: {line!r}") from None
    return values


def thermal_u(block: Mapping[str, Any]) -> float:
    """Standard uncertainty from thermal expansion of a length ``length`` (workpiece
    unit) at temperature ``temperature`` (°C, default 20) with CTE ``cte`` (1/K): the
    uncertainty of the correction to 20 °C, ``L·sqrt(((T−20)·u(α))² + (α·u(T))²)``."""
    if not isinstance(block, Mapping):
        raise InputError("thermal: expected a mapping with length, cte, u_cte, temperature, u_temperature")
    L = _num(block, "length", None)
    if L is None:
        raise InputError("thermal: missing length (the measured size, in the workpiece's unit)")
    alpha = _given(block, "cte", 0.0, minimum=None)
    u_alpha = _given(block, "u_cte", 0.0)
    T = _given(block, "temperature", 20.0, minimum=None)
    u_T = _given(block, "u_temperature", 0.0)
    return float(L * math.hypot((T - 20.0) * u_alpha, alpha * u_T))


def evaluate(
    measurements: Sequence[float],
    calibrated_value: float,
    u_cal: float,
    k: float = 2.0,
    u_w: float = 0.0,
    u_b: float | None = None,
) -> dict[str, Any]:
    """Eq. 4.1 from the numbers; see the module docstring. Returns the JSON dict."""
    y = np.asarray(measurements, dtype=float).ravel()
    if y.size < 2:
        raise InputError(f"measurements: need at least two repeated results, got {y.size}")
    if not np.all(np.isfinite(y)):
        raise InputError(f"measurements: result {int(np.flatnonzero(~np.isfinite(y))[0]) + 1} is not finite")
    for name, v in (("u_cal", u_cal), ("u_w", u_w)):
        if not (v >= 0) or not math.isfinite(v):
            raise InputError(f"{name} = {v!r} must be a finite number >= 0")
    if isinstance(k, bool) or not isinstance(k, (int, float)) or not (math.isfinite(k) and k > 0):
        raise InputError(f"k = {k!r} must be a finite number > 0")
    n = int(y.size)
    with np.errstate(over="ignore", invalid="ignore"):
        mean = float(y.mean())
        u_p = float(y.std(ddof=1))
    if not (math.isfinite(mean) and math.isfinite(u_p)):
        raise InputError("measurements: their mean or spread overflows; check the values")
    bias = mean - float(calibrated_value)
    u_b_method = "given"
    if u_b is None:
        u_b, u_b_method = u_p / math.sqrt(n), "u_p/sqrt(n)"
    elif not (u_b >= 0):
        raise InputError(f"u_b = {u_b!r} must be >= 0")
    uc = math.hypot(u_cal, u_p, u_b, u_w)  # hypot: no overflow in the squares
    uc_unc = math.hypot(u_cal, u_p, u_w)
    if not math.isfinite(k * uc + abs(bias)):
        raise InputError(f"U = k u_c overflows (u_c = {uc:g}, k = {k:g}); check the magnitudes")
    parts = {"u_cal": u_cal, "u_p": u_p, "u_b": u_b, "u_w": u_w}
    return {
        "n": n,
        "mean": mean,
        "std": u_p,
        "calibrated_value": float(calibrated_value),
        "bias": bias,
        "u_cal": u_cal,
        "u_p": u_p,
        "u_b": u_b,
        "u_b_method": u_b_method,
        "u_w": u_w,
        "combined": uc,
        "k": float(k),
        "U": float(k) * uc,
        "U_uncorrected_bias": float(k) * uc_unc + abs(bias),
        "shares": {name: ((v / uc) ** 2 if uc > 0 else 0.0) for name, v in parts.items()},
        "measurements": y.tolist(),
    }


def from_dict(doc: Mapping[str, Any], base_dir: str | Path | None = None) -> dict[str, Any]:
    """Evaluate an input file's content (see ``tests/data/uncertainty/iso15530_*.yaml``).

    ``measurements`` is a list, or ``measurements_file`` names a text/CSV file (relative
    to ``base_dir``). ``u_cal`` is a standard uncertainty; or give ``U_cal`` and ``k_cal``.
    """
    if not isinstance(doc, Mapping):
        raise InputError("ISO 15530-3 file: expected a mapping")
    if doc.get("calibrated_value") is None:
        raise InputError("calibrated_value: missing (the certificate value of the calibrated workpiece)")
    x_cal = _given(doc, "calibrated_value", minimum=None)
    if doc.get("u_cal") is not None:
        u_cal = _given(doc, "u_cal")
    elif doc.get("U_cal") is not None:
        U_cal = _given(doc, "U_cal")
        k_cal = _given(doc, "k_cal", 2.0, strict=True)
        u_cal = U_cal / k_cal
    else:
        raise InputError("u_cal: missing (standard uncertainty of the calibration, or U_cal with k_cal)")
    if doc.get("measurements") is not None:
        meas = doc["measurements"]
        if not isinstance(meas, (list, tuple)):
            raise InputError("measurements: expected a list of repeated results")
        try:
            meas = [float(v) for v in meas]
        except (TypeError, ValueError):
            raise InputError(f"measurements: {meas!r} are not all numbers") from None
    elif doc.get("measurements_file") is not None:
        path = Path(doc["measurements_file"])
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        meas = read_measurements(path)
    elif doc.get("measurements_from") is not None:
        # repeated results straight from the project store, e.g. the sphere diameters of
        # an acceptance test: {project: DIR, result: ID, path: parameters.PS.per_measurement[].value}
        src = doc["measurements_from"]
        if not isinstance(src, Mapping) or not all(src.get(k) is not None for k in ("project", "result", "path")):
            raise InputError("measurements_from: needs project, result and path")
        project = Path(src["project"])
        if base_dir is not None and not project.is_absolute():
            project = Path(base_dir) / project
        meas = project_values(project, int(src["result"]), str(src["path"]))
    else:
        raise InputError(
            "measurements: missing (a list of repeated results, measurements_file, or measurements_from a project)"
        )
    parts: dict[str, float] = {}
    if doc.get("u_w") is not None:
        parts["u_w"] = _given(doc, "u_w")
    for key in ("u_w_material", "u_w_manufacturing"):
        if doc.get(key) is not None:
            parts[key] = _given(doc, key)
    if doc.get("thermal") is not None:
        parts["u_w_thermal"] = thermal_u(doc["thermal"])
    u_w = math.hypot(*parts.values())
    u_b = _num(doc, "u_b") if doc.get("u_b") is not None else None
    out = evaluate(meas, x_cal, u_cal, _given(doc, "k", 2.0, strict=True), u_w, u_b)
    out["u_w_parts"] = parts
    out["measurand"] = str(doc.get("measurand", ""))
    out["unit"] = str(doc.get("unit", ""))
    if out["n"] < 20:
        out["note"] = (
            f"ISO 15530-3 asks for at least 20 measurements in total (n = {out['n']}); "
            "u_p from few repeats is itself uncertain"
        )
    return out
