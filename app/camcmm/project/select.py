"""Pick numbers out of stored results, e.g. the repeated sphere diameters of an
acceptance test for an ISO 15530-3 evaluation.

A *path* walks a result's JSON outputs: dotted keys, ``[i]`` for one list item and
``[]`` for every item of a list::

    parameters.PS.per_measurement[].value      -> one number per sphere position
    lengths[1].values[]                        -> every repeat of the second length
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from ..errors import InputError

_STEP = re.compile(r"([^.\[\]]+)|\[(\d*)\]")


def select(doc: Any, path: str) -> list[Any]:
    """Every value that ``path`` reaches in ``doc`` (a list, flattened one level per ``[]``)."""
    steps = [(m.group(1), m.group(2)) for m in _STEP.finditer(path)]
    if not steps or "".join(m.group(0) for m in _STEP.finditer(path)) != path.replace(".", ""):
        raise InputError(f"path {path!r}: use dotted keys, [i] and [] (e.g. parameters.PS.per_measurement[].value)")
    values = [doc]
    walked = ""
    for key, index in steps:
        nxt = []
        for v in values:
            if key is not None:
                if not isinstance(v, dict) or key not in v:
                    have = ", ".join(map(str, v)) if isinstance(v, dict) else type(v).__name__
                    raise InputError(f"path {path!r}: no key {key!r} after {walked or 'the top'} (there: {have})")
                nxt.append(v[key])
            else:
                if not isinstance(v, list):
                    raise InputError(f"path {path!r}: {walked} is not a list")
                if index == "":
                    nxt.extend(v)
                else:
                    i = int(index)
                    if i >= len(v):
                        raise InputError(f"path {path!r}: {walked} has {len(v)} items, no [{i}]")
                    nxt.append(v[i])
        values = nxt
        walked += f".{key}" if key is not None else f"[{index}]"
    return values


def project_values(project_dir: str | Path, result_id: int, path: str) -> list[float]:
    """The numbers at ``path`` in the outputs of result ``result_id`` of a project.

    Missing values (``null``, e.g. a failed measurement) are left out; anything else
    that is not a finite number is an error naming the path.
    """
    from .store import Project  # here, not at import: the store is only needed when called

    with Project.open(project_dir) as project:
        try:
            result = project.result(int(result_id))
        except Exception as exc:
            raise InputError(f"project {project_dir}: no result {result_id} ({exc})") from None
    out = []
    for v in select(result.get("outputs") or {}, path):
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"path {path!r} in result {result_id}: {v!r} is not a number")
        out.append(float(v))
    if not out:
        raise InputError(f"path {path!r} in result {result_id} of {project_dir}: no numbers there")
    return out
