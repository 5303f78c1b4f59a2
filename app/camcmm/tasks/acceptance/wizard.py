"""The :class:`Wizard`: one acceptance test on a project, made of its parts.

Each part holds what it needs and nothing of the others' insides:

* :class:`~.standards.Standards` — the installed standards, loaded and declared;
* :class:`~.state.TestState` — the saved state, its requirements and position slots;
* :class:`~.setup.Setup` — the plan from the form, the start of a run;
* :class:`~.positions.Positions` — counters and cards;
* :class:`~.evaluate.Evaluator` — prepare → evaluate → record of one measurement;
* :class:`~.result.Result` — summary, report, deviation maps.

The wizard keeps the one interface the page, the demo and the tests use.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.host import default_host
from camcmm.standard import StandardDeclaration

from . import acquire as acquisition
from .evaluate import Evaluator, PendingEvaluation
from .naming import describe_test, status_text
from .options import PlanOption
from .pictograms import pictograms
from .positions import Positions
from .result import Result
from .setup import Setup
from .standards import Standards
from .state import HISTORY_KEY, TestState


class Wizard:
    """An acceptance test on a project, saved under :data:`~.state.STATE_KEY` as it
    happens; a new Wizard on the same project resumes it."""

    def __init__(self, project: Any, host: Any = None):
        self.project = project
        self.host = host if host is not None else default_host()
        self.standards_of = Standards(self.host)
        self.saved = TestState(project, self.standards_of)
        self.setup_step = Setup(self.saved, self.standards_of)
        self.positions = Positions(self.saved)
        self.importer = Evaluator(self.saved, self.standards_of)
        self.result = Result(self.saved, self.standards_of)

    # -- the saved test --------------------------------------------------------------------
    @property
    def state(self) -> dict[str, Any] | None:
        """The saved state dict (None before a setup)."""
        return self.saved.state

    @property
    def load_error(self) -> str:
        return self.saved.load_error

    @property
    def active(self) -> bool:
        return self.saved.active

    @property
    def plan(self) -> dict[str, Any]:
        return self.saved.plan

    def resume(self) -> bool:
        return self.saved.resume()

    def requirements(self) -> list[dict[str, Any]]:
        return self.saved.requirements()

    def requirement(self, test: str) -> dict[str, Any]:
        return self.saved.requirement(test)

    def filled(self, test: str, position: str) -> list[tuple[int, int]]:
        return self.saved.filled(test, position)

    def evaluation(self, mid: int | None) -> dict[str, Any] | None:
        return self.saved.evaluation(mid)

    # -- standards and setup -----------------------------------------------------------------
    def standards(self) -> list[dict[str, Any]]:
        """Installed standard plugins that load: ``{"id", "name", "version", "summary"}``."""
        return self.standards_of.installed()

    def standard(self, sid: str | None = None) -> Any:
        """The standard object of ``sid`` or of the running test."""
        return self.standards_of.load(sid or (self.state or {}).get("standard"))

    def declaration(self, sid: str | None = None) -> StandardDeclaration:
        """What standard ``sid`` (or the running test's) declares."""
        return self.standards_of.declaration(sid or (self.state or {}).get("standard"))

    def plan_options(self, sid: str | None = None) -> list[PlanOption]:
        """The plan keys standard ``sid`` (or the running test's) declares besides the form's."""
        return self.standards_of.plan_options(sid or (self.state or {}).get("standard"))

    def catalogue(self) -> list[dict[str, Any]]:
        return self.setup_step.catalogue()

    def setup_tests(self, sid: str) -> list[dict[str, Any]]:
        return self.setup_step.setup_tests(sid)

    def build_plan(
        self,
        standard: str,
        system_name: str,
        measuring_volume: Any,
        mpe: dict[str, Any],
        artefacts: dict[str, dict[str, Any]],
        options: Any = None,
    ) -> dict[str, Any]:
        """The plan from the setup form (:meth:`Setup.build_plan`)."""
        return self.setup_step.build_plan(standard, system_name, measuring_volume, mpe, artefacts, options)

    def artefact_checks(
        self,
        standard: str,
        system_name: str,
        measuring_volume: Any,
        mpe: dict[str, Any],
        artefacts: dict[str, dict[str, Any]],
        tests: list[str] | None = None,
        options: Any = None,
    ) -> list[dict[str, Any]]:
        """The standard's artefact rules on a setup (:meth:`Setup.artefact_checks`)."""
        return self.setup_step.artefact_checks(standard, system_name, measuring_volume, mpe, artefacts, tests, options)

    def setup(
        self,
        standard: str,
        system_name: str,
        measuring_volume: Any,
        mpe: dict[str, Any],
        artefacts: dict[str, dict[str, Any]],
        tests: list[str] | None = None,
        options: Any = None,
        system_meta: dict[str, Any] | None = None,
    ) -> dict[str, Any]:
        """Start a new test (:meth:`Setup.start`); returns the new state."""
        return self.setup_step.start(
            standard, system_name, measuring_volume, mpe, artefacts, tests, options, system_meta
        )

    # -- positions ---------------------------------------------------------------------------
    def progress(self) -> list[dict[str, Any]]:
        return self.positions.progress()

    @property
    def complete(self) -> bool:
        return self.positions.complete

    def cards(self) -> list[dict[str, Any]]:
        return self.positions.cards()

    def card(self, test: str, position: str) -> dict[str, Any]:
        return self.positions.card(test, position)

    def pictograms(self) -> dict[str, str]:
        """``{"test/position": svg}`` for every position of the running test."""
        return pictograms(self.saved.standard(), self.saved.requirements(), self.saved.plan)

    # -- import: prepare (loop) -> evaluate (any thread) -> record (loop) ----------------------
    def prepare(self, test: str, position: str, repeat: int | None = None) -> PendingEvaluation:
        return self.importer.prepare(test, position, repeat)

    def evaluate(
        self, job: PendingEvaluation, source: str | Path | bytes, name: str | None = None
    ) -> PendingEvaluation:
        return self.importer.evaluate(job, source, name)

    def record(self, job: PendingEvaluation) -> dict[str, Any]:
        """Store an evaluated job (:meth:`Evaluator.record`); returns the position's card."""
        self.importer.record(job)
        return self.card(job.test, job.position)

    def fail(self, job: PendingEvaluation, exc: BaseException) -> str:
        return self.importer.fail(job, exc)

    def import_measurement(
        self, test: str, position: str, source: str | Path | bytes, name: str | None = None, repeat: int | None = None
    ) -> dict[str, Any]:
        """Import, evaluate and store one measurement in the calling thread. Returns the
        position's card; a bad file gives the card with ``status`` "error" and the
        reason (nothing else changes)."""
        job = self.prepare(test, position, repeat)
        try:
            self.evaluate(job, source, name)
        except Exception as exc:
            self.fail(job, exc)
            return self.card(test, position)
        return self.record(job)

    def redo(
        self, test: str, position: str, source: str | Path | bytes, name: str | None = None, repeat: int | None = None
    ) -> dict[str, Any]:
        """Measure a position again: the new evaluation replaces the old one (of
        ``repeat``, default the last filled repeat)."""
        if repeat is None:
            filled = self.filled(test, position)
            repeat = filled[-1][0] if filled else None
        return self.import_measurement(test, position, source, name, repeat)

    # -- acquisition ---------------------------------------------------------------------------
    def acquisition_sources(self) -> list[dict[str, Any]]:
        """The installed measuring systems that acquire a point cloud."""
        return acquisition.acquisition_sources(self.host)

    def placement(self, test: str, position: str) -> dict[str, Any]:
        """What a measuring system is told about a position (:func:`.acquire.placement`)."""
        return acquisition.placement(self.saved, test, position)

    def acquire(self, source: str, params: dict[str, Any], where: dict[str, Any]) -> Path:
        """Run measuring system ``source`` on a placement (any thread); a temporary PLY."""
        return acquisition.acquire(self.host, source, params, where)

    # -- summary and report --------------------------------------------------------------------
    def per_measurement(self, with_deviations: bool = False) -> dict[str, list[dict[str, Any]]]:
        return self.result.per_measurement(with_deviations)

    def summarize(self, per: dict[str, list[dict[str, Any]]] | None = None) -> dict[str, Any]:
        return self.result.summarize(per)

    def make_report(
        self, directory: str | Path, per: dict[str, list[dict[str, Any]]] | None = None
    ) -> tuple[dict[str, Any], dict[str, str]]:
        return self.result.make_report(directory, per)

    def record_report(self, summary: dict[str, Any], paths: dict[str, str], started: str = "") -> dict[str, Any]:
        return self.result.record_report(summary, paths, started)

    def report(self, directory: str | Path | None = None) -> dict[str, Any]:
        return self.result.report(directory)

    def report_paths(self, report: dict[str, str] | None = None) -> dict[str, Path]:
        return self.result.report_paths(report)

    # -- which test is current -------------------------------------------------------------
    def title(self, sid: str | None = None) -> str:
        """The standard's title in words (its id when it cannot be loaded)."""
        sid = sid or (self.state or {}).get("standard") or ""
        try:
            return self.declaration(sid).title or str(sid)
        except Exception:  # an earlier test's standard no longer installed: its id names it
            return str(sid)

    def name(self) -> str:
        """The current test as a person names it (:func:`.naming.describe_test`)."""
        return describe_test(self.state, self.title())

    @property
    def identity(self) -> str:
        """What tells one test from the next: when it was set up ("" before any)."""
        return str((self.state or {}).get("created") or "")

    def worth_keeping(self) -> bool:
        """True when the current test holds work a new one would supersede: a report, or
        at least one measured position."""
        st = self.state or {}
        return bool(self.active and (st.get("summary_result") is not None or any(st.get("measurements", {}).values())))

    def supersede_question(self) -> dict[str, str]:
        """What the operator is asked before a new test replaces the current one: its
        name, where it stands and where it stays findable."""
        st = self.state or {}
        rid = st.get("summary_result")
        done = sum(len(v) for v in (st.get("measurements") or {}).values())
        if rid is not None:
            kept = (
                f"its report stays in the project: result #{rid} "
                f"'Acceptance test {self.title()}' in the results list (Inspect page), and under 'Earlier tests' here"
            )
        else:
            kept = (
                f"its {done} measured position(s) stay in the project's results list, "
                "and the test under 'Earlier tests' here (without a report)"
            )
        return {"name": self.name(), "status": status_text(st, self.complete), "kept": kept, "id": self.identity}

    def earlier_tests(self) -> list[dict[str, Any]]:
        """The tests set up before the current one (newest first), as the setup step lists
        them: ``{key, name, status, result, report}`` (``report``: ``{"report_html": hash}``)."""
        try:
            history = self.project.get_state(HISTORY_KEY, []) or []
        except Exception:  # an unreadable history must not hide the current test
            return []
        rows: list[dict[str, Any]] = []
        for i, h in enumerate(history if isinstance(history, list) else []):
            if not isinstance(h, dict):
                continue
            named = {**h, "plan": {"system": {"name": h.get("system") or ""}}}
            rows.append(
                {
                    "key": f"{i}:{h.get('created') or ''}",
                    "name": describe_test(named, self.title(h.get("standard"))),
                    "status": status_text(h, False) if h.get("summary_result") is not None else "not finished",
                    "result": h.get("summary_result"),
                    "report": h.get("report") if isinstance(h.get("report"), dict) else {},
                }
            )
        return list(reversed(rows))

    def deviations(self, test: str, position: str, repeat: int | None = None) -> Any:
        return self.result.deviations(test, position, repeat)
