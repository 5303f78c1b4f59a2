"""Least-squares cylinder: ``min Σ (|P (x_i − p)| − r)²`` over a point p on the axis
(mm), the unit axis direction a and the radius r (mm), P = I − a aᵀ.

Damped Gauss-Newton in a frame that moves with the solution: at each iteration the
local parameters are two shifts of the axis and two tilts about the current point
(towards the unit vectors b1, b2 perpendicular to the axis) and the radius, with
Jacobian rows ``[−w1, −w2, −z w1, −z w2, −1]`` (w the unit radial vector of the point
in (b1, b2), z its height along the axis). After each step the point p is moved along
the axis to the foot of the centroid, which keeps the tilts uncorrelated with the
shifts.

Start values: the axis candidates are the direction perpendicular to the estimated
surface normals (smallest eigenvector of Σ n nᵀ, normals from the 12 nearest
neighbours) and the three principal directions of the points; for each, the planar
circle of the points projected along it gives p and r; the candidate with the smallest
sum of squares after a short fit on a subset wins. This finds the axis of partial
cylinders (a 60° arc) where a principal-axis start alone fails.

Reference: A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report
DITC 140/89 (1989), section 7; C. M. Shakarji, "Least-squares fitting algorithms of
the NIST algorithm testing system", J. Res. NIST 103 (1998) 633-641.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

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
    orient,
    principal_axes,
    propagate,
    subsample,
)
from .spheres import DIVERGED, SUBSET, HypersphereModel

_PLANAR = HypersphereModel(2)
#: Points used to screen the start candidates.
SCREEN = 3000


def normal_axis(yt: np.ndarray, k: int = 12) -> np.ndarray | None:
    """Axis estimate: the direction most perpendicular to the local surface normals of
    points (3, n) (normals from the k nearest neighbours, :func:`local_normals`)."""
    normals = local_normals(yt, k)
    if normals is None:
        return None
    return np.linalg.eigh(normals.T @ normals)[1][:, 0]


@dataclass
class CylinderModel:
    """The cylinder for the fitting engine; ``state`` is ``[p (3), a (3), r]``
    (normalised), points are columns (3, n)."""

    element: str = "cylinder"
    n_params: int = 5
    dim: int = 3

    def check(self, yt: np.ndarray) -> None:
        s = principal_axes(subsample(yt, SUBSET))[1]
        if s[1] <= FLAT * s[0] or s[2] <= FLAT * s[0]:
            s = principal_axes(yt)[1]
            if s[1] <= FLAT * s[0]:
                raise GeometryError("cylinder fit: the points are collinear; a cylinder needs points around an axis")
            if s[2] <= FLAT * s[0]:
                raise GeometryError("cylinder fit: the points are coplanar; a cylinder needs points off a plane")

    _parts = staticmethod(axial_parts)

    def evaluate(self, state: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        z, uv, rho = self._parts(state, yt)
        w = uv / np.where(rho > 0, rho, 1.0)
        jt = np.empty((5, yt.shape[1]))
        jt[0:2] = -w
        jt[2:4] = -z * w
        jt[4] = -1.0
        return rho - state[6], jt

    @staticmethod
    def update(state: np.ndarray, dp: np.ndarray, centroid: np.ndarray) -> np.ndarray:
        p, a, r = state[:3], state[3:6], state[6]
        b = complement(a)
        p = p + dp[0] * b[0] + dp[1] * b[1]
        a = a + dp[2] * b[0] + dp[3] * b[1]
        a = a / np.linalg.norm(a)
        p = p + ((centroid - p) @ a) * a
        return np.concatenate([p, a, [r + dp[4]]])

    def advance(self, state: np.ndarray, dp: np.ndarray) -> np.ndarray:
        return self.update(state, dp, state[:3])

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        return self._parts(state, yt)[2] - state[6]

    def _check(self, state: np.ndarray) -> None:
        if not abs(state[6]) < DIVERGED:
            raise GeometryError("cylinder fit: the radius diverges; the points lie nearly on a plane")

    def _lm(self, yt, state, max_iter, xtol, rate_hint=None) -> LMResult:
        return model_lm(self, yt, state, max_iter, xtol, rate_hint, "cylinder fit", centred=True)

    def start(self, yt: np.ndarray) -> np.ndarray:
        """Best of the start candidates (see the module docstring) on up to SCREEN points."""
        ys = subsample(yt, SCREEN)
        m, _, vt = principal_axes(ys)
        axes = [vt[0], vt[1], vt[2]]
        na = normal_axis(ys)
        if na is not None:
            axes.insert(0, na)

        def along(a: np.ndarray) -> np.ndarray:  # the circle of the points projected across a
            b = complement(a)
            c2 = _PLANAR.fit(np.ascontiguousarray(b @ (ys - m[:, None])), max_iter=100, xtol=1e-8).state
            return np.concatenate([m + c2[0] * b[0] + c2[1] * b[1], a, [c2[2]]])

        return best_start(
            self,
            ys,
            [partial(along, a) for a in axes],
            "cylinder fit: no start value converged; the points do not look like a cylinder",
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

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        s = frame.scale
        p, a, r = res.state[:3], res.state[3:6], res.state[6]
        assert res.jt is not None  # Gauss-Newton keeps its Jacobian
        cov = covariance(res.jt, float(res.r @ res.r), res.scaled)
        lengths = np.array([s, s, 1.0, 1.0, s])
        cov = cov * np.outer(lengths, lengths)
        b = complement(a)
        dpoint = np.hstack([b.T, np.zeros((3, 3))])
        daxis = np.hstack([np.zeros((3, 2)), b.T, np.zeros((3, 1))])
        var_r = cov[4, 4]
        params = {"point": p * s + frame.origin, "axis": orient(a), "radius": float(r * s)}
        std = {
            "point": propagate(cov, dpoint),
            "axis": propagate(cov, daxis),
            "radius": float(np.sqrt(var_r)) if var_r >= 0 else float("nan"),
        }
        return params, std, cov, ("shift_b1", "shift_b2", "tilt_b1", "tilt_b2", "radius")


CYLINDER = CylinderModel()
