"""Size characteristics (ISO 14405-1): diameter, width and distance, with the nominal,
the deviation and the two-point local sizes (through :mod:`.size`); the definitions as
computed are in :mod:`.characteristics`' docstring."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from camcmm.api import GeometryError, InputError

from . import elements as el
from . import size as iso_size
from .case import AXES, Case, Out, need, to_global
from .model import Associated

# ---- size --------------------------------------------------------------------------


def _reference(etype: str, params: dict, pts: np.ndarray | None) -> tuple[int, np.ndarray, np.ndarray | None]:
    """(rank, reference point, direction): plane 2 (projected centroid), axis 1 (middle
    at the extent), centre 0."""
    d = el.direction(etype, params)
    p = el.location(etype, params)
    if etype == "plane":
        assert d is not None
        cen = pts.mean(axis=0) if pts is not None and len(pts) else p
        return 2, cen - ((cen - p) @ d) * d, d
    if etype in AXES:
        assert d is not None
        lo, hi = el.axial_extent(etype, params, pts)
        return 1, p + 0.5 * (lo + hi) * d, d
    return 0, p, None


def _point_to(rank: int, p: np.ndarray, d: np.ndarray | None, x: np.ndarray) -> float:
    v = x - p
    if rank == 2:
        assert d is not None
        return abs(float(v @ d))
    if rank == 1:
        assert d is not None
        return float(np.linalg.norm(v - (v @ d) * d))
    return float(np.linalg.norm(v))


def element_distance(
    e1: tuple[int, np.ndarray, np.ndarray | None], e2: tuple[int, np.ndarray, np.ndarray | None]
) -> float:
    """Distance (mm) between two references of :func:`_reference` (module docstring)."""
    if e1[0] == e2[0] and e1[0] > 0:
        return 0.5 * (_point_to(*e2, e1[1]) + _point_to(*e1, e2[1]))
    hi, lo = (e1, e2) if e1[0] > e2[0] else (e2, e1)
    return _point_to(*hi, lo[1])


def _local(a: Associated, pts: np.ndarray, start: int = 0) -> Associated:
    """``a`` indexing ``pts`` placed at ``start`` of a cloud of its own (for size.py,
    which takes the whole cloud and the feature's indices)."""
    return replace(a, indices=np.arange(start, start + len(pts)))


def size(c: Case) -> Out:
    a = c.assoc()
    pts = c.pts()
    kind = c.spec.type
    etype, nominal = c.nominal()
    details: dict[str, Any] = {}
    if kind == "diameter":
        if "diameter" not in a.params:
            raise InputError(f"{c.where}: diameter needs a circle, cylinder or sphere, not a {a.type}")
        need(len(pts), {"circle": 4, "sphere": 5}.get(a.type, 6), f"{c.spec.id}: diameter")
        criterion = str(c.spec.options.get("criterion") or a.association)
        nom = float(c.spec.options.get("nominal", nominal.get("diameter", math.nan)))
        if criterion == "ls" and a.association == "ls":

            def value_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                return float(A[a.id].params["diameter"])

            extremes = np.array([int(np.argmax(a.residuals)), int(np.argmin(a.residuals))])
            out = Out(value_fn(c.associated, {}, np.eye(4)), to_global(a, extremes), details, value_fn, ls=(a.id,))
        else:

            def value_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                return float(iso_size.global_size(P[a.id], _local(A[a.id], P[a.id]), criterion))

            out = Out(value_fn(c.associated, {a.id: pts}, np.eye(4)), a.indices[:0], details, value_fn, mc=(a.id,))
        details["criterion"] = criterion
        try:
            local = iso_size.two_point_sizes(c.points, a)
        except GeometryError:
            local = np.zeros(0)
        if len(local):
            details["two_point_min"], details["two_point_max"] = float(local.min()), float(local.max())
    else:
        other = c.other()
        b = c.assoc(other)
        pb = c.pts(other)
        o_type, o_nom = c.nominal(other)
        nom_default = element_distance(_reference(etype, nominal, None), _reference(o_type, o_nom, None))
        nom = float(c.spec.options.get("nominal", nom_default))
        if kind == "width":
            if a.type != "plane" or b.type != "plane":
                raise InputError(f"{c.where}: width needs two planes (feature and other)")
            need(min(len(pts), len(pb)), 3, f"{c.spec.id}: width")

            def width_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                both = np.vstack([P[a.id], P[other]])
                return iso_size.width(both, _local(A[a.id], P[a.id]), _local(A[other], P[other], len(P[a.id])))

            out = Out(width_fn(c.associated, {a.id: pts, other: pb}, np.eye(4)), a.indices[:0], details, width_fn)
            out.mc = (a.id, other)
        else:

            def value_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                return element_distance(
                    _reference(a.type, A[a.id].params, pts), _reference(b.type, A[other].params, pb)
                )

            out = Out(value_fn(c.associated, {}, np.eye(4)), a.indices[:0], details, value_fn, ls=(a.id, other))
    details["nominal"] = nom
    details["deviation"] = out.value - nom if math.isfinite(nom) else None
    return out
