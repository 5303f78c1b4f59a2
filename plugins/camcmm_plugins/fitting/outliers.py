"""Outlier rules: which points a least-squares fit may drop, named and exact.

``none``
    Every point is used.
``vdi2634``
    VDI/VDE 2634 part 2 (thesis ch. 2.7.1, 5.3): remove ``m = floor(3 N / 1000)`` points
    — at most 3 of every 1000 — one at a time, each time the point with the largest
    absolute residual of the current fit (ties: the lowest index), refitting after
    each removal. With fewer than 334 points nothing is removed. The implementation
    (:func:`vdi2634`) keeps O(1) sufficient statistics per removal
    (:mod:`.downdate`) and removes exactly the points of the naive loop
    (:func:`vdi2634_naive`), which a test checks; the parameters are those of a final
    exact fit to the kept points.
``percent:P``
    ISO 10360-8 style (thesis ch. 4.5.1 uses P = 5): fit all points, remove the
    ``k = floor(P N / 100)`` points with the largest absolute residuals (ties: lower
    index first), refit once. 0 ≤ P < 100.
``sigma:K``
    Iterative K-sigma rejection: fit, compute ``s = sqrt(Σ r² / (n − p))`` over the n
    points in use (p free parameters), remove every point with ``|r| > K s``, refit;
    repeat until no point is removed. Removed points are never re-admitted. K > 0.

Every rule works on least-squares residuals; with ``method="minzone"`` the
minimum-zone element is fitted to the points the rule kept.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from camcmm.api import GeometryError, ParameterError

from ._geometry import LMResult
from .downdate import HypersphereDowndater, MomentsDowndater


@dataclass(frozen=True)
class Rule:
    """A parsed outlier rule: ``name`` in none/vdi2634/percent/sigma, ``value`` P or K."""

    name: str
    value: float | None = None

    def __str__(self) -> str:
        return self.name if self.value is None else f"{self.name}:{self.value:g}"


def parse_rule(text: str | Rule | None) -> Rule:
    """Parse ``"none"``, ``"vdi2634"``, ``"percent:P"`` or ``"sigma:K"``; raise
    ParameterError naming the fault otherwise."""
    if isinstance(text, Rule):
        return text
    t = (text or "none").strip().lower()
    if t in ("none", "vdi2634"):
        return Rule(t)
    name, sep, val = t.partition(":")
    if name in ("percent", "sigma") and sep:
        try:
            v = float(val)
        except ValueError:
            raise ParameterError(f"outlier rule {text!r}: {val!r} is not a number") from None
        if name == "percent" and not 0 <= v < 100:
            raise ParameterError(f"outlier rule {text!r}: P must be at least 0 and below 100")
        if name == "sigma" and not (v > 0 and math.isfinite(v)):
            raise ParameterError(f"outlier rule {text!r}: K must be a positive number")
        return Rule(name, v)
    raise ParameterError(f"unknown outlier rule {text!r}; use none, vdi2634, percent:P or sigma:K")


def vdi2634_count(n: int) -> int:
    """Number of points the vdi2634 rule removes from n: floor(3 n / 1000)."""
    return (3 * n) // 1000


def _abs_residuals(model, res: LMResult, yt: np.ndarray) -> np.ndarray:
    return np.abs(model.residuals(res.state, yt))


def _left(model, n_left: int, rule: str) -> None:
    if n_left <= model.n_params:
        raise GeometryError(
            f"outlier rule {rule} would leave {n_left} points, too few for a {model.element} "
            f"with {model.n_params} parameters"
        )


def apply(
    model, y: np.ndarray, rule: Rule, max_iter: int = 100, fast: bool = True
) -> tuple[np.ndarray, np.ndarray, LMResult]:
    """Fit ``model`` to normalised points y (columns, (d, N)) with the outlier rule.

    Returns (used mask, removed indices in removal order, final least-squares fit of
    the used points).
    """
    n = y.shape[1]
    used = np.ones(n, dtype=bool)
    res = model.fit(y, max_iter=max_iter)
    if rule.name == "none":
        return used, np.zeros(0, dtype=np.int64), res
    if rule.name == "percent":
        k = int(math.floor(rule.value * n / 100.0))
        if k == 0:
            return used, np.zeros(0, dtype=np.int64), res
        _left(model, n - k, str(rule))
        order = np.argsort(-_abs_residuals(model, res, y), kind="stable")[:k]
        used[order] = False
        return used, order.astype(np.int64), model.fit(y[:, used], start=res.state, max_iter=max_iter)
    if rule.name == "sigma":
        assert rule.value is not None  # parse_rule gives sigma its K
        removed: list[np.ndarray] = []
        while True:
            idx = np.flatnonzero(used)
            r = np.abs(model.residuals(res.state, y[:, idx]))
            dof = len(idx) - model.n_params
            s = math.sqrt(float(r @ r) / dof) if dof > 0 else 0.0
            out = r > rule.value * s
            if not out.any() or s == 0.0:
                break
            _left(model, len(idx) - int(out.sum()), str(rule))
            drop = idx[out][np.argsort(-r[out], kind="stable")]
            used[drop] = False
            removed.append(drop)
            res = model.fit(y[:, used], start=res.state, max_iter=max_iter)
        rem = np.concatenate(removed) if removed else np.zeros(0, dtype=np.int64)
        return used, rem.astype(np.int64), res
    m = vdi2634_count(n)
    if m == 0:
        return used, np.zeros(0, dtype=np.int64), res
    fn = vdi2634 if fast else vdi2634_naive
    return fn(model, y, res, m, max_iter)


def vdi2634_naive(
    model, y: np.ndarray, res: LMResult, m: int, max_iter: int = 100
) -> tuple[np.ndarray, np.ndarray, LMResult]:
    """The reference loop: m times, remove the point with the largest absolute
    residual and refit from scratch. O(m N); for tests and small clouds."""
    used = np.ones(y.shape[1], dtype=bool)
    removed = []
    for _ in range(m):
        idx = np.flatnonzero(used)
        i = idx[int(np.argmax(_abs_residuals(model, res, y[:, idx])))]
        used[i] = False
        removed.append(i)
        res = model.fit(y[:, used], max_iter=max_iter)
    return used, np.array(removed, dtype=np.int64), res


class _Undecided(Exception):
    """The downdated model cannot prove the next decision; refit exactly."""


def _downdater(model, y_used: np.ndarray, res: LMResult, cand: np.ndarray):
    kind = model.element
    if kind in ("plane", "line"):
        key = "plane" if kind == "plane" else f"line{model.dim}"
        return MomentsDowndater(key, y_used, res.state, cand)
    if kind in ("sphere", "circle"):
        d = model.dim
        if res.eval_state is not None and res.jt is not None and res.jt.shape[1] == y_used.shape[1]:
            # reuse the last Gauss-Newton evaluation: u = −Jᵀ rows, ρ = r + r_eval
            rho = res.eval_r + res.eval_state[d]
            return HypersphereDowndater(y_used, res.eval_state, cand, pre=(res.jt[:d], rho))
        return HypersphereDowndater(y_used, res.state, cand)
    raise ValueError(f"no downdater for a {kind}")


#: Candidates kept per outstanding removal, and the refresh period of their ordering.
_CAND_FACTOR, _CAND_EXTRA, _REFRESH = 2, 64, 256


def vdi2634(
    model, y: np.ndarray, res: LMResult, m: int, max_iter: int = 100
) -> tuple[np.ndarray, np.ndarray, LMResult]:
    """The vdi2634 rule, fast: the same removed points as :func:`vdi2634_naive`.

    Only the ``2 m + 64`` points with the largest absolute residuals are candidates.
    At each step the candidates are visited in decreasing order of their residual at
    a reference solution, and the search stops as soon as the best residual found
    exceeds every other candidate's reference residual plus the proven drift bound
    (and every non-candidate's anchor residual plus its drift bound), with the
    model's error bound as margin on both sides. When the margin cannot be proven the
    current point set is refitted exactly and one step is taken the naive way.
    Elements without a downdater (circle in space, cylinder, cone, torus) refit after each removal,
    started from the first-order prediction of the new optimum (one Gauss-Newton step
    each): O(N m) instead of O(N + m²).
    """
    n = y.shape[1]
    used = np.ones(n, dtype=bool)
    removed: list[int] = []
    if model.element in ("cylinder", "cone", "torus") or (model.element == "circle" and model.dim == 3):
        return _vdi2634_refits(model, y, res, m, max_iter)
    while len(removed) < m:
        idx = np.flatnonzero(used)
        yu = y[:, idx] if len(idx) < n else y
        if res.eval_r is not None and res.jt is not None and len(res.eval_r) == len(idx):
            absr = np.abs(res.eval_r)  # at the last evaluated state: the engine's anchor
        elif len(res.r) == len(idx):  # residuals of the fit, at its solution
            absr = np.abs(res.r)
        else:
            absr = _abs_residuals(model, res, yu)
        left = m - len(removed)
        k = min(len(idx), _CAND_FACTOR * left + _CAND_EXTRA)
        if k < len(idx):
            cand, tau_out = _top(absr, k)
        else:
            cand = np.lexsort((np.arange(len(idx)), -absr))
            tau_out = -np.inf
        eng = None
        try:
            eng = _downdater(model, yu, res, cand)
            _fast_steps(eng, idx, cand, absr[cand], tau_out, left, used, removed)
        except (_Undecided, ZeroDivisionError):
            # Refit the current set exactly and take one naive step; the next engine is
            # anchored at that fit (an anchor need not be the optimum of its set).
            res = model.fit(y[:, used], start=res.state if eng is None else eng.state(), max_iter=max_iter)
            idx = np.flatnonzero(used)
            i = int(np.argmax(_abs_residuals(model, res, y[:, idx])))
            used[idx[i]] = False
            removed.append(int(idx[i]))
            res = dataclasses.replace(
                res,
                r=np.delete(res.r, i) if len(res.r) == len(idx) else res.r,
                jt=None,
                eval_state=None,
                eval_r=None,
                scaled=None,
            )
            if len(removed) == m:
                res = model.fit(y[:, used], start=res.state, max_iter=max_iter)
            continue
        res = model.fit(y[:, used], start=eng.state(), max_iter=max_iter)
    return used, np.array(removed, dtype=np.int64), res


def _vdi2634_refits(
    model, y: np.ndarray, res: LMResult, m: int, max_iter: int
) -> tuple[np.ndarray, np.ndarray, LMResult]:
    """One exact refit per removal, warm started from the first-order prediction."""
    used = np.ones(y.shape[1], dtype=bool)
    removed: list[int] = []
    hint = None
    for _ in range(m):
        idx = np.flatnonzero(used)
        k = len(idx)
        if len(res.r) == 2 * k:  # circle in space: components (ρ − r, h)
            absr = np.hypot(res.r[:k], res.r[k:])
        elif len(res.r) == k:
            absr = np.abs(res.r)
        else:
            absr = _abs_residuals(model, res, y[:, idx])
        i = int(np.argmax(absr))
        used[idx[i]] = False
        removed.append(int(idx[i]))
        hint = hint if res.rate is None else 4 * res.rate
        res = model.fit(y[:, used], start=_predict(model, res, i, k), max_iter=max_iter, rate_hint=hint)
    return used, np.array(removed, dtype=np.int64), res


def _predict(model, res: LMResult, i: int, n: int):
    """Start for the refit after removing point i of the n fitted ones: the
    first-order change of the optimum, Δx = (JᵀJ)⁻¹ J_iᵀ r_i (the removed point's share of
    the gradient), which leaves a single Gauss-Newton step for the refit."""
    if res.jt is None or not hasattr(model, "advance"):
        return res.state
    comps = len(res.r) // n
    cols = [i + c * n for c in range(comps)]
    try:
        dx = np.linalg.solve(res.jt @ res.jt.T, res.jt[:, cols] @ res.r[cols])
    except np.linalg.LinAlgError:
        return res.state
    return model.advance(res.state, dx)


def _fast_steps(eng, idx, cand, ref_abs, tau_out, steps, used, removed) -> None:
    """Up to ``steps`` removals with the downdater ``eng``; raises _Undecided.

    ``queue`` holds the window's candidates sorted by |r| at the engine's state when it
    was evaluated. A removal is made when the best candidate beats the next one and
    the bound for everything else (``limit``) by more than the margins: ``eb`` (the
    error of the engine's state: model error, and for a predicting engine the error
    of its first-order update of the optimum) and ``pending`` (how far residuals may
    have moved since the queue was evaluated). When a decision is not certain the
    queue is re-evaluated, then the engine re-solved; only if it is still not certain
    at a solved state does _Undecided send the driver to an exact refit.
    """
    alive = list(range(len(cand)))  # candidate positions, by decreasing reference |r|
    ref = ref_abs.tolist()  # reference |r| by candidate position
    order_key = cand.tolist()  # ties are broken by the lower index
    gidx = idx[cand].tolist()  # global index of each candidate
    inf = float("inf")
    queue: list = []
    limit = eb = pending = 0.0
    since = done = 0

    def refill(solve: bool):
        nonlocal queue, limit, eb, pending, since, alive, ref
        while True:
            if solve or eng.must_solve():
                eng.solve()
            exact = eng.lazy == 0
            if since >= _REFRESH:  # re-sort the candidates at the current state
                arr = np.array(alive)
                cur = eng.absres(arr)
                order = np.lexsort((cand[arr], -cur))
                alive = arr[order].tolist()
                ref_np = np.asarray(ref)
                ref_np[arr] = cur
                ref = ref_np.tolist()
                eng.set_reference()
                since = 0
            eb, drift, drift0 = eng.bounds()
            outside = tau_out + drift0
            pending = 0.0
            w = 16
            while True:
                win = alive[:w]
                vals = eng.absres(win).tolist()
                queue = sorted(zip(vals, win), key=lambda vp: (-vp[0], order_key[vp[1]]))
                limit = max(ref[alive[w]] + drift, outside) if w < len(alive) else outside
                if queue[0][0] - eb > limit + eb:
                    if len(queue) == 1:
                        queue.append((-inf, -1))
                    return exact
                if w >= len(alive):
                    break
                w *= 4
            if exact:
                raise _Undecided  # a point outside the candidates may be next
            solve = True

    exact = False
    while done < steps:
        if len(queue) < 2:
            if not alive:
                raise _Undecided
            exact = refill(False)
        v1, p = queue[0]
        margin = pending + eb
        if v1 - margin <= max(queue[1][0], limit) + margin:
            if exact:
                raise _Undecided  # too close to call even at a solved state
            exact = refill(not (eng.predictive and pending > 0))
            continue
        queue.pop(0)
        pending += eng.remove(p, v1)
        exact = False
        alive.remove(p)
        gi = gidx[p]
        used[gi] = False
        removed.append(gi)
        since += 1
        done += 1
    if eng.lazy:
        eng.solve()


def _top(absr: np.ndarray, k: int) -> tuple[np.ndarray, float]:
    """Positions of the k largest values, sorted by decreasing value (ties: lower
    position first), and the (k+1)-th largest value. A threshold from a strided
    subset avoids a full partial sort of a million values."""
    n = len(absr)
    if n > 50 * k and n > 100_000:
        step = max(1, n // 100_000)
        sub = absr[::step]
        q = min(len(sub) - 1, int(3 * (k + 1) / step) + 10)
        thr = np.partition(sub, len(sub) - 1 - q)[len(sub) - 1 - q]
        pool = np.flatnonzero(absr >= thr)
        if len(pool) > k:
            order = pool[np.lexsort((pool, -absr[pool]))]
            return order[:k], float(absr[order[k]])
    part = np.argpartition(-absr, k)[: k + 1]
    part = part[np.lexsort((part, -absr[part]))]
    return part[:k], float(absr[part[k]])
