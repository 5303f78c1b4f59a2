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

from ._geometry import Frame, LMResult, complement, covariance, orient, principal_axes, propagate


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

    def fit(self, yt: np.ndarray, start: np.ndarray | None = None, max_iter: int = 100,
            xtol: float = 0.0) -> LMResult:
        m, _, vt = principal_axes(yt)
        a = vt[0]
        d = self.dim
        if start is not None and a @ start[d:] < 0:
            a = -a
        elif start is None:
            a = orient(a)
        state = np.concatenate([m, a])
        r, jt = self._components(state, yt)
        return LMResult(state, r, jt, 0)

    def _components(self, state: np.ndarray, yt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stacked perpendicular residual components (k n,) and their transposed
        Jacobian (2k, k n) w.r.t. the shifts of the line along the perpendicular
        directions and its tilts towards them (k = d − 1)."""
        d = self.dim
        m, a = state[:d], state[d:]
        b = _perp(a)
        yc = yt - m[:, None]
        z = a @ yc
        comp = b @ yc                        # (k, n)
        k = d - 1
        n = yt.shape[1]
        jt = np.zeros((2 * k, n * k))
        for i in range(k):                   # k <= 2: a loop over components, not points
            jt[i, i * n:(i + 1) * n] = -1.0
            jt[k + i, i * n:(i + 1) * n] = -z
        return comp.ravel(), jt

    def residuals(self, state: np.ndarray, yt: np.ndarray) -> np.ndarray:
        d = self.dim
        comp = _perp(state[d:]) @ (yt - state[:d, None])
        return comp[0] if d == 2 else np.sqrt(np.einsum("ij,ij->j", comp, comp))

    def report(self, res: LMResult, frame: Frame) -> tuple[dict, dict, np.ndarray, tuple]:
        d, s = self.dim, frame.scale
        m, a = res.state[:d], res.state[d:]
        k = d - 1
        cov = covariance(res.jt, float(res.r @ res.r))
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
