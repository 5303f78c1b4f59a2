"""Shared numerics for the fits: input checks, centring and scaling, the damped
Gauss-Newton (Levenberg-Marquardt) driver, covariances and form figures.

Every fit works on *normalised* coordinates ``Y = (X - origin) / scale`` where
``origin`` is the centroid of the input and ``scale`` the RMS distance of the points
from it (:class:`Frame`). Lengths in ``Y`` are therefore O(1) whatever the position of
the part: a sphere 10 000 mm from the origin is fitted exactly like one at the origin.
Results are converted back to mm at the very end.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
from scipy.linalg.lapack import dgeqrf

from camcmm.api import GeometryError, InputError

EPS = np.finfo(float).eps

#: Minimum numbers of points per element (and the number of free parameters).
N_MIN = {"line": 2, "plane": 3, "circle": 3, "sphere": 4, "cylinder": 5, "cone": 6, "torus": 7}


def as_points(points: Any, element: str, dims: tuple[int, ...] = (3,)) -> np.ndarray:
    """``points`` as a C-contiguous (N, d) float64 array, d in ``dims``.

    Accepts a numpy array, a nested list or anything with a ``points`` attribute (a
    camcmm PointCloud). Raises InputError for a wrong shape or NaN/Inf coordinates and
    GeometryError for fewer points than the element needs.
    """
    if hasattr(points, "points"):
        points = points.points
    try:
        x = np.ascontiguousarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{element} fit: points are not numeric ({exc})") from None
    if x.ndim != 2 or x.shape[1] not in dims:
        want = " or ".join(f"(N, {d})" for d in dims)
        raise InputError(f"{element} fit: points must have shape {want}, got {x.shape}")
    # one flat pass first: the per-row reduction (which names the first bad point) costs
    # 40 times more and is only needed when something is wrong
    bad = np.zeros(0, bool) if np.isfinite(x).all() else ~np.isfinite(x).all(axis=1)
    if bad.any():
        raise InputError(
            f"{element} fit: {int(bad.sum())} points have NaN or Inf coordinates "
            f"(first at index {int(np.flatnonzero(bad)[0])})"
        )
    need = N_MIN[element]
    if len(x) < need:
        raise GeometryError(f"{element} fit needs at least {need} points, got {len(x)}")
    return x


@dataclass(frozen=True)
class Frame:
    """Normalisation ``Y = (X - origin) / scale``; ``scale`` is in mm.

    Internally the fits keep normalised points *as columns*, an array (d, N): each
    coordinate is then contiguous in memory and a pass over a million points costs a
    quarter of what the row layout (N, d) costs.
    """

    origin: np.ndarray
    scale: float

    @classmethod
    def normalise(cls, x: np.ndarray, element: str) -> tuple[Frame, np.ndarray]:
        """The frame of points x (N, d) mm and the normalised points (d, N)."""
        yt = np.ascontiguousarray(x.T)
        o = yt.mean(axis=1)
        yt -= o[:, None]
        # Second pass: removes the rounding of the first mean, which matters when the
        # coordinates are 1e4 times the size of the part.
        corr = yt.mean(axis=1)
        yt -= corr[:, None]
        o = o + corr
        scale = float(np.sqrt(np.einsum("ij,ij->", yt, yt) / yt.shape[1]))
        if not scale > 0:
            raise GeometryError(f"{element} fit: all {len(x)} points coincide")
        if scale < 1e3 * EPS * max(1.0, float(np.abs(o).max())):
            raise GeometryError(
                f"{element} fit: the points spread {scale:.3g} mm, too little to be "
                f"resolved at their distance from the origin"
            )
        yt /= scale
        return cls(o, scale), yt

    def to_mm(self, y: np.ndarray) -> np.ndarray:
        """A normalised point (d,) to mm."""
        return np.asarray(y) * self.scale + self.origin


def dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a · b`` of two long vectors by numpy's own loop (einsum), not BLAS: OpenBLAS runs
    its level-1 and level-2 routines on all of its threads, which on a loaded machine wait
    for a core (measured at load 10 on 2 cores: 10 ms for a dot of 10^6 numbers, against
    0.4 ms here whatever the load)."""
    return float(np.einsum("i,i->", a, b))


def row_moments(a: np.ndarray) -> np.ndarray:
    """``a aᵀ`` (k, k) of a few long rows a (k, N), one :func:`dot` per pair of rows (for
    k = 3 four times faster than BLAS's threaded product on a loaded machine)."""
    k = len(a)
    out = np.empty((k, k))
    for i in range(k):
        for j in range(i, k):
            out[i, j] = out[j, i] = dot(a[i], a[j])
    return out


def qr_r(a: np.ndarray) -> np.ndarray:
    """The (k, k) R factor of a tall matrix a (n, k) by LAPACK's Householder QR
    (dgeqrf; only R is formed, which scipy.linalg.qr's mode 'r' does not manage for
    tall matrices without a full-size triangular copy)."""
    qr, _, _, info = dgeqrf(a)
    if info != 0:
        raise GeometryError(f"QR decomposition failed (LAPACK info {info})")
    k = a.shape[1]
    return np.triu(qr[:k])


def principal_axes(yt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid, singular values and principal directions (rows, largest first) of
    points given as columns (d, N).

    The singular values come from the R factor of a QR decomposition of the centred
    points, so they are accurate to machine precision relative to the largest one
    (the scatter matrix would square the condition number).
    """
    d, n = yt.shape
    m = yt.mean(axis=1)
    yc = yt - m[:, None]
    corr = yc.mean(axis=1)
    yc -= corr[:, None]
    m = m + corr
    r = qr_r(yc.T) if n > d else yc.T
    _, s, vt = np.linalg.svd(r, full_matrices=True)
    if len(s) < d:  # fewer points than dimensions
        s = np.concatenate([s, np.zeros(d - len(s))])
    return m, s, vt


#: Relative singular value below which points count as lying in a lower dimension.
FLAT = 1e-9


def orient(v: np.ndarray) -> np.ndarray:
    """Unit vector ``v`` with the sign that makes its largest-magnitude component positive
    (so a normal near +z points to +z); the sign of a direction is otherwise arbitrary."""
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v)
    return -v if v[int(np.argmax(np.abs(v)))] < 0 else v


def complement(n: np.ndarray) -> np.ndarray:
    """(2, 3) two orthonormal rows perpendicular to the unit vector ``n`` (right-handed
    with ``n``: rows b1, b2 with b1 × b2 = n)."""
    n = np.asarray(n, dtype=float)
    a = np.zeros(3)
    a[int(np.argmin(np.abs(n)))] = 1.0
    b1 = np.cross(n, a)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(n, b1)
    return np.vstack([b1, b2])


def rotation_to(n: np.ndarray) -> np.ndarray:
    """(3, 3) orthonormal matrix whose third column is ``n`` (columns b1, b2, n)."""
    b = complement(n)
    return np.column_stack([b[0], b[1], n])


# -- linear algebra of a Gauss-Newton step ------------------------------------------

#: Condition number of the column-scaled JᵀJ above which the step is solved by QR.
#: Below it, forming JᵀJ costs at most 8 of the 16 digits of the *step*; the fitted
#: parameters are not affected, since the iteration converges to the point where the
#: gradient Jᵀr (always evaluated directly) vanishes.
COND_NORMAL = 1e8
#: how many times ``max_iter`` a steadily contracting (linearly converging) fit may take
EXTEND = 10


def _scaled(jt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    g = jt @ jt.T
    d = np.sqrt(np.diag(g).copy())
    d[d == 0] = 1.0
    return g / np.outer(d, d), d


def gn_step(
    jt: np.ndarray,
    r: np.ndarray,
    lam: float = 0.0,
    what: str = "fit",
    scaled: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Minimise ``|J δ + r|² + lam |D δ|²`` (D = column norms of J) for δ; the
    Jacobian is given transposed, ``jt`` (k, N); ``scaled`` is ``_scaled(jt)`` when the
    caller has it already (one pass over the Jacobian less).

    JᵀJ of the column-scaled Jacobian is used when its condition number is below
    :data:`COND_NORMAL` (the data are centred and scaled first, so this is the usual
    case, and it is several times faster than a QR of a million rows); otherwise the
    step comes from a least-squares solve (SVD-based LAPACK gelsd) of the scaled
    Jacobian itself, which never squares the condition number. Raises GeometryError
    when the Jacobian is rank-deficient: the points do not determine the element.
    """
    gs, d = _scaled(jt) if scaled is None else scaled
    w = np.linalg.eigvalsh(gs)
    k = len(d)
    if w[0] > w[-1] / COND_NORMAL:
        rhs = -(jt @ r) / d
        ds = sla.solve(gs + lam * np.eye(k), rhs, assume_a="pos", check_finite=False)
        return ds / d
    js = jt.T / d
    if lam > 0:
        js = np.vstack([js, np.sqrt(lam) * np.eye(k)])
        rr = np.concatenate([r, np.zeros(k)])
    else:
        rr = r
    ds, _, rank, sv = sla.lstsq(js, -rr, check_finite=False)
    if sv[-1] <= 1e-13 * sv[0]:
        raise GeometryError(
            f"{what}: the points do not determine the element "
            f"(rank-deficient Jacobian, condition {sv[0] / max(sv[-1], 1e-300):.1e})"
        )
    return ds / d


def fit_covariance(res: LMResult) -> np.ndarray:
    """Covariance of a fit's local parameters (normalised units), from its Jacobian or,
    for the closed-form fits, from its JᵀJ."""
    ssr = float(res.r @ res.r)
    if res.gram is None:
        assert res.jt is not None  # an iterative fit keeps its Jacobian (only closed forms have gram)
        return covariance(res.jt, ssr, res.scaled)
    g, n = res.gram
    k = len(g)
    if n - k <= 0:
        return np.full((k, k), np.nan)
    d = np.sqrt(np.diag(g))
    w = np.linalg.eigvalsh(g / np.outer(d, d)) if d.all() else np.zeros(k)
    if not w[0] > 1e-14 * w[-1]:
        return np.full((k, k), np.nan)
    return ssr / (n - k) * np.linalg.inv(g)


def covariance(jt: np.ndarray, ssr: float, scaled: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Covariance ``s² (JᵀJ)⁻¹`` of the parameters, ``s² = ssr / (n - p)``, from the
    transposed Jacobian ``jt`` (p, n) (``scaled``: its ``_scaled(jt)``, when known).

    NaN when there are no degrees of freedom. Computed from the R factor of J (not from
    an inverse of JᵀJ) when JᵀJ is badly conditioned.
    """
    k, n = jt.shape
    dof = n - k
    if dof <= 0:
        return np.full((k, k), np.nan)
    s2 = ssr / dof
    gs, d = _scaled(jt) if scaled is None else scaled
    w = np.linalg.eigvalsh(gs)
    if w[0] > w[-1] / COND_NORMAL:
        inv = sla.inv(gs, check_finite=False)
    else:
        rfac = qr_r(jt.T / d)
        if abs(rfac.diagonal()).min() <= 1e-13 * abs(rfac.diagonal()).max():
            return np.full((k, k), np.nan)
        rinv = sla.solve_triangular(rfac, np.eye(k), check_finite=False)
        inv = rinv @ rinv.T
    return s2 * inv / np.outer(d, d)


def propagate(cov: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """Standard uncertainties ``sqrt(diag(D C Dᵀ))`` of derived quantities."""
    c = jac @ cov @ jac.T
    return np.sqrt(np.clip(np.diag(c), 0.0, None))


@dataclass
class LMResult:
    """A converged fit: ``state`` (element-specific, normalised units), the residuals
    ``r`` of the fitted points, the transposed Jacobian ``jt`` (p, n) at the solution
    and the number of iterations."""

    state: Any
    r: np.ndarray
    jt: np.ndarray | None
    iterations: int
    #: the last state at which residuals and Jacobian were evaluated (``jt`` belongs
    #: to it) and the residuals there; the converged ``state`` is one tiny step further.
    eval_state: Any = None
    eval_r: np.ndarray | None = None
    #: for closed-form fits (line, plane): JᵀJ and the number of residual components,
    #: computed from moments instead of an (n, p) Jacobian (``jt`` is then None)
    gram: tuple[np.ndarray, int] | None = None
    #: the contraction rate observed in the last iterations (None if not seen)
    rate: float | None = None
    #: ``_scaled(jt)`` (column-scaled JᵀJ and the column norms), computed once by the
    #: iteration and reused by the covariance
    scaled: tuple[np.ndarray, np.ndarray] | None = None


def levenberg_marquardt(
    evaluate: Callable[[Any], tuple[np.ndarray, np.ndarray]],
    state: Any,
    update: Callable[[Any, np.ndarray], Any],
    *,
    max_iter: int = 100,
    xtol: float = 1e-13,
    what: str = "fit",
    check: Callable[[Any], None] | None = None,
    rate_hint: float | None = None,
) -> LMResult:
    """Damped Gauss-Newton on orthogonal residuals.

    ``evaluate(state) -> (r, Jᵀ)`` gives the residuals and their (transposed, (p, n))
    Jacobian with respect to a *local* parameter vector that is zero at ``state``; ``update(state, δ)``
    applies a step (for re-centred parametrisations such as a cylinder's axis, the
    frame moves with the solution). ``check(state)`` may raise GeometryError for a
    diverging solution. Pure Gauss-Newton steps are taken while they decrease the sum
    of squares; otherwise the Marquardt damping grows until they do.

    Convergence: a step whose length (normalised coordinates) times the observed
    contraction rate predicts a remaining error below ``xtol``. That last step is
    applied with the linearised residuals ``r + J δ`` (error O(|δ|²) < 1e-16), which
    saves one pass over the data. Before two steps have been seen the contraction rate
    is taken as 0.5, or as ``rate_hint`` (the rate observed when fitting nearly the same
    points, for warm starts). Raises GeometryError after ``max_iter`` steps, unless
    the steps are still shrinking steadily: a high-residual fit (e.g. a sphere whose
    points scatter by half its radius) converges only linearly, at rates near 0.9, and
    is given up to ``EXTEND`` times the budget while every step contracts.
    """
    r, jt = evaluate(state)
    sc = _scaled(jt)
    ssr = dot(r, r)
    lam = 0.0
    prev = None
    step = np.inf
    shrinking = 0  # consecutive undamped steps each shorter than the one before
    first_rate = 0.5 if rate_hint is None else min(max(rate_hint, 1e-6), 0.5)
    it = 0
    for it in range(1, EXTEND * max_iter + 1):
        if it > max_iter and shrinking < 5:
            it -= 1
            break
        delta = gn_step(jt, r, lam, what, sc)
        step = float(np.linalg.norm(delta))
        if not np.isfinite(step):
            raise GeometryError(f"{what}: the iteration produced a non-finite step")
        shrinking = shrinking + 1 if prev and step < 0.98 * prev else 0
        rate = min(step / prev, 0.5) if prev else (first_rate if it == 1 else 0.5)
        if step <= 1e-7 and step * rate / (1.0 - rate) <= xtol:
            new = update(state, delta)
            if check is not None:
                check(new)
            r_new = r + np.einsum("i,ij->j", delta, jt)  # not BLAS's threaded gemv (see dot)
            return LMResult(new, r_new, jt, it, state, r, rate=rate if prev else None, scaled=sc)
        new = update(state, delta)
        if check is not None:
            check(new)
        r2, jt2 = evaluate(new)
        ssr2 = dot(r2, r2)
        if ssr2 <= ssr * (1.0 + 64 * EPS) or step <= 1e-9:
            state, r, jt, ssr = new, r2, jt2, ssr2
            sc = _scaled(jt)
            prev = step if lam == 0.0 else None
            lam = 0.0 if lam < 1e-6 else lam / 10.0
        else:
            lam = 1e-4 if lam == 0.0 else lam * 10.0
            prev = None
            if lam > 1e12:
                raise GeometryError(f"{what}: no step decreases the sum of squares (the iteration stalled)")
    raise GeometryError(
        f"{what} did not converge in {it} iterations (last step {step:.2g} in units of the point spread)"
    )


def form_figures(residuals: np.ndarray) -> dict[str, float]:
    """Form figures of the residuals in mm: ``range`` = max − min, ``max``, ``min``,
    ``std`` (sample standard deviation, n − 1) and ``rms`` (root mean square)."""
    r = np.asarray(residuals, dtype=float)
    if len(r) == 0:
        return {k: float("nan") for k in ("range", "max", "min", "std", "rms")}
    hi, lo, n = float(r.max()), float(r.min()), len(r)
    dev = r - r.sum() / n
    return {
        "range": hi - lo,
        "max": hi,
        "min": lo,
        # dot products: one pass each, no temporary of squares (as np.std / np.mean(r * r))
        "std": float(np.sqrt(dot(dev, dev) / (n - 1))) if n > 1 else float("nan"),
        "rms": float(np.sqrt(dot(r, r) / n)),
    }


def subsample(yt: np.ndarray, limit: int) -> np.ndarray:
    """A deterministic, evenly strided subset of about ``limit`` of the points (d, N)."""
    step = max(1, yt.shape[1] // limit)
    return yt[:, ::step] if step > 1 else yt


def model_lm(
    model,
    yt: np.ndarray,
    state: np.ndarray,
    max_iter: int,
    xtol: float,
    rate_hint: float | None,
    what: str,
    centred: bool,
) -> LMResult:
    """Levenberg-Marquardt on a model's ``evaluate``/``update``/``_check`` for points (d, N):
    the one call of the models that find their own start values (cylinder, cone, torus).
    ``centred``: the model's update takes the points' centroid (it re-anchors the axis point
    nearest to it, which keeps the parameters well conditioned far from the origin)."""
    if centred:
        centroid = yt.mean(axis=1)
        update = lambda s, dp: model.update(s, dp, centroid)  # noqa: E731
    else:
        update = model.update
    return levenberg_marquardt(
        lambda s: model.evaluate(s, yt),
        np.asarray(state, float),
        update,
        max_iter=max_iter,
        xtol=xtol,
        what=what,
        check=model._check,
        rate_hint=rate_hint,
    )


def axial_parts(state: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (3, n) about the axis of a state ``[origin (3), direction (3), ...]`` (a circle's
    centre and normal, a cylinder's, cone's or torus' axis): z (n,) along the axis, uv (2, n)
    across it in the basis :func:`complement`, ρ (n,) the distance from the axis."""
    o, a = state[:3], state[3:6]
    yc = yt - o[:, None]
    uv = complement(a) @ yc
    return a @ yc, uv, np.sqrt(np.einsum("ij,ij->j", uv, uv))


def best_start(
    model,
    ys: np.ndarray,
    starts: Iterable[Callable[[], np.ndarray]],
    refusal: str,
    accept: Callable[[np.ndarray], bool] | None = None,
) -> np.ndarray:
    """The start candidate whose short Levenberg-Marquardt run (100 iterations, xtol 1e-8)
    on the screening points ``ys`` ends with the least sum of squares: the one selection of
    the models that find their own start values (cylinder, cone, torus). Each of ``starts``
    makes one start state and may raise GeometryError (that candidate is passed over, as is
    a run that does not converge or whose state ``accept`` rejects); GeometryError(refusal)
    when none is left."""
    best, best_ssr = None, np.inf
    for make in starts:
        try:
            res = model._lm(ys, make(), 100, 1e-8)
        except GeometryError:
            continue
        ssr = float(res.r @ res.r)
        if ssr < best_ssr and (accept is None or accept(res.state)):
            best, best_ssr = res.state, ssr
    if best is None:
        raise GeometryError(refusal)
    return best


def fit_from_starts(
    model, yt: np.ndarray, start: np.ndarray | None, max_iter: int, xtol: float, rate_hint: float | None, limit: int
) -> LMResult:
    """The least-squares fit of a model that finds its own start values (``model.start``,
    several candidates; cylinder, cone, torus): without ``start``, the candidates are tried
    and the best refined on a strided subset of about ``limit`` points (a million points
    then need only the final two or three iterations), then ``model._lm`` on all points."""
    if start is None:
        start = model.start(yt)
        sub = subsample(yt, limit)
        if sub is not yt:
            start = model._lm(sub, start, max_iter, 1e-10).state
    return model._lm(yt, start, max_iter, xtol, rate_hint)


# -- surfaces of revolution: normals and the axis they meet -----------------------------


def local_normals(yt: np.ndarray, k: int = 12) -> np.ndarray | None:
    """(n, 3) unit surface normals of points (3, n), each from the scatter of its k nearest
    neighbours (SciPy's KD-tree, batched 3x3 eigen-decompositions); their signs are
    arbitrary. None with fewer than k + 1 points."""
    from scipy.spatial import cKDTree

    y = yt.T
    if len(y) < k + 1:
        return None
    _, idx = cKDTree(y).query(y, k=k)
    nb = y[idx] - y[idx].mean(axis=1, keepdims=True)
    return np.linalg.eigh(np.einsum("nki,nkj->nij", nb, nb))[1][:, :, 0]


def revolution_axes(yt: np.ndarray, normals: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Candidate axes (point, unit direction) of a surface of revolution through points
    (3, n) with surface normals (n, 3): lines that the normal lines meet, best first.

    Every normal line of a surface of revolution meets its axis. In Plücker coordinates a
    line (direction d, moment y × d) meets the axis (a, m = p × a) when
    ``a·(y × d) + m·d = 0``: linear in (a, m), and indifferent to the sign of d. The
    least-squares m for a given a is ``M a`` (pseudo-inverse: a cylinder's normals span
    only a plane), and a is then an eigenvector of the Schur complement of the 6x6 moment
    matrix: the smallest is the first candidate. A short arc of a torus is nearly a bent
    tube whose normals also nearly meet the tube's own axis, so the two smallest
    eigenvectors span both: the lines in their span, ``a = v0 + t v1`` with the Plücker
    condition ``a·M a = 0`` (a quadratic in t), are candidates too. Exact for exact
    normals; with normals from neighbourhoods they are start values.
    Reference: H. Pottmann, T. Randrup, "Rotational and helical surface approximation
    for reverse engineering", Computing 60 (1998) 307-322.
    """
    mom = np.cross(yt.T, normals)
    a_ = mom.T @ mom
    b_ = mom.T @ normals
    cp = np.linalg.pinv(normals.T @ normals, rcond=1e-10)
    mm = -cp @ b_.T
    v = np.linalg.eigh(a_ + b_ @ mm)[1]  # the Schur complement A − B C⁺ Bᵀ
    dirs = [v[:, 0]]
    q = 0.5 * (mm + mm.T)
    q00, q01, q11 = v[:, 0] @ q @ v[:, 0], v[:, 0] @ q @ v[:, 1], v[:, 1] @ q @ v[:, 1]
    disc = q01 * q01 - q00 * q11
    if disc >= 0 and q11 != 0:
        for t in ((-q01 + np.sqrt(disc)) / q11, (-q01 - np.sqrt(disc)) / q11):
            dirs.append(v[:, 0] + t * v[:, 1])
    out = []
    for a in dirs:
        a = a / np.linalg.norm(a)
        out.append((np.cross(a, mm @ a), a))
    return out
