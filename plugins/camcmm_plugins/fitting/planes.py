"""Least-squares plane: ``min Σ ((x_i − p)·n)²`` over a point p (mm) and unit normal n.

Closed form: p is the centroid and n the right singular vector of the centred points
with the smallest singular value (total least squares). The singular vectors come
from an SVD of the R factor of a QR decomposition of the centred, scaled points, so
the normal is accurate to machine precision even for a long thin strip.

Reference: A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report
DITC 140/89 (1989), section 4; ISO 10360-6:2001 annex B.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._geometry import (
    FLAT,
    Frame,
    GeometryError,
    LMResult,
    complement,
    fit_covariance,
    orient,
    principal_axes,
    propagate,
    subsample,
)

#: Points of the strided subset that :meth:`PlaneModel.check` tries first.
SUBSET = 10_000


@dataclass
class PlaneModel:
    """The plane for the fitting engine; ``state`` is ``[p (3), n (3)]`` (normalised),
    points are columns (3, n)."""

    element: str = "plane"
    n_params: int = 3
    dim: int = 3

    def check(self, yt: np.ndarray) -> None:
        # a strided subset that is not collinear proves it for all points (as the sphere's
        # check): the full QR is left to the fit, which needs it anyway
        sub = subsample(yt, SUBSET)
        for pts in (sub, yt) if sub is not yt else (yt,):
            s = principal_axes(pts)[1]
            if s[1] > FLAT * s[0]:
                return
        raise GeometryError("plane fit: the points are collinear; a plane needs points off a line")

    def fit(self, yt: np.ndarray, start: np.ndarray | None = None, max_iter: int = 100, xtol: float = 0.0) -> LMResult:
        m, sv, vt = principal_axes(yt)
        n = vt[2]
        if start is not None and n @ start[3:] < 0:
            n = -n
        elif start is None:
            n = orient(n)
        state = np.concatenate([m, n])
        # JᵀJ for (offset along n, tilts about the centroid towards b1, b2): the Jacobian
        # rows are [−1, ξ, η] with in-plane coordinates of zero mean, so JᵀJ is
        # diag(N, B S Bᵀ) with S the scatter matrix (from the singular values).
        b = complement(n)
        scatter = (vt.T * sv**2) @ vt
        gram = np.zeros((3, 3))
        gram[0, 0] = yt.shape[1]
        gram[1:, 1:] = b @ scatter @ b.T
        return LMResult(state, self.residuals(state, yt), None, 0, gram=(gram, yt.shape[1]))

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        return state[3:] @ yt - state[3:] @ state[:3]

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        s = frame.scale
        m, n = res.state[:3], res.state[3:]
        cov = fit_covariance(res)
        cov[0, :] *= s
        cov[:, 0] *= s
        b = complement(n)
        dpoint = np.column_stack([n, np.zeros((3, 2))])
        dnormal = np.column_stack([np.zeros(3), b[0], b[1]])
        params = {"point": m * s + frame.origin, "normal": n}
        std = {"point": propagate(cov, dpoint), "normal": propagate(cov, dnormal)}
        return params, std, cov, ("offset", "tilt_b1", "tilt_b2")


PLANE = PlaneModel()
