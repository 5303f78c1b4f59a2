"""Runout of ISO 1101 (circular and total, radial and axial) about a datum axis; the
definition as computed is in :mod:`.characteristics`' docstring."""

from __future__ import annotations

import numpy as np

from . import elements as el
from .case import Case, NotEvaluated, Out, need, to_global
from .model import Associated


def runout(c: Case) -> Out:
    a = c.assoc()
    pts = c.pts()
    o, z = c.datum_axis()
    t0 = c.transform()
    axial = a.type == "plane"
    need(len(pts), 3, f"{c.spec.id}: {c.spec.type}")
    n_sec = int(c.spec.options.get("sections") or max(1, min(20, len(pts) // 50)))
    total = c.spec.type == "total-runout"

    def coords(P: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = el.apply(t, P) - o
        h = q @ z
        rho = np.linalg.norm(q - np.outer(h, z), axis=1)
        return (h, rho) if axial else (rho, h)  # (measured, slicing coordinate)

    def runout(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> tuple[float, np.ndarray]:
        m, s = coords(P[a.id], c.transform_of(A, t))
        if total:
            return float(np.ptp(m)), np.array([int(np.argmax(m)), int(np.argmin(m))])
        edges = np.linspace(s.min(), s.max(), n_sec + 1)
        best, dec = -1.0, np.zeros(0, dtype=np.int64)
        for i in range(n_sec):
            sel = np.flatnonzero((s >= edges[i]) & (s <= edges[i + 1]))
            if len(sel) < 3:
                continue
            r = float(np.ptp(m[sel]))
            if r > best:
                best, dec = r, sel[[int(np.argmax(m[sel])), int(np.argmin(m[sel]))]]
        return best, dec

    value, dec = runout(c.associated, {a.id: pts}, t0)
    if value < 0:
        raise NotEvaluated(f"{c.spec.id}: no section holds 3 points")
    return Out(
        value,
        to_global(a, dec),
        {"sections": 1 if total else n_sec, "direction": "axial" if axial else "radial"},
        lambda A, P, t: runout(A, P, t)[0],
        mc=(a.id,),
        ls=c.datum_features(),
    )
