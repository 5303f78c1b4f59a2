"""What a standard returns (:mod:`camcmm.standard`): one evaluated position, a quality
parameter over the test, the whole test. Plain dataclasses whose ``to_dict()`` gives
the JSON-able dicts the project stores; lengths in mm unless a parameter says otherwise."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .conformity import INCOMPLETE, combine, guarded_verdict, simple_verdict

__all__ = ["ParameterResult", "PositionEvaluation", "TestResult", "as_dict"]


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
        out = {
            **self.extra,
            "test": self.test,
            "values": dict(self.values),
            "file": self.file,
            "position": self.position,
            "repeat": self.repeat,
            "fit": list(self.fit),
            "fit_text": self.fit_text,
            "warnings": list(self.warnings),
            "deviations": self.deviations,
        }
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
    def judge(
        cls, parameter: Any, rows: list[dict[str, Any]], mpe: float, U: float = 0.0, required: int = 0
    ) -> ParameterResult:
        """Judge ``rows`` (``{"value", ...}``; ``value`` None for a failed measurement) of
        ``parameter`` (a :class:`camcmm.standard.QualityParameter`): the largest value
        (largest magnitude, sign kept, when ``parameter.signed``), both verdicts;
        incomplete when a row failed or fewer than ``required`` were evaluated."""
        values = [r["value"] for r in rows if r.get("value") is not None]
        reasons = []
        if len(values) < len(rows):
            reasons.append(f"{len(rows) - len(values)} of {len(rows)} measurements failed")
        if len(values) < required:
            reasons.append(f"{len(values)} of the {required} measurements required were evaluated")
        value = (max(values, key=abs) if parameter.signed else max(values)) if values else None
        out = cls(
            parameter.key,
            parameter.name,
            value,
            float(mpe),
            float(U),
            unit=parameter.unit,
            n_evaluated=len(values),
            incomplete_reasons=reasons,
            per_measurement=list(rows),
        )
        if not reasons:
            out.verdict = simple_verdict(value, mpe)
            out.verdict_guarded = guarded_verdict(value, mpe, U)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "value": self.value,
            "mpe": self.mpe,
            "verdict": self.verdict,
            "verdict_guarded": self.verdict_guarded,
            "U": self.U,
            "unit": self.unit,
            "n_evaluated": self.n_evaluated,
            "incomplete_reasons": list(self.incomplete_reasons),
            "per_measurement": list(self.per_measurement),
        }


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
        out = {
            **self.extra,
            "standard": self.standard,
            "standard_name": self.standard_name,
            "verdict": self.verdict or combine(p.verdict for p in params),
            "verdict_guarded": self.verdict_guarded or combine(p.verdict_guarded for p in params),
            "parameters": {k: p.to_dict() for k, p in self.parameters.items()},
            "warnings": list(self.warnings),
            "measurements": self.measurements,
        }
        if self.report:
            out["report"] = dict(self.report)
        return out


def as_dict(x: Any) -> Any:
    """A result dataclass as its dict (``to_dict()``); a dict as it is."""
    return x.to_dict() if hasattr(x, "to_dict") and not isinstance(x, dict) else x
