"""Minimum-zone (Chebyshev) plane and sphere: the narrowest zone between two parallel
planes, or between two concentric spheres, that contains all points; and the same
sequential linear programming for any surface given by its residual model
(:func:`surface`: the cone, the torus).

Both are solved as a sequence of linear programmes (SciPy's HiGHS) in a frame that
moves with the solution:

* Plane — in the frame of the current normal n (basis b1, b2, n), the LP
  ``min t  s.t.  |h_i − c − α ξ_i − β η_i| ≤ t`` over (c, α, β, t) is the exact
  minimum-zone problem for *vertical* distances. Its solution tilts the frame to the
  normal ∝ (−α, −β, 1); the iteration stops when the optimal tilt is zero, where
  vertical and orthogonal distances agree to second order and the LP optimality
  certifies a minimum of the orthogonal zone.
* Sphere — the radial distances are linearised about the current centre,
  ``ρ_i − u_i·δ``, and the LP ``min t  s.t.  |ρ_i − u_i·δ − r| ≤ t`` gives the centre step
  δ (sequential linear programming with a trust region on δ).

Each LP is solved on an active set (the points with the most extreme residuals, grown
by the violators until none remains), so a million points cost a few passes. The LP
vertex is then *polished*: the equations of its active constraints are solved
directly, which gives the solution to machine precision rather than to HiGHS's
feasibility tolerance.

Reference: ISO 12781-1 / ISO 1101 (minimum zone); G. L. Anthony et al., "Reference
software for finding Chebyshev best-fit geometric elements", Precision Engineering
19 (1996) 28-36.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from ._geometry import GeometryError, complement

_OPTS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
_START = 40  # points per side in the first active set
_GROW = 20  # violators added per side and round


def _chebyshev_lp(a: np.ndarray, b: np.ndarray, bounds: list, what: str) -> np.ndarray:
    """Solve ``min t s.t. |b_i − a_i·x| ≤ t`` (x free within ``bounds``) and polish the
    vertex. Returns [x..., t]."""
    m, k = a.shape
    # variables (x, t); rows:  b − a x ≤ t  ->  −a x − t ≤ −b ;  a x − b ≤ t  ->  a x − t ≤ b
    aub = np.vstack([np.hstack([-a, -np.ones((m, 1))]), np.hstack([a, -np.ones((m, 1))])])
    bub = np.concatenate([-b, b])
    cost = np.zeros(k + 1)
    cost[-1] = 1.0
    res = linprog(cost, A_ub=aub, b_ub=bub, bounds=list(bounds) + [(0, None)], method="highs", options=_OPTS)
    if res.status != 0:
        raise GeometryError(f"{what}: the linear programme failed ({res.message})")
    sol = res.x
    # Polish: the constraints active at the vertex, as equations, solved directly.
    slack = bub - aub @ sol
    act = np.flatnonzero(slack <= 1e-8 * max(1.0, sol[-1]))
    lo = np.array([bd[0] if bd[0] is not None else -np.inf for bd in bounds])
    hi = np.array([bd[1] if bd[1] is not None else np.inf for bd in bounds])
    on_box = np.any(np.isclose(sol[:k], lo) | np.isclose(sol[:k], hi))
    if len(act) >= k + 1 and not on_box:
        eq = aub[act]
        rhs = bub[act]
        polished, *_ = np.linalg.lstsq(eq, rhs, rcond=None)
        if np.all(aub @ polished <= bub + 1e-9 * max(1.0, sol[-1])) and abs(polished[-1] - sol[-1]) <= 1e-6 * max(
            1.0, sol[-1]
        ):
            sol = polished
    return sol


def _active_lp(a_all, b_all, bounds, what):
    """Chebyshev LP over all rows, solved on a growing active set."""
    n = len(b_all)
    if n <= 2 * _START:
        return _chebyshev_lp(a_all, b_all, bounds, what)
    order = np.argsort(b_all)
    act = np.unique(np.concatenate([order[:_START], order[-_START:]]))
    for _ in range(200):
        sol = _chebyshev_lp(a_all[act], b_all[act], bounds, what)
        e = b_all - a_all @ sol[:-1]
        t = sol[-1]
        tol = 1e-12 * max(1.0, t)
        hi = np.flatnonzero(e > t + tol)
        lo = np.flatnonzero(e < -t - tol)
        if len(hi) == 0 and len(lo) == 0:
            return sol
        hi = hi[~np.isin(hi, act)]
        lo = lo[~np.isin(lo, act)]
        if len(hi) == 0 and len(lo) == 0:
            return sol  # only rows of the active set, off by the LP's own tolerance
        add = []
        if len(hi):
            add.append(hi[np.argsort(-e[hi])[:_GROW]])
        if len(lo):
            add.append(lo[np.argsort(e[lo])[:_GROW]])
        act = np.union1d(act, np.concatenate(add))
    raise GeometryError(f"{what}: the active set did not settle")


def plane(yt: np.ndarray, state: np.ndarray, max_iter: int = 50) -> tuple[np.ndarray, float]:
    """Minimum-zone plane of normalised points (3, n) from the least-squares ``state``
    ``[p, n]``. Returns (state of the mid-plane, zone width), normalised units.

    The orthogonal width never grows from one iteration to the next (the LP's vertical
    width at the new tilt is at most that at zero tilt, and the orthogonal width is
    the vertical one divided by sqrt(1 + α² + β²)); the iteration stops when the tilt
    vanishes or the width no longer decreases.
    """

    def width(m, n):
        r = n @ yt - n @ m
        return float(r.max() - r.min())

    m, n = state[:3].copy(), state[3:].copy()
    w = width(m, n)
    for _ in range(max_iter):
        b = complement(n)
        yc = yt - m[:, None]
        h = n @ yc
        a = np.column_stack([np.ones(yt.shape[1]), (b @ yc).T])
        sol = _active_lp(a, h, [(None, None), (-1.0, 1.0), (-1.0, 1.0)], "minimum-zone plane")
        c, al, be = sol[:3]
        nn = n - al * b[0] - be * b[1]
        nn /= np.linalg.norm(nn)
        mm = m + c * n
        w_new = width(mm, nn)
        if w_new > w * (1 - 1e-15) and abs(al) + abs(be) > 1e-15:
            break  # no further decrease: a stationary tilt (or a degenerate zone)
        m, n, w = mm, nn, min(w, w_new)
        if abs(al) + abs(be) <= 1e-15:
            break
    else:
        raise GeometryError(f"minimum-zone plane did not converge in {max_iter} iterations")
    r = n @ yt - n @ m
    hi, lo = float(r.max()), float(r.min())
    return np.concatenate([m + 0.5 * (hi + lo) * n, n]), hi - lo


def sphere(yt: np.ndarray, state: np.ndarray, max_iter: int = 100) -> tuple[np.ndarray, float]:
    """Minimum-zone sphere (or planar circle for (2, n) points) of normalised points
    (d, n) from the least-squares ``state`` ``[c, r]``. Returns (state
    ``[c, (R_out + R_in)/2]``, R_out − R_in), normalised units."""
    d = yt.shape[0]
    c = state[:d].copy()

    def zone(cc):
        diff = yt - cc[:, None]
        rho = np.sqrt(np.einsum("ij,ij->j", diff, diff))
        return rho, float(rho.max() - rho.min())

    rho, f = zone(c)
    radius = max(float(state[d]), 1e-300)
    box = 0.1 * radius
    for _ in range(max_iter):
        u = (yt - c[:, None]) / np.where(rho > 0, rho, 1.0)
        a = np.vstack([u, np.ones(yt.shape[1])]).T
        sol = _active_lp(a, rho, [(-box, box)] * d + [(None, None)], "minimum-zone sphere")
        step = sol[:d]
        new = c + step
        rho_new, f_new = zone(new)
        if f_new <= f * (1 + 1e-15):
            small = np.linalg.norm(step) <= 1e-14 * radius or f - f_new <= 1e-16 * f
            c, rho, f = new, rho_new, f_new
            if small:
                break
            box = max(box, 4 * float(np.abs(step).max()))
        else:
            box = 0.25 * float(np.abs(step).max())
            if box <= 1e-15 * radius:
                break
    else:
        raise GeometryError(f"minimum-zone sphere did not converge in {max_iter} iterations")
    return np.append(c, 0.5 * (rho.max() + rho.min())), f


def surface(evaluate, update, state: np.ndarray, size: int, what: str, max_iter: int = 100) -> tuple[np.ndarray, float]:
    """Minimum zone of a surface given by its residual model (cone, torus): sequential
    linear programming as for the sphere, with the model's own linearisation.

    ``evaluate(state) -> (r, Jᵀ)`` are the signed orthogonal residuals (n,) and their
    Jacobian (k, n) in local parameters (``update(state, δ)`` applies a step); the local
    parameter ``size`` must enter as ``r − δ_size`` (its Jacobian row is −1: an offset
    of the surface along its normals, a cone's ``s`` or a torus' minor radius). Each LP
    ``min t s.t. |r_i + K_i δ' − δ_size| ≤ t`` (K the other rows) has a trust region on δ'
    (normalised units and radians); a step is kept only when the true zone shrinks.
    Returns (the state of the mid-zone surface, the zone width), normalised units.
    """
    r, jt = evaluate(state)
    f = float(r.max() - r.min())
    others = [i for i in range(jt.shape[0]) if i != size]
    box = 0.1
    for _ in range(max_iter):
        a = np.column_stack([-jt[others].T, np.ones(jt.shape[1])])
        sol = _active_lp(a, r, [(-box, box)] * len(others) + [(None, None)], what)
        step = np.zeros(jt.shape[0])
        step[others] = sol[: len(others)]
        step[size] = sol[len(others)]
        new = update(state, step)
        r_new, jt_new = evaluate(new)
        f_new = float(r_new.max() - r_new.min())
        big = float(np.abs(step[others]).max()) if others else 0.0
        if f_new <= f * (1 + 1e-15):
            small = big <= 1e-14 or f - f_new <= 1e-16 * max(f, 1e-300)
            state, r, jt, f = new, r_new, jt_new, f_new
            if small:
                break
            box = max(box, 4 * big)
        else:
            box = 0.25 * big
            if box <= 1e-15:
                break
    else:
        raise GeometryError(f"{what} did not converge in {max_iter} iterations")
    step = np.zeros(jt.shape[0])
    step[size] = 0.5 * float(r.max() + r.min())  # centre the zone on the surface
    return update(state, step), f
