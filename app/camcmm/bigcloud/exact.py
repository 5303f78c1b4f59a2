"""Statistics of a field met in chunks, merged so that the chunking does not change a digit.

* :class:`ExactSum` — the exact sum of float64 values as integers per binary exponent.
  A double is ``M 2^(e-53)`` with an integer ``|M| < 2^53`` (``numpy.frexp``); ``M`` is
  cut into three pieces below ``2^18`` and each piece summed per exponent with
  ``numpy.bincount`` (float64 sums of integers below ``2^53`` are exact for up to
  ``2^35`` values a chunk), then held as Python integers. Sums of chunks add exactly in
  any order; :meth:`ExactSum.value` is the correctly rounded sum, the same number as
  ``math.fsum`` of all the values (Shewchuk 1997), whatever the chunks and their order.
* :class:`Histogram` — counts in bins of a fixed width ``w`` (mm): bin ``k`` holds
  ``k w <= d < (k + 1) w``, with the edges computed as ``float(k) * w`` exactly as the
  test ``numpy.histogram(d, bins=edges)`` does, so merged counts equal a histogram of all
  values over the same edges, to the count. Bins are kept sparse (a dict).
* :func:`hazen` — percentiles by the Hazen rule, ``numpy.percentile(..., method="hazen")``
  done with numpy's own arithmetic (virtual index ``n q + 1/2 - 1``, its ``_lerp``), from
  exact order statistics: the histogram tells the bin of each rank; one more pass over
  the values collects those bins (:func:`order_statistics`). The result equals numpy's
  percentile of all the values held in memory, to the last digit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from fractions import Fraction

import numpy as np

from ..errors import ParameterError

_EXP0 = 1100  # frexp exponents lie in -1073 .. 1024
_NBIN = 2200
_PIECE = 18
_MASK = (1 << _PIECE) - 1


class ExactSum:
    """An exact sum of float64 values (see the module docstring)."""

    def __init__(self) -> None:
        self.parts: dict[int, int] = {}  # exponent e -> integer S: the sum is sum(S 2^(e-53))

    def add(self, values: np.ndarray) -> ExactSum:
        x = np.asarray(values, dtype=np.float64).ravel()
        if x.size > (1 << 35):  # keep every bincount partial sum below 2^53
            for s in range(0, x.size, 1 << 34):
                self.add(x[s : s + (1 << 34)])
            return self
        m, e = np.frexp(x)
        mi = (m * 2.0**53).astype(np.int64)  # exact: |m| < 1
        a = np.abs(mi)
        sign = np.where(mi < 0, -1.0, 1.0)
        idx = e.astype(np.int64) + _EXP0
        sums = [
            np.bincount(idx, weights=sign * ((a >> (_PIECE * j)) & _MASK).astype(np.float64), minlength=_NBIN)
            for j in range(3)
        ]
        for b in np.flatnonzero((sums[0] != 0) | (sums[1] != 0) | (sums[2] != 0)):
            total = sum(int(sums[j][b]) << (_PIECE * j) for j in range(3))
            if total:
                k = int(b) - _EXP0
                self.parts[k] = self.parts.get(k, 0) + total
        return self

    def merge(self, other: ExactSum) -> ExactSum:
        for k, v in other.parts.items():
            self.parts[k] = self.parts.get(k, 0) + v
        return self

    def fraction(self) -> Fraction:
        """The exact sum as a rational number."""
        if not self.parts:
            return Fraction(0)
        lo = min(self.parts)
        total = sum(v << (k - lo) for k, v in self.parts.items())
        return Fraction(total) * Fraction(2) ** (lo - 53)

    def value(self) -> float:
        """The correctly rounded sum (equals ``math.fsum`` of the values)."""
        return float(self.fraction())


class Histogram:
    """Counts in bins ``[k w, (k + 1) w)`` of fixed width ``w`` (see the module docstring)."""

    def __init__(self, width: float):
        if not (math.isfinite(width) and width > 0):
            raise ParameterError(f"bin width {width!r}: must be a finite length above 0 mm")
        self.width = float(width)
        self.counts: dict[int, int] = {}

    def bins(self, d: np.ndarray) -> np.ndarray:
        """The bin ``k`` of each value: ``float(k) * w <= d < float(k + 1) * w``."""
        k = np.floor(d / self.width)
        k -= d < k * self.width  # the division's rounding, corrected against the edges
        k += d >= (k + 1) * self.width
        return k.astype(np.int64)

    def add(self, d: np.ndarray) -> Histogram:
        k, c = np.unique(self.bins(np.asarray(d, dtype=float)), return_counts=True)
        for kk, cc in zip(k.tolist(), c.tolist()):
            self.counts[kk] = self.counts.get(kk, 0) + cc
        return self

    def merge(self, other: Histogram) -> Histogram:
        if other.width != self.width:
            raise ParameterError(f"histograms of bin widths {self.width} and {other.width} do not merge")
        for k, c in other.counts.items():
            self.counts[k] = self.counts.get(k, 0) + c
        return self

    def dense(self) -> tuple[int, np.ndarray, np.ndarray]:
        """(first bin k0, edges (K+1,) mm, counts (K,)) from the lowest to the highest occupied bin."""
        if not self.counts:
            return 0, np.zeros(1), np.zeros(0, dtype=np.int64)
        k0, k1 = min(self.counts), max(self.counts)
        counts = np.zeros(k1 - k0 + 1, dtype=np.int64)
        for k, c in self.counts.items():
            counts[k - k0] = c
        return k0, np.arange(k0, k1 + 2, dtype=np.float64) * self.width, counts


def hazen_positions(n: int, percents: Iterable[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """numpy's Hazen percentile positions for ``n`` sorted values: (previous rank,
    next rank, gamma), ranks 0-based, as ``numpy.percentile`` computes them."""
    q = np.true_divide(np.asarray(list(percents), dtype=np.float64), 100)
    vi = n * q + (0.5 + q * (1 - 0.5 - 0.5)) - 1
    prev = np.floor(vi)
    nxt = prev + 1
    above, below = vi >= n - 1, vi < 0
    prev[above], nxt[above] = -1, -1
    prev[below], nxt[below] = 0, 0
    gamma = vi - prev
    prev_i, next_i = prev.astype(np.int64), nxt.astype(np.int64)
    prev_i[prev_i < 0] += n
    next_i[next_i < 0] += n
    return prev_i, next_i, gamma


def lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """numpy's quantile interpolation, operation by operation."""
    diff = b - a
    out = np.add(a, diff * t)
    np.subtract(b, diff * (1 - t), out=out, where=t >= 0.5)
    return out


def order_statistics(
    hist: Histogram, ranks: np.ndarray, values: Callable[[], Iterable[np.ndarray]], limit: int = 20_000_000
) -> np.ndarray | None:
    """The values of 0-based ``ranks`` in the sorted data, exactly: the bins holding them
    (from ``hist``'s cumulative counts), then one pass over ``values()`` (chunks of the
    data) that keeps the values in those bins. None when those bins hold more than
    ``limit`` values (the caller then states histogram figures instead)."""
    k0, _, counts = hist.dense()
    cum = np.concatenate([[0], np.cumsum(counts)])
    b = np.searchsorted(cum, ranks, side="right") - 1  # cum[b] <= r < cum[b + 1]
    targets = np.unique(b)
    if int(counts[targets].sum()) > limit:
        return None
    want = np.zeros(len(counts), dtype=bool)
    want[targets] = True
    kept_v, kept_b = [], []
    for d in values():
        kb = hist.bins(d) - k0
        ok = (kb >= 0) & (kb < len(counts))
        ok[ok] = want[kb[ok]]
        kept_v.append(d[ok])
        kept_b.append(kb[ok])
    v = np.concatenate(kept_v) if kept_v else np.empty(0)
    kb = np.concatenate(kept_b) if kept_b else np.empty(0, dtype=np.int64)
    order = np.lexsort((v, kb))
    v, kb = v[order], kb[order]
    # position of rank r: the values of earlier target bins, then r - cum[b]
    first = np.searchsorted(kb, b)
    return v[first + (ranks - cum[b])]


def hazen(
    hist: Histogram,
    n: int,
    percents: Iterable[float],
    values: Callable[[], Iterable[np.ndarray]],
    limit: int = 20_000_000,
) -> tuple[np.ndarray, bool]:
    """Hazen percentiles of ``n`` values (see :func:`order_statistics`); ``(values, exact)``.
    Not exact (the bins hold too many values): linear within the histogram's bins."""
    pct = list(percents)
    prev, nxt, gamma = hazen_positions(n, pct)
    ranks = np.concatenate([prev, nxt])
    got = order_statistics(hist, ranks, values, limit)
    if got is not None:
        return lerp(got[: len(prev)], got[len(prev) :], gamma), True
    _, edges, counts = hist.dense()
    cum = np.concatenate([[0], np.cumsum(counts)])
    pos = prev + gamma.clip(0, 1) + 0.5
    return np.interp(pos, cum, edges), False
