"""The one JSON cleaner and the one UTC clock of camcmm.

Every result, project record, report and device log passes through :func:`to_jsonable`
before ``json.dumps``, and every time stamp comes from :func:`utc_now`, so that all
files agree on what a NaN, a numpy array or a time looks like. Plugins reach both
through :mod:`camcmm.api`.
"""

from __future__ import annotations

import math
import time
from datetime import UTC, date, datetime
from pathlib import PurePath
from typing import Any

__all__ = ["NotJsonable", "to_jsonable", "utc_now"]


class NotJsonable(TypeError):
    """A value :func:`to_jsonable` cannot turn into JSON data (with ``strict=True``);
    ``where`` names its place (``"outputs['fit'][2]"``), ``type_name`` its type."""

    def __init__(self, where: str, type_name: str):
        super().__init__(f"{where}: cannot put a {type_name} into JSON; give numbers, strings, lists or dicts")
        self.where, self.type_name = where, type_name


def utc_now(t: float | None = None, timespec: str = "milliseconds") -> str:
    """Wall-clock time as UTC ISO 8601, e.g. ``2026-11-25T01:45:20.123+00:00``.

    ``t`` is epoch seconds (now when None); ``timespec`` as for
    :meth:`datetime.isoformat` (``"milliseconds"``: the format of run results and
    project records; ``"seconds"``: a report's creation time).
    """
    return datetime.fromtimestamp(time.time() if t is None else t, UTC).isoformat(timespec=timespec)


def to_jsonable(x: Any, *, strict: bool = False, where: str = "data", keep_nan: bool = False) -> Any:
    """``x`` as plain JSON data.

    - numpy arrays become (nested) lists, numpy scalars Python numbers;
    - NaN and ±Inf become ``None`` (JSON has none of them; ``null`` says "not defined"),
      unless ``keep_nan`` (for files written with ``allow_nan``, such as calibration JSON,
      whose readers expect NaN back);
    - dict keys become strings, tuples and sets lists (a set sorted by ``repr``);
    - paths become strings, dates and times ISO 8601;
    - a point cloud, mesh or height map becomes a short summary (``kind``, ``name``, counts):
      results hold the numbers, the project holds the geometry;
    - an object with ``to_dict()`` or a dataclass becomes its mapping;
    - bytes become hex text.

    Anything else is returned as it is, or, with ``strict=True``, raises
    :class:`NotJsonable` (a TypeError) naming where it sits (``where`` is the caller's
    name for ``x``, e.g. ``"table rows"``), so that the caller learns which key to fix.
    numpy is recognised by its module name: importing this module does not import numpy.
    """

    def sub(v: Any, at: str) -> Any:
        return to_jsonable(v, strict=strict, where=at, keep_nan=keep_nan)

    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, int):
        return int(x)  # also int subclasses (IntEnum ...)
    if isinstance(x, float):
        return float(x) if keep_nan or math.isfinite(x) else None
    if isinstance(x, dict):
        return {str(k): sub(v, f"{where}[{k!r}]") for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [sub(v, f"{where}[{i}]") for i, v in enumerate(x)]
    if isinstance(x, (set, frozenset)):
        return [sub(v, where) for v in sorted(x, key=repr)]
    if type(x).__module__.split(".")[0] == "numpy" and hasattr(x, "tolist"):
        return sub(x.tolist(), where)  # arrays and scalars (float32, bool_ ...)
    if isinstance(x, PurePath):
        return str(x)
    if isinstance(x, (datetime, date)):
        return x.isoformat()
    if isinstance(x, bytes):
        return x.hex()
    if hasattr(x, "n_points") and hasattr(x, "points"):
        return {"kind": "pointcloud", "name": getattr(x, "name", ""), "n_points": int(x.n_points)}
    if hasattr(x, "heights") and hasattr(x, "dx") and hasattr(x, "n_valid"):  # HeightMap: 4 M values are no result
        ny, nx = x.shape
        return {
            "kind": "heightmap",
            "name": getattr(x, "name", ""),
            "grid": [int(nx), int(ny)],
            "steps_mm": [float(x.dx), float(x.dy)],
            "n_valid": int(x.n_valid),
        }
    if hasattr(x, "n_faces") and hasattr(x, "n_vertices"):
        return {
            "kind": "mesh",
            "name": getattr(x, "name", ""),
            "n_vertices": int(x.n_vertices),
            "n_faces": int(x.n_faces),
        }
    if callable(getattr(x, "to_dict", None)):  # Artefact, PluginSpec, Certificate-like records ...
        return sub(x.to_dict(), where)
    if hasattr(x, "__dataclass_fields__") and not isinstance(x, type):
        return {k: sub(getattr(x, k), f"{where}.{k}") for k in x.__dataclass_fields__}
    if strict:
        raise NotJsonable(where, type(x).__name__)
    return x
