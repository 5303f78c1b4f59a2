"""The standard protocol shared by VDI/VDE 2634 part 2 and part 3 (docs/standards.md).

An instance is the manifest ``entry`` of a standard plugin; the host loads it with
``host.load(id)``. It offers:

* ``declare()`` -> the :class:`camcmm.api.StandardDeclaration` (parameters, artefacts,
  tests, positions; :mod:`.declaration`);
* ``__call__(ctx, plan)`` -> the full result JSON (so ``host.run(id, {"plan": ...})`` works);
* ``requirements(plan)`` -> per test the positions the standard asks for;
* ``evaluate_measurement(ctx, test, cloud, plan)`` -> one measurement at once;
* ``summarize(ctx, plan, per_measurement)`` -> the full JSON from stored evaluations;
* ``write_report(result, directory, plan)`` -> {"html", "pdf", "json"} paths;
* ``pictograms(requirements, plan)`` -> an SVG per position (:mod:`.pictograms`).

Verdicts (ISO 14253-1, via camcmm.api): simple acceptance |E| <= MPE as VDI/VDE 2634
states it, and beside it guarded acceptance |E| <= MPE - U with U the test's own
uncertainty (:mod:`.uncertainty`). A parameter with a failed measurement, or fewer
successful measurements than the standard requires, is ``incomplete`` — never ``pass``.
"""

from __future__ import annotations

import importlib.metadata
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from camcmm.api import (
    CamcmmError,
    InputError,
    PointCloud,
    RunContext,
    StandardDeclaration,
    combine,
    default_host,
    guarded_verdict,
    simple_verdict,
    to_jsonable,
)

from . import declaration, describe, measure, positions, report, rules, uncertainty
from . import pictograms as drawings
from . import plan as plans
from .threads import single_blas_thread

INCOMPLETE = "incomplete"
#: A deviations cloud kept in a batch result (for the report's colour maps) has at most this many points.
REPORT_POINTS = 30_000
#: The algorithms a standard asks the host for (their versions go into the provenance).
ALGORITHMS = ("fit.sphere", "fit.plane", "segment.spheres", "segment.sphere")
PARAMETER_NAMES = declaration.NAMES


@dataclass(frozen=True)
class TestSpec:
    """One test of a standard: its artefact, the parameters it yields, how many
    positions it needs, whether the standard requires it."""

    test: str
    label: str
    parameters: tuple[str, ...]
    min_count: int
    required: bool = True


def _version() -> str:
    try:
        return importlib.metadata.version("camcmm")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def decimate(cloud: PointCloud | None, limit: int = REPORT_POINTS) -> PointCloud | None:
    if cloud is None or cloud.n_points <= limit:
        return cloud
    return cloud.subset(slice(None, None, -(-cloud.n_points // limit)))


def signed_largest(values: list[float]) -> float | None:
    """The value of largest magnitude, sign kept (P_S, SD)."""
    return max(values, key=abs) if values else None


class Standard:
    """Base of the VDI/VDE 2634 standards; subclasses set ``id``, ``part``, ``title``,
    ``specs`` and may override :meth:`tests` and :meth:`extra`."""

    id = "vdi2634"
    part = 0
    title = "VDI/VDE 2634"
    specs: tuple[TestSpec, ...] = ()
    default_outliers = "vdi2634"

    # -- plan ----------------------------------------------------------------------------
    def load_plan(self, plan: Any) -> plans.Plan:
        p = plans.load(plan, self.id)
        for test in plans.TESTS:
            p.outliers.setdefault(test, self.default_outliers)
        self.check_plan(p)
        return p

    def check_plan(self, plan: plans.Plan) -> None:
        """Raise InputError naming the key when the plan lacks what the tests need."""
        for spec in self.tests(plan):
            for param in spec.parameters:
                if param not in plan.mpe and (spec.required or plan.measurements.get(spec.test)):
                    raise InputError(
                        f"{plan.source}: mpe.{param} is missing; {self.title} judges "
                        f"{PARAMETER_NAMES[param]} against it"
                    )
            if spec.required and spec.test not in plan.artefacts:
                raise InputError(f"{plan.source}: artefacts.{spec.test} is missing; {self.title} needs it")

    def spec(self, test: str) -> TestSpec:
        for s in self.specs:
            if s.test == test:
                return s
        raise InputError(f"{self.id} has no test {test!r}; its tests: {', '.join(s.test for s in self.specs)}")

    def tests(self, plan: plans.Plan | None) -> list[TestSpec]:
        """The tests this plan runs: the required ones, and an optional one when the plan
        lists measurements for it or asks (``mpe``) for a parameter only it yields."""
        if plan is None:
            return [s for s in self.specs if s.required]
        covered = {p for s in self.specs if s.required for p in s.parameters}
        return [
            s
            for s in self.specs
            if s.required
            or plan.measurements.get(s.test)
            or any(p in plan.mpe and p not in covered for p in s.parameters)
        ]

    def repeats(self, plan: plans.Plan | None) -> int:
        return 1

    # -- protocol ------------------------------------------------------------------------
    def declare(self) -> StandardDeclaration:
        """Parameters, artefacts, tests and positions (before any plan; part 3's repeats
        are its default, a plan may change them)."""
        return declaration.declare(self.id, self.title, self.part, self.specs, self.repeats(None))

    def plan_options(self) -> list[dict[str, Any]]:
        """The plan keys besides the setup form's, declared as parameters (optional
        protocol method: the GUI's "More plan options" form is built from it)."""
        return declaration.plan_options(self.part)

    def pictograms(self, requirements: list[dict[str, Any]], plan: dict[str, Any]) -> dict[str, str]:
        """``{"test/position": svg}``: each position drawn in the plan's measuring volume."""
        return drawings.pictograms(requirements, plan)

    def requirements(self, plan: Any = None) -> list[dict[str, Any]]:
        """Per test: label, parameters, minimum number of positions, repeats, whether
        required, the artefact and the positions (ids, labels, hints, coordinates)."""
        p = self.load_plan(plan) if plan is not None else None
        out = []
        for spec in self.tests(p) if p is not None else self.specs:
            art = p.artefacts.get(spec.test) if p is not None else None
            out.append(
                {
                    "test": spec.test,
                    "label": spec.label,
                    "parameters": list(spec.parameters),
                    "min_count": spec.min_count,
                    "repeats": self.repeats(p),
                    "required": spec.required,
                    "artefact": None if art is None else art.to_dict(),
                    "planned": len(p.measurements.get(spec.test, [])) if p is not None else 0,
                    "positions": positions.for_test(spec.test, self.part),
                }
            )
        return out

    def evaluate_measurement(
        self,
        ctx: RunContext | None,
        test: str,
        cloud: Any,
        plan: Any,
        *,
        file: str | None = None,
        position: str | None = None,
        repeat: int | None = None,
    ) -> dict[str, Any]:
        """Evaluate one measurement now; ``cloud`` is a PointCloud or a file path (read
        with the plan's unit). Raises a one-line error for bad input."""
        p = self.load_plan(plan)
        ctx = ctx or RunContext(default_host(), self.id)
        self.spec(test)
        sha = None
        if isinstance(cloud, (str, Path)):
            path = Path(cloud)
            item = plans.PlannedMeasurement(test, path.name, path, position or "", repeat or 1, p.unit, path.name)
            cloud, sha = measure.load(item)
        name = file or getattr(cloud, "name", None)
        out = describe.add_words(measure.evaluate(ctx, test, cloud, p, name))
        out.update({"file": name, "position": position, "repeat": repeat or 1})
        if sha:
            out["sha256"] = sha
        return out

    def _evaluate_item(self, ctx: RunContext, item: plans.PlannedMeasurement, p: plans.Plan) -> dict[str, Any]:
        base = {"test": item.test, "file": item.name, "position": item.position, "repeat": item.repeat}
        try:
            cloud, sha = measure.load(item)
            out = describe.add_words(measure.evaluate(ctx, item.test, cloud, p, item.name))
            out["deviations"] = decimate(out.get("deviations"))
            out.update(base, sha256=sha)
            return out
        except CamcmmError as exc:
            return {**base, "error": str(exc)}

    def __call__(self, ctx: RunContext | None, plan: Any, workers: int | None = None) -> dict[str, Any]:
        """Evaluate every measurement of the plan and summarise (the full result JSON)."""
        ctx = ctx or RunContext(default_host(), self.id)
        p = self.load_plan(plan)
        items = [m for spec in self.tests(p) for m in p.measurements.get(spec.test, [])]
        workers = workers or min(4, os.cpu_count() or 1)
        for pid in ALGORITHMS:  # import the fits once, before threads would queue on the import lock
            if pid in ctx.host.plugins:
                ctx.host.load(pid)
        per: dict[str, list[dict[str, Any]]] = {s.test: [] for s in self.tests(p)}
        # Threads: the fits are numpy-bound and release the GIL for most of their time; with
        # more than one, each keeps to one BLAS thread (threads.py: BLAS's own threads would
        # only oversubscribe the cores the pool already fills).
        pool = ThreadPoolExecutor(max_workers=max(1, workers))
        with single_blas_thread(workers > 1 and len(items) > 1):
            try:
                futures = [pool.submit(self._evaluate_item, ctx, m, p) for m in items]
                for i, (m, f) in enumerate(zip(items, futures)):
                    per[m.test].append(f.result())
                    ctx.progress((i + 1) / max(len(items), 1), f"{m.name} evaluated")  # raises when cancelled
            finally:
                pool.shutdown(wait=True, cancel_futures=True)  # on cancel: drop what has not started
        return self.summarize(ctx, p, per)

    # -- summary -------------------------------------------------------------------------
    def summarize(
        self, ctx: RunContext | None, plan: Any, per_measurement: dict[str, list[dict[str, Any]]]
    ) -> dict[str, Any]:
        """The full result from already-evaluated measurements (dicts as
        :meth:`evaluate_measurement` returns them, or ``{"file", "error"}`` entries)."""
        ctx = ctx or RunContext(default_host(), self.id)
        p = self.load_plan(plan)
        specs = self.tests(p)
        checks = rules.check(p, [s.test for s in specs])
        warnings = [c["text"] for c in checks if not c["ok"]]
        per = {s.test: list(per_measurement.get(s.test) or []) for s in specs}
        for evs in per.values():
            for ev in evs:
                warnings += [w for w in ev.get("warnings") or []]
                if ev.get("error"):
                    warnings.append(
                        ev["error"] if ev.get("file", "") in ev["error"] else f"{ev.get('file')}: {ev['error']}"
                    )
        params = {}
        for param in ("PF", "PS", "SD", "F"):
            tests = [s for s in specs if param in s.parameters]
            if tests and param in p.mpe:
                params[param] = self._parameter(param, tests, per, p)
                warnings += params[param].pop("_notes")
        result = {
            "standard": self.id,
            "standard_name": self.title,
            "verdict": combine(v["verdict"] for v in params.values()),
            "verdict_guarded": combine(v["verdict_guarded"] for v in params.values()),
            "decision_rules": {
                "verdict": "simple acceptance (VDI/VDE 2634, ISO 14253-1 'simple'): pass when |E| <= MPE",
                "verdict_guarded": "guarded acceptance (ISO 14253-1:2017): pass when |E| <= MPE - U, fail when "
                "|E| > MPE + U, else inconclusive; U = expanded uncertainty of the test (k = 2)",
            },
            "system": {"name": p.system_name, "measuring_volume": p.measuring_volume.tolist(), "diagonal": p.diagonal},
            "parameters": params,
            "artefacts": {k: a.to_dict() for k, a in p.artefacts.items()},
            "artefact_checks": checks,
            "outliers": {s.test: p.rule(s.test) for s in specs},
            "measurements": per,
            "warnings": warnings,
            "provenance": self._provenance(ctx, p, per),
        }
        result.update(self.extra(p, per))
        return result

    def _parameter(self, param: str, specs: list[TestSpec], per: dict[str, list[dict]], p: plans.Plan) -> dict:
        rows, notes, reasons = [], [], []
        for spec in specs:
            evs = per.get(spec.test, [])
            ok = [e for e in evs if not e.get("error")]
            for e in evs:
                base = {
                    "file": e.get("file"),
                    "position": e.get("position"),
                    "repeat": e.get("repeat", 1),
                    "test": spec.test,
                }
                if e.get("error"):
                    rows.append({**base, "value": None, "error": e["error"]})
                    continue
                v = e["values"].get(param)
                items = e.get("items", {}).get(param)
                for j, x in enumerate(v if isinstance(v, list) else [v]):
                    row = {**base, "value": x}
                    if items:
                        row["item"] = items[j]
                    rows.append(row)
            failed = len(evs) - len(ok)
            what = spec.test.replace("_", " ")
            if failed:
                reasons.append(f"{failed} of {len(evs)} {what} measurements failed")
            need = spec.min_count * self.repeats(p)
            if len(ok) < need:
                reasons.append(f"{len(ok)} of the {need} {what} measurements required were evaluated")
        values = [r["value"] for r in rows if r["value"] is not None]
        if param in ("PS", "SD"):
            value = signed_largest(values)
        else:
            value = max(values) if values else None
        mpe = p.mpe[param]
        unc = max((uncertainty.for_parameter(p, param, s.test) for s in specs), key=lambda u: u["U"])
        if reasons:
            simple = guarded = INCOMPLETE
            notes.append(f"{param} incomplete: " + "; ".join(reasons))
        else:
            simple = simple_verdict(value, mpe)
            guarded = guarded_verdict(value, mpe, unc["U"])
        return {
            "name": PARAMETER_NAMES[param],
            "value": value,
            "mpe": mpe,
            "verdict": simple,
            "verdict_guarded": guarded,
            "U": unc["U"],
            "uncertainty": unc,
            "unit": "mm",
            "n_evaluated": sum(1 for r in rows if r["value"] is not None),
            "incomplete_reasons": reasons,
            "per_measurement": rows,
            "_notes": notes,
        }

    def extra(self, p: plans.Plan, per: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
        """More result keys (part 3: lengths, repeats)."""
        return {}

    def _provenance(self, ctx: RunContext, p: plans.Plan, per: dict[str, list[dict]]) -> dict[str, Any]:
        host = ctx.host
        plugins = []
        for pid in (self.id, *ALGORITHMS):
            try:
                plugins.append({"id": pid, "version": host.get(pid).version})
            except CamcmmError:
                plugins.append({"id": pid, "version": "not installed"})
        inputs = [{"file": e.get("file"), "sha256": e.get("sha256")} for evs in per.values() for e in evs]
        return {
            "software": {"camcmm": _version()},
            "plugins": plugins,
            "inputs": inputs,
            "plan": p.source,
            "plan_dict": to_jsonable(p.raw),
        }

    # -- report --------------------------------------------------------------------------
    def write_report(self, result: dict[str, Any], directory: str | Path, plan: Any = None) -> dict[str, str]:
        """Write the HTML/PDF/JSON report of a result into ``directory``."""
        return report.write(result, Path(directory), self.load_plan(plan) if plan is not None else None)
