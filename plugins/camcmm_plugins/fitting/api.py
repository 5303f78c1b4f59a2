"""Plain Python API of the fitting plugin.

>>> from camcmm_plugins.fitting.api import fit_sphere
>>> res = fit_sphere(points, outliers="vdi2634")          # points: (N, 3) mm
>>> res.center, res.radius, res.std_uncertainty["radius"], res.form["range"]

Functions
---------
fit(element, points, outliers="none", method="ls", *, max_iter=100, nominal_radius=None)
    Fit ``element`` ("line", "plane", "circle", "sphere", "cylinder") to points (N, 3)
    in mm — (N, 2) is accepted for line and circle — with an outlier rule (see
    :mod:`.outliers`: ``"none"``, ``"vdi2634"``, ``"percent:P"``, ``"sigma:K"``) and a
    method: ``"ls"`` least squares in the orthogonal sense, or ``"minzone"``
    (Chebyshev, plane and sphere only). Returns a :class:`~.result.FitResult`.
fit_line, fit_plane, fit_circle, fit_sphere, fit_cylinder
    ``fit`` with the element fixed.
segment_spheres(points, nominal_radius, ...), extract_sphere(points, ...)
    Split a ball-bar or ball-plate cloud into its spheres; extract one sphere from a
    raw scan (see :mod:`.segment`).

Conventions
-----------
* Least squares is in the orthogonal (geometric) sense: the sum of squared distances
  of the points from the element. A circle in space uses the full 3D distance from
  the circle, ``sqrt(h² + (ρ − r)²)``. Start values are algebraic or closed-form, then
  damped Gauss-Newton on normalised (centred, scaled) coordinates.
* Residuals are signed: positive outside a sphere, circle or cylinder, on the
  normal's side of a plane, left of a 2D line; in 3D a line's residual is the
  distance. ``form`` = range (max − min), max, min, std (n − 1), rms of the residuals
  of the points used.
* ``std_uncertainty`` comes from the covariance ``s² (JᵀJ)⁻¹``, ``s² = Σr²/(n − p)``;
  NaN (JSON null) with no degrees of freedom and for minimum-zone fits.
* ``warnings`` on the result say when the element does not describe the points (form
  systematic and large, an ill-determined direction or radius): see :mod:`.checks`.
* Outlier rules always work on least-squares residuals; with ``method="minzone"``
  the minimum-zone element is fitted to the points the rule kept.
* ``vdi2634`` costs O(N + m²) for lines, planes, spheres and planar circles (a few
  times one fit for a million points) and O(N m) — one Gauss-Newton step per removal
  — for circles in space and cylinders.

Errors: :class:`camcmm.api.InputError` for bad input (NaN, wrong shape),
:class:`camcmm.api.GeometryError` for degenerate geometry or a fit that does not
converge, :class:`camcmm.api.ParameterError` for an unknown rule or method — each with
a one-line reason.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import ParameterError

from . import minzone
from ._geometry import Frame, as_points
from .checks import fit_warnings
from .circles import CIRCLE3D
from .cylinders import CYLINDER
from .lines import LINE2D, LINE3D
from .outliers import Rule, apply, parse_rule, vdi2634_count
from .planes import PLANE
from .result import FitResult
from .spheres import CIRCLE2D, SPHERE

ELEMENTS = ("line", "plane", "circle", "sphere", "cylinder")
METHODS = ("ls", "minzone")
MINZONE = ("plane", "sphere")


def _model(element: str, dim: int):
    return {("line", 3): LINE3D, ("line", 2): LINE2D, ("plane", 3): PLANE, ("circle", 3): CIRCLE3D,
            ("circle", 2): CIRCLE2D, ("sphere", 3): SPHERE, ("cylinder", 3): CYLINDER}[(element, dim)]


def fit(element: str, points: Any, outliers: str | Rule = "none", method: str = "ls", *,
        max_iter: int = 100, nominal_radius: float | None = None, fast: bool = True) -> FitResult:
    """Fit a geometric element to points in mm; see the module docstring.

    ``nominal_radius`` (mm, circle/sphere/cylinder) adds ``radius_deviation`` = fitted −
    nominal to the result. ``fast=False`` runs the vdi2634 rule as the naive loop (for
    checks). ``max_iter`` bounds the Gauss-Newton iterations of each fit.
    """
    if element not in ELEMENTS:
        raise ParameterError(f"unknown element {element!r}; use one of {', '.join(ELEMENTS)}")
    if method not in METHODS:
        raise ParameterError(f"unknown method {method!r}; use ls or minzone")
    if method == "minzone" and element not in MINZONE:
        raise ParameterError(f"method minzone is available for {' and '.join(MINZONE)}, not for a {element}")
    rule = parse_rule(outliers)
    dims = (2, 3) if element in ("line", "circle") else (3,)
    x = as_points(points, element, dims)
    frame, y = Frame.normalise(x, element)          # y: normalised points as columns (d, N)
    model = _model(element, x.shape[1])
    model.check(y)
    used, removed, res = apply(model, y, rule, max_iter=max_iter, fast=fast)
    params, std, cov, names = model.report(res, frame)
    state = res.state
    extra: dict[str, Any] = {}
    if method == "minzone":
        yu = y[:, used] if not used.all() else y
        if element == "plane":
            state, width = minzone.plane(yu, res.state)
            params = {"point": state[:3] * frame.scale + frame.origin, "normal": state[3:]}
        else:
            state, width = minzone.sphere(yu, res.state)
            params = {"center": state[:-1] * frame.scale + frame.origin, "radius": float(state[-1] * frame.scale)}
        std = {k: (np.full(np.shape(v), np.nan) if np.ndim(v) else float("nan")) for k, v in params.items()}
        cov, names = None, ()
    if method == "ls" and len(res.r) == int(used.sum()):
        # the fit's residuals are at the solution already (linearised last step)
        residuals = np.empty(y.shape[1])
        residuals[used] = res.r
        if not used.all():
            residuals[~used] = model.residuals(state, y[:, ~used])
        residuals *= frame.scale
    else:
        residuals = model.residuals(state, y) * frame.scale
    warnings = fit_warnings(element, params, std, x[used], residuals[used], method)
    if nominal_radius is not None and "radius" in params:
        extra["nominal_radius"] = float(nominal_radius)
        extra["radius_deviation"] = float(params["radius"] - nominal_radius)
    return FitResult(element=element, method=method, outliers=str(rule), params=params,
                     std_uncertainty=std, residuals=residuals, used=used, removed=removed,
                     iterations=res.iterations, covariance=cov, covariance_names=names, extra=extra,
                     warnings=warnings)


def fit_line(points: Any, outliers: str = "none", **kw) -> FitResult:
    """Least-squares line; points (N, 3) or (N, 2) mm. See :func:`fit`."""
    return fit("line", points, outliers, **kw)


def fit_plane(points: Any, outliers: str = "none", method: str = "ls", **kw) -> FitResult:
    """Least-squares or minimum-zone plane; points (N, 3) mm. See :func:`fit`."""
    return fit("plane", points, outliers, method, **kw)


def fit_circle(points: Any, outliers: str = "none", **kw) -> FitResult:
    """Least-squares circle in space (N, 3) or in the plane (N, 2), mm. See :func:`fit`."""
    return fit("circle", points, outliers, **kw)


def fit_sphere(points: Any, outliers: str = "none", method: str = "ls", **kw) -> FitResult:
    """Least-squares or minimum-zone sphere; points (N, 3) mm. See :func:`fit`."""
    return fit("sphere", points, outliers, method, **kw)


def fit_cylinder(points: Any, outliers: str = "none", **kw) -> FitResult:
    """Least-squares cylinder; points (N, 3) mm. See :func:`fit`."""
    return fit("cylinder", points, outliers, **kw)


def segment_spheres(points: Any, nominal_radius: float, **kw):
    """Split a multi-sphere cloud; see :func:`.segment.segment_spheres`."""
    from .segment import segment_spheres as _seg

    return _seg(points, nominal_radius, **kw)


def extract_sphere(points: Any, nominal_radius: float | None = None, **kw):
    """Extract one sphere from a raw scan; see :func:`.segment.extract_sphere`."""
    from .segment import extract_sphere as _ext

    return _ext(points, nominal_radius, **kw)


__all__ = ["ELEMENTS", "FitResult", "Rule", "extract_sphere", "fit", "fit_circle", "fit_cylinder", "fit_line",
           "fit_plane", "fit_sphere", "parse_rule", "segment_spheres", "vdi2634_count"]
