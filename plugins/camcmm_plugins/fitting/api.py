"""Plain Python API of the fitting plugin.

>>> from camcmm_plugins.fitting.api import fit_sphere
>>> res = fit_sphere(points, outliers="vdi2634")          # points: (N, 3) mm
>>> res.center, res.radius, res.std_uncertainty["radius"], res.form["range"]

Functions
---------
fit(element, points, outliers="none", method="ls", *, max_iter=100, nominal_radius=None)
    Fit ``element`` ("line", "plane", "circle", "sphere", "cylinder", "cone", "torus") to points (N, 3)
    in mm — (N, 2) is accepted for line and circle — with an outlier rule (see
    :mod:`.outliers`: ``"none"``, ``"vdi2634"``, ``"percent:P"``, ``"sigma:K"``) and a
    method: ``"ls"`` least squares in the orthogonal sense, or ``"minzone"``
    (Chebyshev: plane, sphere, cone and torus). Returns a :class:`~.result.FitResult`.
fit_line, fit_plane, fit_circle, fit_sphere, fit_cylinder, fit_cone, fit_torus
    ``fit`` with the element fixed. A cone is ``apex`` (mm), ``axis`` (unit, from the
    apex into the cone) and the full apex ``angle`` (degrees); a torus ``center`` (mm),
    ``axis``, ``major_radius`` and ``minor_radius`` (mm).
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
  — for circles in space, cylinders, cones and tori.

Errors: :class:`camcmm.api.InputError` for bad input (NaN, wrong shape),
:class:`camcmm.api.GeometryError` for degenerate geometry or a fit that does not
converge, :class:`camcmm.api.ParameterError` for an unknown rule or method — each with
a one-line reason.
"""

from __future__ import annotations

from .elements import (
    ELEMENTS,
    METHODS,
    MINZONE,
    fit,
    fit_circle,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
    fit_torus,
)
from .outliers import Rule, parse_rule, vdi2634_count
from .result import FitResult
from .segment import extract_sphere, segment_spheres

__all__ = [
    "ELEMENTS",
    "FitResult",
    "METHODS",
    "MINZONE",
    "Rule",
    "extract_sphere",
    "fit",
    "fit_circle",
    "fit_cone",
    "fit_cylinder",
    "fit_line",
    "fit_plane",
    "fit_sphere",
    "fit_torus",
    "parse_rule",
    "segment_spheres",
    "vdi2634_count",
]
