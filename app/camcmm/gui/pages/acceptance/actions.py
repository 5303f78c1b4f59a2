"""The page's slow steps and the 3D view: imports evaluated in the worker thread and
recorded on the loop, busy cards, a position's colour map shown from the side the
standard suggests (an evaluation's ``view``), and the report written in the worker.
What is evaluated, stored and reported is the task's
(:class:`camcmm.tasks.acceptance.Wizard`); here it is only run and shown."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

from camcmm.errors import CamcmmError, one_line
from camcmm.project.store import utcnow
from camcmm.tasks.acceptance import PendingEvaluation, fit_rows

#: What the page's 3D view says before a position's deviations are shown.
VIEW_HINT = "No deviations shown yet: Show on a measured position's card (2 · Positions) draws its colour map here."


def view_direction(ev: dict[str, Any]) -> tuple[list[float], list[float]] | None:
    """(direction from the object to the camera, view-up) the standard suggests for an
    evaluation's colour map (its ``view``); None when it suggests none."""
    view = ev.get("view")
    if not isinstance(view, dict) or not view.get("direction"):
        return None
    return [float(x) for x in view["direction"]], [float(x) for x in view.get("up") or (0.0, 0.0, 1.0)]


class PositionActions:
    """The position and report handlers of a :class:`~camcmm.gui.pages.acceptance.WizardPage`:
    each runs the slow part of the page's wizard in the page's job and publishes the outcome."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.session = page.session

    @property
    def wizard(self) -> Any:
        return self.page.wizard

    # -- handlers: positions -----------------------------------------------------------------
    async def upload_async(self, test: str, position: str, upload: Any, repeat: int | None = None) -> None:
        """A file chosen in a card's file input: evaluate in the worker, record on the loop."""
        files = self.session.import_upload(upload) if upload else []
        if not files:
            return
        f = files[0]
        await self.import_async(test, position, f["content"], f["name"], repeat)

    async def import_async(
        self, test: str, position: str, source: str | Path | bytes, name: str | None = None, repeat: int | None = None
    ) -> dict[str, Any] | None:
        key = f"{test}/{position}"
        page = self.page
        if key in page.busy:
            self.session.error(f"{position}: a measurement is being evaluated; wait for it")
            return None
        self.session.bind_loop()
        try:
            job = self.wizard.prepare(test, position, repeat)
        except Exception as exc:
            self.session.error(one_line(exc))
            return None
        page.set_busy(key, True)
        page.refresh_cards()
        page.flush()
        try:
            await page.job.call(self.wizard.evaluate, job, source, name)
        except Exception as exc:
            msg = self.wizard.fail(job, exc)
            page.set_busy(key, False)
            self.state.wz_redo = None
            page.refresh()
            self.session.error(msg)
            page.flush()
            return None
        try:
            card = self.wizard.record(job)
        except Exception as exc:
            msg = self.wizard.fail(job, exc)
            page.set_busy(key, False)
            page.refresh()
            self.session.error(f"{position}: could not be saved in the project: {msg}")
            page.flush()
            return None
        page.set_busy(key, False)
        self.state.wz_redo = None
        page.refresh()
        self._after_record(job, card)
        page.flush()
        return card

    def _after_record(self, job: PendingEvaluation, card: dict[str, Any]) -> None:
        self.page.last_card = card
        self.session.refresh_items()
        rep = next((r for r in card["repeats"] if r["repeat"] == job.repeat), None)
        self._detail(job.test, job.position, job.repeat, job.evaluation or {})
        dev = job.extra.get("deviations")
        if dev is not None:
            self.show_cloud(f"wizard:{job.extra.get('result')}", dev, job.evaluation)
        verdict = (rep or {}).get("verdict") or ""
        values = ", ".join(f"{v['symbol']} {v['text']}" for v in (rep or {}).get("values", []))
        prog = next((p["text"] for p in self.state.wz_progress if p["test"] == job.test), "")
        self.session.info(f"{job.position}: {values} — {verdict}; {prog}")

    def _detail(self, test: str, position: str, repeat: int, ev: dict[str, Any]) -> None:
        self.state.wz_detail = {
            "title": f"{position} (repeat {repeat})" if self._repeats(test) > 1 else position,
            "file": ev.get("file") or "",
            "rows": fit_rows(ev, self.wizard.declaration()),
            "warnings": [str(x) for x in ev.get("warnings") or []],
        }

    def _repeats(self, test: str) -> int:
        try:
            return self.wizard.requirement(test)["repeats"]
        except CamcmmError:
            return 1

    def show(self, test: str, position: str, repeat: int | None = None) -> None:
        """Show a done position's deviation colour map in the 3D view and its fit."""
        try:
            cloud = self.wizard.deviations(test, position, repeat)
        except Exception as exc:
            self.session.error(one_line(exc))
            return
        filled = self.wizard.filled(test, position)
        rep, mid = (repeat, dict(filled).get(repeat)) if repeat else filled[-1]
        self._detail(test, position, rep, self.wizard.evaluation(mid) or {})
        self.show_cloud(f"wizard:{self.wizard.state['evaluations'].get(str(mid))}", cloud, self.wizard.evaluation(mid))

    def show_cloud(self, key: str, cloud: Any, evaluation: dict[str, Any] | None = None) -> None:
        """Show a deviations cloud coloured by ``deviation`` as this page's scene in the
        session's 3D view (:mod:`camcmm.gui.scenes`: never left on another page's view),
        looking at it as :func:`view_direction` suggests."""
        field_name = "deviation" if "deviation" in (getattr(cloud, "fields", {}) or {}) else None
        name = str(getattr(cloud, "name", "") or key)
        self.session.shared.show_object(
            "acceptance", key, cloud, field_name, view_direction(evaluation or {}), label=name
        )

    def redo(self, test: str, position: str) -> None:
        """Offer the file input again on a done card (the import then replaces it)."""
        self.state.wz_redo = f"{test}/{position}"

    # -- handlers: report ------------------------------------------------------------------
    async def report_async(self) -> dict[str, Any] | None:
        if self.state.wz_reporting:
            return None
        page = self.page
        self.session.bind_loop()
        s = self.state
        s.wz_reporting = True
        page.flush()
        started = utcnow()
        folder = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
        try:
            per = self.wizard.per_measurement(with_deviations=True)
            summary, paths = await page.job.call(self.wizard.make_report, folder, per)
            out = self.wizard.record_report(summary, paths, started)
        except Exception as exc:
            self.session.error(f"report: {one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
            s.wz_reporting = False
        page.refresh()
        self.session.refresh_results()
        self.session.info(f"report written (result #{out['summary_result']}): verdict {s.wz_verdict}")
        page.flush()
        return out
