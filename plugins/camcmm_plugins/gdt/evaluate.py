"""The evaluation pipeline of a plan on a measured cloud: align, select and associate the
features, build the datum frames, evaluate the characteristics.

:func:`evaluate` is the whole of ``camcmm gdt evaluate`` and of the plugin
``gdt.evaluate``; :class:`Evaluation` holds what it found and gives the command's JSON
(:meth:`Evaluation.to_json`, the keys of issue 27), the 3-D labels and the per-point
feature field.

A feature with too few points within its band (:data:`MIN_POINTS`), or whose association
fails, is "not evaluated" with its reason; so is every characteristic that depends on it
(its feature, a datum built on it). The run goes on with the rest, and each such case is
a warning of the run: a missing number is never silent.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import CadModel, CamcmmError, InputError, to_jsonable

from . import alignment as al
from .model import Associated, CharacteristicResult, CharacteristicSpec, DatumFrame, Plan

#: Least points within its band a feature needs to be associated, by type (the element's
#: parameters plus one, so that its form is not zero by construction).
MIN_POINTS = {"plane": 4, "line": 3, "point": 1, "circle": 4, "cylinder": 6, "sphere": 5, "cone": 7, "torus": 8}
#: Decisive points given per label (the 3-D view shows these).
MAX_LABEL_POINTS = 20
NOT_EVALUATED = "not evaluated"
#: What a feature's or characteristic's computation may refuse with, besides camcmm's own
#: errors: numerical failures on degenerate points. Anything else is a bug and propagates.
_REFUSALS = (CamcmmError, ValueError, ArithmeticError, np.linalg.LinAlgError)


@dataclass
class Evaluation:
    """What :func:`evaluate` found. ``points`` in plan coordinates (mm); ``transform``
    measured -> plan; ``associated`` the evaluated features by id; ``skipped`` the others'
    reasons; ``results`` the characteristics in plan order."""

    plan: Plan
    points: np.ndarray
    transform: np.ndarray
    alignment: dict[str, Any]
    associated: dict[str, Associated]
    selected: dict[str, np.ndarray]
    skipped: dict[str, str]
    results: list[CharacteristicResult]
    warnings: list[str] = field(default_factory=list)

    # ------------------------------------------------------------------ outputs
    def features_json(self) -> list[dict[str, Any]]:
        out = []
        for fid, spec in self.plan.features.items():
            a = self.associated.get(fid)
            d: dict[str, Any] = {
                "id": fid,
                "type": spec.type,
                "association": a.association if a is not None else spec.association,
                "n_points": a.n_points if a is not None else int(len(self.selected.get(fid, ()))),
                "params": to_jsonable(a.params) if a is not None else None,
                "form": to_jsonable(a.form) if a is not None else None,
                "status": "evaluated" if a is not None else NOT_EVALUATED,
            }
            if a is None:
                d["reason"] = self.skipped.get(fid, "")
            elif a.warnings:
                d["warnings"] = list(a.warnings)
            out.append(d)
        return out

    def datums_json(self) -> list[dict[str, Any]]:
        return [{"label": lab, "feature": "-".join(fids)} for lab, fids in self.plan.datums.items()]

    def characteristics_json(self) -> list[dict[str, Any]]:
        return [result_json(r) for r in self.results]

    def alignment_json(self) -> dict[str, Any]:
        return to_jsonable(self.alignment)

    def to_json(self) -> dict[str, Any]:
        """The issue's document: features, datums, alignment, characteristics, warnings."""
        return {
            "unit": "mm",
            "features": self.features_json(),
            "datums": self.datums_json(),
            "alignment": self.alignment_json(),
            "characteristics": self.characteristics_json(),
            "warnings": list(self.warnings),
        }

    def labels(self) -> list[dict[str, Any]]:
        """Per characteristic: ``anchor`` (the centroid of its feature's points, else of
        its decisive points, else the nominal location; plan coordinates, mm), up to
        :data:`MAX_LABEL_POINTS` ``decisive`` points, ``verdict`` (guarded)."""
        out = []
        for r in self.results:
            dec = np.asarray(r.decisive, dtype=np.int64)
            dec = dec[(dec >= 0) & (dec < len(self.points))]
            pts = self.points[dec[:MAX_LABEL_POINTS]]
            a = self.associated.get(r.feature)
            if a is not None and a.n_points:
                anchor = self.points[a.indices].mean(axis=0)
            elif len(pts):
                anchor = pts.mean(axis=0)
            else:
                anchor = _nominal_location(self.plan, r.feature)
            out.append(
                {
                    "id": r.id,
                    "anchor": [float(v) for v in anchor],
                    "decisive": pts.tolist(),
                    "verdict": r.verdict_guarded if r.verdict_guarded != NOT_EVALUATED else r.verdict,
                }
            )
        return out

    def feature_field(self) -> np.ndarray:
        """(N,) index into the plan's features of the feature each point belongs to (the
        first that takes it), -1 none."""
        f = np.full(len(self.points), -1, dtype=np.int64)
        for i, fid in enumerate(self.plan.features):
            idx = self.selected.get(fid)
            if idx is not None and len(idx):
                free = f[idx] < 0
                f[idx[free]] = i
        return f


def result_json(r: CharacteristicResult) -> dict[str, Any]:
    """One characteristic's JSON: the issue's keys first, then the rest."""
    d = {
        "id": r.id,
        "type": r.type,
        "feature": r.feature,
        "datums": list(r.datums),
        "value": r.value,
        "unit": r.unit,
        "tolerance": r.tolerance,
        "u": r.u,
        "verdict": r.verdict,
        "verdict_guarded": r.verdict_guarded,
        "lower": r.lower,
        "upper": r.upper,
        "U": r.U,
        "k": r.k,
        "u_method": r.u_method,
        "n_decisive": int(len(r.decisive)),
        "warnings": list(r.warnings),
        "details": to_jsonable(r.details),
    }
    return to_jsonable(d)


def _nominal_location(plan: Plan, fid: str) -> np.ndarray:
    nom = plan.features[fid].nominal
    for key in ("point", "centre", "apex"):
        if key in nom:
            return np.asarray(nom[key], float)
    box = plan.features[fid].box
    return box.mean(axis=0) if box is not None else np.zeros(3)


def not_evaluated(spec: CharacteristicSpec, reason: str) -> CharacteristicResult:
    """A characteristic that could not be evaluated: no value, the verdict says so."""
    return CharacteristicResult(
        id=spec.id,
        type=spec.type,
        feature=spec.feature,
        datums=spec.datums,
        value=None,
        unit="mm",
        tolerance=spec.tolerance,
        lower=spec.lower,
        upper=spec.upper,
        u=None,
        u_method="",
        k=spec.k,
        verdict=NOT_EVALUATED,
        verdict_guarded=NOT_EVALUATED,
        details={"reason": reason},
        warnings=[reason],
    )


def _names(value: Any) -> list[str]:
    """Feature ids a characteristic option names (one id or a list; None: none)."""
    if value is None:
        return []
    return [str(v) for v in (value if isinstance(value, (list, tuple)) else [value])]


def _reason(exc: BaseException) -> str:
    s = str(exc).strip().splitlines()
    return s[0] if s else type(exc).__name__


def _associate_features(
    plan: Plan, X: np.ndarray, cad: Any, warnings: list[str]
) -> tuple[dict[str, Associated], dict[str, np.ndarray], dict[str, str]]:
    from . import features

    associated: dict[str, Associated] = {}
    selected: dict[str, np.ndarray] = {}
    skipped: dict[str, str] = {}
    for fid, spec in plan.features.items():
        try:
            notes: list[str] = []
            idx = np.asarray(features.select(X, spec, cad, notes), dtype=np.int64)
            warnings += [f"feature {fid}: {n}" for n in notes]
        except _REFUSALS as exc:
            skipped[fid] = _reason(exc)
            warnings.append(f"feature {fid} not evaluated: {skipped[fid]}")
            continue
        selected[fid] = idx
        need = MIN_POINTS.get(spec.type, 4)
        if len(idx) < need:
            skipped[fid] = f"{len(idx)} points within its band of {spec.band:g} mm (a {spec.type} needs {need})"
            warnings.append(f"feature {fid} not evaluated: {skipped[fid]}")
            continue
        try:
            a = features.associate(X, idx, spec)
        except _REFUSALS as exc:
            skipped[fid] = _reason(exc)
            warnings.append(f"feature {fid} not evaluated: {skipped[fid]}")
            continue
        associated[fid] = a
        warnings += [f"feature {fid}: {w}" for w in a.warnings]
    return associated, selected, skipped


def resolve_faces(plan: Plan, cad: Any) -> Plan:
    """The plan with each ``face`` feature as the analytic feature of its CAD face (a plane,
    cylinder, cone, sphere or torus with the CAD's parameters, :func:`.features.resolve_face`),
    so that alignment, datums and characteristics see its type; a free-form face stays a
    face (its points and profile come from the CAD's exact distances)."""
    from . import features

    n = len(cad.faces)
    out = {}
    for fid, spec in plan.features.items():
        if spec.type == "face":
            k = spec.nominal["cad"]
            if not 1 <= k <= n:
                name = Path(plan.source).name if plan.source else "plan"
                raise InputError(f"{name}: features.{fid}.cad: face {k} does not exist (the CAD has {n} faces)")
            spec = features.resolve_face(spec, cad)
        out[fid] = spec
    return replace(plan, features=out)


def evaluate(
    plan: Plan,
    points: np.ndarray,
    nominal: Any = None,
    align: str = "best-fit",
    k: float | None = None,
    start: str = "auto",
    seed: int = 0,
    max_iterations: int = 50,
) -> Evaluation:
    """Evaluate ``plan`` on ``points`` (N, 3 mm, as measured). ``nominal``: a mesh,
    reference cloud or CAD model in plan coordinates (best fit to it; a CAD model's
    faces are the ``face`` features' nominals: :func:`resolve_faces`); ``align``:
    :data:`.model.ALIGNMENTS`; ``k``: coverage factor for every characteristic (None:
    each one's own, default 2); ``start``, ``seed``, ``max_iterations``: of the
    alignment (:func:`.alignment.align`)."""
    from . import characteristics as chars
    from . import datums as dmod

    P = np.asarray(points, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or not len(P):
        raise InputError(f"gdt: expected (N, 3) points, got shape {P.shape}")
    cad = nominal if isinstance(nominal, CadModel) else None
    if cad is not None:
        plan = resolve_faces(plan, cad)
    warnings: list[str] = []
    T, info = al.align(align, plan, P, nominal, cad, start=start, seed=seed, max_iterations=max_iterations)
    if not info.get("converged", True):
        warnings.append(f"alignment {align} did not settle in {info.get('iterations')} iterations")
    if info.get("free"):
        warnings.append(f"alignment {align} leaves free (held where the start put them): " + "; ".join(info["free"]))
    X = al.apply(T, P)
    associated, selected, skipped = _associate_features(plan, X, cad, warnings)

    frames: dict[tuple[str, ...], DatumFrame | str] = {}

    def frame(labels: tuple[str, ...]) -> DatumFrame:
        labels = tuple(labels)
        if labels not in frames:
            missing = [f for lab in labels for f in plan.datums.get(lab, ()) if f not in associated]
            if missing:
                frames[labels] = f"datum feature {missing[0]} not evaluated ({skipped.get(missing[0], '')})"
            else:
                try:
                    frames[labels] = dmod.datum_frame(plan, associated, labels)
                except _REFUSALS as exc:
                    frames[labels] = f"datum frame {'|'.join(labels)}: {_reason(exc)}"
        got = frames[labels]
        if isinstance(got, str):
            raise InputError(got)
        return got

    results: list[CharacteristicResult] = []
    for spec in plan.characteristics:
        if k is not None:
            spec = replace(spec, k=float(k))
        deps = [spec.feature, *_names(spec.options.get("features")), *_names(spec.options.get("to"))]
        missing = [f for f in deps if f not in associated]
        if missing:
            r = not_evaluated(spec, f"feature {missing[0]} not evaluated: {skipped.get(missing[0], '')}")
        else:
            try:
                r = chars.evaluate_characteristic(spec, plan, X, associated, frame)
            except _REFUSALS as exc:
                r = not_evaluated(spec, _reason(exc))
        if r.verdict == NOT_EVALUATED:
            warnings.append(f"{spec.id} not evaluated: {r.details.get('reason', '')}".rstrip(": "))
        else:
            warnings += [f"{spec.id}: {w}" for w in r.warnings]
        results.append(r)
    return Evaluation(plan, X, T, info, associated, selected, skipped, results, warnings)
