"""Least-squares straight line in 3D (or 2D): ``min Σ |P (x_i − p)|²`` over a point p
(mm) and unit direction a, P = I − a aᵀ.

Closed form: p is the centroid and a the right singular vector of the centred points
with the largest singular value (from an SVD of the R factor of their QR
decomposition). In 3D the residual of a point is its distance from the line (≥ 0,
a distance to a line in space has no sign); in 2D it is signed, positive on the left
of the direction (towards ``(−a_y, a_x)``).

Reference: A. B. Forbes, "Least-squares best-fit geometric elements", NPL Report
DITC 140/89 (1989), section 4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._geometry import Frame, LMResult, complement, fit_covariance, orient, principal_axes, propagate


def _perp(a: np.ndarray) -> np.ndarray:
    """Unit rows perpendicular to the direction a: (2, 3) in 3D, (1, 2) in 2D."""
    if len(a) == 2:
        return np.array([[-a[1], a[0]]])
    return complement(a)


@dataclass
class LineModel:
    """The line for the fitting engine; ``state`` is ``[p (d), a (d)]`` (normalised),
    points are columns (d, n)."""

    dim: int = 3
    element: str = "line"

    @property
    def n_params(self) -> int:
        return 2 * (self.dim - 1)

    def check(self, yt: np.ndarray) -> None:
        pass  # two distinct points define a line; coincident points are caught earlier

    def fit(self, yt: np.ndarray, start: np.ndarray | None = None, max_iter: int = 100, xtol: float = 0.0) -> LMResult:
        m, sv, vt = principal_axes(yt)
        a = vt[0]
        d = self.dim
        if start is not None and a @ start[d:] < 0:
            a = -a
        elif start is None:
            a = orient(a)
        state = np.concatenate([m, a])
        # The residual components across the line have Jacobian rows [−1, −z] per
        # component (shift, tilt), z the position along the line from the centroid:
        # JᵀJ = diag(N, …, Σz², …) with Σz² the largest squared singular value.
        k, n = d - 1, yt.shape[1]
        gram = np.diag([float(n)] * k + [float(sv[0] ** 2)] * k)
        return LMResult(state, self.residuals(state, yt), None, 0, gram=(gram, k * n))

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        d = self.dim
        comp = _perp(state[d:]) @ (yt - state[:d, None])
        return comp[0] if d == 2 else np.sqrt(np.einsum("ij,ij->j", comp, comp))

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        d, s = self.dim, frame.scale
        m, a = res.state[:d], res.state[d:]
        k = d - 1
        cov = fit_covariance(res)
        cov[:k, :] *= s
        cov[:, :k] *= s
        b = _perp(a)
        dpoint = np.hstack([b.T, np.zeros((d, k))])
        ddir = np.hstack([np.zeros((d, k)), b.T])
        params = {"point": m * s + frame.origin, "direction": a}
        std = {"point": propagate(cov, dpoint), "direction": propagate(cov, ddir)}
        names = tuple(f"shift_{i}" for i in range(k)) + tuple(f"tilt_{i}" for i in range(k))
        return params, std, cov, names


LINE3D = LineModel(3)
LINE2D = LineModel(2)
