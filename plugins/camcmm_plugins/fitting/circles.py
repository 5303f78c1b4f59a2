"""Least-squares circles: in the plane (points (N, 2)) and in space (points (N, 3)).

In the plane: ``min Σ (|x_i − c| − r)²``, see :mod:`.spheres` (the same problem in
two dimensions).

In space the orthogonal distance of a point from the circle (centre c, unit normal
n, radius r) is ``d_i = sqrt(h_i² + (ρ_i − r)²)`` with ``h_i = (x_i − c)·n`` its height
above the circle's plane and ``ρ_i`` its distance from the centre within that plane.
The fit minimises ``Σ d_i²`` by damped Gauss-Newton on the 2N stacked components
``(ρ_i − r, h_i)``, which are smooth where ``d_i`` itself is not. Start: the
least-squares plane, then the planar circle of the points projected onto it. The
reported residual is ``d_i`` signed by the side of the circle's cylinder the point is
on: positive for ``ρ_i ≥ r``.

Reference: A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report
DITC 140/89 (1989), section 6 (circle in space).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._geometry import (
    FLAT,
    Frame,
    GeometryError,
    LMResult,
    axial_parts,
    complement,
    covariance,
    levenberg_marquardt,
    orient,
    principal_axes,
    propagate,
    subsample,
)
from .spheres import DIVERGED, SUBSET, HypersphereModel

_PLANAR = HypersphereModel(2)


@dataclass
class Circle3DModel:
    """The circle in space for the fitting engine; ``state`` is ``[c (3), n (3), r]``
    (normalised), points are columns (3, n)."""

    element: str = "circle"
    n_params: int = 6
    dim: int = 3

    def check(self, yt: np.ndarray) -> None:
        s = principal_axes(subsample(yt, SUBSET))[1]
        if s[1] <= FLAT * s[0]:
            s = principal_axes(yt)[1]
            if s[1] <= FLAT * s[0]:
                raise GeometryError("circle fit: the points are collinear; a circle needs points off a line")

    _parts = staticmethod(axial_parts)  # h along the normal, uv and ρ in the plane

    def evaluate(self, state: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h, uv, rho = self._parts(state, yt)
        w = uv / np.where(rho > 0, rho, 1.0)
        m = yt.shape[1]
        jt = np.zeros((6, 2 * m))
        jt[0, :m] = -w[0]
        jt[1, :m] = -w[1]
        jt[3, :m] = -h * w[0]
        jt[4, :m] = -h * w[1]
        jt[5, :m] = -1.0
        jt[2, m:] = -1.0
        jt[3, m:] = uv[0]
        jt[4, m:] = uv[1]
        return np.concatenate([rho - state[6], h]), jt

    @staticmethod
    def update(state: np.ndarray, dp: np.ndarray) -> np.ndarray:
        c, n, r = state[:3], state[3:6], state[6]
        b = complement(n)
        c = c + dp[0] * b[0] + dp[1] * b[1] + dp[2] * n
        n = n + dp[3] * b[0] + dp[4] * b[1]
        return np.concatenate([c, n / np.linalg.norm(n), [r + dp[5]]])

    def advance(self, state: np.ndarray, dp: np.ndarray) -> np.ndarray:
        return self.update(state, dp)

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        h, _, rho = self._parts(state, yt)
        e = rho - state[6]
        return np.where(e >= 0, 1.0, -1.0) * np.hypot(e, h)

    def start(self, yt: np.ndarray) -> np.ndarray:
        """The least-squares plane, then the planar circle of the projected points."""
        m, _, vt = principal_axes(yt)
        n = vt[2]
        b = vt[:2]
        uv = b @ (yt - m[:, None])
        p = _PLANAR.fit(np.ascontiguousarray(uv), max_iter=200, xtol=1e-10).state
        return np.concatenate([m + p[0] * b[0] + p[1] * b[1], n, [p[2]]])

    def _check(self, state: np.ndarray) -> None:
        if not abs(state[6]) < DIVERGED:
            raise GeometryError("circle fit: the radius diverges; the points lie nearly on a line")

    def fit(
        self,
        yt: np.ndarray,
        start: np.ndarray | None = None,
        max_iter: int = 100,
        xtol: float = 1e-13,
        rate_hint: float | None = None,
    ) -> LMResult:
        if start is None:
            sub = subsample(yt, SUBSET)
            start = self.start(sub)
            if sub is not yt:
                start = self._lm(sub, start, max_iter, 1e-10).state
        return self._lm(yt, start, max_iter, xtol, rate_hint)

    def _lm(self, yt, state, max_iter, xtol, rate_hint=None) -> LMResult:
        return levenberg_marquardt(
            lambda s: self.evaluate(s, yt),
            np.asarray(state, float),
            self.update,
            max_iter=max_iter,
            xtol=xtol,
            what="circle fit",
            check=self._check,
            rate_hint=rate_hint,
        )

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        s = frame.scale
        c, n, r = res.state[:3], res.state[3:6], res.state[6]
        assert res.jt is not None  # Gauss-Newton keeps its Jacobian
        cov = covariance(res.jt, float(res.r @ res.r), res.scaled)
        lengths = np.array([s, s, s, 1.0, 1.0, s])
        cov = cov * np.outer(lengths, lengths)
        b = complement(n)
        z3 = np.zeros((3, 3))
        dcenter = np.hstack([np.column_stack([b[0], b[1], n]), z3])
        dnormal = np.hstack([z3, np.column_stack([b[0], b[1], np.zeros(3)])])
        var_r = cov[5, 5]
        params = {"center": c * s + frame.origin, "normal": orient(n), "radius": float(r * s)}
        std = {
            "center": propagate(cov, dcenter),
            "normal": propagate(cov, dnormal),
            "radius": float(np.sqrt(var_r)) if var_r >= 0 else float("nan"),
        }
        return params, std, cov, ("center_b1", "center_b2", "center_n", "tilt_b1", "tilt_b2", "radius")


CIRCLE3D = Circle3DModel()
