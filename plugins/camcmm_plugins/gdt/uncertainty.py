"""Standard uncertainty of a characteristic and its ISO 14253-1 verdicts.

u (k = 1) combines, in quadrature, the parts that apply (the result's ``u_method``
names them, ``details["u_parts"]`` gives each):

* **covariance of the least-squares fit** — for a value computed from associated
  elements (an axis or centre position, a diameter, a distance, an orientation of an
  axis, a symmetry), and for the datum frame when its features are least-squares. Each
  element carries the covariance of its least-squares fit over its global parameters
  (``point_x`` ... ``diameter``; :func:`.features.ls_covariance`): ``s² (JᵀJ)⁻¹``,
  ``s² = Σr²/(n − p)``. (A toleranced element associated otherwise, e.g. an axis by
  minimum zone, enters with the least-squares covariance of its points at that element:
  an approximation.) The value's gradient over all those parameters is taken
  numerically (central differences, 1e-7 mm or unit-vector component) and
  u² = Σ_f g_f C_f g_fᵀ (features independent).
* **Monte Carlo of the points** — for a value that is an extreme of the points (form by
  minimum zone, orientation or position of a surface, profile, runout; and a width,
  which :func:`.size.width` refits to both faces at once): the value is recomputed
  :data:`MC_REPLICATES` (= 30) times with every point of the toleranced feature(s)
  moved by independent N(0, σ²) per coordinate; u is the standard deviation of the
  replicates (seed fixed: reproducible; a replicate whose zone does not converge is
  left out, and u is not given when half of them fail).
* **Monte Carlo of the datum frame** — datum features associated otherwise than by
  least squares (the ISO 5459 tangent default: an extreme of their points) are
  re-associated by their own criterion in :data:`MC_DATUM_REPLICATES` (= 20) replicates
  of their points; the value's standard deviation over the replicated frames, the
  toleranced feature held, is their part.

σ, the point noise of a feature: the plan's ``point_noise`` (in its unit) when it states
one (a lab knows its instrument's probing noise), else estimated from the differences of
the residuals of nearest neighbours, σ² = mean((r_i − r_nn(i))²)/2 — smooth form error
cancels in them, form that changes from point to point counts as noise. A feature whose
σ is below :data:`NOISELESS` contributes 0. Noise added to points that already carry it
makes the Monte Carlo conservative for an extreme: by simulation the spread of the
maximum of 30 .. 3000 normal deviates comes out 1.25–1.35 times its true standard
deviation (tests/gdt/test_uncertainty.py: 1.36 for a tangent datum plane).

Verdicts (ISO 14253-1:2017, through :mod:`camcmm.api`'s conformity rules): a zone value
v with tolerance t conforms when v ≤ t (simple) / v ≤ t − U (guarded), does not conform
when v > t (simple) / v > t + U, is ``undecided`` in between; a size deviation d with
limits [lower, upper] the same on the interval. U = k·u.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from camcmm.api import GeometryError, guarded_verdict, simple_verdict

from . import features
from .model import Associated

MC_REPLICATES = 30
#: Replicates of the datum frame when datum features are not least-squares (each one
#: re-associates them: fewer, to keep an evaluation fast).
MC_DATUM_REPLICATES = 20
MC_SEED = 27
#: Point noise (mm) below which a feature is taken as noiseless (its Monte Carlo part 0).
NOISELESS = 1e-9
_H = 1e-7  # step of the numerical Jacobians (mm, rad)

_WORDS = {"pass": "conform", "fail": "not conform", "inconclusive": "undecided", "incomplete": "not evaluated"}


def covariance(assoc: Associated, pts: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]] | None:
    """The element's covariance over its global parameter names (``point_x`` ...
    ``diameter``, :func:`.features.ls_covariance`): the least-squares association's own,
    or for another association the least-squares covariance of the same points at the
    associated element (an approximation: module docstring). None without degrees of
    freedom."""
    if assoc.covariance is not None and len(assoc.covariance_names):
        return np.asarray(assoc.covariance, dtype=float), tuple(assoc.covariance_names)
    cov, names = features.ls_covariance(pts, assoc.type, assoc.params)
    return None if cov is None else (cov, names)


def moved(params: dict[str, Any], name: str, h: float) -> dict[str, Any]:
    """``params`` with the global parameter ``name`` (``point_x``, ``diameter``, ...)
    changed by h (mm; unit-vector component; degrees for a cone's angle)."""
    q = dict(params)
    key, _, comp = name.rpartition("_")
    if key and comp in "xyz" and len(comp) == 1 and key in q:
        v = np.array(q[key], dtype=float)
        v["xyz".index(comp)] += h
        q[key] = v
    else:
        q[name] = float(q[name]) + h
    return q


def propagate(
    value: Callable[[dict[str, Associated]], float],
    associated: dict[str, Associated],
    covs: dict[str, tuple[np.ndarray, tuple[str, ...]]],
) -> float:
    """Standard uncertainty of ``value(associated)`` from the independent covariances
    ``covs`` (feature id -> (C, names)): u² = Σ_f g_f C_f g_fᵀ, g_f the value's gradient
    over feature f's global parameters (central differences)."""
    var = 0.0
    for fid, (cov, names) in covs.items():
        a = associated[fid]
        g = np.empty(len(names))
        for j, name in enumerate(names):
            up = {**associated, fid: replace(a, params=moved(a.params, name, _H))}
            dn = {**associated, fid: replace(a, params=moved(a.params, name, -_H))}
            g[j] = (value(up) - value(dn)) / (2 * _H)
        var += float(g @ cov @ g)
    return math.sqrt(max(var, 0.0)) if math.isfinite(var) else float("nan")


def noise_sigma(pts: np.ndarray, residuals: np.ndarray) -> float:
    """Point noise (mm) of a feature from nearest-neighbour residual differences."""
    if len(pts) < 3:
        return float("nan")
    _, nn = cKDTree(pts).query(pts, k=2)
    d = residuals - residuals[nn[:, 1]]
    return math.sqrt(float(np.mean(d * d)) / 2.0)


def monte_carlo(value: Callable[[dict[str, np.ndarray]], float], clouds: dict[str, tuple[np.ndarray, float]]) -> float:
    """Standard deviation of ``value(points by feature id)`` over MC_REPLICATES copies of
    ``clouds`` (feature id -> (points (n, 3), σ mm)) with N(0, σ²) added per coordinate."""
    clouds = {fid: ps for fid, ps in clouds.items() if not ps[1] <= NOISELESS}
    if not clouds:
        return 0.0
    rng = np.random.default_rng(MC_SEED)
    vals = []
    for _ in range(MC_REPLICATES):
        moved = {fid: p + rng.normal(0.0, s, p.shape) for fid, (p, s) in clouds.items()}
        try:
            vals.append(value(moved))
        except GeometryError:  # a replicate whose zone did not converge: left out
            continue
    if len(vals) < MC_REPLICATES // 2:
        return float("nan")
    return float(np.std(vals, ddof=1))


def zone_verdicts(value: float | None, tolerance: float | None, u: float | None, k: float) -> tuple[str, str]:
    """(simple, guarded) verdict words of a zone value against its tolerance."""
    if value is None or tolerance is None or not math.isfinite(value):
        return "not evaluated", "not evaluated"
    simple = _WORDS[simple_verdict(value, tolerance)]
    if u is None or not math.isfinite(u):
        return simple, "not evaluated"
    return simple, _WORDS[guarded_verdict(value, tolerance, k * u)]


def size_verdicts(
    deviation: float | None, lower: float | None, upper: float | None, u: float | None, k: float
) -> tuple[str, str]:
    """(simple, guarded) verdicts of a size deviation against [lower, upper] (a missing
    limit is open on that side)."""
    if deviation is None or not math.isfinite(deviation) or (lower is None and upper is None):
        return "not evaluated", "not evaluated"
    lo = -math.inf if lower is None else lower
    hi = math.inf if upper is None else upper
    if math.isinf(lo) or math.isinf(hi):  # one-sided: shift the open side far away
        span = 1e9
        lo, hi = (hi - span, hi) if math.isinf(lo) else (lo, lo + span)
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    simple = _WORDS[simple_verdict(deviation - centre, half)]
    if u is None or not math.isfinite(u):
        return simple, "not evaluated"
    return simple, _WORDS[guarded_verdict(deviation - centre, half, k * u)]


def combined(*parts: float) -> float:
    vals = [p for p in parts if p is not None]
    return math.sqrt(sum(p * p for p in vals)) if all(math.isfinite(p) for p in vals) else float("nan")
