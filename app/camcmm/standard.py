"""The typed standard protocol: what an acceptance-test plugin DECLARES and what it RETURNS.

A standard plugin (manifest ``kind: standard``) is an object the host loads with
``host.load(id)``. The GUI's acceptance page, ``camcmm verify`` and the demo know a
standard only through :class:`Standard` (the methods they call) and the
:class:`StandardDeclaration` its ``declare()`` returns: which quality parameters it
judges, which artefacts it needs (and their calibrated fields), which tests and
positions it asks for. Nothing about a particular standard is written in the GUI; a
lab's own standard that implements this protocol appears beside the built-in ones.

Results travel as plain JSON-able dicts (they are stored in the project); the result
dataclasses here build them (``to_dict()``) and name their keys. Lengths are mm unless
a parameter declares another unit. See docs/standards.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from .conformity import INCOMPLETE, combine, guarded_verdict, simple_verdict

__all__ = ["ArtefactField", "ArtefactKind", "ParameterResult", "PositionEvaluation", "PositionSpec",
           "QualityParameter", "Standard", "StandardDeclaration", "TestDeclaration", "TestResult", "as_dict"]


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
        out = {"id": self.id, "label": self.title, "hint": self.hint, "where": list(self.where),
               **self.placement}
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
        return [{"test": t.test, "label": t.title, "parameters": list(t.parameters), "min_count": t.min_count,
                 "repeats": t.repeats, "required": t.required, "artefact": arts.get(t.test),
                 "positions": [p.to_dict() for p in self.positions_of(t.test)]} for t in self.tests]


# -- what a standard returns -----------------------------------------------------------------
@dataclass
class PositionEvaluation:
    """One measurement evaluated at once.

    Attributes
    ----------
    test : str
    values : dict
        Per parameter key its value (a number, or a list of numbers when one
        measurement yields several, e.g. three lengths), in the parameter's unit.
    file, position : str or None
    repeat : int
    fit : list of dict
        ``{"name", "value"}`` rows describing the fit for the operator (text).
    fit_text : str
        The fit in one line (``"Ø 20.0012 mm · 3990 of 4000 pts"``).
    warnings : list of str
    deviations : PointCloud or None
        The cloud with the field ``deviation`` (mm) for the colour map.
    view : dict or None
        ``{"direction": [x, y, z], "up": [x, y, z]}``: from where the colour map reads
        best (direction from the object to the camera).
    extra : dict
        More keys the standard keeps for its summary (diameters, centres ...).
    """

    test: str
    values: dict[str, Any]
    file: str | None = None
    position: str | None = None
    repeat: int = 1
    fit: list[dict[str, str]] = field(default_factory=list)
    fit_text: str = ""
    warnings: list[str] = field(default_factory=list)
    deviations: Any = None
    view: dict[str, list[float]] | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        out = {**self.extra, "test": self.test, "values": dict(self.values), "file": self.file,
               "position": self.position, "repeat": self.repeat, "fit": list(self.fit), "fit_text": self.fit_text,
               "warnings": list(self.warnings), "deviations": self.deviations}
        if self.view is not None:
            out["view"] = self.view
        return out


@dataclass
class ParameterResult:
    """A quality parameter over the whole test.

    Attributes
    ----------
    key, name, unit : str
    value : float or None
        The value judged (largest magnitude, sign kept for a signed parameter).
    mpe : float
        Maximum permissible error.
    U : float
        Expanded uncertainty of the test (k = 2), same unit.
    verdict : str
        Simple acceptance: ``pass`` | ``fail`` | ``incomplete``.
    verdict_guarded : str
        ISO 14253-1 guarded acceptance: also ``inconclusive``.
    n_evaluated : int
    incomplete_reasons : list of str
    per_measurement : list of dict
        ``{"file", "position", "repeat", "value"}`` per value.
    """

    key: str
    name: str
    value: float | None
    mpe: float
    U: float = 0.0
    verdict: str = INCOMPLETE
    verdict_guarded: str = INCOMPLETE
    unit: str = "mm"
    n_evaluated: int = 0
    incomplete_reasons: list[str] = field(default_factory=list)
    per_measurement: list[dict[str, Any]] = field(default_factory=list)

    @classmethod
    def judge(cls, parameter: QualityParameter, rows: list[dict[str, Any]], mpe: float, U: float = 0.0,
              required: int = 0) -> "ParameterResult":
        """Judge ``rows`` (``{"value", ...}``; ``value`` None for a failed measurement):
        the largest value (largest magnitude, sign kept, when ``parameter.signed``), both
        verdicts; incomplete when a row failed or fewer than ``required`` were evaluated."""
        values = [r["value"] for r in rows if r.get("value") is not None]
        reasons = []
        if len(values) < len(rows):
            reasons.append(f"{len(rows) - len(values)} of {len(rows)} measurements failed")
        if len(values) < required:
            reasons.append(f"{len(values)} of the {required} measurements required were evaluated")
        value = (max(values, key=abs) if parameter.signed else max(values)) if values else None
        out = cls(parameter.key, parameter.name, value, float(mpe), float(U), unit=parameter.unit,
                  n_evaluated=len(values), incomplete_reasons=reasons, per_measurement=list(rows))
        if not reasons:
            out.verdict = simple_verdict(value, mpe)
            out.verdict_guarded = guarded_verdict(value, mpe, U)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "value": self.value, "mpe": self.mpe, "verdict": self.verdict,
                "verdict_guarded": self.verdict_guarded, "U": self.U, "unit": self.unit,
                "n_evaluated": self.n_evaluated, "incomplete_reasons": list(self.incomplete_reasons),
                "per_measurement": list(self.per_measurement)}


@dataclass
class TestResult:
    """The whole test: every parameter and the verdicts.

    Attributes
    ----------
    standard, standard_name : str
    parameters : dict of str to ParameterResult
    verdict, verdict_guarded : str
        Combined over the parameters (:func:`camcmm.api.combine`); None: computed.
    warnings : list of str
    measurements : dict
        ``{test: [evaluation dict, ...]}`` as summarised.
    report : dict
        Report files written (``{"html": path, ...}``), once written.
    extra : dict
        More keys of the result (system, artefacts, provenance ...).
    """

    __test__ = False  # not a pytest class

    standard: str
    standard_name: str
    parameters: dict[str, ParameterResult]
    verdict: str | None = None
    verdict_guarded: str | None = None
    warnings: list[str] = field(default_factory=list)
    measurements: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    report: dict[str, str] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        params = self.parameters.values()
        out = {**self.extra, "standard": self.standard, "standard_name": self.standard_name,
               "verdict": self.verdict or combine(p.verdict for p in params),
               "verdict_guarded": self.verdict_guarded or combine(p.verdict_guarded for p in params),
               "parameters": {k: p.to_dict() for k, p in self.parameters.items()},
               "warnings": list(self.warnings), "measurements": self.measurements}
        if self.report:
            out["report"] = dict(self.report)
        return out


def as_dict(x: Any) -> Any:
    """A result dataclass as its dict (``to_dict()``); a dict as it is."""
    return x.to_dict() if hasattr(x, "to_dict") and not isinstance(x, dict) else x


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

    def evaluate_measurement(self, ctx: Any, test: str, cloud: Any, plan: Any, *, file: str | None = None,
                             position: str | None = None, repeat: int | None = None
                             ) -> PositionEvaluation | dict[str, Any]:
        """One measurement (a PointCloud or a path) at once."""

    def summarize(self, ctx: Any, plan: Any, per_measurement: dict[str, list[dict[str, Any]]]
                  ) -> TestResult | dict[str, Any]:
        """The result from evaluations already made (``{test: [evaluation dict, ...]}``;
        an evaluation may be ``{"file", "position", "error"}``)."""

    def write_report(self, result: dict[str, Any], directory: str | Path, plan: Any = None) -> dict[str, str]:
        """Write the report files; ``{"html", "pdf", "json"}`` paths."""
