"""The typed standard protocol: what an acceptance-test plugin DECLARES and what it RETURNS.

A standard plugin (manifest ``kind: standard``) is an object the host loads with
``host.load(id)``. The GUI's acceptance page, ``camcmm verify`` and the demo know a
standard only through :class:`Standard` (the methods they call) and the
:class:`StandardDeclaration` its ``declare()`` returns: which quality parameters it
judges, which artefacts it needs (and their calibrated fields), which tests and
positions it asks for. Nothing about a particular standard is written in the GUI; a
lab's own standard that implements this protocol appears beside the built-in ones.

Results travel as plain JSON-able dicts (they are stored in the project); the result
dataclasses of :mod:`camcmm.standard_results` (re-exported here) build them
(``to_dict()``) and name their keys. Lengths are mm unless
a parameter declares another unit. See docs/standards.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from .standard_results import ParameterResult, PositionEvaluation, TestResult, as_dict

__all__ = [
    "ArtefactField",
    "ArtefactKind",
    "ParameterResult",
    "PositionEvaluation",
    "PositionSpec",
    "QualityParameter",
    "Standard",
    "StandardDeclaration",
    "TestDeclaration",
    "TestResult",
    "as_dict",
]


# -- what a standard declares ---------------------------------------------------------------
@dataclass(frozen=True)
class QualityParameter:
    """A quality parameter the standard judges against an MPE.

    Attributes
    ----------
    key : str
        Its key in the plan's ``mpe`` and in an evaluation's ``values`` (``"PF"``).
    symbol : str
        How cards and reports print it (``"P_F"``).
    name : str
        Its full name (``"Probing error form P_F"``).
    unit : str
        Unit of its value and MPE (default ``"mm"``).
    signed : bool
        True: the value has a sign (a size error, measured − calibrated) and is shown
        with it; False: a range or form error, never negative.
    help : str
        One line on how it is measured.
    """

    key: str
    symbol: str
    name: str
    unit: str = "mm"
    signed: bool = False
    help: str = ""


@dataclass(frozen=True)
class ArtefactField:
    """One value of an artefact entry in the plan, as the setup form asks for it.

    Attributes
    ----------
    key : str
        Its key in the plan's artefact entry (``"diameter"``).
    label : str
        The form's label (``"Diameter (calibrated)"``).
    unit : str
        Unit of the value (``"mm"``; ``""`` for a factor).
    kind : str
        ``"number"`` or ``"vector"`` (``size`` numbers).
    size : int
        Length of a vector field.
    min, max : float or None
        Inclusive limits of the value (None: unbounded).
    help : str
        One line for the operator.
    certificate : str
        The name the value is kept under as a calibration certificate in the project
        store (``"diameter"``); ``""`` for a nominal value. For a vector,
        ``"length_{i}"`` names one certificate per element (i = 1, 2, ...).
    uncertainty : str
        The plan key holding the expanded uncertainty U of this value (``"uncertainty"``);
        ``""`` when it has none.
    """

    key: str
    label: str
    unit: str = "mm"
    kind: str = "number"
    size: int = 1
    min: float | None = None
    max: float | None = None
    help: str = ""
    certificate: str = ""
    uncertainty: str = ""


@dataclass(frozen=True)
class ArtefactKind:
    """A kind of calibrated artefact a test measures (sphere, ball bar, gauge block ...).

    Attributes
    ----------
    kind : str
        Its id; the shipped artefact catalogue (``resources/artefacts.yaml``) files its
        artefacts under the same ``kind``.
    title : str
        Its name for the operator.
    fields : tuple of ArtefactField
        The plan values the setup form shows, in order.
    """

    kind: str
    title: str
    fields: tuple[ArtefactField, ...] = ()

    def field(self, key: str) -> ArtefactField | None:
        return next((f for f in self.fields if f.key == key), None)


@dataclass(frozen=True)
class TestDeclaration:
    """One test of a standard.

    Attributes
    ----------
    test : str
        Its key in the plan's ``artefacts`` and ``measurements`` (``"sphere"``).
    title : str
        Its name as counters print it (``"Sphere positions"``).
    artefact : str
        The :class:`ArtefactKind` it measures.
    parameters : tuple of str
        Keys of the :class:`QualityParameter` s it yields.
    min_count : int
        Positions required.
    repeats : int
        Measurements per position (before the plan changes it).
    required : bool
        False: the operator may add it.
    """

    __test__ = False  # not a pytest class

    test: str
    title: str
    artefact: str
    parameters: tuple[str, ...]
    min_count: int
    repeats: int = 1
    required: bool = True


@dataclass(frozen=True)
class PositionSpec:
    """Where the operator puts the artefact for one measurement.

    Attributes
    ----------
    test : str
        The test it belongs to.
    id : str
        Its id, unique in the test (``"sphere-01"``).
    title : str
        Its name on the card (``"Sphere position 1"``).
    artefact : str
        The artefact kind placed there.
    hint : str
        One line saying where (``"front left, low"``).
    repeats : int
        Measurements of this position.
    where : tuple of 3 float
        The artefact centre as fractions of the measuring volume's edges (-0.5..0.5,
        origin at the volume centre, +z towards the sensor).
    placement : dict
        More of the lay-out (``direction``, ``normal``, ``camera`` ...) for a
        simulation or a pictogram.
    pictogram : str
        An inline SVG of the position, or ``""`` (the standard may draw them for a plan
        with ``pictograms()``; the GUI draws a plain one otherwise).
    """

    test: str
    id: str
    title: str
    artefact: str
    hint: str = ""
    repeats: int = 1
    where: tuple[float, float, float] = (0.0, 0.0, 0.0)
    placement: dict[str, Any] = field(default_factory=dict)
    pictogram: str = ""

    def to_dict(self) -> dict[str, Any]:
        """As ``requirements()`` lists it: ``{"id", "label", "hint", "where", ...placement}``."""
        out = {"id": self.id, "label": self.title, "hint": self.hint, "where": list(self.where), **self.placement}
        if self.pictogram:
            out["pictogram"] = self.pictogram
        return out


@dataclass(frozen=True)
class StandardDeclaration:
    """Everything a standard declares before any plan exists.

    Attributes
    ----------
    id, title : str
        The plugin id and the standard's name.
    parameters : tuple of QualityParameter
    artefacts : tuple of ArtefactKind
    tests : tuple of TestDeclaration
    positions : tuple of PositionSpec
        Every position of every test, in order.
    requirements : tuple of str
        What the standard asks of artefacts and plan, one sentence each (shown to the
        operator and in docs).
    """

    id: str
    title: str
    parameters: tuple[QualityParameter, ...]
    artefacts: tuple[ArtefactKind, ...]
    tests: tuple[TestDeclaration, ...]
    positions: tuple[PositionSpec, ...] = ()
    requirements: tuple[str, ...] = ()

    def parameter(self, key: str) -> QualityParameter:
        """The parameter ``key``; an undeclared key is a plain unsigned one in mm."""
        return next((p for p in self.parameters if p.key == key), None) or QualityParameter(key, key, key)

    def artefact(self, kind: str) -> ArtefactKind | None:
        return next((a for a in self.artefacts if a.kind == kind), None)

    def test(self, test: str) -> TestDeclaration | None:
        return next((t for t in self.tests if t.test == test), None)

    def positions_of(self, test: str) -> list[PositionSpec]:
        return [p for p in self.positions if p.test == test]

    def requirements_list(self, plan_artefacts: dict[str, Any] | None = None) -> list[dict[str, Any]]:
        """The declared tests as ``requirements()`` returns them (a standard whose
        positions do not depend on the plan can return this)."""
        arts = plan_artefacts or {}
        return [
            {
                "test": t.test,
                "label": t.title,
                "parameters": list(t.parameters),
                "min_count": t.min_count,
                "repeats": t.repeats,
                "required": t.required,
                "artefact": arts.get(t.test),
                "positions": [p.to_dict() for p in self.positions_of(t.test)],
            }
            for t in self.tests
        ]


# -- the protocol ----------------------------------------------------------------------------
@runtime_checkable
class Standard(Protocol):
    """The methods the acceptance page, ``camcmm verify`` and the demo call on a standard.

    ``plan`` is the plan dict (docs/standards.md: standard, system, mpe, artefacts,
    measurements, and the standard's own keys); ``ctx`` a :class:`camcmm.api.RunContext`
    (or None). Bad input raises a one-line :class:`camcmm.api.InputError` or
    ``GeometryError`` naming the file or plan key. A standard may also offer
    ``pictograms(requirements, plan) -> {"test/position": svg}`` and ``__call__(ctx,
    plan)`` (the whole plan at once, for ``host.run``).
    """

    def declare(self) -> StandardDeclaration:
        """What it judges, with which artefacts, in which positions."""

    def requirements(self, plan: Any = None) -> list[dict[str, Any]]:
        """Per test of this plan (None: the declared tests): ``{"test", "label",
        "parameters", "min_count", "repeats", "required", "artefact", "positions"}``;
        checks the plan (one-line InputError naming the key)."""

    def evaluate_measurement(
        self,
        ctx: Any,
        test: str,
        cloud: Any,
        plan: Any,
        *,
        file: str | None = None,
        position: str | None = None,
        repeat: int | None = None,
    ) -> PositionEvaluation | dict[str, Any]:
        """One measurement (a PointCloud or a path) at once."""

    def summarize(
        self, ctx: Any, plan: Any, per_measurement: dict[str, list[dict[str, Any]]]
    ) -> TestResult | dict[str, Any]:
        """The result from evaluations already made (``{test: [evaluation dict, ...]}``;
        an evaluation may be ``{"file", "position", "error"}``)."""

    def write_report(self, result: dict[str, Any], directory: str | Path, plan: Any = None) -> dict[str, str]:
        """Write the report files; ``{"html", "pdf", "json"}`` paths."""
