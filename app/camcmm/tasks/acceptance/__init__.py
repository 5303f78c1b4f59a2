"""The acceptance test (VDI/VDE 2634 parts 2/3, or any standard plugin) as a headless task.

The operator (or the demo, or a test) picks a standard (any installed plugin of kind
``standard`` that speaks the protocol of :mod:`camcmm.standard`, docs/standards.md), the
measuring system and the artefacts, then imports (or acquires) one measurement per
position the standard asks for. Each is evaluated at once and saved in the project as it
happens; a new :class:`Wizard` on the same project resumes where the test stopped. At
the end the standard plugin summarises and writes the report (``write_report`` of the
object the host loads). The task knows a standard only by its declaration
(``declare()``): parameter symbols and signs, artefact fields, tests and positions.

Importing a measurement is split into ``prepare`` (server loop) → ``evaluate`` (any
thread: reads the file, runs the standard; touches no store) → ``record`` (server loop:
stores file, measurement, deviations, result, state); :meth:`Wizard.import_measurement`
does all three in the calling thread. Every stored result is a
:class:`camcmm.host.RunResult` row. The page (:mod:`camcmm.gui.pages.acceptance`) holds
a Wizard and only shows it; nothing here imports trame or VTK.

Saved state (project state key ``acceptance.current``)::

    {"standard": "<plugin id>", "plan": {...the plan contract...},
     "measurements": {test: [measurement ids in position order]},
     "evaluations": {"<measurement id>": result id},
     "summary_result": result id or None, "report": {"report_html": hash, ...} or None,
     "verdict": ..., "verdict_guarded": ...,
     "positions": {test: {position id: [measurement id or None per repeat]}},
     "errors": {"test/position": one-line reason of the last failed import},
     "superseded": [{"test", "position", "repeat", "measurement", "result", "replaced"}],
     "tests": [tests in this run], "system_id": id, "artefact_ids": {test: id}}

A redo stores the new measurement and result and soft-deletes the replaced one.

Modules, one topic each: :mod:`.wizard` (the :class:`Wizard`, made of the parts below),
:mod:`.standards` (installed standards, loaded and declared), :mod:`.state` (saved state,
resume, requirements, slots), :mod:`.setup` (the plan from the form, a new run),
:mod:`.declared` (the standard's declaration), :mod:`.catalogue` (artefact catalogue ⇄
plan entries), :mod:`.positions` (counters, cards), :mod:`.evaluate` (prepare → evaluate
→ record), :mod:`.result` (summary, report, deviation maps), :mod:`.acquire` (a position
from a measuring system), :mod:`.pictograms`, :mod:`.values` (numbers in, text out).
"""

from __future__ import annotations

from .acquire import acquisition_sources
from .catalogue import artefact_plan_fields, load_catalogue, plan_fields_to_artefact
from .declared import artefact_fields, artefact_kind, parameter
from .evaluate import PendingEvaluation, safe_name
from .positions import fit_rows
from .result import REPORT_POINTS
from .setup import FORM_KEYS, parse_options
from .state import HISTORY_KEY, STATE_KEY, TestState
from .values import fmt_mm
from .wizard import Wizard

__all__ = [
    "FORM_KEYS",
    "HISTORY_KEY",
    "REPORT_POINTS",
    "STATE_KEY",
    "PendingEvaluation",
    "TestState",
    "Wizard",
    "acquisition_sources",
    "artefact_fields",
    "artefact_kind",
    "artefact_plan_fields",
    "fit_rows",
    "fmt_mm",
    "load_catalogue",
    "parameter",
    "parse_options",
    "plan_fields_to_artefact",
    "safe_name",
]
