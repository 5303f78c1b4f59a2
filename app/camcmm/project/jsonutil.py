"""JSON for the store's JSON columns (params, outputs, meta, state).

Plugin outputs are full of numpy scalars and arrays and sometimes NaN (a fit that is
not defined). JSON has no NaN, and a column that ``json.loads`` cannot read would lose
the whole result, so NaN and ±Inf are stored as ``null`` ("not defined") and numpy
values as plain Python numbers and lists. numpy is recognised by duck typing so that
importing the store does not import numpy (the crash test starts many processes).
"""

from __future__ import annotations

import json
import math
from datetime import date, datetime
from pathlib import PurePath
from typing import Any

from ..errors import ProjectError


def clean(x: Any, where: str = "value") -> Any:
    """``x`` as plain JSON data; raises ProjectError naming ``where`` for anything else."""
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, int):
        return int(x)  # also numpy ints that subclass int
    if isinstance(x, float):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, dict):
        return {str(k): clean(v, f"{where}[{k!r}]") for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean(v, f"{where}[{i}]") for i, v in enumerate(x)]
    if isinstance(x, (set, frozenset)):
        return [clean(v, where) for v in sorted(x, key=repr)]
    if isinstance(x, PurePath):
        return str(x)
    if isinstance(x, (datetime, date)):
        return x.isoformat()
    if isinstance(x, bytes):
        return x.hex()
    if hasattr(x, "n_points"):  # PointCloud: the store keeps a summary; the data goes in a file
        return {"kind": "pointcloud", "name": getattr(x, "name", ""), "n_points": int(x.n_points)}
    if hasattr(x, "n_faces"):
        return {"kind": "mesh", "name": getattr(x, "name", ""), "n_vertices": int(x.n_vertices),
                "n_faces": int(x.n_faces)}
    if hasattr(x, "to_dict"):  # Artefact and similar model records
        return clean(x.to_dict(), where)
    if hasattr(x, "tolist") and type(x).__module__.split(".")[0] == "numpy":
        return clean(x.tolist(), where)  # numpy arrays and scalars (np.float32, np.bool_ ...)
    raise ProjectError(f"cannot store {where} of type {type(x).__name__} in the project; "
                       "give numbers, strings, lists or dicts")


def dumps(x: Any, where: str = "value") -> str:
    """Compact, strict JSON text (``allow_nan=False`` guards against NaN slipping through)."""
    return json.dumps(clean(x, where), allow_nan=False, ensure_ascii=False, separators=(",", ":"))


def loads(text: str | None, default: Any = None) -> Any:
    return default if text is None else json.loads(text)
