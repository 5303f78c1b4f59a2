"""Cheap refits after removing one point, for the fast ``vdi2634`` outlier rule.

The rule removes, one at a time, the point with the largest absolute residual and
refits after each removal. Refitting a million points 3 000 times is what the fast
implementation avoids; it must still remove exactly the same points as the naive
loop. Each *downdater* keeps sufficient statistics of the current point set in one
flat array, downdated in O(1) per removed point (a subtraction of the point's
precomputed terms), and re-solves the fit from them when asked (:meth:`solve`). It
gives the absolute residuals of candidate points at its current state
(:meth:`absres`); :meth:`remove` returns how far any residual may have moved with
that removal; :meth:`bounds` gives the error bound of the state and its drift since
a reference and since the anchor, which bound the change of every residual (used to
prove that no point outside the candidates can be next).

The driver (:func:`camcmm_plugins.fitting.outliers.vdi2634`) certifies each decision
with these bounds, re-evaluates or re-solves only when a decision is not certain,
and falls back to an exact refit when it is not certain even at a solved state.

* Line and plane — exact: the fit is a function of the first and second moments
  ``n, Σz, Σz zᵀ`` of the points (relative to the anchor centroid), re-solved by a
  3x3 eigen-decomposition. Between solves the state is left as it is and each
  removal adds ``1.25 |r_j| β_j`` to the margin, with ``β_j`` the first-order change
  of the element per unit residual of the removed point, ``H⁻¹ ∇f_j`` (H = JᵀJ of the
  offset and tilts), times the lever arm of the farthest point.
* Sphere and planar circle — the least-squares problem reduces to the centre c alone:
  ``F(c) = ½[Σ|y_i − c|² − Φ(c)²/n]`` with ``Φ(c) = Σ|y_i − c|`` and ``r = Φ/n``. The
  first term is a quadratic in c (exact moments); Φ is replaced by its third-order
  Taylor expansion about the anchor centre c0, whose coefficients are the sums
  ``Σρ, Σu, Σ(I − u uᵀ)/ρ, Σu/ρ², Σu⊗u⊗u/ρ²`` (u unit vector, ρ distance from c0);
  Newton steps on the model give the centre. The neglected fourth-order term is
  bounded by ``(1/8)|δ|⁴ Σ1/ρ³`` (δ the centre shift since the anchor), ~1e-20
  relative for the shifts that 0.3 % of typical points cause. Between Newton solves
  (at most 32 removals apart) the state moves to the first-order prediction of the
  new optimum, ``Δx = H⁻¹ ∇f_j`` in (c, r), whose error enters the error bound.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dgesv as _dgesv

from ._geometry import complement

#: Rounding floor of the residuals computed from downdated sums, per unit of the
#: problem's conditioning (normalised units). Measured: after 3 000 downdates of a
#: million-point plane or sphere the residuals agree with an exact refit to 3e-16;
#: the floor is scaled by the condition of the fit (a cap or a strip rounds worse).
ROUNDING = 1e-14
#: Margin on the first-order removal bounds.
SAFETY = 1.25


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve a tiny dense system (LAPACK gesv without numpy.linalg's overhead)."""
    _, _, x, info = _dgesv(a, b)
    if info != 0:
        raise ZeroDivisionError("singular model Hessian")
    return x


class MomentsDowndater:
    """Line (largest principal direction) or plane (smallest) from running moments."""

    def __init__(self, kind: str, yt: np.ndarray, state: np.ndarray, cand: np.ndarray):
        self.kind = kind  # "plane", "line3", "line2"
        d = yt.shape[0]
        self.d = d
        self.m0 = state[:d].copy()
        z = yt - self.m0[:, None]
        # flat sums [n, Σz (d), Σz zᵀ (d·d)] and each candidate's terms
        self.sums = np.concatenate([[yt.shape[1]], z.sum(axis=1), (z @ z.T).ravel()])
        zc = np.ascontiguousarray(z[:, cand].T)
        self.zc = zc
        self.terms = np.hstack([np.ones((len(cand), 1)), zc, (zc[:, :, None] * zc[:, None, :]).reshape(len(cand), -1)])
        self.r0 = float(np.sqrt(np.einsum("ij,ij->j", z, z).max()))
        self.v0 = state[d:].copy()  # normal (plane) or direction (line)
        self.solve()
        self.mu_anchor, self.v_anchor = self.mu.copy(), self.v.copy()
        self.set_reference()
        self._betas()

    def _betas(self) -> None:
        """β_j per candidate: residual drift per unit residual of the removed point, from
        the moments (JᵀJ of the plane's offset and tilts, or of a line's shift and tilt)."""
        d = self.d
        n = self.sums[0]
        cov = self.sums[d + 1 :].reshape(d, d) - n * np.outer(self.mu, self.mu)  # scatter about μ
        lever = self.r0 + float(np.linalg.norm(self.mu))
        zc = self.zc - self.mu
        if self.kind == "plane":
            b = complement(self.v)
            gram = np.zeros((3, 3))
            gram[0, 0] = n
            gram[1:, 1:] = b @ cov @ b.T
            g = np.vstack([np.ones(len(zc)), b @ zc.T])
        else:
            gram = np.diag([n, float(self.v @ cov @ self.v)])
            g = np.vstack([np.ones(len(zc)), zc @ self.v])
        q = np.linalg.solve(gram, g)  # H⁻¹ ∇f_j per unit residual
        k = 2.0 if self.kind == "line3" else 1.0
        self.beta = (np.abs(q[0]) + k * lever * np.linalg.norm(q[1:], axis=0)) * SAFETY
        self.n_beta = n

    def solve(self) -> None:
        self.lazy = 0
        d = self.d
        n = self.sums[0]
        mean = self.sums[1 : d + 1] / n
        cov = self.sums[d + 1 :].reshape(d, d) / n - np.outer(mean, mean)
        w, vec = np.linalg.eigh(cov)
        gap = (w[1] - w[0]) if self.kind == "plane" else (w[-1] - w[-2])
        self.rounding = ROUNDING * (1.0 + self.r0) * max(1.0, w[-1] / max(gap, 1e-300))
        v = vec[:, 0] if self.kind == "plane" else vec[:, -1]
        self.v = -v if v @ self.v0 < 0 else v
        self.mu = mean  # relative to m0

    def set_reference(self) -> None:
        self.mu_ref, self.v_ref = self.mu.copy(), self.v.copy()

    def _perp(self) -> np.ndarray:
        return np.array([-self.v[1], self.v[0]])

    def absres(self, pos) -> np.ndarray:
        zc = self.zc[pos] - self.mu
        if self.kind == "plane":
            return np.abs(zc @ self.v)
        if self.kind == "line2":
            return np.abs(zc @ self._perp())
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

    def bounds(self) -> tuple[float, float, float]:
        """(model error bound, drift since the reference, drift since the anchor)."""
        return self.rounding, self._drift(self.mu_ref, self.v_ref), self._drift(self.mu_anchor, self.v_anchor)

    predictive = False

    def must_solve(self) -> bool:
        return self.lazy > 0

    def remove(self, pos: int, absval: float) -> float:
        """Downdate the sums (the solution is not updated until :meth:`solve`); returns
        the bound on how far any residual moves with the true solution."""
        self.sums -= self.terms[pos]
        self.lazy += 1
        return absval * float(self.beta[pos]) * self.n_beta / self.sums[0]

    def state(self) -> np.ndarray:
        return np.concatenate([self.m0 + self.mu, self.v])


class HypersphereDowndater:
    """Sphere (d = 3) or planar circle (d = 2) from a third-order model of Φ (see the
    module docstring)."""

    def __init__(
        self, yt: np.ndarray, state: np.ndarray, cand: np.ndarray, pre: tuple[np.ndarray, np.ndarray] | None = None
    ):
        """Anchor at ``state`` = [c0, r0]; ``pre`` = (−u, ρ) of the points at c0 when the
        caller has them (the last Gauss-Newton evaluation: −u are the Jacobian's rows)."""
        d = yt.shape[0]
        self.d = d
        self.c0 = state[:d].copy()
        self.rad0 = float(state[d])
        if pre is None:
            v = self.c0[:, None] - yt  # −a: the anchor centre relative to the points
            rho = np.sqrt(np.einsum("ij,ij->j", v, v))
        else:
            v, rho = pre  # −u, ρ
        if rho.min() <= 0:
            raise ZeroDivisionError("a point at the centre")
        inv = np.divide(1.0, rho)
        if pre is None:
            v *= inv  # now −u
        # v = −u below: odd powers of u change sign, even ones do not
        n = yt.shape[1]
        self.rho_min = float(rho.min())
        vi = v * inv  # −u/ρ
        hsum = -(vi @ v.T)  # −Σ u uᵀ/ρ
        vi *= inv  # −u/ρ²
        u3 = np.empty((d, d, d))  # Σ u⊗u⊗u/ρ² = −Σ v⊗v⊗v/ρ², d(d+1)/2 passes
        for i in range(d):
            for j in range(i, d):
                col = -((vi[i] * v[j]) @ v.T)
                for k in range(d):
                    for perm in {(i, j, k), (i, k, j), (j, i, k), (j, k, i), (k, i, j), (k, j, i)}:
                        u3[perm] = col[k]
        # flat sums: [n, Σ(ρ−r0), Σa (d), ∇Φ = −Σu (d), H = Σ(I−uuᵀ)/ρ (d·d), Σu/ρ² (d), U3 (d³), Σρ⁻³]
        self.sums = np.concatenate(
            [
                [n, float(rho.sum() - n * self.rad0)],
                -(v @ rho),
                v.sum(axis=1),
                (inv.sum() * np.eye(d) + hsum).ravel(),
                -vi.sum(axis=1),
                u3.ravel(),
                [float(inv @ (inv * inv))],
            ]
        )
        u = v  # for the candidates below: u = −v
        o = np.cumsum([0, 1, 1, d, d, d * d, d, d**3, 1])
        s = self.sums
        self.a1, self.g = s[o[2] : o[3]], s[o[3] : o[4]]  # views: downdated in place
        self.h, self.w = s[o[4] : o[5]].reshape(d, d), s[o[5] : o[6]]
        self.u3 = s[o[6] : o[7]].reshape(d, d, d)
        # candidates: their points relative to c0 and their terms of every sum
        uc = -np.ascontiguousarray(u[:, cand].T)
        rc = rho[cand]
        k = len(cand)
        self.ac = uc * rc[:, None]
        self._ac = self.ac.tolist()
        r2 = rc * rc
        self.terms = np.hstack(
            [
                np.ones((k, 1)),
                (rc - self.rad0)[:, None],
                self.ac,
                -uc,
                ((np.eye(d) - uc[:, :, None] * uc[:, None, :]) / rc[:, None, None]).reshape(k, -1),
                uc / r2[:, None],
                (uc[:, :, None, None] * uc[:, None, :, None] * uc[:, None, None, :] / r2[:, None, None, None]).reshape(
                    k, -1
                ),
                (1.0 / (r2 * rc))[:, None],
            ]
        )
        self.eye = np.eye(d)
        self.delta = np.zeros(d)
        self.newton_step = 0.0
        hess = self.solve()
        self.kappa = 1.0 / (np.linalg.eigvalsh(hess)[0] / n)  # ‖(F''/n)⁻¹‖, nearly constant
        self.set_reference()

    def solve(self) -> np.ndarray:
        """Newton steps on the model from the current δ until the step is below 1e-8;
        updates δ and the radius, and the inverse Hessian of the sum of squares in
        (c, r) used by :meth:`remove` to predict the next optimum."""
        d, s = self.d, self.sums
        n, e0 = s[0], s[1]
        eye, dl = self.eye, self.delta
        for _ in range(8):
            wd = self.w @ dl
            td = eye * wd + self.w[:, None] * dl + dl[:, None] * self.w - 3.0 * (self.u3 @ dl)
            hd = self.h @ dl
            tdd = td @ dl
            dphi = self.g + hd + 0.5 * tdd
            rstar = self.rad0 + (e0 + self.g @ dl + 0.5 * (dl @ hd) + (dl @ tdd) / 6.0) / n
            grad = n * dl - self.a1 - rstar * dphi
            hess = n * eye - dphi[:, None] * dphi / n - rstar * (self.h + td)
            step = _solve(hess, -grad)
            dl = dl + step
            st = float(np.sqrt(step @ step))
            if st < 1e-8:
                break
        self.delta = dl
        self.newton_step = st
        td_dl = 3.0 * (self.w @ dl) * dl - 3.0 * (self.u3 @ dl) @ dl  # T[δ, δ]
        self.rad = self.rad0 + float(e0 + self.g @ dl + 0.5 * (dl @ self.h @ dl) + (dl @ td_dl) / 6.0) / n
        # Hessian of ½Σ(ρ_i − r)² in (c, r): [[n I − r ∇²Φ, −∇Φ], [−∇Φᵀ, n]]
        hf = np.empty((d + 1, d + 1))
        hf[:d, :d] = n * eye - self.rad * (self.h + td)
        hf[:d, d] = hf[d, :d] = -dphi
        hf[d, d] = n
        self.hinv = np.linalg.inv(hf)
        self._hinv = self.hinv.tolist()  # for the pure-Python update in remove()
        self.kappa_f = float(np.linalg.norm(self.hinv, 2)) * n
        self.lazy = 0
        self.disp = 0.0
        return hess

    def set_reference(self) -> None:
        self.delta_ref, self.rad_ref = self.delta.copy(), self.rad

    def absres(self, pos) -> np.ndarray:
        diff = self.ac[pos] - self.delta
        return np.abs(np.sqrt(np.einsum("ij,ij->i", diff, diff)) - self.rad)

    def bounds(self) -> tuple[float, float, float]:
        """(model error bound, drift since the reference, drift since the anchor).

        Error bound: the fourth directional derivative of |y| is at most 3/|y|³ (it
        is −3 (1 − c²)(1 − 5c²)/ρ³, c the cosine between y and the direction), which
        for a symmetric tensor also bounds the multilinear form; between the anchor
        and the current centre every distance is at least ρ − |δ|. Hence
        |∇Φ − model| ≤ ½ f Σρ⁻³ |δ|³ and |Φ − model| ≤ ⅛ f Σρ⁻³ |δ|⁴ with
        f = (1 − |δ|/ρ_min)⁻³; the centre error is at most ‖F''⁻¹‖ times the error of
        ∇F = n δ − Σa − r ∇Φ; the last Newton step adds its quadratic remainder.
        """
        dl = self.delta
        nd = float(np.sqrt(dl @ dl))
        dd = dl - self.delta_ref
        drift = float(np.sqrt(dd @ dd)) + abs(self.rad - self.rad_ref)
        drift0 = nd + abs(self.rad - self.rad0)
        if nd >= 0.5 * self.rho_min:
            return np.inf, drift, drift0
        n, s3 = self.sums[0], self.sums[-1]
        f = (1.0 - nd / self.rho_min) ** -3
        e_grad = 0.5 * f * s3 * nd**3
        e_phi = 0.125 * f * s3 * nd**4
        e_delta = self.kappa / n * (abs(self.rad) * e_grad + e_phi)
        e_rad = e_phi / n + e_delta
        eb = (
            4.0 * (e_delta + e_rad)
            + 10.0 * self.newton_step**2 * self.kappa
            + ROUNDING * self.kappa * (1.0 + abs(self.rad))
        )
        if self.lazy:
            # first-order prediction of the optimum after `lazy` removals: its error is
            # at most ‖H⁻¹‖ (‖ΔH‖ D + ½ L D²) with D the distance moved, ‖ΔH‖ ≤ 3 per removed
            # point plus 3 Σ1/ρ per unit of D, L ≤ 3 Σ1/ρ; doubled for safety, and
            # √2 maps it onto residuals (|Δc| + |Δr|).
            disp = self.disp
            err = 2.0 * self.kappa_f / n * (3.0 * self.lazy + 6.0 * n / self.rho_min * disp) * disp
            eb += 1.5 * err
        return eb, drift, drift0

    predictive = True
    #: removals between two Newton solves at most
    MAX_LAZY = 32

    def must_solve(self) -> bool:
        return self.lazy >= self.MAX_LAZY

    def remove(self, pos: int, absval: float) -> float:
        """Downdate the sums and move the state to the first-order prediction of the new
        optimum, Δx = H⁻¹ ∇f_j; returns |Δc| + |Δr|, the most any residual moved.

        The (d+1)-vector arithmetic is plain Python: for four numbers it is several
        times faster than numpy's per-call overhead, and it runs 3 000 times."""
        self.sums -= self.terms[pos]
        dl = self.delta.tolist()
        a = self._ac[pos]
        h = self._hinv
        if self.d == 3:
            x0, x1, x2 = a[0] - dl[0], a[1] - dl[1], a[2] - dl[2]
            rho = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
            r = rho - self.rad
            k = -r / rho
            g: tuple[float, ...] = (x0 * k, x1 * k, x2 * k, -r)
        else:
            x0, x1 = a[0] - dl[0], a[1] - dl[1]
            rho = math.sqrt(x0 * x0 + x1 * x1)
            r = rho - self.rad
            k = -r / rho
            g = (x0 * k, x1 * k, -r)
        dx = [sum(map(float.__mul__, row, g)) for row in h]
        self.delta = np.array([dl[i] + dx[i] for i in range(self.d)])
        self.rad += dx[-1]
        moved = math.sqrt(sum(map(float.__mul__, dx[:-1], dx[:-1]))) + abs(dx[-1])
        self.disp += moved
        self.lazy += 1
        return moved

    def state(self) -> np.ndarray:
        return np.append(self.c0 + self.delta, self.rad)
