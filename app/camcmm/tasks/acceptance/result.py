"""The end of a test: the standard's summary from the stored evaluations, the report
files written in a worker and stored as a result, and the deviation maps they draw on."""

from __future__ import annotations

import copy
import shutil
import tempfile
from pathlib import Path
from typing import Any

from camcmm import io as cio
from camcmm.errors import CamcmmError, InputError
from camcmm.host import RunContext, RunResult
from camcmm.project.store import utcnow
from camcmm.standard import as_dict

from .standards import Standards
from .state import TestState
from .values import log

#: Points of a deviations cloud handed to the report's colour maps.
REPORT_POINTS = 30_000


class Result:
    """The end of the running test (:class:`TestState`): summary, report, deviation maps.

    The report is written by the standard plugin itself (``write_report`` of the object
    the host loads), never by importing a writer here."""

    def __init__(self, saved: TestState, standards: Standards):
        self.saved = saved
        self.standards = standards
        self.host = standards.host
        self.project = saved.project

    def per_measurement(self, with_deviations: bool = False) -> dict[str, list[dict[str, Any]]]:
        """The stored evaluations per test, in position order (the summary's input)."""
        per: dict[str, list[dict[str, Any]]] = {}
        for r in self.saved.requirements():
            slots = self.saved.slots(r["test"])
            evs = per.setdefault(r["test"], [])
            for p in r["positions"]:
                for mid in slots[p["id"]]:
                    ev = self.saved.evaluation(mid)
                    if ev is None:
                        continue
                    ev = copy.deepcopy(ev)
                    if with_deviations:
                        ev["_deviations_path"] = self.deviations_path(mid)
                    evs.append(ev)
        return per

    def deviations_path(self, mid: Any) -> str | None:
        rid = (self.saved.state or {}).get("evaluations", {}).get(str(mid))
        if rid is None:
            return None
        try:
            h = (self.project.result(int(rid)).get("files") or {}).get("deviations")
            return str(self.project.file_path(h)) if h else None
        except CamcmmError:
            return None

    def summarize(self, per: dict[str, list[dict[str, Any]]] | None = None) -> dict[str, Any]:
        """The standard's full result from the stored evaluations (any time: an
        unfinished test is ``incomplete``)."""
        with self.saved.lock:
            plan = copy.deepcopy(self.saved.plan)
            sid = self.saved.standard_id
        ctx = RunContext(self.host, sid)
        return as_dict(
            self.standards.load(sid).summarize(ctx, plan, per if per is not None else self.per_measurement())
        )

    def make_report(
        self, directory: str | Path, per: dict[str, list[dict[str, Any]]] | None = None
    ) -> tuple[dict[str, Any], dict[str, str]]:
        """Summarise and write the report files into ``directory`` (any thread; give
        ``per`` from :meth:`per_measurement` taken on the loop). Returns (summary, paths)."""
        per = copy.deepcopy(per) if per is not None else self.per_measurement(with_deviations=True)
        for evs in per.values():
            for ev in evs:
                path = ev.pop("_deviations_path", None)
                if path:
                    try:
                        dev: Any = cio.read(path)  # a deviations cloud (field ``deviation``)
                        if dev.n_points > REPORT_POINTS:
                            dev = dev.subset(slice(None, None, -(-dev.n_points // REPORT_POINTS)))
                        ev["deviations"] = dev
                    except CamcmmError as exc:
                        log.warning("no colour map for %s: %s", ev.get("file"), exc)
        summary = self.summarize(per)
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        with self.saved.lock:
            plan = copy.deepcopy(self.saved.plan)
        paths = self.saved.standard().write_report(summary, directory, plan)
        return summary, {k: str(v) for k, v in paths.items()}

    def record_report(self, summary: dict[str, Any], paths: dict[str, str], started: str = "") -> dict[str, Any]:
        """Store the summary as a result with the report files; the state names it."""
        saved = self.saved
        with saved.lock:
            state = saved.state
            assert state is not None
            saved.check_current()
            std_id = state["standard"]
            files = {f"report_{k}": self.project.add_file(p) for k, p in paths.items()}
            mids = [m for ms in state["measurements"].values() for m in ms]
            hashes = {}
            for evs in (summary.get("measurements") or {}).values():
                for e in evs:
                    if e.get("file") and e.get("sha256"):
                        hashes[str(e["file"])] = e["sha256"]
            run = RunResult(
                std_id,
                self.standards.version(std_id),
                {},
                hashes,
                dict(summary),
                started or utcnow(),
                utcnow(),
                [str(w) for w in summary.get("warnings") or []],
            )
            rid = self.project.add_result(
                run.to_json(),
                mids,
                files,
                label=f"{std_id} acceptance test",
            )
            state.update(
                {
                    "summary_result": rid,
                    "report": files,
                    "verdict": summary.get("verdict"),
                    "verdict_guarded": summary.get("verdict_guarded"),
                }
            )
            saved.save()
        return {"summary_result": rid, "files": files}

    def report(self, directory: str | Path | None = None) -> dict[str, Any]:
        """Summary + report in the calling thread; returns ``{"summary_result", "files"
        ({"report_html": hash, ...}), "paths" (the files in the project)}``."""
        started = utcnow()
        tmp = None
        if directory is None:
            tmp = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
            directory = tmp
        try:
            summary, paths = self.make_report(directory)
            out = self.record_report(summary, paths, started)
        finally:
            if tmp is not None:
                shutil.rmtree(tmp, ignore_errors=True)
        out["paths"] = self.report_paths()
        out["summary"] = summary
        return out

    def report_paths(self, report: dict[str, str] | None = None) -> dict[str, Path]:
        """The current report's files in the project (``{"html": path, ...}``); of
        ``report`` (``{"report_html": hash, ...}``, an earlier test's) when given."""
        out = {}
        files = report if report is not None else (self.saved.state or {}).get("report")
        for name, h in (files or {}).items():
            try:
                out[name.removeprefix("report_")] = self.project.file_path(h)
            except CamcmmError as exc:
                log.warning("report file %s: %s", name, exc)
        return out

    def deviations(self, test: str, position: str, repeat: int | None = None) -> Any:
        """The deviations cloud (field ``deviation``, mm) of a done position, from the project."""
        filled = self.saved.filled(test, position)
        if not filled:
            raise InputError(f"{position}: nothing measured yet")
        mid = dict(filled).get(repeat) if repeat else filled[-1][1]
        path = self.deviations_path(mid)
        if not path:
            raise InputError(f"{position}: its evaluation has no deviation map")
        cloud = cio.read(path)
        cloud.name = f"{position} deviations"
        return cloud
