"""The page's state: one :class:`WizardPage` per server holds a
:class:`~camcmm.tasks.acceptance.Wizard` (the headless task) and publishes it through
the trame ``state`` (keys ``wz_*``) for :mod:`.layout`; its handlers are three small
helpers it holds: :class:`.form.SetupForm`, :class:`.actions.PositionActions` and
:class:`.acquire.Acquisition`."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from camcmm.errors import one_line
from camcmm.tasks.acceptance import STATE_KEY, Wizard, fmt_mm, parameter
from camcmm.tasks.acceptance.naming import status_text, verdict_text
from camcmm.tasks.acceptance.values import log

from ...downloads import REPORT_TITLES, Downloads, sort_links
from ...jobs import Job
from .acquire import Acquisition
from .actions import VIEW_HINT, PositionActions
from .form import SetupForm


class WizardPage:
    """Publishes a :class:`Wizard` through the session's trame state (``wz_*`` keys)
    and runs its slow steps in the worker thread of its :class:`~camcmm.gui.jobs.Job`.
    One per server. The handlers the layout binds are its helpers' (:attr:`form`,
    :attr:`actions`, :attr:`acquisition`), named here once."""

    def __init__(self, session: Any, wizard: Wizard | None = None, downloads: str | Path | None = None):
        self.session = session
        self.state = session.state
        self.wizard = wizard if wizard is not None else Wizard(session.project, session.host)
        self.offered = Downloads("camcmm-downloads", "camcmm-downloads-", downloads)
        self.downloads, self.download_route = self.offered.folder, self.offered.route
        # one worker: evaluations, acquisitions and the report run in order
        self.job = Job("acceptance test", state=self.state)
        self.busy: set[str] = set()  # "test/position" keys being evaluated or acquired
        self.last_card: dict[str, Any] | None = None
        # the test the operator agreed to replace (its identity); a new Start over any
        # other test with work in it asks first (issue 30)
        self.confirmed = ""
        self._follow_later = False  # another session changed the test while we evaluated
        self.form = SetupForm(self)
        self.actions = PositionActions(self)
        self.acquisition = Acquisition(self)
        self._init_state()
        self.refresh(setup_form=True)
        w = self.wizard
        if w.active:  # resume where the test stopped
            done = w.complete and (w.state or {}).get("summary_result") is not None
            self.state.wz_step = "result" if done else "positions"
        watch = getattr(session, "watch_items", None)
        if callable(watch):  # the project's changes from another tab or the CLI, as the item list follows them
            watch(self.follow_project)

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
        s.wz_test_name = ""
        s.wz_supersede = None
        s.wz_earlier = []
        s.wz_option_fields = []
        s.wz_options_yaml = ""
        s.wz_options_error = ""
        s.wz_options_note = ""
        s.wz_options_import = ""
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
        s.wz_sources = self.wizard.acquisition_sources()
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
                # named in words; the plugin id stays the value (issue 30)
                {"title": x["name"], "value": x["id"], "summary": x["summary"]}
                for x in w.standards()
            ]
        except Exception as exc:  # discovery problems are shown, the page stays
            s.wz_standards = []
            s.wz_error = one_line(exc)
        s.wz_active = w.active
        if setup_form:
            self.form.fill()
        s.wz_earlier = self._earlier()
        s.wz_test_name = w.name() if w.active else ""
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
        """Where the current test stands, in words (:func:`status_text`): finished with its
        verdicts, every position measured but no report yet, or running."""
        return status_text(self.wizard.state, bool(self.state.wz_complete))

    def _earlier(self) -> list[dict[str, Any]]:
        """The tests set up before the current one, each with links to its report."""
        rows = []
        for row in self.wizard.earlier_tests():
            links = (
                self.offered.offer(
                    f"acceptance-test-{row['result']}.{kind}", path, kind=kind, title=REPORT_TITLES.get(kind, kind)
                )
                for kind, path in self.wizard.report_paths(row["report"]).items()
            )
            rows.append(
                {k: row[k] for k in ("key", "name", "status", "result")} | {"links": sort_links(l for l in links if l)}
            )
        return rows

    # -- which test is current ----------------------------------------------------------------
    def follow_project(self) -> bool:
        """Show the acceptance test the project holds now when another session (a second
        tab, the CLI) changed it: set up a new test, measured a position, wrote the report.
        Called each time the item list is refreshed (:meth:`Session.watch_items`: after
        another session's commit, too); one state read when nothing changed. While this
        page evaluates, it waits for the evaluation to end. True when the page changed."""
        if self.busy:
            self._follow_later = True
            return False
        try:
            stored = self.session.project.get_state(STATE_KEY)
        except Exception:  # a busy store: the next change looks again
            return False
        theirs = stored if isinstance(stored, dict) else {}
        mine = self.wizard.state or {}
        if (theirs.get("created"), theirs.get("updated")) == (mine.get("created"), mine.get("updated")):
            return False
        s = self.state
        new_test = theirs.get("created") != mine.get("created")
        unlocked = bool(mine) and not s.wz_locked
        with self.wizard.saved.lock:
            self.wizard.resume()
        if new_test:
            s.wz_svgs = {}
            s.wz_detail, s.wz_redo, self.last_card = None, None, None
            shared = getattr(self.session, "shared", None)
            if shared is not None:  # the replaced test's colour map is not this test's
                shared.clear("acceptance")
            # a form the operator is filling in for a new test stays as typed (its Start asks
            # again, naming the test that is current now)
            self.refresh(setup_form=not unlocked)
            if unlocked and self.wizard.active:
                s.wz_locked = False
            if not self.wizard.active:
                s.wz_step = "setup"
            elif s.wz_step != "setup":
                done = (self.wizard.state or {}).get("summary_result") is not None
                s.wz_step = "result" if done else "positions"
            if s.wz_supersede:  # the question named the test that was replaced meanwhile
                asked = {**self.wizard.supersede_question(), "action": s.wz_supersede.get("action", "unlock")}
                s.wz_supersede = asked if self.wizard.worth_keeping() else None
            if self.wizard.active:
                self.session.info(
                    f"another window set up a new acceptance test: {self.wizard.name()}", page="acceptance"
                )
        else:
            self.refresh(setup_form=not unlocked)
            if unlocked:
                s.wz_locked = False
        return True

    def ask_new_test(self) -> None:
        """The button "Set up a new test": over a test with work in it, ask first (``wz_supersede``,
        the dialog naming the test, its verdict and where it stays); else open the form."""
        w = self.wizard
        if w.worth_keeping() and self.confirmed != w.identity:
            self.state.wz_supersede = {**w.supersede_question(), "action": "unlock"}
            return
        self.unlock()

    def confirm_supersede(self, test_id: str, form: dict[str, Any] | None = None) -> bool:
        """The operator agreed to replace test ``test_id``: open the form ("unlock") or
        start the new test ("start"). A test replaced meanwhile (another tab) is asked about again."""
        s = self.state
        action = (s.wz_supersede or {}).get("action", "unlock")
        s.wz_supersede = None
        self.confirmed = str(test_id or "")
        if action == "start":
            return self.start(form)
        self.unlock()
        return True

    def cancel_supersede(self) -> None:
        """Keep the current test: the form stays locked to it."""
        self.state.wz_supersede = None
        self.confirmed = ""
        self.refresh(setup_form=True)

    def _publish_positions(self) -> None:
        s = self.state
        w = self.wizard
        blocks = w.cards()
        busy = set(self.busy)
        for b in blocks:
            for c in b["cards"]:
                c["busy"] = c["key"] in busy
        s.wz_blocks = blocks
        prog = w.progress()
        s.wz_progress = prog
        s.wz_progress_text = " · ".join(p["text"] for p in prog)
        s.wz_complete = all(p["complete"] for p in prog)
        if not s.wz_svgs or set(s.wz_svgs) != {c["key"] for b in blocks for c in b["cards"]}:
            s.wz_svgs = w.pictograms()
        plan = w.plan or {}
        s.wz_title = (
            f"{w.title()} — {plan['system'].get('name', '')}, measuring volume "
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
                    "verdict_text": verdict_text(p.get("verdict")),
                    "guarded_text": verdict_text(p.get("verdict_guarded")),
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

    # -- busy cards ------------------------------------------------------------------------
    def set_busy(self, key: str, on: bool) -> None:
        (self.busy.add if on else self.busy.discard)(key)
        self.state.wz_busy = {k: True for k in self.busy}
        if not self.busy and self._follow_later:
            self._follow_later = False
            self.follow_project()

    def refresh_cards(self) -> None:
        blocks = copy.deepcopy(self.state.wz_blocks or [])
        for b in blocks:
            for c in b["cards"]:
                c["busy"] = c["key"] in self.busy
        self.state.wz_blocks = blocks

    # -- handlers (bound by the layout, called by tests) -------------------------------------
    def check_artefacts(self, form: dict[str, Any] | None = None) -> list[str]:
        return self.form.check_artefacts(form)

    def choose_standard(self, standard: str, form: dict[str, Any] | None = None) -> None:
        self.form.choose_standard(standard, form)

    def pick_artefact(self, test: str, choice: str, form: dict[str, Any] | None = None) -> None:
        self.form.pick_artefact(test, choice, form)

    def import_options(self, text: str, form: dict[str, Any] | None = None) -> bool:
        return self.form.import_options(text, form)

    def start(self, form: dict[str, Any] | None = None) -> bool:
        return self.form.start(form)

    def unlock(self) -> None:
        self.form.unlock()

    async def upload_async(self, test: str, position: str, upload: Any, repeat: int | None = None) -> None:
        await self.actions.upload_async(test, position, upload, repeat)

    async def import_async(
        self, test: str, position: str, source: str | Path | bytes, name: str | None = None, repeat: int | None = None
    ) -> dict[str, Any] | None:
        return await self.actions.import_async(test, position, source, name, repeat)

    def show(self, test: str, position: str, repeat: int | None = None) -> None:
        self.actions.show(test, position, repeat)

    def redo(self, test: str, position: str) -> None:
        self.actions.redo(test, position)

    async def report_async(self) -> dict[str, Any] | None:
        return await self.actions.report_async()

    def set_source(self, plugin_id: str | None, params: dict[str, Any] | None = None) -> None:
        self.acquisition.set_source(plugin_id, params)

    async def acquire_async(self, test: str, position: str, repeat: int | None = None) -> dict[str, Any] | None:
        return await self.acquisition.acquire_async(test, position, repeat)

    async def acquire_all_async(self) -> int:
        return await self.acquisition.acquire_all_async()

    def close(self) -> None:
        self.job.close()
        self.offered.close()


def mount(server: Any, session: Any) -> WizardPage:
    """Create the page for a session and serve its downloads folder (call before the
    server starts)."""
    page = WizardPage(session)
    page.offered.mount(server)
    session.shared.share("acceptance", VIEW_HINT)  # the 3D view beside it shows this page's scene only
    return page
