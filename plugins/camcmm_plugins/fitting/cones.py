"""Least-squares and minimum-zone cone: apex (mm), unit axis a pointing from the apex
into the cone, full apex angle 2ψ (degrees; the half-angle ψ in radians internally).

Residual (signed, outside positive): the orthogonal distance of a point from the
cone's generatrix in its meridian half-plane,

    d = ρ cos ψ − z sin ψ − s,

with z the height of the point along the axis above a point p of the axis, ρ its
distance from the axis and s the distance from p to the cone surface (the radius at p
is s / cos ψ). This is the exact distance for every point whose foot lies on the nappe
(not beyond the apex), and the parametrisation stays regular as ψ → 0 (a cylinder: s
is its radius, the apex goes to infinity), which an apex-based one does not.

Damped Gauss-Newton in a frame that moves with the solution, as for the cylinder: local
parameters two shifts and two tilts of the axis (towards b1, b2 ⊥ a), s and ψ, with
Jacobian rows ``[−w1 c, −w2 c, −z w1 c − u1 sn, −z w2 c − u2 sn, −1, −ρ sn − z c]``
(c = cos ψ, sn = sin ψ, (u1, u2) = ρ w the point's components across the axis). After
each step p moves along the axis to the foot of the centroid (s changes by Δz sin ψ),
which keeps the tilts uncorrelated with the shifts. The minimum zone (two coaxial
cones of the same angle, offset along their normals) is solved by sequential linear
programming on the same linearisation (:func:`.minzone.surface`).

Start values: the axis that the surface normals meet (:func:`._geometry.revolution_axes`,
every normal line of a surface of revolution meets its axis), then the three principal
directions through the centroid; for each, the straight line through the points in the
meridian half-plane (z, ρ) gives ψ and s; the candidate with the smallest sum of squares
after a short fit on a subset wins. This finds 30° arcs of a cone.

References: A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report DITC
140/89 (1989), section 8 (cone); C. M. Shakarji, "Least-squares fitting algorithms of
the NIST algorithm testing system", J. Res. NIST 103 (1998) 633-641; ISO 10360-6:2001
(test of the fitting software with reference data sets).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from . import minzone
from ._geometry import (
    FLAT,
    Frame,
    GeometryError,
    LMResult,
    axial_parts,
    best_start,
    complement,
    covariance,
    fit_from_starts,
    local_normals,
    model_lm,
    principal_axes,
    propagate,
    revolution_axes,
    subsample,
)
from .spheres import SUBSET

#: Points used to screen the start candidates.
SCREEN = 3000
#: |ψ| beyond this (radians, 89.9°) is a plane, not a cone: the axis shifts lose their effect.
PSI_MAX = np.radians(89.9)


def _meridian(yt: np.ndarray, p: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heights z along the unit axis a above p and distances ρ from the axis of points (3, n)."""
    yc = yt - p[:, None]
    z = a @ yc
    uv = complement(a) @ yc
    return z, np.sqrt(np.einsum("ij,ij->j", uv, uv))


def candidate_axes(yt: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Start axes (point, unit direction) of a surface of revolution through points (3, n):
    the axis its normals meet, then the principal directions through the centroid."""
    m, _, vt = principal_axes(yt)
    axes = [(m, vt[0]), (m, vt[1]), (m, vt[2])]
    normals = local_normals(yt)
    if normals is not None:
        axes = revolution_axes(yt, normals) + axes
    return axes


def check_spread(yt: np.ndarray, element: str) -> None:
    """GeometryError when points (3, n) are collinear or coplanar (no surface of
    revolution is determined by them)."""
    s = principal_axes(subsample(yt, SUBSET))[1]
    if s[1] <= FLAT * s[0] or s[2] <= FLAT * s[0]:
        s = principal_axes(yt)[1]
        if s[1] <= FLAT * s[0]:
            raise GeometryError(f"{element} fit: the points are collinear; a {element} needs points around an axis")
        if s[2] <= FLAT * s[0]:
            raise GeometryError(f"{element} fit: the points are coplanar; a {element} needs points off a plane")


@dataclass
class ConeModel:
    """The cone for the fitting engine; ``state`` is ``[p (3), a (3), s, ψ]`` (normalised
    lengths, ψ in radians, signed: ψ < 0 when the cone opens towards −a), points are
    columns (3, n)."""

    element: str = "cone"
    n_params: int = 6
    dim: int = 3

    def check(self, yt: np.ndarray) -> None:
        check_spread(yt, self.element)

    _parts = staticmethod(axial_parts)

    def evaluate(self, state: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        z, uv, rho = self._parts(state, yt)
        c, sn = np.cos(state[7]), np.sin(state[7])
        w = uv / np.where(rho > 0, rho, 1.0)
        jt = np.empty((6, yt.shape[1]))
        jt[0:2] = -c * w
        jt[2:4] = -c * z * w - sn * uv
        jt[4] = -1.0
        jt[5] = -sn * rho - c * z
        return c * rho - sn * z - state[6], jt

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        z, _, rho = self._parts(state, yt)
        return np.cos(state[7]) * rho - np.sin(state[7]) * z - state[6]

    @staticmethod
    def update(state: np.ndarray, dp: np.ndarray, centroid: np.ndarray) -> np.ndarray:
        p, a = state[:3], state[3:6]
        b = complement(a)
        p = p + dp[0] * b[0] + dp[1] * b[1]
        a = a + dp[2] * b[0] + dp[3] * b[1]
        a = a / np.linalg.norm(a)
        s, psi = state[6] + dp[4], state[7] + dp[5]
        dz = (centroid - p) @ a  # the same cone seen from the centroid's foot on the axis
        return np.concatenate([p + dz * a, a, [s + dz * np.sin(psi), psi]])

    def advance(self, state: np.ndarray, dp: np.ndarray) -> np.ndarray:
        return self.update(state, dp, state[:3])

    def _check(self, state: np.ndarray) -> None:
        if not abs(state[7]) < PSI_MAX:
            raise GeometryError("cone fit: the apex angle reaches 180°; the points lie nearly on a plane")

    def _lm(self, yt, state, max_iter, xtol, rate_hint=None) -> LMResult:
        return model_lm(self, yt, state, max_iter, xtol, rate_hint, "cone fit", centred=True)

    def start(self, yt: np.ndarray) -> np.ndarray:
        """Best of the start candidates (module docstring) on up to SCREEN points."""
        ys = subsample(yt, SCREEN)

        def generatrix(p: np.ndarray, a: np.ndarray) -> np.ndarray:
            z, rho = _meridian(ys, p, a)
            # the generatrix: the straight line through (z, ρ), orthogonal least squares
            mz, sv, vt = principal_axes(np.vstack([z, rho]))
            ez, er = vt[0] if vt[0][0] >= 0 else -vt[0]
            psi = float(np.arctan2(er, ez))
            return np.concatenate([p + mz[0] * a, a, [mz[1] * np.cos(psi), psi]])

        return best_start(
            self,
            ys,
            [partial(generatrix, p, a) for p, a in candidate_axes(ys)],
            "cone fit: no start value converged; the points do not look like a cone",
        )

    def fit(
        self,
        yt: np.ndarray,
        start: np.ndarray | None = None,
        max_iter: int = 100,
        xtol: float = 1e-13,
        rate_hint: float | None = None,
    ) -> LMResult:
        return fit_from_starts(self, yt, start, max_iter, xtol, rate_hint, SUBSET)

    def minzone(self, yt: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, float]:
        """Minimum-zone cone from the least-squares ``state``: (mid-zone state, width)."""
        centroid = yt.mean(axis=1)
        return minzone.surface(
            lambda s: self.evaluate(s, yt),
            lambda s, dp: self.update(s, dp, centroid),
            state,
            4,
            "minimum-zone cone",
        )

    @staticmethod
    def params(state: np.ndarray, frame: Frame) -> dict:
        """apex (3,) mm, unit axis (3,) from the apex into the cone, full angle (degrees)."""
        p, a, s, psi = state[:3], state[3:6], state[6], state[7]
        sign = 1.0 if psi >= 0 else -1.0
        apex = p - (s / np.sin(psi)) * a if psi != 0 else np.full(3, np.inf)
        return {"apex": apex * frame.scale + frame.origin, "axis": sign * a, "angle": float(np.degrees(2 * abs(psi)))}

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        sc = frame.scale
        a, psi = res.state[3:6], res.state[7]
        s_mm = res.state[6] * sc
        assert res.jt is not None  # Gauss-Newton keeps its Jacobian
        cov = covariance(res.jt, float(res.r @ res.r), res.scaled)
        lengths = np.array([sc, sc, 1.0, 1.0, sc, 1.0])
        cov = cov * np.outer(lengths, lengths)
        b = complement(a)
        sn = np.sin(psi) if psi != 0 else np.finfo(float).tiny
        # apex = p − (s / sin ψ) a: its derivatives with respect to the local parameters
        tilt = -s_mm / sn
        dapex = np.column_stack([b[0], b[1], tilt * b[0], tilt * b[1], -a / sn, s_mm * np.cos(psi) / sn**2 * a])
        daxis = np.hstack([np.zeros((3, 2)), b.T, np.zeros((3, 2))])
        var_psi = cov[5, 5]
        params = self.params(res.state, frame)
        std = {
            "apex": propagate(cov, dapex),
            "axis": propagate(cov, daxis),
            "angle": float(np.degrees(2 * np.sqrt(var_psi))) if var_psi >= 0 else float("nan"),
        }
        return params, std, cov, ("shift_b1", "shift_b2", "tilt_b1", "tilt_b2", "offset", "half_angle")


CONE = ConeModel()
