"""Straight-line fits of the light-field scale (thesis ch. 6.3.2-6.3.3, fig. 6.15, table 6.3, fig. 6.16).

* :func:`fit_view`: photogrammetric depth against lambda for one view, least squares as the
  thesis, made robust in two ways. (1) A band ``|lambda| < band`` about the focal plane is
  left out: the thesis finds the light-field depth worst there (disparity minimised), and
  those errors are in lambda, the regressor, where least squares cannot absorb them.
  (2) Points whose residual exceeds ``k`` × 1.4826 × the median absolute residual are
  dropped and the line refitted (twice): the z-buffer leaves a few pixels at a rear
  surface or at a silhouette, a one-sided error that would tilt the line. For Gaussian
  scatter k = 4 drops ~0.006 % and does not bias the slope (symmetric cut).
  The slope's standard uncertainty is the ordinary least-squares one. Noise in lambda
  itself attenuates an ordinary least-squares slope by var(lambda_true) / var(lambda)
  (regression dilution); with the spread of lambda over a view this is small (~5e-5 relative
  for 0.02 lambda of noise over a 45° view of a flat), and ``sigma_lambda`` > 0 corrects it
  (the method-of-moments errors-in-variables slope, slope / (1 - sigma² / var(lambda))).
* :func:`set_stats`: mean and sample standard deviation (n - 1: table 6.3's last row is the
  sample standard deviation of each set's four gradients; see tests/test_lightfield_table.py).
* :func:`focal_fit`: the mean gradient against calibrated focal length, first order
  (fig. 6.16), its covariance, and the gradient predicted for a new focal length with its
  standard uncertainty from the covariance (GUM, linear propagation).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError


def line_fit(x: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    """Least-squares y = a x + b: a, b, their covariance (scaled by the residual variance, n - 2
    degrees of freedom), r2 and the residuals."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    n = len(x)
    A = np.column_stack([x, np.ones(n)])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    res = y - A @ coef
    ss_res = float(res @ res)
    ss_tot = float(((y - y.mean()) ** 2).sum())
    dof = n - 2
    cov = np.linalg.inv(A.T @ A) * (ss_res / dof) if dof > 0 else np.full((2, 2), np.nan)
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan")
    return {"a": float(coef[0]), "b": float(coef[1]), "cov": cov, "r2": r2, "res": res, "dof": dof}


def fit_view(
    depth: np.ndarray,
    lam: np.ndarray,
    lam_abs: np.ndarray | None = None,
    *,
    band: float = 0.0,
    robust: bool = True,
    k: float = 4.0,
    min_pixels: int = 10,
    sigma_lambda: float = 0.0,
) -> dict[str, Any]:
    """Depth (mm) against lambda for the pixels where both are known.

    Parameters
    ----------
    depth : (H, W) photogrammetric depth, NaN where none (mm).
    lam : (H, W) lambda in the convention reported (eq. 6.5).
    lam_abs : (H, W) lambda about the focal plane for the band test (default ``lam``).
    band : pixels with ``|lam_abs| < band`` are left out (lambda units; 0: none).
    robust : drop residuals beyond ``k`` robust standard deviations and refit (twice).
    sigma_lambda : the light-field map's own lambda noise (standard deviation), known from
        elsewhere; > 0 removes the regression dilution it causes. 0: the plain least squares.

    Returns
    -------
    dict ``gradient_mm_per_lambda``, ``intercept`` (mm), ``r2``, ``n_pixels`` (used),
    ``u_gradient``, ``u_intercept`` (standard uncertainties), ``n_band`` (left out by the
    band), ``n_rejected`` (by the residual test), ``mask`` (H, W) of the pixels used.
    """
    depth, lam = np.asarray(depth, float), np.asarray(lam, float)
    la = lam if lam_abs is None else np.asarray(lam_abs, float)
    ok = np.isfinite(depth) & np.isfinite(lam)
    in_band = ok & (np.abs(la) < band) if band > 0 else np.zeros_like(ok)
    use = ok & ~in_band
    n_rej = 0
    if use.sum() < min_pixels:
        raise InputError(f"{int(use.sum())} pixels with both depths (after the lambda band), fewer than {min_pixels}")
    if np.ptp(lam[use]) <= 0:
        raise InputError(f"lambda is the same ({lam[use][0]:g}) at all {int(use.sum())} pixels: no line to fit")
    f = line_fit(lam[use], depth[use])
    if robust:
        for _ in range(2):
            r = depth - (f["a"] * lam + f["b"])
            s = 1.4826 * np.median(np.abs(r[use]))
            keep = use & (np.abs(r) <= k * s) if s > 0 else use
            if keep.sum() == use.sum() or keep.sum() < min_pixels:
                break
            n_rej += int(use.sum() - keep.sum())
            use = keep
            f = line_fit(lam[use], depth[use])
    cov = f["cov"]
    a, b = f["a"], f["b"]
    if sigma_lambda > 0:
        atten = 1.0 - sigma_lambda**2 / float(np.var(lam[use]))
        if atten <= 0.1:
            raise InputError(f"sigma_lambda {sigma_lambda}: as large as the spread of lambda itself; no correction")
        a = a / atten
        b = float(np.mean(depth[use]) - a * np.mean(lam[use]))
        cov = cov / atten**2
    return {
        "gradient_mm_per_lambda": a,
        "intercept": b,
        "r2": f["r2"],
        "n_pixels": int(use.sum()),
        "u_gradient": float(np.sqrt(cov[0, 0])),
        "u_intercept": float(np.sqrt(cov[1, 1])),
        "n_band": int(in_band.sum()),
        "n_rejected": n_rej,
        "mask": use,
    }


def set_stats(gradients: list[float] | np.ndarray) -> dict[str, Any]:
    """Mean and sample standard deviation (ddof = 1, as table 6.3) of a set's gradients."""
    g = np.asarray(gradients, float)
    g = g[np.isfinite(g)]
    return {
        "mean": float(g.mean()) if len(g) else None,
        "std": float(g.std(ddof=1)) if len(g) > 1 else None,
        "n": int(len(g)),
        "std_ddof": 1,
    }


def focal_fit(
    focal_mm: list[float] | np.ndarray, gradients: list[float] | np.ndarray, predict_mm: float | None = None
) -> dict[str, Any]:
    """First-order fit gradient = slope × f + intercept (fig. 6.16) and a prediction.

    Parameters
    ----------
    focal_mm : (n,) calibrated focal lengths (mm, or px: the unit of the input is kept).
    gradients : (n,) mean gradients of the sets (mm per lambda).
    predict_mm : a new focal length (same unit), optional.

    Returns
    -------
    dict ``slope`` (mm λ⁻¹ per mm), ``intercept`` (mm λ⁻¹), ``cov`` (2 × 2, [slope,
    intercept], from the residual variance with n - 2 degrees of freedom; None for n = 2),
    ``r2``, ``residual_std``, ``n``, and with ``predict_mm``: ``predicted`` {``focal_length``,
    ``gradient_mm_per_lambda``, ``u`` (the line's standard uncertainty there,
    sqrt(J C Jᵀ), J = [f, 1]), ``u_new_set`` (adding a new set's own scatter, the residual
    variance)}.
    """
    f, g = np.asarray(focal_mm, float), np.asarray(gradients, float)
    if len(f) != len(g) or len(f) < 2:
        raise InputError(f"focal-length fit: {len(f)} focal lengths for {len(g)} gradients; need two or more of each")
    if np.ptp(f) <= 0:
        raise InputError("focal-length fit: all sets have the same focal length; a line needs two or more")
    fit = line_fit(f, g)
    has_cov = fit["dof"] > 0
    out: dict[str, Any] = {
        "slope": fit["a"],
        "intercept": fit["b"],
        "cov": fit["cov"].tolist() if has_cov else None,
        "r2": fit["r2"],
        "residual_std": float(np.sqrt(fit["res"] @ fit["res"] / fit["dof"])) if has_cov else None,
        "n": int(len(f)),
    }
    if predict_mm is not None:
        J = np.array([float(predict_mm), 1.0])
        u = float(np.sqrt(J @ fit["cov"] @ J)) if has_cov else None
        out["predicted"] = {
            "focal_length": float(predict_mm),
            "gradient_mm_per_lambda": float(fit["a"] * predict_mm + fit["b"]),
            "u": u,
            "u_new_set": float(np.hypot(u, out["residual_std"])) if u is not None else None,
        }
    return out
