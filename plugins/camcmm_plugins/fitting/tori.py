"""Least-squares and minimum-zone torus: centre c (mm), unit axis a, major radius R (mm,
from the axis to the centre of the tube) and minor radius r (mm, of the tube).

Residual (signed, outside the tube positive): the distance of a point from the tube's
centre circle minus r,

    d = sqrt((ρ − R)² + z²) − r,

with z the height of the point along the axis above c and ρ its distance from the axis.

Damped Gauss-Newton in a frame that moves with the solution: local parameters three
shifts of the centre (along b1, b2 ⊥ a and along a), two tilts of the axis about the
centre (towards b1, b2), R and r. With q = sqrt((ρ − R)² + z²), e_ρ = (ρ − R)/q,
e_z = z/q and (u1, u2) = ρ w the point's components across the axis, the Jacobian rows
are ``[−e_ρ w1, −e_ρ w2, −e_z, −e_ρ z w1 + e_z u1, −e_ρ z w2 + e_z u2, −e_ρ, −1]``. The
minimum zone (two tori of the same centre circle, radii r ± t/2) is solved by
sequential linear programming on the same linearisation (:func:`.minzone.surface`).

Start values: the axis that the surface normals meet (every normal line of a torus
meets its axis; :func:`._geometry.revolution_axes`) and the three principal directions
through the centroid; for each, the circle through the points in the meridian
half-plane (z, ρ) gives the height of the centre, R and r; the candidate with the
smallest sum of squares after a short fit on a subset wins. This finds tori from 30°
of arc around the axis and part of the tube's circle.

References: A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report DITC
140/89 (1989), section 9 (torus); ISO 10360-6:2001 (test of the fitting software with
reference data sets).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from . import minzone
from ._geometry import (
    Frame,
    GeometryError,
    LMResult,
    axial_parts,
    best_start,
    complement,
    covariance,
    fit_from_starts,
    model_lm,
    orient,
    propagate,
    subsample,
)
from .cones import SCREEN, _meridian, candidate_axes, check_spread
from .spheres import DIVERGED, SUBSET, HypersphereModel

_PLANAR = HypersphereModel(2)


@dataclass
class TorusModel:
    """The torus for the fitting engine; ``state`` is ``[c (3), a (3), R, r]``
    (normalised), points are columns (3, n)."""

    element: str = "torus"
    n_params: int = 7
    dim: int = 3

    def check(self, yt: np.ndarray) -> None:
        check_spread(yt, self.element)

    @staticmethod
    def _parts(state: np.ndarray, yt: np.ndarray):
        z, uv, rho = axial_parts(state, yt)
        return z, uv, rho, np.hypot(rho - state[6], z)

    def evaluate(self, state: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        z, uv, rho, q = self._parts(state, yt)
        qs = np.where(q > 0, q, 1.0)
        er, ez = (rho - state[6]) / qs, z / qs
        w = uv / np.where(rho > 0, rho, 1.0)
        jt = np.empty((7, yt.shape[1]))
        jt[0:2] = -er * w
        jt[2] = -ez
        jt[3:5] = -er * z * w + ez * uv
        jt[5] = -er
        jt[6] = -1.0
        return q - state[7], jt

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        return self._parts(state, yt)[3] - state[7]

    @staticmethod
    def update(state: np.ndarray, dp: np.ndarray) -> np.ndarray:
        c, a = state[:3], state[3:6]
        b = complement(a)
        c = c + dp[0] * b[0] + dp[1] * b[1] + dp[2] * a
        a = a + dp[3] * b[0] + dp[4] * b[1]
        a = a / np.linalg.norm(a)
        return np.concatenate([c, a, [state[6] + dp[5], state[7] + dp[6]]])

    def advance(self, state: np.ndarray, dp: np.ndarray) -> np.ndarray:
        return self.update(state, dp)

    def _check(self, state: np.ndarray) -> None:
        if not (abs(state[6]) < DIVERGED and abs(state[7]) < DIVERGED):
            raise GeometryError("torus fit: the radii diverge; the points do not determine a torus")

    def _lm(self, yt, state, max_iter, xtol, rate_hint=None) -> LMResult:
        return model_lm(self, yt, state, max_iter, xtol, rate_hint, "torus fit", centred=False)

    def start(self, yt: np.ndarray) -> np.ndarray:
        """Best of the start candidates (module docstring) on up to SCREEN points."""
        ys = subsample(yt, SCREEN)

        def meridian_circle(p: np.ndarray, a: np.ndarray) -> np.ndarray:  # the tube's section
            z, rho = _meridian(ys, p, a)
            zc, big, small = _PLANAR.fit(np.vstack([z, rho]), max_iter=100, xtol=1e-8).state
            return np.concatenate([p + zc * a, a, [big, small]])

        return best_start(
            self,
            ys,
            [partial(meridian_circle, p, a) for p, a in candidate_axes(ys)],
            "torus fit: no start value converged; the points do not look like a torus (a short arc of "
            "a tube does not fix the major radius: fit a cylinder)",
            accept=lambda s: s[6] > 0 and s[7] > 0,
        )

    def fit(
        self,
        yt: np.ndarray,
        start: np.ndarray | None = None,
        max_iter: int = 100,
        xtol: float = 1e-13,
        rate_hint: float | None = None,
    ) -> LMResult:
        res = fit_from_starts(self, yt, start, max_iter, xtol, rate_hint, SUBSET)
        if not (res.state[6] > 0 and res.state[7] > 0):
            raise GeometryError("torus fit converged to a negative radius; the points do not look like a torus")
        return res

    def minzone(self, yt: np.ndarray, state: np.ndarray) -> tuple[np.ndarray, float]:
        """Minimum-zone torus from the least-squares ``state``: (mid-zone state, width)."""
        return minzone.surface(lambda s: self.evaluate(s, yt), self.update, state, 6, "minimum-zone torus")

    @staticmethod
    def params(state: np.ndarray, frame: Frame) -> dict:
        """centre (3,) mm, unit axis (3,), major and minor radius (mm)."""
        return {
            "center": state[:3] * frame.scale + frame.origin,
            "axis": orient(state[3:6]),
            "major_radius": float(state[6] * frame.scale),
            "minor_radius": float(state[7] * frame.scale),
        }

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        sc = frame.scale
        a = res.state[3:6]
        assert res.jt is not None  # Gauss-Newton keeps its Jacobian
        cov = covariance(res.jt, float(res.r @ res.r), res.scaled)
        lengths = np.array([sc, sc, sc, 1.0, 1.0, sc, sc])
        cov = cov * np.outer(lengths, lengths)
        b = complement(a)
        dcentre = np.hstack([b.T, a[:, None], np.zeros((3, 4))])
        daxis = np.hstack([np.zeros((3, 3)), b.T, np.zeros((3, 2))])
        var = np.diag(cov)
        std = {
            "center": propagate(cov, dcentre),
            "axis": propagate(cov, daxis),
            "major_radius": float(np.sqrt(var[5])) if var[5] >= 0 else float("nan"),
            "minor_radius": float(np.sqrt(var[6])) if var[6] >= 0 else float("nan"),
        }
        names = ("shift_b1", "shift_b2", "shift_axis", "tilt_b1", "tilt_b2", "major_radius", "minor_radius")
        return self.params(res.state, frame), std, cov, names


TORUS = TorusModel()
