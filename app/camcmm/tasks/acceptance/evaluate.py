"""Importing one measurement: ``prepare`` on the server loop picks the slot,
``evaluate`` in any thread reads the file and runs the standard without touching the
store, ``record`` on the loop stores everything, so the GUI can run the slow middle in a
worker."""

from __future__ import annotations

import copy
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from camcmm import io as cio
from camcmm import numbers
from camcmm.errors import CamcmmError, InputError, one_line
from camcmm.host import RunContext, RunResult, to_jsonable
from camcmm.project.store import utcnow
from camcmm.standard import as_dict
from camcmm.tasks.items import safe_name

from .naming import evaluation_label
from .standards import Standards
from .state import TestState
from .values import log


@dataclass
class PendingEvaluation:
    """One import for one position: what ``prepare`` decided, ``evaluate`` computed."""

    test: str
    position: str
    repeat: int
    name: str = ""
    path: Path | None = None
    temp: Path | None = None  # a temp folder to remove after recording
    cloud: Any = None
    evaluation: dict[str, Any] | None = None
    started: str = ""
    error: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def key(self) -> str:
        return f"{self.test}/{self.position}"


class Evaluator:
    """Imports measurements into the running test (:class:`TestState`): prepare (loop)
    -> evaluate (any thread) -> record (loop), or :meth:`fail`."""

    def __init__(self, saved: TestState, standards: Standards):
        self.saved = saved
        self.standards = standards
        self.host = standards.host
        self.project = saved.project

    def prepare(self, test: str, position: str, repeat: int | None = None) -> PendingEvaluation:
        """Check the position and pick its repeat slot: ``repeat`` (a redo) or the first
        empty one; a position whose slots are all filled is redone at its last repeat."""
        if not self.saved.active:
            raise InputError(self.saved.load_error or "set up the acceptance test first")
        r = self.saved.requirement(test)
        ids = [p["id"] for p in r["positions"]]
        if position not in ids:
            raise InputError(f"{test.replace('_', ' ')} has no position {position!r}; its positions: {', '.join(ids)}")
        slots = self.saved.slots(test)[position]
        if repeat is None:
            repeat = next((i + 1 for i, mid in enumerate(slots) if mid is None), len(slots))
        if not 1 <= int(repeat) <= len(slots):
            raise InputError(f"{position}: repeat {repeat} is outside 1..{len(slots)}")
        return PendingEvaluation(test, position, int(repeat), started=utcnow())

    def evaluate(
        self, job: PendingEvaluation, source: str | Path | bytes, name: str | None = None
    ) -> PendingEvaluation:
        """Read the file and evaluate it with the standard. Thread-safe: touches neither
        the store nor the wizard's state. Raises a one-line CamcmmError naming the file."""
        if isinstance(source, (bytes, bytearray, memoryview)):
            job.name = safe_name(name or "upload")
            job.temp = Path(tempfile.mkdtemp(prefix="camcmm-wizard-"))
            job.path = job.temp / job.name
            job.path.write_bytes(bytes(source))
        else:
            job.path = Path(source)
            job.name = name or job.path.name
            if not job.path.is_file():
                raise InputError(f"{job.name}: no such file" if not job.path.exists() else f"{job.name}: is not a file")
        try:
            cloud = cio.read(job.path, unit=(self.saved.state or {}).get("plan", {}).get("unit"))
        except Exception as exc:
            raise InputError(one_line(exc, job.name, job.path)) from exc
        if not hasattr(cloud, "n_points"):
            raise InputError(f"{job.name}: holds a {type(cloud).__name__.lower()}, not a point cloud")
        if cloud.n_points == 0:
            raise InputError(f"{job.name}: the file holds no points")
        with self.saved.lock:  # the loop may be recording another position meanwhile
            plan = copy.deepcopy(self.saved.plan)
            sid = self.saved.standard_id
        std = self.standards.load(sid)
        ctx = RunContext(self.host, sid)
        try:
            ev = std.evaluate_measurement(
                ctx, job.test, cloud, plan, file=job.name, position=job.position, repeat=job.repeat
            )
        except CamcmmError as exc:
            raise type(exc)(one_line(exc, job.name)) from exc
        except Exception as exc:  # a plugin bug: one line naming the file and the standard
            raise InputError(f"{job.name}: {sid} failed: {one_line(exc)}") from exc
        ev = as_dict(ev)
        if not isinstance(ev, dict):
            raise InputError(f"{job.name}: {sid} returned {type(ev).__name__}, not a dict")
        ev = dict(ev)
        ev.setdefault("test", job.test)
        ev["file"], ev["position"], ev["repeat"] = job.name, job.position, job.repeat
        for w in ctx.warnings:
            ev.setdefault("warnings", [])
            if w not in ev["warnings"]:
                ev["warnings"].append(w)
        job.cloud, job.evaluation = cloud, ev
        return job

    def record(self, job: PendingEvaluation) -> int:
        """Store an evaluated job: its file, measurement, deviations and result; the
        replaced measurement (a redo) is soft-deleted; the state is saved. Returns the
        result id."""
        assert job.evaluation is not None and job.path is not None
        saved = self.saved
        with saved.lock:
            state = saved.state
            assert state is not None
            saved.check_current()
            std_id = state["standard"]
            ev = dict(job.evaluation)
            deviations = ev.pop("deviations", None)
            h = self.project.add_file(job.path)
            ev["sha256"] = h
            meta = {
                "standard": std_id,
                "test": job.test,
                "position": job.position,
                "repeat": job.repeat,
                "file": job.name,
                "summary": f"{numbers.count(getattr(job.cloud, 'n_points', 0))} points",
                # the unit it was read in (the plan's, the file's, else mm), so that it loads the same
                "unit": str(getattr(job.cloud, "source_unit", "") or "mm"),
            }
            mid = self.project.add_measurement(
                f"{job.position} ({job.name})",
                h,
                kind="pointcloud",
                system_id=state.get("system_id"),
                artefact_id=(state.get("artefact_ids") or {}).get(job.test),
                meta=meta,
            )
            files = {}
            if deviations is not None and hasattr(deviations, "n_points"):
                files["deviations"] = self.project.add_object(deviations, f"{job.position} deviations")
            params = {"test": job.test, "position": job.position, "repeat": job.repeat}
            run = RunResult(
                std_id,
                self.standards.version(std_id),
                params,
                {"cloud": h},
                ev,
                job.started,
                utcnow(),
                [str(w) for w in ev.get("warnings") or []],
            )
            rid = self.project.add_result(
                run.to_json(),
                [mid],
                files,
                label=evaluation_label(
                    std_id, job.position, str((state["plan"].get("system") or {}).get("name") or "")
                ),
            )
            slots = self.saved.slots(job.test)[job.position]
            old = slots[job.repeat - 1]
            if old is not None:
                state["superseded"].append(
                    {
                        "test": job.test,
                        "position": job.position,
                        "repeat": job.repeat,
                        "measurement": old,
                        "result": state["evaluations"].get(str(old)),
                        "replaced": utcnow(),
                    }
                )
            slots[job.repeat - 1] = mid
            state["evaluations"][str(mid)] = rid
            state["errors"].pop(job.key, None)
            saved.remember(rid, to_jsonable(ev))
            saved.stale_summary()
            saved.sync_measurements()
            saved.save()
            if old is not None:
                try:
                    self.project.remove_measurement(int(old))
                except CamcmmError as exc:
                    log.warning("replaced measurement %s stays listed: %s", old, exc)
        job.extra.update(measurement=mid, result=rid, deviations=deviations)
        self._cleanup(job)
        return rid

    def fail(self, job: PendingEvaluation, exc: BaseException) -> str:
        """Remember why an import failed, for that position only; returns the message."""
        msg = one_line(exc, job.name)
        job.error = msg
        with self.saved.lock:
            if self.saved.state is not None and self.saved.is_current():
                self.saved.state.setdefault("errors", {})[job.key] = msg
                try:
                    self.saved.save()
                except CamcmmError as e:
                    log.warning("could not save the error of %s: %s", job.key, e)
        self._cleanup(job)
        return msg

    @staticmethod
    def _cleanup(job: PendingEvaluation) -> None:
        if job.temp is not None:
            shutil.rmtree(job.temp, ignore_errors=True)
            job.temp = None
