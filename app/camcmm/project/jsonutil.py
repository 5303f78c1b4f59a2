"""JSON for the store's JSON columns (params, outputs, meta, state).

Plugin outputs are full of numpy scalars and arrays and sometimes NaN (a fit that is
not defined). JSON has no NaN, and a column that ``json.loads`` cannot read would lose
the whole result, so NaN and ±Inf are stored as ``null`` ("not defined") and numpy
values as plain Python numbers and lists. numpy is recognised by duck typing so that
importing the store does not import numpy (the crash test starts many processes).
"""

from __future__ import annotations

import json
from typing import Any

from ..errors import ProjectError
from ..jsonable import NotJsonable, to_jsonable


def clean(x: Any, where: str = "value") -> Any:
    """``x`` as plain JSON data (:func:`camcmm.jsonable.to_jsonable`); raises ProjectError
    naming ``where`` for anything else."""
    try:
        return to_jsonable(x, strict=True, where=where)
    except NotJsonable as exc:
        raise ProjectError(
            f"cannot store {exc.where} of type {exc.type_name} in the project; give numbers, strings, lists or dicts"
        ) from None


def dumps(x: Any, where: str = "value") -> str:
    """Compact, strict JSON text (``allow_nan=False`` guards against NaN slipping through)."""
    return json.dumps(clean(x, where), allow_nan=False, ensure_ascii=False, separators=(",", ":"))


def loads(text: str | None, default: Any = None) -> Any:
    return default if text is None else json.loads(text)
