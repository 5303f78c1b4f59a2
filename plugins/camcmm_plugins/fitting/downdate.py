"""Cheap refits after removing one point, for the fast ``vdi2634`` outlier rule.

The rule removes, one at a time, the point with the largest absolute residual and
refits after each removal. Refitting a million points 3 000 times is what the fast
implementation avoids; it must still remove exactly the same points as the naive
loop. Each *downdater* here keeps sufficient statistics of the current point set
that are updated in O(1) per removed point, re-solves the fit from them, and gives
the residuals of any candidate point at the current solution, plus a rigorous bound
on how far any point's residual has moved (used to prove that no point outside the
candidate set can be the next one) and a bound on the error of the model itself.
The driver (:func:`camcmm_plugins.fitting.outliers.vdi2634`) falls back to an exact
refit whenever a decision is closer than that error bound.

* Line and plane — exact: the fit is a function of the first and second moments
  ``n, Σy, Σy yᵀ`` of the points (relative to the anchor centroid), downdated by the
  removed point's contribution (a rank-one downdate) and re-solved by a 3x3
  eigen-decomposition.
* Sphere and planar circle — the least-squares problem reduces to the centre c alone:
  ``F(c) = ½[Σ|y_i − c|² − Φ(c)²/n]`` with ``Φ(c) = Σ|y_i − c|`` and ``r = Φ/n``. The
  first term is a quadratic in c (exact moments); Φ is replaced by its third-order
  Taylor expansion about the anchor centre c0, whose coefficients are the sums
  ``Σρ, Σu, Σ(I − u uᵀ)/ρ, Σu/ρ², Σu⊗u⊗u/ρ²`` (u unit vector, ρ distance from c0).
  Each removal subtracts the point's terms (O(d³)) and one or two Newton steps on
  the model give the new centre. The neglected fourth-order term is bounded by
  ``(1/8)|δ|⁴ Σ1/ρ³`` (δ the centre shift since the anchor), i.e. ~1e-20 relative
  for the shifts that 0.3 % of typical points cause; it enters the error bound, and a
  decision closer than that bound is taken after an exact refit instead.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgesv as _dgesv


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve a tiny dense system (LAPACK gesv without numpy.linalg's overhead)."""
    _, _, x, info = _dgesv(a, b)
    if info != 0:
        raise ZeroDivisionError("singular model Hessian")
    return x


#: Rounding floor of the residuals computed from downdated sums (normalised units).
ROUNDING = 1e-12


class MomentsDowndater:
    """Line (largest principal direction) or plane (smallest) from running moments."""

    def __init__(self, kind: str, yt: np.ndarray, state: np.ndarray, cand: np.ndarray):
        self.kind = kind                         # "plane", "line3", "line2"
        d = yt.shape[0]
        self.d = d
        self.m0 = state[:d].copy()
        z = yt - self.m0[:, None]
        self.n = yt.shape[1]
        self.s1 = z.sum(axis=1)
        self.s2 = z @ z.T
        self.r0 = float(np.sqrt(np.einsum("ij,ij->j", z, z).max()))
        self.zc = np.ascontiguousarray(z[:, cand].T)
        self.v0 = state[d:].copy()               # normal (plane) or direction (line)
        self._solve()
        self.mu_anchor, self.v_anchor = self.mu.copy(), self.v.copy()
        self.set_reference()

    def _solve(self) -> None:
        mean = self.s1 / self.n
        cov = self.s2 / self.n - np.outer(mean, mean)
        w, vec = np.linalg.eigh(cov)
        v = vec[:, 0] if self.kind == "plane" else vec[:, -1]
        self.v = -v if v @ self.v0 < 0 else v
        self.mu = mean                            # relative to m0

    def set_reference(self) -> None:
        self.mu_ref, self.v_ref = self.mu.copy(), self.v.copy()

    def _perp(self) -> np.ndarray:
        return np.array([-self.v[1], self.v[0]])

    def residuals(self, pos: np.ndarray) -> np.ndarray:
        zc = self.zc[pos] - self.mu
        if self.kind == "plane":
            return zc @ self.v
        if self.kind == "line2":
            return zc @ self._perp()
        along = zc @ self.v
        return np.sqrt(np.maximum(np.einsum("ij,ij->i", zc, zc) - along * along, 0.0))

    def _drift(self, mu, v) -> float:
        """Bound on |r_i(now) − r_i(then)| for any point: the change of the normal
        (direction) times the largest lever arm, plus the shift of the centroid across
        the element (a shift along a line or within a plane changes no residual)."""
        lever = self.r0 + float(np.linalg.norm(mu))
        dmu = self.mu - mu
        if self.kind == "line3":
            across = float(np.linalg.norm(dmu - (dmu @ self.v) * self.v))
            return 2.0 * lever * float(np.linalg.norm(self.v - v)) + across
        nrm = self.v if self.kind == "plane" else self._perp()
        return lever * float(np.linalg.norm(self.v - v)) + abs(float(dmu @ nrm))

    def drift(self) -> float:
        return self._drift(self.mu_ref, self.v_ref)

    def drift_anchor(self) -> float:
        return self._drift(self.mu_anchor, self.v_anchor)

    def error_bound(self) -> float:
        return ROUNDING

    def remove(self, pos: int) -> None:
        z = self.zc[pos]
        self.n -= 1
        self.s1 -= z
        self.s2 -= np.outer(z, z)
        self._solve()

    def state(self) -> np.ndarray:
        return np.concatenate([self.m0 + self.mu, self.v])


class HypersphereDowndater:
    """Sphere (d = 3) or planar circle (d = 2) from a third-order model of Φ (see the
    module docstring). The per-candidate terms of the sums are precomputed, so a
    removal is a handful of small array subtractions and one Newton step."""

    def __init__(self, yt: np.ndarray, state: np.ndarray, cand: np.ndarray,
                 pre: tuple[np.ndarray, np.ndarray] | None = None):
        """Anchor at ``state`` = [c0, r0]; ``pre`` = (u, ρ) of the points at c0 when the
        caller has them (the last Gauss-Newton evaluation: u = −Jᵀ rows)."""
        d = yt.shape[0]
        self.d = d
        self.c0 = state[:d].copy()
        self.rad0 = float(state[d])
        if pre is None:
            a = yt - self.c0[:, None]            # points relative to the anchor centre (d, n)
            rho = np.sqrt(np.einsum("ij,ij->j", a, a))
            if rho.min() <= 0:
                raise ZeroDivisionError("a point at the centre")
            inv = np.divide(1.0, rho)
            u = np.multiply(a, inv, out=a)      # a is not needed after its sum below
        else:
            u, rho = pre
            if rho.min() <= 0:
                raise ZeroDivisionError("a point at the centre")
            inv = np.divide(1.0, rho)
        self.n = yt.shape[1]
        self.rho_min = float(rho.min())
        self.e0 = float(rho.sum() - self.n * self.rad0)  # Σ (ρ_i − r0): Φ0 = n r0 + e0
        self.g = -u.sum(axis=1)                  # ∇Φ at c0
        self.a1 = (u * rho).sum(axis=1)          # Σ a_i
        self.h = inv.sum() * np.eye(d) - (u * inv) @ u.T
        inv = np.multiply(inv, inv, out=inv if pre is None else None)  # now 1/ρ²
        ui = u * inv
        self.w = ui.sum(axis=1)
        u3 = np.empty((d, d, d))                 # Σ u⊗u⊗u/ρ², symmetric: d(d+1)/2 passes
        for i in range(d):
            for j in range(i, d):
                col = (ui[i] * u[j]) @ u.T
                for k in range(d):
                    for perm in {(i, j, k), (i, k, j), (j, i, k), (j, k, i), (k, i, j), (k, j, i)}:
                        u3[perm] = col[k]
        self.u3 = u3
        self.s3 = float((inv / rho).sum())
        # candidates: positions, and their terms of every sum
        uc = np.ascontiguousarray(u[:, cand].T)
        rc = rho[cand]
        self.ac = uc * rc[:, None]
        self.t_e = rc - self.rad0
        self.t_u = uc
        self.t_h = (np.eye(d) - uc[:, :, None] * uc[:, None, :]) / rc[:, None, None]
        self.t_w = uc / (rc * rc)[:, None]
        self.t_u3 = uc[:, :, None, None] * uc[:, None, :, None] * uc[:, None, None, :] / (rc * rc)[:, None, None, None]
        self.t_s3 = 1.0 / rc ** 3
        self.eye = np.eye(d)
        self.delta = np.zeros(d)
        self.newton_step = 0.0
        hess = self._newton(first=True)
        self.kappa = 1.0 / (np.linalg.eigvalsh(hess)[0] / self.n)  # ‖(F''/n)⁻¹‖, nearly constant
        self.set_reference()

    def _newton(self, first: bool = False) -> np.ndarray:
        """Newton steps on the model from the current δ until the step is below 1e-8
        (one step after a typical removal); updates δ, the radius and the step size."""
        n, eye, dl = self.n, self.eye, self.delta
        for _ in range(8):
            wd = self.w @ dl
            td = eye * wd + self.w[:, None] * dl + dl[:, None] * self.w - 3.0 * (self.u3 @ dl)
            hd = self.h @ dl
            tdd = td @ dl
            dphi = self.g + hd + 0.5 * tdd
            rstar = (n * self.rad0 + self.e0 + self.g @ dl + 0.5 * (dl @ hd) + (dl @ tdd) / 6.0) / n
            grad = n * dl - self.a1 - rstar * dphi
            hess = n * eye - dphi[:, None] * dphi / n - rstar * (self.h + td)
            step = _solve(hess, -grad)
            dl = dl + step
            s = float(np.sqrt(step @ step))
            if s < 1e-8:
                break
        self.delta = dl
        self.newton_step = s
        self.rad = self._phi(dl) / n
        return hess

    def _phi(self, dl: np.ndarray) -> float:
        td_dl = (self.w @ dl) * dl * 3.0 - 3.0 * (self.u3 @ dl) @ dl  # T[δ]δ (the 3 symmetric terms)
        return float(self.n * self.rad0 + self.e0 + self.g @ dl + 0.5 * (dl @ self.h @ dl) + (dl @ td_dl) / 6.0)

    def set_reference(self) -> None:
        self.delta_ref, self.rad_ref = self.delta.copy(), self.rad

    def residuals(self, pos: np.ndarray) -> np.ndarray:
        diff = self.ac[pos] - self.delta
        return np.sqrt(np.einsum("ij,ij->i", diff, diff)) - self.rad

    def drift(self) -> float:
        dd = self.delta - self.delta_ref
        return float(np.sqrt(dd @ dd)) + abs(self.rad - self.rad_ref)

    def drift_anchor(self) -> float:
        return float(np.sqrt(self.delta @ self.delta)) + abs(self.rad - self.rad0)

    def error_bound(self) -> float:
        """Bound on the error of a residual computed from the model (normalised units).

        The fourth directional derivative of |y| is at most 3/|y|³ (it is
        −3 (1 − c²)(1 − 5c²)/ρ³ with c the cosine between y and the direction), and
        for a symmetric tensor that also bounds the multilinear form; between the
        anchor and the current centre every distance is at least ρ − |δ|. Hence
        |∇Φ − model| ≤ ½ f Σρ⁻³ |δ|³ and |Φ − model| ≤ ⅛ f Σρ⁻³ |δ|⁴ with
        f = (1 − |δ|/ρ_min)⁻³, and the centre error is at most ‖F''⁻¹‖ times the error
        of ∇F = n δ − Σa − r ∇Φ.
        """
        nd = float(np.sqrt(self.delta @ self.delta))
        if nd >= 0.5 * self.rho_min:
            return np.inf
        f = (1.0 - nd / self.rho_min) ** -3
        e_grad = 0.5 * f * self.s3 * nd ** 3
        e_phi = 0.125 * f * self.s3 * nd ** 4
        e_delta = self.kappa / self.n * (abs(self.rad) * e_grad + e_phi)
        e_rad = e_phi / self.n + e_delta
        return 4.0 * (e_delta + e_rad) + 10.0 * self.newton_step ** 2 * self.kappa + ROUNDING

    def remove(self, pos: int) -> None:
        self.n -= 1
        self.a1 -= self.ac[pos]
        self.e0 -= self.t_e[pos]
        self.g += self.t_u[pos]
        self.h -= self.t_h[pos]
        self.w -= self.t_w[pos]
        self.u3 -= self.t_u3[pos]
        self.s3 -= self.t_s3[pos]
        self._newton()

    def state(self) -> np.ndarray:
        return np.append(self.c0 + self.delta, self.rad)
