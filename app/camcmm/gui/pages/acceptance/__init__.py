"""The "Acceptance test" page: an operator-guided test of any standard plugin, beside the 3D view.

The test itself is the headless task :mod:`camcmm.tasks.acceptance` (its
:class:`~camcmm.tasks.acceptance.Wizard`: setup, positions, import/redo, counters,
summary, report; saved under the project state key ``acceptance.current``); the demo and
the tests drive it without trame. This page holds one and shows it:

* :class:`WizardPage` (:mod:`.page`) — publishes the wizard through the trame ``state``
  (keys ``wz_*``) for :mod:`.layout`, runs evaluations, acquisitions and the report in its
  :class:`~camcmm.gui.jobs.Job`, shows each deviation cloud in the session's 3D view and
  offers the report files for download. Its handlers are three helpers it holds:
  :class:`.form.SetupForm` (the setup form), :class:`.actions.PositionActions` (imports,
  the 3D view, the report), :class:`.acquire.Acquisition` (measuring with a system).
* the widgets: :mod:`.layout`, :mod:`.setup_view`, :mod:`.positions_view`,
  :mod:`.result_view`.

The task's names are re-exported here for callers of the page's former home.
"""

from __future__ import annotations

from typing import Any

from camcmm.tasks.acceptance import (
    HISTORY_KEY,
    REPORT_POINTS,
    STATE_KEY,
    PendingEvaluation,
    Wizard,
    artefact_plan_fields,
    fit_rows,
    fmt_mm,
    load_catalogue,
    parse_options,
    plan_fields_to_artefact,
)

from .. import Page
from .page import WizardPage, mount


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
