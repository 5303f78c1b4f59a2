"""The fits themselves: :func:`fit` and one function per element (the conventions
are described in :mod:`.api`, the module to import)."""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import ParameterError

from . import minzone
from ._geometry import Frame, as_points, row_moments
from .checks import fit_warnings
from .circles import CIRCLE3D
from .cones import CONE
from .cylinders import CYLINDER
from .lines import LINE2D, LINE3D
from .outliers import Rule, apply, parse_rule
from .planes import PLANE
from .result import FitResult
from .spheres import CIRCLE2D, SPHERE
from .tori import TORUS

ELEMENTS = ("line", "plane", "circle", "sphere", "cylinder", "cone", "torus")
METHODS = ("ls", "minzone")
MINZONE = ("plane", "sphere", "cone", "torus")


def _model(element: str, dim: int):
    return {
        ("line", 3): LINE3D,
        ("line", 2): LINE2D,
        ("plane", 3): PLANE,
        ("circle", 3): CIRCLE3D,
        ("circle", 2): CIRCLE2D,
        ("sphere", 3): SPHERE,
        ("cylinder", 3): CYLINDER,
        ("cone", 3): CONE,
        ("torus", 3): TORUS,
    }[(element, dim)]


def _spread(y: np.ndarray, used: np.ndarray, scale: float) -> np.ndarray:
    """RMS spread (mm) of the used points about their centroid along their principal axes,
    largest first (for :func:`.checks.fit_warnings`), from the normalised points y (d, N):
    their moments, minus those of the few removed points, so no copy of the used ones."""
    s1, s2, n = y.sum(axis=1), row_moments(y), y.shape[1]
    if not used.all():
        yr = y[:, ~used]
        s1, s2, n = s1 - yr.sum(axis=1), s2 - yr @ yr.T, n - yr.shape[1]
    m = s1 / n
    w = np.linalg.eigvalsh(s2 / n - np.outer(m, m))
    return np.sqrt(np.clip(w, 0.0, None))[::-1] * scale


def fit(
    element: str,
    points: Any,
    outliers: str | Rule = "none",
    method: str = "ls",
    *,
    max_iter: int = 100,
    nominal_radius: float | None = None,
    fast: bool = True,
) -> FitResult:
    """Fit a geometric element to points in mm (conventions: :mod:`.api`).

    Least squares in the orthogonal sense, or minimum zone (Chebyshev) for a plane, a
    sphere, a cone or a torus, after the outlier rule has removed what it removes.

    Parameters
    ----------
    element : {"line", "plane", "circle", "sphere", "cylinder", "cone", "torus"}
    points : array_like, shape (N, 3), or (N, 2) for a line or circle
        Coordinates in mm; a PointCloud's ``points`` or any numeric array. NaN or Inf
        is refused (InputError).
    outliers : str or Rule, default "none"
        ``"none"``, ``"vdi2634"`` (3 of every 1000 points, one at a time, largest residual
        first), ``"percent:P"`` or ``"sigma:K"``; see :mod:`.outliers`.
    method : {"ls", "minzone"}, default "ls"
        ``"minzone"`` only for a plane, a sphere, a cone or a torus.
    max_iter : int, default 100
        Bound on the Gauss-Newton iterations of each fit.
    nominal_radius : float, optional
        mm; for a circle, sphere or cylinder adds ``nominal_radius`` and
        ``radius_deviation`` (fitted − nominal, mm) to the result.
    fast : bool, default True
        False runs the vdi2634 rule as the naive loop (for checks).

    Returns
    -------
    FitResult
        ``params`` (centre/point/apex (3,) mm, normal/axis/direction (3,) unit vector,
        radius, major_radius, minor_radius mm, a cone's full apex angle in degrees),
        ``std_uncertainty`` of each (same shapes and units; NaN for minimum zone),
        ``form`` (range, max, min, std, rms in mm over the points used), signed
        ``residuals`` (N,) mm for every point, boolean ``used`` and index ``removed``
        arrays, and ``warnings`` when the element does not describe the points.

    Raises
    ------
    ParameterError
        Unknown element, method or rule.
    InputError, GeometryError
        Bad points; degenerate geometry or no convergence.
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
    frame, y = Frame.normalise(x, element)  # y: normalised points as columns (d, N)
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
        elif element == "sphere":
            state, width = minzone.sphere(yu, res.state)
            params = {"center": state[:-1] * frame.scale + frame.origin, "radius": float(state[-1] * frame.scale)}
        else:  # cone, torus: sequential LP on the model's own linearisation
            state, width = model.minzone(yu, res.state)
            params = model.params(state, frame)
        std = {k: (np.full(np.shape(v), np.nan) if np.ndim(v) else float("nan")) for k, v in params.items()}
        cov, names = None, ()
    all_used = bool(used.all())
    if method == "ls" and len(res.r) == int(used.sum()):
        # the fit's residuals are at the solution already (linearised last step)
        if all_used:
            residuals = res.r * frame.scale
        else:
            residuals = np.empty(y.shape[1])
            residuals[used] = res.r
            residuals[~used] = model.residuals(state, y[:, ~used])
            residuals *= frame.scale
    else:
        residuals = model.residuals(state, y) * frame.scale
    # no copies of a million points when the rule removed none (boolean indexing copies)
    xu, ru = (x, residuals) if all_used else (x[used], residuals[used])
    warnings = fit_warnings(element, params, std, xu, ru, method, axes_rms=_spread(y, used, frame.scale))
    if nominal_radius is not None and "radius" in params:
        extra["nominal_radius"] = float(nominal_radius)
        extra["radius_deviation"] = float(params["radius"] - nominal_radius)
    return FitResult(
        element=element,
        method=method,
        outliers=str(rule),
        params=params,
        std_uncertainty=std,
        residuals=residuals,
        used=used,
        removed=removed,
        iterations=res.iterations,
        covariance=cov,
        covariance_names=names,
        extra=extra,
        warnings=warnings,
    )


def fit_line(points: Any, outliers: str = "none", **kw) -> FitResult:
    """Least-squares line through points (N, 3) or (N, 2), mm: :func:`fit` with ``element="line"``.

    Returns a FitResult with ``point`` (3,) or (2,) mm and unit ``direction``; residuals
    are distances (3-D) or signed, left of the line positive (2-D)."""
    return fit("line", points, outliers, **kw)


def fit_plane(points: Any, outliers: str = "none", method: str = "ls", **kw) -> FitResult:
    """Least-squares or minimum-zone plane through points (N, 3), mm: :func:`fit` with
    ``element="plane"``.

    Returns a FitResult with ``point`` (3,) mm and unit ``normal`` (3,); residuals are
    signed, on the normal's side positive; ``form["range"]`` is the flatness (mm)."""
    return fit("plane", points, outliers, method, **kw)


def fit_circle(points: Any, outliers: str = "none", **kw) -> FitResult:
    """Least-squares circle in space (points (N, 3)) or in the plane ((N, 2)), mm:
    :func:`fit` with ``element="circle"``.

    Returns a FitResult with ``center`` mm, unit ``normal`` (3-D only) and ``radius`` mm;
    in space the residual is the full distance from the circle, sqrt(h² + (ρ − r)²)."""
    return fit("circle", points, outliers, **kw)


def fit_sphere(points: Any, outliers: str = "none", method: str = "ls", **kw) -> FitResult:
    """Least-squares or minimum-zone sphere through points (N, 3), mm: :func:`fit` with
    ``element="sphere"``.

    Returns a FitResult with ``center`` (3,) mm and ``radius`` mm; residuals are signed,
    outside positive. With ``outliers="vdi2634"`` this is the VDI/VDE 2634 probing fit."""
    return fit("sphere", points, outliers, method, **kw)


def fit_cylinder(points: Any, outliers: str = "none", **kw) -> FitResult:
    """Least-squares cylinder through points (N, 3), mm, also on a partial arc: :func:`fit`
    with ``element="cylinder"``.

    Returns a FitResult with ``point`` (3,) mm on the axis, unit ``axis`` (3,) and
    ``radius`` mm; residuals are signed, outside positive."""
    return fit("cylinder", points, outliers, **kw)


def fit_cone(points: Any, outliers: str = "none", method: str = "ls", **kw) -> FitResult:
    """Least-squares or minimum-zone cone through points (N, 3), mm, also on a partial
    arc: :func:`fit` with ``element="cone"``.

    Returns a FitResult with ``apex`` (3,) mm, unit ``axis`` (3,) pointing from the apex
    into the cone and the full apex ``angle`` in degrees; residuals are signed, outside
    positive (see :mod:`.cones`)."""
    return fit("cone", points, outliers, method, **kw)


def fit_torus(points: Any, outliers: str = "none", method: str = "ls", **kw) -> FitResult:
    """Least-squares or minimum-zone torus through points (N, 3), mm, also on partial arcs
    of either circle: :func:`fit` with ``element="torus"``.

    Returns a FitResult with ``center`` (3,) mm, unit ``axis`` (3,), ``major_radius`` and
    ``minor_radius`` mm; residuals are signed, outside the tube positive (see :mod:`.tori`)."""
    return fit("torus", points, outliers, method, **kw)
