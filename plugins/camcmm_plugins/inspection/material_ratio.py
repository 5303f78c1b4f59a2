"""The material-ratio (Abbott-Firestone) curve and the ISO 13565-2 / ISO 25178-2
functional parameters Sk, Spk, Svk, Smr1, Smr2, the inverse Smc(mr) and the volume
parameters Vmp, Vmc, Vvc, Vvv.

Works on any set of heights: a height map (ISO 25178-2, areal) or a field of signed
deviations from a nominal (the thesis, ch. 6.1, draws "Abbott-Firestone curves" of the
topography differences between CSI and photogrammetry). Heights keep the caller's unit
and datum; material ratios are fractions 0..1 inside and percent in :func:`parameters`,
as the standards print them.

The curve
---------
The heights are sorted from the highest to the lowest, ``h_1 >= h_2 >= ... >= h_N``. Each
represents an equal share of the evaluated area (or the share ``w_i / W`` given in
``weights``, e.g. the area each point of an irregular cloud stands for). Height ``h_i``
is placed at the middle of its share::

    mr_i = (w_1 + ... + w_(i-1) + w_i / 2) / W        (= (i - 1/2) / N for equal shares)

and the material-ratio curve ``c(mr)`` is the piecewise-linear line through the nodes
``(0, h_1), (mr_1, h_1), (mr_2, h_2), ..., (mr_N, h_N), (1, h_N)``. For equal shares
``c(mr)`` equals the Hazen quantile of the heights at ``1 - mr``
(``numpy.percentile(h, 100 (1 - mr), method="hazen")``), so the percentiles of
:mod:`.stats` and the curve agree. ``Smr(c)``, the areal material ratio at height c, is
the share of the curve above c; ``Smc(mr) = c(mr)`` is its inverse.

The construction (ISO 13565-2:1996 clause 4, used by ISO 25178-2:2012 for Sk ...)
-----------------------------------------------------------------------------------
1. **Secant of least gradient over 40 %.** For every start ``a`` in [0, 60 %] the secant
   joins ``(a, c(a))`` and ``(a + 40 %, c(a + 40 %))``; its drop is
   ``g(a) = c(a) - c(a + 40 %)``. The secant with the least drop (least gradient) is the
   *equivalent straight line* of the core. ``g`` is piecewise linear in ``a`` with
   breakpoints where ``a`` or ``a + 40 %`` meets a node, so its minimum lies on one of
   those breakpoints: all of them are evaluated and the search is exact, not a grid
   search. Equally small drops (a straight core) keep the first, smallest ``a``. The
   secant's ends are kept within ``[mr_1, mr_N]``: the flat end pieces of the curve are
   an artefact of sampling (with them, N uniform heights would give Sk = R (1 - 1/0.8N)
   instead of R).
2. **Core height.** The equivalent straight line ``L(mr) = c(a) - g (mr - a) / 40 %`` is
   extended to ``mr = 0`` and ``mr = 100 %``: ``C1 = L(0)`` and ``C2 = L(100 %)``.
   ``Sk = C1 - C2 = g / 0.4``.
3. **Smr1, Smr2.** The horizontal lines at ``C1`` and ``C2`` cut the material-ratio curve at
   ``Smr1 = Smr(C1)`` and ``Smr2 = Smr(C2)`` (percent): the share of the surface above the
   core and the share above the bottom of the core. If ``C1`` lies above the highest
   point, ``Smr1 = 0``; if ``C2`` lies below the lowest, ``Smr2 = 100 %``.
4. **Equal-area triangles.** The peak area ``A1 = ∫_0^Smr1 (c(mr) - C1) dmr`` (the area of
   the curve above ``C1``) is replaced by a right-angled triangle with base ``Smr1`` and
   the same area; its height is ``Spk = 2 A1 / Smr1``. Likewise the valley area
   ``A2 = ∫_Smr2^100% (C2 - c(mr)) dmr`` gives ``Svk = 2 A2 / (100 % - Smr2)``.
   ``Spk = 0`` when ``Smr1 = 0`` and ``Svk = 0`` when ``Smr2 = 100 %`` (no area, no base).
   Both integrals are exact for the piecewise-linear curve (the segment that crosses the
   line is split where it crosses).

Volume parameters (ISO 25178-2 clause 4.4.2, ``p = 10 %``, ``q = 80 %``): with
``Vm(mr) = ∫_0^mr (c(m) - c(mr)) dm`` and ``Vv(mr) = ∫_mr^100% (c(mr) - c(m)) dm``
(volume per unit area, in the height unit): ``Vmp = Vm(p)``, ``Vmc = Vm(q) - Vm(p)``,
``Vvc = Vv(p) - Vv(q)``, ``Vvv = Vv(q)``.

Known answers (tests/test_inspection_material_ratio.py): Gaussian heights of standard
deviation σ have ``c(mr) = σ Φ⁻¹(1 - mr)``; the flattest 40 % secant is centred at 50 %,
so ``Sk = 2 σ Φ⁻¹(0.7) / 0.4 = 2.6220 σ``, ``Smr1 = 100 % - Smr2 = 1 - Φ(1.3110) =
9.49 %``. Uniform heights over a range R have a straight curve: every secant is the
curve itself, ``Sk = R`` (the full range, × 1), ``Smr1 = 0``, ``Smr2 = 100 %``,
``Spk = Svk = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import InputError, ParameterError

#: Width of the secant window in ISO 13565-2 (40 % of material ratio).
WINDOW = 0.4


@dataclass
class MaterialRatioCurve:
    """The material-ratio curve as nodes of a piecewise-linear line.

    ``mr`` (fractions 0..1, non-decreasing, first 0 and last 1) and ``height``
    (non-increasing, in the unit of the input heights); ``n`` heights were used.
    """

    mr: np.ndarray
    height: np.ndarray
    n: int
    _cum: np.ndarray | None = field(default=None, repr=False)  # running ∫ h dmr at the nodes

    def smc(self, mr: Any) -> np.ndarray | float:
        """Inverse areal material ratio: the height ``c`` at material ratio ``mr`` (0..1)."""
        m = np.asarray(mr, dtype=float)
        if np.any((m < 0) | (m > 1)):
            raise ParameterError(f"material ratio {mr!r} must lie between 0 and 1")
        out = np.interp(m, self.mr, self.height)
        return float(out) if out.ndim == 0 else out

    def smr(self, c: Any) -> np.ndarray | float:
        """Areal material ratio at height ``c``: the share (0..1) of the curve above ``c``."""
        cc = np.atleast_1d(np.asarray(c, dtype=float))
        H, M = self.height, self.mr
        # H is non-increasing: the number of nodes strictly above c
        k = np.searchsorted(-H, -cc, side="left")
        out = np.empty_like(cc)
        top, bottom = k == 0, k >= len(H)
        out[top] = 0.0
        out[bottom] = 1.0
        mid = ~(top | bottom)
        j = k[mid]
        h0, h1 = H[j - 1], H[j]
        m0, m1 = M[j - 1], M[j]
        frac = np.where(h0 > h1, (h0 - cc[mid]) / np.where(h0 > h1, h0 - h1, 1.0), 0.0)
        out[mid] = m0 + frac * (m1 - m0)
        return float(out[0]) if np.ndim(c) == 0 else out

    def area_above(self, c: float) -> float:
        """Exact ∫ max(h(mr) - c, 0) dmr over the piecewise-linear curve.

        The curve falls, so h - c is positive on a prefix of the nodes: the sum of the
        trapezoids before the crossing (from the running integral, computed once) plus
        the triangle up to it. O(log N) per call instead of a pass over all nodes."""
        M, H = self.mr, self.height
        if self._cum is None:
            self._cum = np.concatenate([[0.0], np.cumsum(0.5 * (H[:-1] + H[1:]) * np.diff(M))])
        k = int(np.searchsorted(-H, -c, side="left"))  # nodes with H > c
        if k == 0:
            return 0.0
        j = k - 1  # the last node above c
        area = float(self._cum[j] - c * (M[j] - M[0]))
        if k < len(H) and H[j] > H[k]:
            area += 0.5 * (H[j] - c) ** 2 / (H[j] - H[k]) * (M[k] - M[j])
        return area

    def area_below(self, c: float) -> float:
        """Exact ∫ max(c - h(mr), 0) dmr: ∫ (c - h) dmr plus :meth:`area_above`."""
        self.area_above(c)  # makes the running integral
        assert self._cum is not None
        return float(c * (self.mr[-1] - self.mr[0]) - self._cum[-1]) + self.area_above(c)

    def resampled(self, n: int = 1001) -> dict[str, np.ndarray]:
        """The curve on ``n`` equally spaced material ratios (percent) for plots and JSON."""
        mr = np.linspace(0.0, 1.0, n)
        return {"mr_percent": mr * 100.0, "height": np.interp(mr, self.mr, self.height)}


def material_ratio_curve(heights: Any, weights: Any = None, presorted: np.ndarray | None = None) -> MaterialRatioCurve:
    """The material-ratio curve of ``heights`` (any shape; NaN entries are left out).

    ``weights`` (same shape, >= 0) is the share of area each height stands for; by
    default all are equal, as for the pixels of a height map. ``presorted``: the finite
    heights sorted ascending, if at hand (unweighted only; ``stats.sorted_finite``).
    """
    if presorted is not None and weights is None:
        heights = presorted[::-1]  # falling already: the sort below finds nothing to do
    h = np.asarray(heights, dtype=float).ravel()
    if weights is None:
        w = None
        keep = np.isfinite(h)
    else:
        w = np.asarray(weights, dtype=float).ravel()
        if w.shape != h.shape:
            raise InputError(f"material ratio: {w.size} weights for {h.size} heights")
        if np.any(w[np.isfinite(w)] < 0):
            raise InputError("material ratio: weights must not be negative")
        keep = np.isfinite(h) & np.isfinite(w) & (w > 0)
    h = h if keep.all() else h[keep]  # no copy of a clean field
    if h.size < 2:
        raise InputError(f"material ratio: {h.size} finite heights; need at least 2")
    if w is None:
        hs = h if presorted is not None else np.sort(h)[::-1]
        n = hs.size
        mr = (np.arange(n, dtype=float) + 0.5) / n
    else:
        order = np.argsort(-h, kind="stable")
        hs = h[order]
        ws = w[keep][order]
        cw = np.cumsum(ws)
        total = cw[-1]
        mr = (cw - 0.5 * ws) / total
        n = hs.size
    if not hs[0] > hs[-1]:
        # a perfectly flat field has no curve to speak of; keep it defined (Sk = 0)
        pass
    M = np.concatenate([[0.0], mr, [1.0]])
    H = np.concatenate([[hs[0]], hs, [hs[-1]]])
    return MaterialRatioCurve(M, H, int(n))


def least_gradient_secant(curve: MaterialRatioCurve, window: float = WINDOW) -> tuple[float, float]:
    """Start ``a`` (0..1) and drop ``g = c(a) - c(a + window)`` of the flattest secant.

    Exact for the piecewise-linear curve: ``g(a)`` is piecewise linear with breakpoints
    at the nodes and at the nodes shifted by ``-window``, so the minimum is on one of them.
    Ties (a straight core) keep the smallest ``a``.
    """
    M, H = curve.mr, curve.height
    # the secant's ends stay between the first and the last height's own position: the
    # flat pieces before mr_1 and after mr_N only say that a height stands for a share
    # of the area, and a secant over them would be flatter than the surface is
    first, last = M[1], M[-2] - window
    if last < first:  # very few heights: allow the whole range
        first, last = 0.0, 1.0 - window
    # g on the three candidate sets, each sorted by itself (no sort of their union); at
    # the nodes c(a) is the node's height (np.interp returns it there); the first
    # (smallest a) of the minima wins, as over their union
    at = (M >= first) & (M <= last)
    shifted = M - window
    sh = (shifted >= first) & (shifted <= last)
    a_sets = (M[at], shifted[sh], np.array([first, last]))
    g_sets = (
        H[at] - np.interp(M[at] + window, M, H),
        np.interp(a_sets[1], M, H) - np.interp(a_sets[1] + window, M, H),
        np.interp(a_sets[2], M, H) - np.interp(a_sets[2] + window, M, H),
    )
    gmin = min(float(g.min()) for g in g_sets if g.size)
    tol = 1e-12 * max(float(H[0] - H[-1]), 1e-300)
    best_a, best_g = np.inf, 0.0
    for a, g in zip(a_sets, g_sets):
        i = np.flatnonzero(g <= gmin + tol)
        if i.size and a[i[0]] < best_a:
            best_a, best_g = float(a[i[0]]), float(g[i[0]])
    return best_a, best_g


def iso13565(curve: MaterialRatioCurve, window: float = WINDOW) -> dict[str, float]:
    """Sk, Spk, Svk (height unit), Smr1, Smr2 (percent) and the construction behind them.

    Also returns ``C1``, ``C2`` (heights of the core's top and bottom), ``secant_start``
    and ``secant_end`` (percent), ``A1`` and ``A2`` (peak and valley areas, height × 1
    of material ratio). See the module docstring for the construction.
    """
    a, g = least_gradient_secant(curve, window)
    ca = float(np.interp(a, curve.mr, curve.height))
    slope = g / window  # height drop per unit material ratio
    C1 = ca + slope * a
    C2 = ca - slope * (1.0 - a)
    smr1 = float(curve.smr(C1))
    smr2 = float(curve.smr(C2))
    A1 = curve.area_above(C1)
    A2 = curve.area_below(C2)
    spk = 2.0 * A1 / smr1 if smr1 > 0 else 0.0
    svk = 2.0 * A2 / (1.0 - smr2) if smr2 < 1 else 0.0
    return {
        "Sk": C1 - C2,
        "Spk": spk,
        "Svk": svk,
        "Smr1": 100.0 * smr1,
        "Smr2": 100.0 * smr2,
        "C1": C1,
        "C2": C2,
        "secant_start": 100.0 * a,
        "secant_end": 100.0 * (a + window),
        "A1": A1,
        "A2": A2,
    }


def volume_parameters(curve: MaterialRatioCurve, p: float = 0.10, q: float = 0.80) -> dict[str, float]:
    """Vmp, Vmc, Vvc, Vvv (ISO 25178-2, volume per unit area in the height unit)."""
    if not 0 < p < q < 1:
        raise ParameterError(f"volume parameters need 0 < p < q < 1, got p={p}, q={q}")

    def vm(mr: float) -> float:
        return curve.area_above(float(curve.smc(mr)))

    def vv(mr: float) -> float:
        return curve.area_below(float(curve.smc(mr)))

    return {"Vmp": vm(p), "Vmc": vm(q) - vm(p), "Vvc": vv(p) - vv(q), "Vvv": vv(q)}


def parameters(
    heights: Any,
    weights: Any = None,
    window: float = WINDOW,
    curve_points: int = 1001,
    presorted: np.ndarray | None = None,
) -> dict[str, Any]:
    """Everything about the material ratio of ``heights``, as JSON-able data.

    Keys: ``Sk Spk Svk Smr1 Smr2`` (ISO 13565-2 / 25178-2; Smr in percent), the
    construction (``C1 C2 secant_start secant_end A1 A2``), ``Vmp Vmc Vvc Vvv``,
    ``Smc`` (heights at material ratios 2.5, 10, 50, 80, 97.5 %: "95 % lie within
    Smc(2.5 %) .. Smc(97.5 %)"), ``n`` and ``curve`` {``mr_percent``, ``height``} on
    ``curve_points`` equally spaced ratios, for plots. ``presorted``: see
    :func:`material_ratio_curve`.
    """
    curve = material_ratio_curve(heights, weights, presorted)
    out: dict[str, Any] = dict(iso13565(curve, window))
    out.update(volume_parameters(curve))
    out["Smc"] = {f"{m:g}": float(curve.smc(m / 100.0)) for m in (2.5, 10.0, 50.0, 80.0, 97.5)}
    out["n"] = curve.n
    out["curve"] = curve.resampled(curve_points)
    return out


def level(heights: np.ndarray) -> np.ndarray:
    """A 2-D height map minus its least-squares plane over the pixel grid (NaN kept).

    Tilt removal only: the residuals of a plane fit do not depend on the pixel pitch.
    """
    z = np.asarray(heights, dtype=float)
    if z.ndim != 2:
        raise InputError(f"height map: levelling needs a 2-D array, got shape {z.shape}")
    yy, xx = np.indices(z.shape, dtype=float)
    ok = np.isfinite(z)
    if ok.sum() < 3:
        raise InputError("height map: fewer than 3 finite heights, cannot level")
    A = np.column_stack([xx[ok], yy[ok], np.ones(int(ok.sum()))])
    coef, *_ = np.linalg.lstsq(A, z[ok], rcond=None)
    return z - (coef[0] * xx + coef[1] * yy + coef[2])
