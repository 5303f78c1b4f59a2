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
        kb = self.bins(np.asarray(d, dtype=float))
        if kb.size == 0:
            return self
        lo, hi = int(kb.min()), int(kb.max())
        if hi - lo < 4 * kb.size + 1024:  # a compact range: counted, not sorted
            c = np.bincount(kb - lo, minlength=hi - lo + 1)
            k = np.flatnonzero(c)
            k, c = k + lo, c[k]
        else:
            k, c = np.unique(kb, return_counts=True)
        for kk, cc in zip(k.tolist(), c.tolist()):
            self.counts[kk] = self.counts.get(kk, 0) + cc
        return self

    def merge(self, other: Histogram) -> Histogram:
        if other.width != self.width:
            raise ParameterError(f"histograms of bin widths {self.width} and {other.width} do not merge")
        for k, c in other.counts.items():
            self.counts[k] = self.counts.get(k, 0) + c
        return self

    def sparse(self) -> tuple[np.ndarray, np.ndarray]:
        """(occupied bins k, ascending, int64; their counts, int64)."""
        keys = np.array(sorted(self.counts), dtype=np.int64)
        return keys, np.array([self.counts[k] for k in keys.tolist()], dtype=np.int64)

    def dense(self, max_bins: int | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """(edges (K+1,) mm, counts (K,), bins merged per reported bin) from the lowest to
        the highest occupied bin. With ``max_bins`` every ``g`` bins are merged into one
        (``g`` the least whole number giving at most ``max_bins``; edges ``k w`` at
        multiples of ``g`` from the first bin, counts summed exactly)."""
        keys, counts = self.sparse()
        if keys.size == 0:
            return np.zeros(1), np.zeros(0, dtype=np.int64), 1
        k0, span = int(keys[0]), int(keys[-1] - keys[0]) + 1
        g = 1 if max_bins is None else max(1, -(-span // max_bins))
        if span // g > 50_000_000:
            raise ParameterError(
                f"histogram: {span} bins of {self.width} mm between the extreme deviations; use a wider bin"
            )
        out = np.zeros(-(-span // g), dtype=np.int64)
        np.add.at(out, (keys - k0) // g, counts)
        edges = (k0 + g * np.arange(len(out) + 1, dtype=np.int64)).astype(np.float64) * self.width
        return edges, out, g


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


#: Sub-bins a histogram bin is split into when its values are too many to collect.
SUB_BINS = 4096
#: Values collected at most in one pass (8 bytes each, plus their keys).
COLLECT = 2_000_000


def order_statistics(
    hist: Histogram, ranks: np.ndarray, values: Callable[[], Iterable[np.ndarray]], limit: int = 20_000_000
) -> np.ndarray | None:
    """The values of 0-based ``ranks`` in the sorted data, exactly.

    ``hist``'s cumulative counts name the bin holding each rank. When those bins hold
    more than :data:`COLLECT` values, one pass over ``values()`` (the data in chunks)
    counts them in :data:`SUB_BINS` sub-bins each (``floor((d - k w) S / w)``, monotone in
    ``d`` within bin ``k``, so bins and sub-bins keep the values' order) and the ranks are
    located in sub-bins. A last pass collects the values of the bins or sub-bins holding
    the ranks; sorted, they give the ranks' values. None when these hold more than
    ``limit`` values (e.g. one value repeated millions of times; the caller then states
    histogram figures instead)."""
    bins, counts = hist.sparse()  # occupied bins only: their order is the values' order
    cum = np.concatenate([[0], np.cumsum(counts)])
    b = np.searchsorted(cum, ranks, side="right") - 1  # cum[b] <= r < cum[b + 1]
    targets = np.unique(b)
    target_bins = bins[targets]
    slot = np.full(len(counts), -1, dtype=np.int64)
    slot[targets] = np.arange(len(targets))
    local = ranks - cum[b]  # rank within its bin
    n_sub = 1 if int(counts[targets].sum()) <= COLLECT else SUB_BINS

    lo_bin, span = int(target_bins[0]), int(target_bins[-1] - target_bins[0]) + 1
    table = None
    if span <= 1 << 22:  # the target bins' slots by lookup (a search per value is 3x slower)
        table = np.full(span + 2, -1, dtype=np.int64)  # [0] and [-1]: below and above the range
        table[target_bins - lo_bin + 1] = np.arange(len(target_bins))

    def keyed(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(values in the target bins, their key slot * n_sub + sub-bin)."""
        kb = hist.bins(d)
        if table is not None:
            t = table[np.clip(kb - (lo_bin - 1), 0, span + 1)]
            sel = t >= 0
        else:
            t = np.minimum(np.searchsorted(target_bins, kb), len(target_bins) - 1)
            sel = target_bins[t] == kb
        v, t = d[sel], t[sel]
        if n_sub == 1:
            return v, t
        edge = kb[sel].astype(np.float64) * hist.width
        sub = np.clip(np.floor((v - edge) * (n_sub / hist.width)), 0, n_sub - 1).astype(np.int64)
        return v, t * n_sub + sub

    want = slot[b] * n_sub
    sub_counts = None
    if n_sub > 1:  # pass: sub-bin counts of the target bins, then each rank's sub-bin
        sub_counts = np.zeros(len(targets) * n_sub, dtype=np.int64)
        for d in values():
            _, key = keyed(d)
            sub_counts += np.bincount(key, minlength=len(sub_counts))
        per = sub_counts.reshape(len(targets), n_sub).cumsum(axis=1)
        row = per[slot[b]]
        s = np.array([np.searchsorted(c, q, side="right") for c, q in zip(row, local)], dtype=np.int64)
        below = np.where(s > 0, np.take_along_axis(row, np.maximum(s - 1, 0)[:, None], axis=1)[:, 0], 0)
        want, local = want + s, local - below
    keys = np.unique(want)
    held = int(counts[targets].sum()) if sub_counts is None else int(sub_counts[keys].sum())
    if held > limit:
        return None
    is_wanted = np.zeros(len(targets) * n_sub, dtype=bool)
    is_wanted[keys] = True
    kept_v, kept_k = [], []
    for d in values():
        v, key = keyed(d)
        m = is_wanted[key]
        kept_v.append(v[m])
        kept_k.append(key[m])
    v = np.concatenate(kept_v) if kept_v else np.empty(0)
    kk = np.concatenate(kept_k) if kept_k else np.empty(0, dtype=np.int64)
    order = np.lexsort((v, kk))
    v, kk = v[order], kk[order]
    return v[np.searchsorted(kk, want) + local]


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
    bins, counts = hist.sparse()
    cum = np.concatenate([[0], np.cumsum(counts)])
    pos = prev + gamma.clip(0, 1) + 0.5  # rank as a position along the counts
    j = np.clip(np.searchsorted(cum, pos, side="right") - 1, 0, len(counts) - 1)
    frac = np.clip((pos - cum[j]) / counts[j], 0.0, 1.0)
    return (bins[j] + frac) * hist.width, False
