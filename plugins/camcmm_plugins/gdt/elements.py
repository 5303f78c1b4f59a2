"""Geometric elements as the datums and characteristics see them (mm, unit directions).

An element is a feature type of :data:`.model.FEATURE_TYPES` with its parameters (the
nominal of a :class:`~.model.FeatureSpec` or the ``params`` of an
:class:`~.model.Associated`). This module gives its direction, its location, its extent
along its direction and its image under a rigid transform; signed distances are
:func:`.features.surface_distance`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError

#: Parameter holding each type's direction (None: the element has none).
DIRECTION = {
    "plane": "normal",
    "line": "direction",
    "circle": "normal",
    "cylinder": "axis",
    "cone": "axis",
    "torus": "axis",
    "sphere": None,
    "point": None,
}
#: Parameter holding each type's location.
LOCATION = {
    "plane": "point",
    "line": "point",
    "circle": "centre",
    "cylinder": "point",
    "cone": "apex",
    "torus": "centre",
    "sphere": "centre",
    "point": "point",
}


def unit(v: Any) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(v))
    if not n > 0:
        raise InputError("gdt: a direction of length zero")
    return v / n


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b of two 3-vectors (numpy's cross costs ~20 µs of axis handling a call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def complement(n: np.ndarray) -> np.ndarray:
    """(2, 3) orthonormal rows b1, b2 perpendicular to the unit vector n (b1 × b2 = n)."""
    a = np.zeros(3)
    a[int(np.argmin(np.abs(n)))] = 1.0
    b1 = unit(cross(n, a))
    return np.vstack([b1, cross(n, b1)])


def supported(etype: str, what: str) -> None:
    if etype not in LOCATION:
        raise InputError(f"{what}: a feature of type {etype} is not supported here")


def direction(etype: str, params: dict[str, Any]) -> np.ndarray | None:
    """The element's unit direction (plane normal, axis, line direction) or None."""
    key = DIRECTION.get(etype)
    return None if key is None else unit(params[key])


def location(etype: str, params: dict[str, Any]) -> np.ndarray:
    return np.asarray(params[LOCATION[etype]], dtype=float)


def radius(params: dict[str, Any]) -> float:
    return 0.5 * float(params["diameter"])


def axial_extent(etype: str, params: dict[str, Any], pts: np.ndarray | None = None) -> tuple[float, float]:
    """Extent (mm) along the direction from the location: of the points when given, else
    of the element's ``length`` (0 .. length)."""
    d = direction(etype, params)
    if pts is not None and len(pts) and d is not None:
        h = (pts - location(etype, params)) @ d
        return float(h.min()), float(h.max())
    return 0.0, float(params.get("length") or 0.0)


def rigid(t: np.ndarray, etype: str, params: dict[str, Any]) -> dict[str, Any]:
    """The element's parameters carried through the rigid transform t (4, 4)."""
    q = dict(params)
    r, s = t[:3, :3], t[:3, 3]
    q[LOCATION[etype]] = r @ location(etype, params) + s
    key = DIRECTION.get(etype)
    if key is not None:
        q[key] = r @ unit(params[key])
    return q


def apply(t: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return pts @ t[:3, :3].T + t[:3, 3]
