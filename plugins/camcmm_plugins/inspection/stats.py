"""Statistics of a deviation field: mean, standard deviation, RMS, extremes, percentiles,
the central interval holding 95 % of the deviations, the share within a tolerance and
a histogram.

Percentiles use the Hazen plotting position ``(k - 1/2) / n`` (``numpy.percentile(...,
method="hazen")``), the same convention as the material-ratio curve of
:mod:`.material_ratio`, so "95 % of the deviations lie within p2.5 .. p97.5" reads the
same from the statistics and from the Abbott-Firestone curve (the thesis, ch. 6.1:
"95 % of topography differences lie within +24 µm / −33 µm").
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError

#: Percentiles reported besides the 95 % interval (keys ``p0_5`` ... ``p99_5``).
PERCENTILES = (0.5, 2.5, 5.0, 25.0, 50.0, 75.0, 95.0, 97.5, 99.5)


def _key(p: float) -> str:
    return "p" + f"{p:g}".replace(".", "_")


def deviation_stats(dev: Any, tolerance: float | None = None) -> dict[str, Any]:
    """Statistics of the finite values of ``dev`` (mm).

    Keys: ``n``, ``n_invalid`` (NaN/Inf left out), ``mean``, ``std`` (sample, n - 1),
    ``rms``, ``min``, ``max``, ``max_abs``, ``p0_5`` ... ``p99_5`` (see
    :data:`PERCENTILES`; ``p2_5`` and ``p97_5`` bound the central 95 %), ``interval95``
    [p2.5, p97.5], and with a ``tolerance`` T: ``tolerance`` and ``within_tolerance``
    (share of |dev| <= T, 0..1).
    """
    d = np.asarray(dev, dtype=float).ravel()
    ok = np.isfinite(d)
    n_bad = int(d.size - ok.sum())
    d = d[ok] if n_bad else d
    if d.size == 0:
        raise InputError("deviation statistics: no finite deviations")
    mean = float(d.mean())
    out: dict[str, Any] = {
        "n": int(d.size),
        "n_invalid": n_bad,
        "mean": mean,
        "std": float(d.std(ddof=1)) if d.size > 1 else 0.0,
        "rms": float(np.sqrt(np.mean(d * d))),
        "min": float(d.min()),
        "max": float(d.max()),
    }
    out["max_abs"] = max(abs(out["min"]), abs(out["max"]))
    pct = np.percentile(d, PERCENTILES, method="hazen")
    out.update({_key(p): float(v) for p, v in zip(PERCENTILES, pct)})
    out["interval95"] = [out["p2_5"], out["p97_5"]]
    if tolerance is not None:
        out["tolerance"] = float(tolerance)
        out["within_tolerance"] = float(np.mean(np.abs(d) <= tolerance))
    return out


def histogram(dev: Any, bins: int | str = "auto", max_bins: int = 200, limit: float | None = None) -> dict[str, Any]:
    """Histogram of the finite deviations: ``edges`` (mm, length k+1), ``counts`` (k).

    ``bins`` as numpy takes it ("auto", "fd", an int); more than ``max_bins`` bins are
    reduced to ``max_bins`` (a GUI draws them as bars). With ``limit`` the range is
    symmetric, ±max(limit, max|dev|), so 0 sits on a bin edge and the bars line up
    with a colour scale of ±limit.
    """
    d = np.asarray(dev, dtype=float).ravel()
    d = d[np.isfinite(d)]
    if d.size == 0:
        raise InputError("histogram: no finite deviations")
    rng = None
    if limit is not None and limit > 0:
        half = max(float(limit), float(np.abs(d).max()))
        rng = (-half, half)
    if bins in ("auto", "fd"):
        # numpy makes (range / width) bins, the width from the data (auto: the smaller of
        # Freedman-Diaconis and Sturges, ptp / (log2 n + 1)): a near-constant set (every
        # deviation 3 µm to an exact surface, rounding apart) over a range set by ``limit``
        # asked for petabytes; such a width is cut to max_bins below anyway
        lo, hi = rng if rng is not None else (float(d.min()), float(d.max()))
        q25, q75 = np.percentile(d, [25, 75])
        fd = 2 * (q75 - q25) / d.size ** (1 / 3)
        sturges = float(np.ptp(d)) / (np.log2(d.size) + 1)
        width = fd if bins == "fd" else (min(fd, sturges) if fd > 0 else sturges)
        if hi > lo and 0 < width < (hi - lo) / max_bins:
            bins = max_bins
    edges = np.histogram_bin_edges(d, bins=bins, range=rng)
    if edges.size - 1 > max_bins:
        edges = np.histogram_bin_edges(d, bins=max_bins, range=rng)
    counts, edges = np.histogram(d, bins=edges)
    return {"edges": edges, "counts": counts, "unit": "mm"}
