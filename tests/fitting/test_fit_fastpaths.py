"""The shortcuts of the fitting engine (issue 29) against the plain computations they
replace: the principal spreads from moments minus the removed points, the form figures
by dot products, the covariance from the Jacobian's Gram matrix kept by the iteration,
and the sphere fit of far-off points against its exact construction."""

from __future__ import annotations

import numpy as np

from camcmm_plugins.fitting import elements
from camcmm_plugins.fitting._geometry import Frame, covariance, form_figures
from camcmm_plugins.fitting.api import fit_sphere
from camcmm_plugins.fitting.spheres import SPHERE


def test_spread_from_moments_is_the_scatter_of_the_used_points():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(3000, 3)) * [30.0, 5.0, 0.5] + [1e4, -2e3, 50.0]
    frame, y = Frame.normalise(x, "plane")
    used = np.ones(len(x), bool)
    used[rng.choice(len(x), 40, replace=False)] = False
    for mask in (used, np.ones(len(x), bool)):
        xu = x[mask] - x[mask].mean(axis=0)
        ref = np.sqrt(np.linalg.eigvalsh(xu.T @ xu / len(xu)))[::-1]
        np.testing.assert_allclose(elements._spread(y, mask, frame.scale), ref, rtol=1e-9)


def test_form_figures_are_numpys():
    r = np.random.default_rng(1).normal(0.01, 0.003, 5001)
    f = form_figures(r)
    assert f["range"] == np.ptp(r) and f["max"] == r.max() and f["min"] == r.min()
    np.testing.assert_allclose(f["std"], np.std(r, ddof=1), rtol=1e-12)
    np.testing.assert_allclose(f["rms"], np.sqrt(np.mean(r**2)), rtol=1e-12)
    assert np.isnan(form_figures(r[:1])["std"])


def test_covariance_from_the_kept_gram_matrix_is_the_direct_one():
    rng = np.random.default_rng(2)
    u = rng.normal(size=(2000, 3))
    x = 10.0 * u / np.linalg.norm(u, axis=1)[:, None] + rng.normal(0, 0.01, (2000, 1)) * u
    _, y = Frame.normalise(x, "sphere")
    res = SPHERE.fit(y)
    assert res.scaled is not None
    ssr = float(res.r @ res.r)
    np.testing.assert_allclose(covariance(res.jt, ssr, res.scaled), covariance(res.jt, ssr), rtol=1e-12)


def test_far_sphere_against_its_construction():
    """Exact points on a sphere of radius 10 mm at 17 000 mm from the origin, then the
    same with noise of known size: centre, radius and their uncertainty."""
    rng = np.random.default_rng(3)
    c, r = np.array([1e4, -1e4, 1e4]), 10.0
    u = rng.normal(size=(20_000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    exact = fit_sphere(c + r * u)
    assert np.abs(exact.center - c).max() < 1e-9 and abs(exact.radius - r) < 1e-9
    assert exact.form["range"] < 1e-9
    noisy = fit_sphere(c + (r + rng.normal(0, 0.01, len(u)))[:, None] * u)
    # least squares on n points with noise s: u(r) = s / sqrt(n), u(centre) = s sqrt(3 / n)
    np.testing.assert_allclose(noisy.std_uncertainty["radius"], 0.01 / np.sqrt(len(u)), rtol=0.05)
    np.testing.assert_allclose(noisy.std_uncertainty["center"], 0.01 * np.sqrt(3 / len(u)), rtol=0.05)
    assert abs(noisy.radius - r) < 4 * 0.01 / np.sqrt(len(u))
