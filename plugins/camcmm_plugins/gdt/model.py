"""The objects of a GD&T evaluation, shared by every module of this package.

A *plan* (:class:`Plan`, read from the YAML of ``camcmm gdt evaluate``) names features by
their nominal geometry, the datums built on them and the characteristics to evaluate.
Evaluating it turns each :class:`FeatureSpec` into an :class:`Associated` feature (the
measured points that belong to it and the element associated with them), the datum
labels into a :class:`DatumFrame`, and each :class:`CharacteristicSpec` into a
:class:`CharacteristicResult` with its uncertainty and ISO 14253-1 verdicts.

Everything inside is in mm, angles in degrees where a person states them (a cone's full
apex angle, an angularity's nominal angle) and radians nowhere in the interface;
directions are unit (3,) vectors, points (3,) arrays. The plan's ``unit`` is converted
on reading (:mod:`.plan`).

References: ISO 1101:2017 (characteristics, tolerance zones), ISO 5459:2011 (datums and
datum systems), ISO 14405-1:2016 (size), ISO 14253-1:2017 (decision rules),
ASME Y14.5-2018 §4 (datum reference frames).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Feature types a plan may name, and the nominal parameters each takes (mm, degrees).
#: ``face`` is a face of the STEP nominal (its type and parameters come from the CAD).
FEATURE_TYPES: dict[str, tuple[str, ...]] = {
    "plane": ("point", "normal"),
    "line": ("point", "direction", "length"),
    "point": ("point",),
    "circle": ("centre", "normal", "diameter"),
    "cylinder": ("point", "axis", "diameter", "length"),
    "sphere": ("centre", "diameter"),
    "cone": ("apex", "axis", "angle"),
    "torus": ("centre", "axis", "major_diameter", "minor_diameter"),
    "face": ("cad",),
}

#: Association criteria (ISO 14405-1 / ISO 5459): least squares, minimum zone
#: (Chebyshev), minimum circumscribed, maximum inscribed, and the datum default (the
#: outer tangent plane / constrained minimax of ISO 5459).
ASSOCIATIONS = ("ls", "minzone", "mincircumscribed", "maxinscribed", "tangent")

#: Characteristic types, by family (ISO 1101 symbols in docs/gdt.md).
CHARACTERISTICS: dict[str, tuple[str, ...]] = {
    "form": ("straightness", "flatness", "roundness", "cylindricity", "line-profile", "surface-profile"),
    "orientation": ("parallelism", "perpendicularity", "angularity"),
    "location": ("position", "coaxiality", "concentricity", "symmetry", "profile"),
    "runout": ("circular-runout", "total-runout"),
    "size": ("diameter", "width", "distance"),
}

#: Alignment methods of ``camcmm gdt evaluate --align``.
ALIGNMENTS = ("best-fit", "datums", "rps", "3-2-1", "none")


@dataclass(frozen=True)
class FeatureSpec:
    """A feature of the plan: its nominal geometry and how its points are found.

    ``nominal`` holds the type's parameters of :data:`FEATURE_TYPES` in mm (vectors as
    (3,) float arrays, directions normalised; ``angle`` in degrees). ``band`` (mm, > 0) is
    the half-width of the zone about the nominal surface whose points belong to the
    feature; ``box`` an optional (2, 3) array [min corner, max corner] (mm) the points
    must also lie in. ``association`` is one of :data:`ASSOCIATIONS`.
    """

    id: str
    type: str
    nominal: dict[str, Any]
    band: float
    box: np.ndarray | None = None
    association: str = "ls"


@dataclass(frozen=True)
class CharacteristicSpec:
    """A characteristic of the plan. ``tolerance`` (mm, > 0) for a zone; ``lower`` /
    ``upper`` (mm, deviations from the nominal size) for a size; ``datums`` labels in
    order of precedence (primary first; ``"A-B"`` a common datum); ``k`` the coverage
    factor of U = k·u (default 2); ``modifier`` e.g. ``"MMC"`` where supported; ``options``
    anything else the plan sets for it (e.g. ``angle`` of an angularity in degrees,
    ``nominal`` of a distance in mm, ``section`` of a roundness)."""

    id: str
    type: str
    feature: str
    datums: tuple[str, ...] = ()
    tolerance: float | None = None
    lower: float | None = None
    upper: float | None = None
    modifier: str | None = None
    k: float = 2.0
    options: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Plan:
    """A whole plan: ``features`` by id, ``datums`` label -> feature id (or ``"A-B"``
    style common datums: label -> tuple of feature ids), ``characteristics`` in order.
    ``unit`` is the unit the file stated (values here are already in mm); ``source`` the
    file it came from (for messages)."""

    unit: str
    band: float
    features: dict[str, FeatureSpec]
    datums: dict[str, tuple[str, ...]]
    characteristics: list[CharacteristicSpec]
    options: dict[str, Any] = field(default_factory=dict)
    source: str = ""


@dataclass
class Associated:
    """A feature as measured: the points that belong to it and the associated element.

    ``indices`` (n,) into the evaluated cloud; ``params`` the element's parameters in mm
    (``point``/``normal`` plane, ``point``/``direction`` line, ``centre``/``normal``/
    ``diameter`` circle, ``point``/``axis``/``diameter`` cylinder — ``point`` the foot of
    the axis at the feature's start, ``length`` its extent along the axis —, ``centre``/
    ``diameter`` sphere, ``apex``/``axis``/``angle`` cone, ``centre``/``axis``/
    ``major_diameter``/``minor_diameter`` torus); ``residuals`` (n,) signed distances of
    the points from the element (mm; + outside the material for closed features, on the
    normal's side for a plane); ``form`` the fitting plugin's {range, max, min, std,
    rms}; ``covariance`` over ``covariance_names`` (mm, rad) of a least-squares
    association, None for the others."""

    id: str
    type: str
    association: str
    indices: np.ndarray
    params: dict[str, Any]
    residuals: np.ndarray
    form: dict[str, float]
    covariance: np.ndarray | None = None
    covariance_names: tuple[str, ...] = ()
    warnings: list[str] = field(default_factory=list)

    @property
    def n_points(self) -> int:
        return int(len(self.indices))


@dataclass
class DatumFrame:
    """A datum reference frame (ISO 5459): ``labels`` in precedence order and
    ``transform`` (4, 4) from the evaluated (part) coordinates into the frame's
    coordinates, in which the nominal geometry of the plan is stated. ``free`` names
    the degrees of freedom the datums leave unconstrained (e.g. ``["rotation z"]`` for
    A|B with B a cylinder coaxial to A's normal)."""

    labels: tuple[str, ...]
    transform: np.ndarray
    free: list[str] = field(default_factory=list)


@dataclass
class CharacteristicResult:
    """A characteristic evaluated: ``value`` (mm unless ``unit`` says otherwise), its
    standard uncertainty ``u`` (k = 1) with ``u_method`` ("covariance", "bootstrap" or
    "monte-carlo", and what of), ``U`` = k·u, ``verdict`` (simple: value within the
    tolerance) and ``verdict_guarded`` (ISO 14253-1 with the guard band U): "conform",
    "not conform", "undecided" (guarded only) or "not evaluated"; ``decisive`` the indices
    of the points that decide the value (for the 3-D labels)."""

    id: str
    type: str
    feature: str
    datums: tuple[str, ...]
    value: float | None
    unit: str
    tolerance: float | None
    lower: float | None
    upper: float | None
    u: float | None
    u_method: str
    k: float
    verdict: str
    verdict_guarded: str
    decisive: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    details: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def U(self) -> float | None:  # noqa: N802 - the standard's symbol
        return None if self.u is None else self.k * self.u
