"""Least-squares spheres (3D) and circles in the plane (2D): the same problem in d
dimensions, ``min Σ (|x_i − c| − r)²`` over the centre c (mm) and radius r (mm).

Start: the algebraic (Kåsa) fit ``|x|² = 2 c·x + k`` on the centred, scaled points —
linear, but biased on partial arcs and caps — then damped Gauss-Newton on the
orthogonal residuals ``|x_i − c| − r`` with Jacobian rows ``[−u_iᵀ, −1]``, u_i the unit
vector from the centre to the point. For a million points the start comes from a
strided subset of 10 000 points; the full data then need two or three iterations.

References: W. Gander, G. H. Golub, R. Strebel, "Least-squares fitting of circles and
ellipses", BIT 34 (1994) 558-578; A. B. Forbes, "Least-squares best-fit geometric
elements", NPL Report DITC 140/89 (1989).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ._geometry import (
    FLAT,
    Frame,
    GeometryError,
    LMResult,
    covariance,
    dot,
    levenberg_marquardt,
    principal_axes,
    subsample,
)

#: Above this many points the start values come from a strided subset.
SUBSET = 10_000
#: A radius beyond this many times the point spread means the points are (nearly) flat.
DIVERGED = 1e7


def algebraic(yt: np.ndarray) -> np.ndarray:
    """Kåsa's algebraic hypersphere ``[c, r]`` of normalised points (d, n) by a linear
    least-squares solve (SVD-based, no normal equations)."""
    a = np.vstack([2.0 * yt, np.ones(yt.shape[1])]).T
    b = np.einsum("ij,ij->j", yt, yt)
    sol = sla.lstsq(a, b, check_finite=False)[0]
    c = sol[:-1]
    rr = sol[-1] + c @ c
    r = np.sqrt(rr) if rr > 0 else float(np.mean(np.linalg.norm(yt - c[:, None], axis=0)))
    return np.append(c, r)


def _distances(c: np.ndarray, yt: np.ndarray, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(c − y) (d, n) and the distances |y − c| (n,), on points as columns (fast layout)."""
    diff = np.subtract(c[:, None], yt, out=out)
    rho = np.einsum("ij,ij->j", diff, diff)  # one pass, no temporaries of squares
    np.sqrt(rho, out=rho)
    return diff, rho


@dataclass
class HypersphereModel:
    """The sphere (d = 3) or the planar circle (d = 2) for the fitting engine.

    ``state`` is the array ``[c_1..c_d, r]`` in normalised coordinates; points are
    columns (d, n).
    """

    dim: int = 3

    @property
    def element(self) -> str:
        return "sphere" if self.dim == 3 else "circle"

    @property
    def n_params(self) -> int:
        return self.dim + 1

    def check(self, yt: np.ndarray) -> None:
        """Raise GeometryError when the points lie in a (d − 1)-dimensional flat."""
        sub = subsample(yt, SUBSET)
        for pts in (sub, yt) if sub is not yt else (yt,):
            s = principal_axes(pts)[1]
            if s[-1] > FLAT * s[0]:
                return
        flat = "a plane (coplanar)" if self.dim == 3 else "a straight line (collinear)"
        if self.dim == 3 and s[1] <= FLAT * s[0]:
            flat = "a straight line (collinear)"
        raise GeometryError(f"{self.element} fit: the points lie on {flat}; a {self.element} needs points off it")

    def evaluate(self, p: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = self.dim
        jt = np.empty((d + 1, yt.shape[1]))
        diff, rho = _distances(p[:d], yt, out=jt[:d])
        # rows 0..d-1: −u (a point at the centre keeps its zero row; checked first, as
        # the guarded division costs a temporary of the whole array)
        if rho.min() > 0:
            diff /= rho
        else:
            diff /= np.where(rho > 0, rho, 1.0)
        jt[d] = -1.0
        return rho - p[d], jt

    def residuals(self, p: np.ndarray, yt: np.ndarray) -> np.ndarray:
        return _distances(p[: self.dim], yt)[1] - p[self.dim]

    def _check_radius(self, p: np.ndarray) -> None:
        if not (abs(p[self.dim]) < DIVERGED):
            flat = "a plane" if self.dim == 3 else "a line"
            raise GeometryError(f"{self.element} fit: the radius diverges; the points lie nearly on {flat}")

    def fit(
        self,
        yt: np.ndarray,
        start: np.ndarray | None = None,
        max_iter: int = 100,
        xtol: float = 1e-13,
        rate_hint: float | None = None,
    ) -> LMResult:
        """Least-squares fit to normalised points (d, n); ``start`` a previous state."""
        if start is None:
            sub = subsample(yt, SUBSET)
            start = algebraic(sub)
            if sub is not yt:
                start = self._lm(sub, start, max_iter, 1e-10).state
        return self._lm(yt, np.asarray(start, dtype=float), max_iter, xtol, rate_hint)

    def _lm(self, yt, p0, max_iter, xtol, rate_hint=None) -> LMResult:
        try:
            res = levenberg_marquardt(
                lambda p: self.evaluate(p, yt),
                p0,
                lambda p, dp: p + dp,
                max_iter=max_iter,
                xtol=xtol,
                what=f"{self.element} fit",
                check=self._check_radius,
                rate_hint=rate_hint,
            )
        except GeometryError as exc:
            s = principal_axes(subsample(yt, SUBSET))[1]
            if s[-1] < 0.02 * s[0] and "diverges" not in str(exc):
                flat = "a plane" if self.dim == 3 else "a line"
                raise GeometryError(
                    f"{self.element} fit: the points lie nearly on {flat} (thickness "
                    f"{s[-1] / s[0]:.1e} of their spread), which determines no {self.element}: "
                    f"{exc}"
                ) from None
            raise
        if res.state[self.dim] < 0:
            raise GeometryError(f"{self.element} fit converged to a negative radius")
        return res

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        """Parameters and standard uncertainties in mm."""
        d, s = self.dim, frame.scale
        p = res.state
        assert res.jt is not None  # Gauss-Newton keeps its Jacobian
        cov = covariance(res.jt, dot(res.r, res.r), res.scaled) * s * s
        params = {"center": p[:d] * s + frame.origin, "radius": float(p[d] * s)}
        var = np.clip(np.diag(cov), 0, None)  # NaN (no degrees of freedom) stays NaN
        std = {"center": np.sqrt(var[:d]), "radius": float(np.sqrt(var[d]))}
        names = tuple(f"center_{a}" for a in "xyz"[:d]) + ("radius",)
        return params, std, cov, names


SPHERE = HypersphereModel(3)
CIRCLE2D = HypersphereModel(2)
