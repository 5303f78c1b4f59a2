"""The result of a fit: :class:`FitResult`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import to_jsonable

from ._geometry import form_figures

#: Parameter names per element, in the order of the JSON document.
PARAMETERS = {
    "line": ("point", "direction"),
    "plane": ("point", "normal"),
    "circle": ("center", "normal", "radius"),
    "sphere": ("center", "radius"),
    "cylinder": ("point", "axis", "radius"),
    "cone": ("apex", "axis", "angle"),
    "torus": ("center", "axis", "major_radius", "minor_radius"),
}


@dataclass
class FitResult:
    """A fitted geometric element.

    Attributes
    ----------
    element : ``"line"``, ``"plane"``, ``"circle"``, ``"sphere"``, ``"cylinder"``, ``"cone"``
        or ``"torus"``.
    method : ``"ls"`` (least squares, Gaussian) or ``"minzone"`` (Chebyshev).
    outliers : the outlier rule applied, as given (``"none"``, ``"vdi2634"``,
        ``"percent:5"``, ``"sigma:3"``).
    params : the element's parameters in mm (vectors as (d,) arrays; directions are
        unit vectors) — also available as attributes, ``result.radius``.
    std_uncertainty : standard uncertainty of each parameter from the fit covariance
        ``s² (JᵀJ)⁻¹`` with ``s² = Σr²/(n − p)`` (mm, per vector component; NaN when
        undefined, e.g. no degrees of freedom or a minimum-zone fit).
    residuals : (N,) signed orthogonal distance of *every* input point from the fitted
        element in mm, removed points included (positive outside a sphere, circle or
        cylinder, on the normal's side of a plane; a line in 3D gives the distance ≥ 0).
    used : (N,) bool, the points the final fit used.
    removed : indices of the removed points, in the order of removal.
    covariance : covariance of the parameters in ``covariance_names`` (mm, rad).
    warnings : one-line warnings when the element does not describe the points (see
        :mod:`.checks`); empty when it does.
    """

    element: str
    method: str
    outliers: str
    params: dict[str, Any]
    std_uncertainty: dict[str, Any]
    residuals: np.ndarray
    used: np.ndarray
    removed: np.ndarray
    iterations: int = 0
    covariance: np.ndarray | None = None
    covariance_names: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def __getattr__(self, name: str) -> Any:
        params = self.__dict__.get("params", {})
        if name in params:
            return params[name]
        raise AttributeError(name)

    @property
    def n_points(self) -> int:
        return int(len(self.residuals))

    @property
    def n_used(self) -> int:
        return int(self.used.sum())

    @property
    def n_removed(self) -> int:
        return int(len(self.removed))

    @property
    def form(self) -> dict[str, float]:
        """Form figures of the used points' residuals (mm): range, max, min, std, rms."""
        return form_figures(self.residuals if self.used.all() else self.residuals[self.used])

    def to_dict(self, residuals: bool = False) -> dict[str, Any]:
        """The JSON document of ``camcmm fit`` (lengths in mm). With ``residuals`` the
        per-point residuals and the removed indices are included too."""
        d: dict[str, Any] = {
            "element": self.element,
            "method": self.method,
            "outliers": self.outliers,
            "n_points": self.n_points,
            "n_used": self.n_used,
            "n_removed": self.n_removed,
        }
        for k in PARAMETERS[self.element]:
            if k in self.params:
                d[k] = to_jsonable(self.params[k])
        for k, v in self.params.items():
            if k not in d:
                d[k] = to_jsonable(v)
        d["form"] = self.form
        d["std_uncertainty"] = {k: to_jsonable(v) for k, v in self.std_uncertainty.items()}
        d.update({k: to_jsonable(v) for k, v in self.extra.items()})
        d["warnings"] = list(self.warnings)
        if residuals:
            d["residuals"] = self.residuals.tolist()
            d["removed_indices"] = self.removed.tolist()
        return d
