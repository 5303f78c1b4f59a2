"""The "Series" page's state and handlers (``se_*`` keys): a plan and several parts in,
the parts × characteristics table, one part's labels and one characteristic's run chart
with its capability out.

The series is the headless task :mod:`camcmm.tasks.series` (the plan and clouds checked,
the plugin providing ``gdt-series`` run in a worker process, the result stored in the
project); the page runs it in a :class:`~camcmm.gui.jobs.Job` with progress and cancel and
shows the last series again when the project reopens. Tests call
``asyncio.run(page.run_async(...))`` and ``page.open_cell(part, id)``.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from .... import numbers as num
from ....errors import one_line
from ....tasks import gdt, series
from ....tasks.gdt import SIZES
from ....tasks.series import SeriesRequest, SeriesTask
from ...jobs import Job
from . import figures

log = logging.getLogger("camcmm.gui.series")
KEY = "series"
#: Most points of a part drawn under its labels.
MAX_DRAWN = 4000
EMPTY_HINT = (
    "Choose the plan (empty: the project's plan, made on the Compare page; or a YAML file on the server) and the "
    "parts — project clouds and/or files on the server, one a line, in production order — then Run. Each part is "
    "aligned and evaluated; the table shows every characteristic of every part coloured by its ISO 14253-1 "
    "verdict. Click a cell: the part's labels and the characteristic's run chart with Cp/Cpk."
)


def _mm(x: Any, digits: int = 4) -> str:
    """A plain number (Cp, Cpk) with ``digits`` decimals, a real minus; "—" when missing."""
    return "—" if not num.finite(x) else f"{float(x):.{digits}f}".replace("-", num.MINUS)


def _value(x: Any, kind: Any, u: Any = None) -> str:
    """A characteristic's value as the Compare page writes it (:func:`camcmm.numbers.characteristic`):
    a size in mm, a zone (form, orientation, location) in µm."""
    return "—" if not num.finite(x) else num.characteristic(x, kind in SIZES, u)


def _ci(ci: Any) -> str:
    return "" if not ci else f" [{_mm(ci[0], 2)}, {_mm(ci[1], 2)}]"


def capability_rows(c: dict[str, Any] | None) -> list[dict[str, str]]:
    """The numbers beside the run chart: n, mean, s, Cp and Cpk with their intervals,
    the control limits, the parts out of tolerance and undecided, and why a figure is missing."""
    if not c:
        return []
    conf = num.percentile(100 * float(c.get("confidence") or 0.95))
    kind = c.get("type")
    rows = [
        ("n", "parts evaluated", str(c.get("n"))),
        ("mean", "mean", _value(c.get("mean"), kind)),
        ("s", "s (standard deviation)", num.uncertainty(c.get("s")) if num.finite(c.get("s")) else "—"),
        ("cp", f"Cp [{conf} interval]", _mm(c.get("cp"), 2) + _ci(c.get("cp_ci"))),
        ("cpk", f"Cpk [{conf} interval]", _mm(c.get("cpk"), 2) + _ci(c.get("cpk_ci"))),
        (
            "control",
            f"control limits ({c.get('control') or 'none'})",
            f"{_value(c.get('lcl'), kind)} … {_value(c.get('ucl'), kind)}",
        ),
        ("limits", "tolerance limits", f"{_value(c.get('lsl'), kind)} … {_value(c.get('usl'), kind)}"),
        ("out", "out of tolerance", ", ".join(c.get("out") or []) or "none"),
        ("undecided", "undecided (ISO 14253-1)", ", ".join(c.get("undecided") or []) or "none"),
    ]
    rows += [("note", "note", str(n)) for n in c.get("notes") or []]
    return [{"name": k, "label": label, "value": v} for k, label, v in rows]


class SeriesPage:
    KEY = KEY

    def __init__(self, server: Any, session: Any):
        self.server, self.session, self.state, self.host = server, session, session.state, session.host
        self.job = Job("the series", state=self.state, on_progress=self._show_progress, interval=0.2)
        self.batch: dict[str, Any] | None = None
        self._points: dict[str, Any] = {}
        self._init_state()
        self.restore()

    @property
    def project(self) -> Any:
        return self.session.project

    def task(self) -> SeriesTask:
        return SeriesTask(self.host, self.session, self.project, getattr(self.session, "roots", None))

    def _init_state(self) -> None:
        s = self.state
        s.se_plan, s.se_clouds, s.se_files, s.se_align, s.se_nominal = "", [], "", "best-fit", None
        s.se_aligns = [{"title": gdt.ALIGN_TITLES[a], "value": a} for a in gdt.ALIGNMENTS]
        s.se_running, s.se_progress, s.se_message, s.se_error = False, 0.0, "", ""
        s.se_warnings, s.se_title, s.se_ids, s.se_rows = [], "", [], []
        s.se_cell, s.se_part_title, s.se_part_rows, s.se_capability = None, "", [], []
        s.se_fig_chart = figures.run_chart(None)
        s.se_fig_labels = figures.empty("click a cell: the part's labels appear here")
        s.se_colours = dict(series.VERDICT_COLOURS)
        s.se_empty_hint = EMPTY_HINT

    def error(self, msg: Any) -> None:
        line = one_line(msg)
        self.state.se_error = line
        self.session.error(line, page=KEY)

    def restore(self) -> None:
        """The last series, as the project keeps it (a damaged record is a message)."""
        try:
            got = self.task().restore()
        except Exception as exc:
            log.warning("cannot restore the series: %s", exc)
            self.state.se_message = f"the stored series could not be read: {one_line(exc)}"
            return
        if got is None:
            return
        req, rec = got
        s = self.state
        s.se_align, s.se_nominal = req.align, req.nominal
        s.se_clouds = [c for c in req.clouds if str(c).isdigit()]
        s.se_files = "\n".join(c for c in req.clouds if not str(c).isdigit())
        self.show(rec["batch"], rec)
        s.se_message = f"result #{rec['result']} from the project"

    # -- the run ----------------------------------------------------------------------------
    def _show_progress(self, fraction: float, message: str) -> None:
        self.state.se_progress = round(100.0 * float(fraction), 1)
        self.state.se_message = message or self.state.se_message

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.se_message = "cancelling …"

    def request(
        self, plan: Any = None, clouds: Any = None, files: Any = None, align: Any = None, nominal: Any = None
    ) -> SeriesRequest:
        """The request from the page's fields (or the values given: the browser's, a test's)."""
        s = self.state
        plan = s.se_plan if plan is None else plan
        chosen = [str(c) for c in (s.se_clouds if clouds is None else clouds) or []]
        text = s.se_files if files is None else files
        lines = [ln.strip() for ln in str(text or "").splitlines() if ln.strip()]
        return SeriesRequest(
            plan=str(plan).strip() or "project",
            clouds=chosen + lines,
            nominal=(s.se_nominal if nominal is None else nominal) or None,
            align=str(align or s.se_align or "best-fit"),
        )

    async def run_async(
        self, plan: Any = None, clouds: Any = None, files: Any = None, align: Any = None, nominal: Any = None
    ) -> dict[str, Any] | None:
        """Run the series and store it; the record, or None with the reason on the page."""
        s = self.state
        if self.job.running:
            self.error("a series is running; wait for it or cancel it")
            return None
        req = self.request(plan, clouds, files, align, nominal)
        s.se_error, s.se_running, s.se_progress, s.se_message = "", True, 0.0, "starting …"
        self.session.clear_error(page=KEY)
        self.session.flush()
        task = self.task()
        cancel = self.job.begin()
        try:
            run = await self.job.call(task.run, req, self.job.progress, cancel)
            rec = task.store(run)
        except Exception as exc:
            status, line = Job.outcome(exc)
            s.se_running, s.se_progress, s.se_message = False, 0.0, status
            self.error(line)
            self.session.flush()
            return None
        finally:
            self.job.end()
        s.se_running, s.se_progress = False, 100.0
        self.show(run.batch, rec)
        c = run.batch.get("counts") or {}
        s.se_message = f"done: {c.get('evaluated', 0)} of {c.get('parts', 0)} parts evaluated, result #{rec['result']}"
        self.session.refresh_results()
        self.session.info(f"series stored as result #{rec['result']}", page=KEY)
        self.session.flush()
        return rec

    # -- what is shown ----------------------------------------------------------------------
    def show(self, batch: dict[str, Any], rec: dict[str, Any]) -> None:
        """The table of a series; the first characteristic's chart and the first part's labels."""
        s = self.state
        self.batch = batch
        ids, rows = series.table(batch)
        kinds = {  # each characteristic's GD&T type: a size reads in mm, a zone in µm
            c["id"]: c.get("type")
            for p in batch.get("parts") or []
            for c in (p.get("evaluation") or {}).get("characteristics") or []
        }
        s.se_ids = ids
        s.se_rows = [
            {
                "part": r["part"],
                "status": r["status"],
                "reason": r["reason"],
                "cells": [
                    {
                        "id": cid,
                        "text": _value(r["cells"][cid]["value"], kinds.get(cid)),
                        "verdict": r["cells"][cid]["verdict"],
                        "colour": r["cells"][cid]["colour"],
                    }
                    for cid in ids
                ],
            }
            for r in rows
        ]
        s.se_warnings = list(dict.fromkeys(str(w) for w in rec.get("warnings") or []))[:6]
        c = batch.get("counts") or {}
        s.se_title = f"{c.get('parts', len(rows))} parts, {len(ids)} characteristics — result #{rec.get('result')}"
        if rows and ids:
            self.open_cell(rows[0]["part"], ids[0])

    def open_cell(self, part: Any, cid: Any) -> None:
        """A click on a table cell: that part's labels and that characteristic's chart."""
        batch = self.batch or {}
        p = next((q for q in batch.get("parts") or [] if str(q.get("part")) == str(part)), None)
        if p is None:
            return
        s = self.state
        s.se_cell = {"part": str(part), "id": str(cid)}
        ev = p.get("evaluation") or {}
        s.se_part_title = f"{part}: {p.get('status')}" + (f" — {p['reason']}" if p.get("reason") else "")
        s.se_part_rows = [
            {
                "id": c["id"],
                "title": gdt.char_title(c.get("type")),
                "value": _value(c.get("value"), c.get("type"), c.get("u")),
                "U": num.uncertainty(c.get("U"), c.get("k") or 2) if num.finite(c.get("U")) else "—",
                "verdict": gdt.verdict_of(c),
                "colour": series.VERDICT_COLOURS.get(gdt.verdict_of(c), "#9e9e9e"),
            }
            for c in ev.get("characteristics") or []
        ]
        s.se_fig_labels = figures.labels_figure(str(part), ev, self.aligned_points(p))
        chart = series.chart(batch, str(cid))
        s.se_fig_chart = figures.run_chart(chart)
        s.se_capability = capability_rows(chart)

    def aligned_points(self, part: dict[str, Any]) -> Any:
        """The part's cloud in plan coordinates (its file read again, moved by the transform
        its evaluation found), at most :data:`MAX_DRAWN` points; None when it cannot be had
        (not evaluated, the file gone: the labels are drawn alone)."""
        key = str(part.get("file") or "")
        if key in self._points:
            return self._points[key]
        pts = None
        try:
            T = np.asarray(((part.get("evaluation") or {}).get("alignment") or {})["transform"], float)
            from ....io import read

            roots = getattr(self.session, "roots", None)
            path = roots.check(key, "cloud") if roots is not None else key  # a stored path: held to the roots
            cloud: Any = read(path)  # a part is a cloud (the run read it as one)
            P = np.asarray(cloud.points, float)
            if len(P) > MAX_DRAWN:  # a seeded sample: the same picture each time
                P = P[np.random.default_rng(0).choice(len(P), MAX_DRAWN, replace=False)]
            pts = P @ T[:3, :3].T + T[:3, 3]
        except Exception as exc:
            log.info("no aligned cloud for %s: %s", part.get("part"), one_line(exc))
        self._points = {key: pts}  # one part kept: a click on another row reads its file
        return pts

    def close(self) -> None:
        self.job.close()


def mount(server: Any, session: Any) -> SeriesPage:
    """Create the page for a session (before the server starts); it has no 3-D view."""
    return SeriesPage(server, session)
