"""The page's state: one :class:`WizardPage` per server publishes a
:class:`~camcmm.gui.pages.acceptance.Wizard` through the trame ``state`` (keys ``wz_*``)
for :mod:`.layout`; its handlers live in :mod:`.form`, :mod:`.actions` and
:mod:`.acquire`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.errors import one_line

from ...downloads import REPORT_TITLES, Downloads, sort_links
from ...jobs import Job
from .acquire import PageAcquire, acquisition_sources
from .actions import PageActions
from .declared import parameter
from .form import PageSetup
from .pictograms import pictograms
from .values import fmt_mm, log
from .wizard import Wizard


class WizardPage(PageSetup, PageActions, PageAcquire):
    """Publishes a :class:`Wizard` through the session's trame state (``wz_*`` keys)
    and runs its slow steps in the worker thread of its :class:`~camcmm.gui.jobs.Job`.
    One per server."""

    def __init__(self, session: Any, wizard: Wizard | None = None, downloads: str | Path | None = None):
        self.session = session
        self.state = session.state
        self.wizard = wizard if wizard is not None else Wizard(session.project, session.host)
        self.offered = Downloads("camcmm-downloads", "camcmm-downloads-", downloads)
        self.downloads, self.download_route = self.offered.folder, self.offered.route
        # one worker: evaluations, acquisitions and the report run in order
        self.job = Job("acceptance test", state=self.state)
        self._busy: set[str] = set()
        self.last_card: dict[str, Any] | None = None
        self._init_state()
        self.refresh(setup_form=True)
        w = self.wizard
        if w.active:  # resume where the test stopped
            done = w.complete and (w.state or {}).get("summary_result") is not None
            self.state.wz_step = "result" if done else "positions"

    # -- state ---------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.page = s.page if getattr(s, "page", None) else "inspect"
        s.wz_step = "setup"
        s.wz_active = False
        s.wz_error = ""
        s.wz_setup_error = ""
        s.wz_standards = []
        s.wz_form = {}
        s.wz_form_tests = []
        s.wz_catalogue = {}
        s.wz_mpe_fields = []
        s.wz_locked = False
        s.wz_artefact_warnings = []
        s.wz_artefact_note = ""
        s.wz_confirm_violations = False
        s.wz_test_status = ""
        s.wz_title = ""
        s.wz_blocks = []
        s.wz_svgs = {}
        s.wz_progress = []
        s.wz_progress_text = ""
        s.wz_busy = {}
        s.wz_redo = None
        s.wz_detail = None
        s.wz_parameters = []
        s.wz_verdict = ""
        s.wz_verdict_guarded = ""
        s.wz_complete = False
        s.wz_summary_warnings = []
        s.wz_reporting = False
        s.wz_report_links = []
        s.wz_sources = acquisition_sources(self.session.host)
        s.wz_source = None
        s.wz_source_params = {}
        s.wz_source_fields = []
        s.wz_acquiring_all = False

    def flush(self) -> None:
        self.session.flush()

    def refresh(self, setup_form: bool = False) -> None:
        """Publish everything the page shows."""
        s = self.state
        w = self.wizard
        s.wz_error = w.load_error
        try:
            s.wz_standards = [
                {"title": f"{x['name']} ({x['id']})", "value": x["id"], "summary": x["summary"]} for x in w.standards()
            ]
        except Exception as exc:  # discovery problems are shown, the page stays
            s.wz_standards = []
            s.wz_error = one_line(exc)
        s.wz_active = w.active
        if setup_form:
            self._setup_form()
        if not w.active:
            s.wz_locked = False
            s.wz_blocks, s.wz_progress, s.wz_parameters = [], [], []
            s.wz_title, s.wz_progress_text, s.wz_test_status = "", "", ""
            s.wz_verdict = s.wz_verdict_guarded = ""
            s.wz_report_links = []
            return
        s.wz_locked = True
        try:
            self._publish_positions()
            self._publish_summary()
        except Exception as exc:
            log.exception("wizard refresh failed")
            s.wz_error = one_line(exc)
        s.wz_test_status = self._test_status()

    def _test_status(self) -> str:
        """What the test in the project is: finished (its summary and report stored, with
        the verdict), every position measured but no report yet, or running."""
        st = self.wizard.state or {}
        if st.get("summary_result") is not None:
            verdict = st.get("verdict") or self.state.wz_verdict or "incomplete"
            return f"A finished test is in this project (verdict: {verdict})"
        if self.state.wz_complete:
            return "A test is in this project with every position measured (no report yet)"
        return "A test is running in this project"

    def _publish_positions(self) -> None:
        s = self.state
        w = self.wizard
        blocks = w.cards()
        busy = set(self._busy)
        for b in blocks:
            for c in b["cards"]:
                c["busy"] = c["key"] in busy
        s.wz_blocks = blocks
        prog = w.progress()
        s.wz_progress = prog
        s.wz_progress_text = " · ".join(p["text"] for p in prog)
        s.wz_complete = all(p["complete"] for p in prog)
        if not s.wz_svgs or set(s.wz_svgs) != {c["key"] for b in blocks for c in b["cards"]}:
            s.wz_svgs = pictograms(w.standard(), w.requirements(), w.plan)
        plan = w.plan
        s.wz_title = (
            f"{w.state['standard']} — {plan['system'].get('name', '')}, measuring volume "
            + " × ".join(f"{x:g}" for x in plan["system"]["measuring_volume"])
            + " mm"
        )

    def _publish_summary(self) -> None:
        s = self.state
        w = self.wizard
        try:
            summary = w.summarize()
        except Exception as exc:
            s.wz_parameters = []
            s.wz_verdict = s.wz_verdict_guarded = ""
            s.wz_summary_warnings = [f"no summary: {one_line(exc)}"]
            return
        rows = []
        decl = w.declaration()
        for key, p in (summary.get("parameters") or {}).items():
            q = parameter(decl, key)
            unit = p.get("unit") or q.unit
            rows.append(
                {
                    "key": key,
                    "symbol": q.symbol,
                    "name": p.get("name") or q.name,
                    "value": fmt_mm(p.get("value"), q.signed, unit),
                    "mpe": fmt_mm(p.get("mpe"), unit=unit),
                    "U": fmt_mm(p.get("U"), unit=unit),
                    "verdict": p.get("verdict") or "incomplete",
                    "verdict_guarded": p.get("verdict_guarded") or "incomplete",
                    "n": p.get("n_evaluated", ""),
                    "note": "; ".join(p.get("incomplete_reasons") or []),
                }
            )
        s.wz_parameters = rows
        s.wz_verdict = summary.get("verdict") or "incomplete"
        s.wz_verdict_guarded = summary.get("verdict_guarded") or ""
        s.wz_summary_warnings = [str(x) for x in (summary.get("warnings") or [])][:20]
        s.wz_report_links = self._links()

    def _links(self) -> list[dict[str, str]]:
        rid = (self.wizard.state or {}).get("summary_result")
        links = (
            self.offered.offer(f"acceptance-test-{rid}.{kind}", path, kind=kind, title=REPORT_TITLES.get(kind, kind))
            for kind, path in self.wizard.report_paths().items()
        )
        return sort_links(l for l in links if l)

    def close(self) -> None:
        self.job.close()
        self.offered.close()


def mount(server: Any, session: Any) -> WizardPage:
    """Create the page for a session and serve its downloads folder (call before the
    server starts)."""
    page = WizardPage(session)
    page.offered.mount(server)
    return page
