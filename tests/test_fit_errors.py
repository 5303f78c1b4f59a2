"""Bad input gets a clear one-line error naming the reason, never a silent wrong answer."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import GeometryError, InputError, ParameterError
from camcmm_plugins.fitting.api import fit, fit_circle, fit_cylinder, fit_line, fit_plane, fit_sphere

FAR = np.array([10_000.0, -10_000.0, 10_000.0])


def _one_line(exc):
    text = str(exc.value)
    assert text and "\n" not in text
    return text


@pytest.mark.parametrize("element, need", [("line", 2), ("plane", 3), ("circle", 3), ("sphere", 4), ("cylinder", 5)])
def test_too_few_points(element, need):
    rng = np.random.default_rng(1)
    with pytest.raises(GeometryError) as exc:
        fit(element, rng.normal(size=(need - 1, 3)))
    assert f"at least {need} points" in _one_line(exc)


def test_collinear_points_for_plane_and_circle():
    t = np.linspace(0, 10, 50)[:, None]
    pts = FAR + t * np.array([1.0, 2.0, -0.5])
    with pytest.raises(GeometryError, match="collinear") as exc:
        fit_plane(pts)
    _one_line(exc)
    with pytest.raises(GeometryError, match="collinear"):
        fit_circle(pts)
    with pytest.raises(GeometryError, match="collinear"):
        fit_circle(pts[:, :2])
    with pytest.raises(GeometryError, match="collinear"):
        fit_cylinder(pts)


def test_coplanar_points_for_sphere_and_cylinder():
    rng = np.random.default_rng(2)
    pts = FAR + np.column_stack([rng.normal(size=(200, 2)), np.zeros(200)]) @ np.array(
        [[1, 0, 0], [0, 0.6, 0.8], [0, -0.8, 0.6]]
    )
    with pytest.raises(GeometryError, match="coplanar") as exc:
        fit_sphere(pts)
    _one_line(exc)
    with pytest.raises(GeometryError, match="coplanar"):
        fit_cylinder(pts)


def test_nearly_coplanar_sphere_does_not_give_a_silent_answer():
    """A flat patch with 1e-7 mm of noise: far too flat for a sphere; the radius
    diverges and the fit says so."""
    rng = np.random.default_rng(3)
    xy = rng.uniform(-10, 10, (500, 2))
    pts = FAR + np.column_stack([xy, rng.normal(scale=1e-7, size=500)])
    with pytest.raises(GeometryError, match="radius diverges|coplanar|converge|determine") as exc:
        fit_sphere(pts)
    _one_line(exc)


def test_nan_and_inf_coordinates():
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(100, 3))
    pts[17, 1] = np.nan
    pts[40, 2] = np.inf
    with pytest.raises(InputError, match=r"2 points have NaN or Inf coordinates \(first at index 17\)") as exc:
        fit_sphere(pts)
    _one_line(exc)


def test_wrong_shapes_and_names():
    with pytest.raises(InputError, match="shape"):
        fit_sphere(np.zeros((10, 2)))
    with pytest.raises(InputError, match="shape"):
        fit_plane(np.zeros(30))
    with pytest.raises(InputError, match="not numeric"):
        fit_line([["a", "b", "c"], ["d", "e", "f"]])
    with pytest.raises(ParameterError, match="unknown element"):
        fit("torus", np.zeros((10, 3)))
    with pytest.raises(ParameterError, match="unknown method"):
        fit("plane", np.zeros((10, 3)), method="l1")
    with pytest.raises(ParameterError, match="unknown outlier rule"):
        fit("plane", np.zeros((10, 3)), outliers="tukey")


def test_coincident_points():
    with pytest.raises(GeometryError, match="coincide"):
        fit_line(np.tile(FAR, (20, 1)))
    with pytest.raises(GeometryError, match="coincide"):
        fit_sphere(np.tile(FAR, (20, 1)))


def test_fit_that_does_not_converge():
    """A 10° cap with noise does not converge in a single Gauss-Newton step."""
    rng = np.random.default_rng(5)
    z = rng.uniform(np.cos(np.radians(10)), 1, 400)
    phi = rng.uniform(0, 2 * np.pi, 400)
    u = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    pts = FAR + (10 + rng.normal(scale=0.05, size=400))[:, None] * u
    with pytest.raises(GeometryError, match="did not converge in 1 iterations") as exc:
        fit_sphere(pts, max_iter=1)
    _one_line(exc)
    assert fit_sphere(pts).radius > 0  # with the default budget it converges


def test_two_blobs_are_no_sphere():
    """Two tight clusters 10 mm apart determine no sphere: an error, not a number."""
    rng = np.random.default_rng(6)
    pts = np.vstack([rng.normal(size=(100, 3)) * 0.01, rng.normal(size=(100, 3)) * 0.01 + [0, 0, 10]])
    with pytest.raises(GeometryError) as exc:
        fit_sphere(pts + FAR)
    _one_line(exc)
