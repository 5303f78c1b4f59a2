"""The shared machinery of the characteristics (:mod:`.characteristics`): a
characteristic being evaluated (:class:`Case`: its spec, the plan, the evaluated points,
the associated features and the datum frames), what an evaluator returns (:class:`Out`:
the value, the decisive points, and the value as a function of the features for the
uncertainty) and the one-line reason a value would be meaningless (:class:`NotEvaluated`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import InputError, to_mm_factor

from .datums import datum_frame, nominal_frame, primary_kind
from .model import Associated, CharacteristicSpec, DatumFrame, Plan
from .uncertainty import noise_sigma

AXES = ("cylinder", "cone", "line")
CENTRES = ("sphere", "point", "circle")


class NotEvaluated(Exception):
    """The characteristic cannot be given a meaningful value (the message says why)."""


@dataclass
class Out:
    """An evaluated value: ``decisive`` indices into the evaluated cloud; ``fn`` the
    value as a function of (associated features, points by feature id, transform) for
    the uncertainty; ``mc`` the features whose points enter by Monte Carlo, ``ls`` those
    whose parameters enter by their covariance."""

    value: float
    decisive: np.ndarray  # indices into the evaluated cloud
    details: dict[str, Any]
    # value as a function of (associated, points by feature id, transform) for u
    fn: Callable[[dict[str, Associated], dict[str, np.ndarray], np.ndarray], float]
    mc: tuple[str, ...] = ()  # features whose points enter by Monte Carlo
    ls: tuple[str, ...] = ()  # features whose parameters enter by their covariance
    warnings: list[str] = field(default_factory=list)


@dataclass
class Case:
    """A characteristic being evaluated (see :func:`.characteristics.evaluate_characteristic`)."""

    spec: CharacteristicSpec
    plan: Plan
    points: np.ndarray
    associated: dict[str, Associated]
    frames: Callable[[tuple[str, ...]], DatumFrame]
    _base_inv: np.ndarray | None = None

    @property
    def where(self) -> str:
        return f"{self.plan.source or 'plan'}: characteristics: {self.spec.id}"

    def assoc(self, fid: str | None = None) -> Associated:
        fid = fid or self.spec.feature
        a = self.associated.get(fid)
        if a is None:
            raise NotEvaluated(f"{self.spec.id}: feature {fid} was not measured")
        return a

    def pts(self, fid: str | None = None) -> np.ndarray:
        return self.points[self.assoc(fid).indices]

    def nominal(self, fid: str | None = None) -> tuple[str, dict[str, Any]]:
        f = self.plan.features.get(fid or self.spec.feature)
        if f is None:
            raise InputError(f"{self.where}: no feature {fid or self.spec.feature}")
        return f.type, f.nominal

    def other(self) -> str:
        o = self.spec.options.get("other") or self.spec.options.get("to")
        if not o:
            raise InputError(f"{self.where}: other: {self.spec.type} needs option other (the second feature)")
        if str(o) not in self.plan.features:
            raise InputError(f"{self.where}: other: no feature {o}")
        return str(o)

    def transform(self) -> np.ndarray:
        return self.frames(self.spec.datums).transform if self.spec.datums else np.eye(4)

    def transform_of(self, associated: dict[str, Associated], t: np.ndarray) -> np.ndarray:
        """The transform ``t`` corrected for datum features moved in ``associated``
        (the frame is rebuilt only when one of its features was moved)."""
        if not self.spec.datums or all(associated.get(f) is self.associated.get(f) for f in self.datum_features()):
            return t
        if self._base_inv is None:
            self._base_inv = np.linalg.inv(datum_frame(self.plan, self.associated, self.spec.datums).transform)
        moved = datum_frame(self.plan, associated, self.spec.datums).transform
        return moved @ self._base_inv @ t

    def datum_features(self) -> tuple[str, ...]:
        out: list[str] = []
        for label in self.spec.datums:
            out += [f for f in self.plan.datums.get(label, ()) if f not in out]
        return tuple(out)

    def noise(self, fid: str) -> float:
        """The point noise (mm, standard deviation) of feature ``fid`` for the Monte Carlo:
        the plan's ``point_noise`` (in its unit) when it states one, else estimated from
        the feature's residuals (:func:`.uncertainty.noise_sigma`)."""
        stated = self.plan.options.get("point_noise")
        if stated is not None:
            try:
                value = float(stated) * to_mm_factor(self.plan.unit)
            except (TypeError, ValueError):
                value = -1.0
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"{self.plan.source or 'plan'}: point_noise: {stated!r} is not a length >= 0")
            return value
        return noise_sigma(self.pts(fid), self.assoc(fid).residuals)

    def datum_axis(self) -> tuple[np.ndarray, np.ndarray]:
        """Origin and direction (plan coordinates) of the primary datum axis, for runout,
        coaxiality and concentricity; a one-line InputError when the primary is none."""
        if not self.spec.datums or primary_kind(self.plan, self.spec.datums) != "axis":
            raise InputError(f"{self.where}: datums: {self.spec.type} needs a datum axis (a cylinder, cone or line)")
        o, z, _ = self.frame_axis()
        return o, z

    def frame_axis(self) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Origin, primary direction (plan coordinates) and free dofs of the datums."""
        f, free = nominal_frame(self.plan, self.spec.datums)
        return f[:3, 3], f[:3, 2], free


def need(n: int, minimum: int, what: str) -> None:
    if n < minimum:
        raise NotEvaluated(f"{what}: {n} points, at least {minimum} needed")


def to_global(a: Associated, local: np.ndarray) -> np.ndarray:
    return np.asarray(a.indices)[np.asarray(local, dtype=np.int64)]
