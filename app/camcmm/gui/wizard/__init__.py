"""The acceptance-test wizard: logic apart from the page, testable without a browser.

The operator picks a standard (any installed plugin of kind ``standard`` that speaks the
standard protocol of docs/standards.md), the measuring system and the artefacts, then
imports one measurement per position the standard asks for. Each is evaluated at once
(fit, quality parameters, deviation colour map) and saved in the project as it
happens; a restart resumes where the test stopped. At the end the report is one click
away.

Two layers:

* :class:`Wizard` — the test on a project: setup, positions, import/redo, counters,
  summary, report. Plain Python on the project store and the standard protocol; no
  trame, no VTK. Importing a measurement is split into ``prepare`` (server loop) →
  ``evaluate`` (any thread: reads the file, runs the standard; touches no store) →
  ``record`` (server loop: stores file, measurement, deviations, result, state), so
  the GUI can run the slow middle in a worker; :meth:`Wizard.import_measurement` does
  all three in the calling thread.
* :class:`WizardPage` — publishes the wizard through the trame ``state`` (keys
  ``wz_*``) for :mod:`camcmm.gui.wizard_layout`, runs evaluations and the report in a
  worker thread, shows each deviation cloud in the session's 3D view and offers the
  report files for download.

Saved state (project state key ``acceptance.current``, the key the demo writes too)::

    {"standard": "vdi2634-2", "plan": {...the plan contract...},
     "measurements": {test: [measurement ids in position order]},
     "evaluations": {"<measurement id>": result id},
     "summary_result": result id or None, "report": {"report_html": hash, ...} or None,
     "verdict": ..., "verdict_guarded": ...,
     # written by the wizard (derived from measurement meta when absent, as in the demo):
     "positions": {test: {position id: [measurement id or None per repeat]}},
     "errors": {"test/position": one-line reason of the last failed import},
     "superseded": [{"test", "position", "repeat", "measurement", "result", "replaced"}],
     "tests": [tests in this run], "system_id": id, "artefact_ids": {test: id}}

A redo stores the new measurement and result and soft-deletes the replaced measurement
(nothing is deleted: results are immutable, the superseded list names them).

The package, one topic a module (``Wizard`` is assembled in :mod:`.core` from the step
classes; ``WizardPage`` in :mod:`.page` from its handler classes):

* :mod:`.state` — the saved state, resume, requirements and position slots;
* :mod:`.setup` — installed standards, the plan from the setup form, a new run;
* :mod:`.catalogue` — the artefact catalogue and plan entries ⇄ Artefact dicts;
* :mod:`.positions` — counters, position cards, the fit in words;
* :mod:`.evaluate` — prepare → evaluate → record, failures, redo;
* :mod:`.result` — summary, report, deviation maps;
* :mod:`.values` — numbers in, mm text and verdicts out, one-line errors;
* :mod:`.page`, :mod:`.page_setup`, :mod:`.page_actions` — the trame page.
"""

from .catalogue import ARTEFACT_FIELDS, artefact_plan_fields, load_catalogue, plan_fields_to_artefact, resources_dir
from .core import Wizard
from .evaluate import Job
from .page import WizardPage, mount
from .page_actions import view_direction
from .positions import fit_rows, fit_text
from .result import REPORT_POINTS
from .setup import parse_options
from .state import HISTORY_KEY, STATE_KEY
from .values import SIGNED, SYMBOLS, fmt_mm

__all__ = ["ARTEFACT_FIELDS", "HISTORY_KEY", "REPORT_POINTS", "SIGNED", "STATE_KEY", "SYMBOLS", "Job", "Wizard",
           "WizardPage", "artefact_plan_fields", "fit_rows", "fit_text", "fmt_mm", "load_catalogue", "mount",
           "parse_options", "plan_fields_to_artefact", "resources_dir", "view_direction"]
