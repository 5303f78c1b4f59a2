"""The "Acceptance test" page: an operator-guided test of any standard plugin, beside the 3D view.

The operator picks a standard (any installed plugin of kind ``standard`` that speaks
the protocol of :mod:`camcmm.standard`, docs/standards.md), the measuring system and the
artefacts, then imports (or acquires) one measurement per position the standard asks
for. Each is evaluated at once (fit, quality parameters, deviation colour map) and saved
in the project as it happens; a restart resumes where the test stopped. At the end the
report is one click away. The page knows a standard only by its declaration
(``declare()``): parameter symbols and signs, artefact fields, tests and positions.

Two layers:

* :class:`Wizard` — the test on a project: setup, positions, import/redo, counters,
  summary, report. Plain Python on the project store and the standard protocol; no
  trame, no VTK. Importing a measurement is split into ``prepare`` (server loop) →
  ``evaluate`` (any thread: reads the file, runs the standard; touches no store) →
  ``record`` (server loop: stores file, measurement, deviations, result, state);
  :meth:`Wizard.import_measurement` does all three in the calling thread.
* :class:`WizardPage` — publishes the wizard through the trame ``state`` (keys
  ``wz_*``) for :mod:`.layout`, runs evaluations, acquisitions and the report in its
  :class:`~camcmm.gui.jobs.Job`, shows each deviation cloud in the session's 3D view
  and offers the report files for download.

Saved state (project state key ``acceptance.current``, the key the demo writes too)::

    {"standard": "<plugin id>", "plan": {...the plan contract...},
     "measurements": {test: [measurement ids in position order]},
     "evaluations": {"<measurement id>": result id},
     "summary_result": result id or None, "report": {"report_html": hash, ...} or None,
     "verdict": ..., "verdict_guarded": ...,
     # written by the page (derived from measurement meta when absent, as in the demo):
     "positions": {test: {position id: [measurement id or None per repeat]}},
     "errors": {"test/position": one-line reason of the last failed import},
     "superseded": [{"test", "position", "repeat", "measurement", "result", "replaced"}],
     "tests": [tests in this run], "system_id": id, "artefact_ids": {test: id}}

A redo stores the new measurement and result and soft-deletes the replaced one.

Modules, one topic each: :mod:`.state` (saved state, resume, requirements, slots),
:mod:`.setup` (installed standards, the plan from the form, a new run),
:mod:`.declared` (the standard's declaration), :mod:`.catalogue` (artefact catalogue ⇄
plan entries), :mod:`.positions` (counters, cards), :mod:`.evaluate` (prepare → evaluate
→ record), :mod:`.result` (summary, report, deviation maps), :mod:`.values` (numbers in,
text out), :mod:`.wizard` (the :class:`Wizard`); the page: :mod:`.page`, :mod:`.form`,
:mod:`.actions`, :mod:`.acquire`, :mod:`.pictograms`; the widgets: :mod:`.layout`,
:mod:`.setup_view`, :mod:`.positions_view`, :mod:`.result_view`.
"""

from __future__ import annotations

from typing import Any

from .. import Page
from .catalogue import artefact_plan_fields, load_catalogue, plan_fields_to_artefact
from .evaluate import PendingEvaluation
from .page import WizardPage, mount
from .positions import fit_rows
from .result import REPORT_POINTS
from .setup import parse_options
from .state import HISTORY_KEY, STATE_KEY
from .values import fmt_mm
from .wizard import Wizard


def _build(page: Any) -> None:
    from ...widgets import accepted_extensions
    from .layout import build

    build(page, accepted_extensions())


PAGE = Page("acceptance", "Acceptance test", "mdi-clipboard-check-outline", mount, _build, order=10, full=False)

__all__ = [
    "HISTORY_KEY",
    "PAGE",
    "PendingEvaluation",
    "REPORT_POINTS",
    "STATE_KEY",
    "Wizard",
    "WizardPage",
    "artefact_plan_fields",
    "fit_rows",
    "fmt_mm",
    "load_catalogue",
    "mount",
    "parse_options",
    "plan_fields_to_artefact",
]
