"""The persisted acceptance state: what a run keeps under :data:`STATE_KEY` in the
project, how a restart resumes it, and the plan's requirements and position slots that
every other part of the :class:`~camcmm.tasks.acceptance.Wizard` reads and writes."""

from __future__ import annotations

import copy
import threading
from typing import Any

from camcmm.errors import CamcmmError, InputError
from camcmm.project.store import utcnow

from .standards import Standards

STATE_KEY = "acceptance.current"
HISTORY_KEY = "acceptance.history"


class TestState:
    """The saved state of a test on a project and the lookups on it.

    :attr:`state` is the dict kept under :data:`STATE_KEY` (None before a setup);
    :attr:`lock` guards it when the GUI evaluates in a worker thread while the loop
    records another position."""

    __test__ = False  # not a pytest test class despite its name

    def __init__(self, project: Any, standards: Standards):
        self.project = project
        self.standards = standards
        self.state: dict[str, Any] | None = None
        self.load_error = ""
        self.lock = threading.RLock()
        self._reqs: list[dict[str, Any]] | None = None
        self._outputs: dict[int, dict[str, Any]] = {}  # result id -> stored evaluation
        self.resume()

    def start(self, state: dict[str, Any]) -> None:
        """Make ``state`` the running test (a new setup) and save it."""
        self.state = state
        self.load_error = ""
        self._reqs = None
        self._outputs = {}
        self.save()

    # -- resume --------------------------------------------------------------------------
    def resume(self) -> bool:
        """Read the saved test (``acceptance.current``); True if there is one to go on
        with. A test whose standard is not installed is kept, with :attr:`load_error`."""
        self.load_error = ""
        try:
            state = self.project.get_state(STATE_KEY)
        except CamcmmError as exc:
            self.load_error = f"cannot read the saved acceptance test: {exc}"
            return False
        if not isinstance(state, dict) or not state.get("standard") or not isinstance(state.get("plan"), dict):
            self.state = None
            return False
        state.setdefault("measurements", {})
        state.setdefault("evaluations", {})
        state.setdefault("errors", {})
        state.setdefault("superseded", [])
        self.state = state
        self._reqs = None
        self._outputs = {}
        try:
            self.standards.load(state["standard"])
        except CamcmmError as exc:
            self.load_error = (
                f"the acceptance test in this project uses standard {state['standard']!r}, "
                f"which cannot be loaded: {exc}"
            )
            return False
        if not isinstance(state.get("positions"), dict) or not state["positions"]:
            state["positions"] = self._derive_positions()
        return True

    def _derive_positions(self) -> dict[str, dict[str, list]]:
        """Positions of a state written without them (the demo): from each measurement's
        meta ``position``/``repeat``, else from its place in the list."""
        out: dict[str, dict[str, list]] = {}
        reqs = {r["test"]: r for r in self.requirements()}
        for test, mids in (self.state or {}).get("measurements", {}).items():
            r = reqs.get(test)
            if r is None:
                continue
            reps = r["repeats"]
            ids = [p["id"] for p in r["positions"]]
            slots: dict[str, list[int | None]] = {pid: [None] * reps for pid in ids}
            for i, mid in enumerate(mids):
                try:
                    meta = self.project.measurement(int(mid)).get("meta") or {}
                except CamcmmError:
                    meta = {}
                pos = meta.get("position")
                rep = int(meta.get("repeat") or 1)
                if pos not in slots:
                    if i // reps >= len(ids):
                        continue
                    pos, rep = ids[i // reps], i % reps + 1
                if 1 <= rep <= reps:
                    slots[pos][rep - 1] = int(mid)
            out[test] = slots
        return out

    # -- the running test ----------------------------------------------------------------
    @property
    def active(self) -> bool:
        return bool(self.state) and not self.load_error

    @property
    def plan(self) -> dict[str, Any]:
        if not self.state:
            raise InputError("no acceptance test set up yet")
        return self.state["plan"]

    @property
    def running(self) -> dict[str, Any]:
        """The state dict of the running test (raises before a setup)."""
        if not self.state:
            raise InputError("no acceptance test set up yet")
        return self.state

    @property
    def standard_id(self) -> str:
        return str(self.running["standard"])

    def standard(self) -> Any:
        """The running test's standard object."""
        return self.standards.load(self.standard_id)

    def declaration(self) -> Any:
        """The running test's standard declaration."""
        return self.standards.declaration(self.standard_id)

    def requirements(self) -> list[dict[str, Any]]:
        """Per test of this run: test, label, parameters, min_count, repeats, positions
        (from ``std.requirements(plan)``; an optional test the operator added but has no
        measurement yet comes from the standard's own list)."""
        if self._reqs is not None:
            return self._reqs
        std = self.standard()
        plan = copy.deepcopy(self.plan)
        got = {r["test"]: r for r in std.requirements(plan)}
        wanted = list((self.state or {}).get("tests") or got)
        if any(t not in got for t in wanted):
            for r in std.requirements(None):
                if r["test"] in wanted and r["test"] not in got:
                    got[r["test"]] = r
        order = [t for t in wanted if t in got] + [t for t in got if t not in wanted]
        reqs = []
        for t in order:
            r = got[t]
            reqs.append(
                {
                    "test": t,
                    "label": r.get("label") or t,
                    "parameters": list(r.get("parameters") or []),
                    "min_count": int(r.get("min_count") or len(r.get("positions") or [])),
                    "repeats": max(1, int(r.get("repeats") or 1)),
                    "required": bool(r.get("required", True)),
                    "positions": list(r.get("positions") or []),
                    "artefact": r.get("artefact"),
                }
            )
        self._reqs = reqs
        return reqs

    def requirement(self, test: str) -> dict[str, Any]:
        for r in self.requirements():
            if r["test"] == test:
                return r
        raise InputError(
            f"this test has no {test.replace('_', ' ')} measurements; its tests: "
            f"{', '.join(r['test'] for r in self.requirements())}"
        )

    def slots(self, test: str) -> dict[str, list]:
        r = self.requirement(test)
        positions = self.running.setdefault("positions", {}).setdefault(test, {})
        for p in r["positions"]:
            slot = positions.setdefault(p["id"], [None] * r["repeats"])
            if len(slot) < r["repeats"]:
                slot.extend([None] * (r["repeats"] - len(slot)))
        return positions

    def filled(self, test: str, position: str) -> list[tuple[int, int]]:
        """(repeat, measurement id) of each measured repeat of a position, in order."""
        slots = self.slots(test).get(position) or []
        return [(i + 1, mid) for i, mid in enumerate(slots) if mid is not None]

    def evaluation(self, mid: int | None) -> dict[str, Any] | None:
        """The stored evaluation (result outputs) of a measurement of this test."""
        if mid is None:
            return None
        rid = (self.state or {}).get("evaluations", {}).get(str(mid))
        if rid is None:
            return None
        rid = int(rid)
        if rid not in self._outputs:
            try:
                self._outputs[rid] = dict(self.project.result(rid).get("outputs") or {})
            except CamcmmError as exc:
                return {"error": f"its stored result {rid} cannot be read: {exc}"}
        return self._outputs[rid]

    def remember(self, rid: int, outputs: dict[str, Any]) -> None:
        """Keep a just-stored evaluation (result ``rid``'s outputs) without reading it back."""
        self._outputs[int(rid)] = outputs

    def sync_measurements(self) -> None:
        """``measurements`` (position order) and the plan's measurement list follow the slots."""
        ms: dict[str, list[int]] = {}
        plan_ms: dict[str, list[dict[str, Any]]] = {}
        for r in self.requirements():
            slots = self.slots(r["test"])
            for p in r["positions"]:
                for i, mid in enumerate(slots[p["id"]]):
                    if mid is None:
                        continue
                    ms.setdefault(r["test"], []).append(int(mid))
                    ev = self.evaluation(mid) or {}
                    plan_ms.setdefault(r["test"], []).append(
                        {"file": ev.get("file") or f"measurement-{mid}", "position": p["id"], "repeat": i + 1}
                    )
        state = self.running
        state["measurements"] = ms
        state["plan"]["measurements"] = plan_ms
        self._reqs = None

    def stale_summary(self) -> None:
        """A changed measurement makes a written report stale (it stays in the project)."""
        state = self.running
        if state.get("summary_result") is not None:
            state.setdefault("reports", []).append(
                {"summary_result": state["summary_result"], "report": state.get("report")}
            )
        state.update({"summary_result": None, "report": None, "verdict": None, "verdict_guarded": None})

    def is_current(self) -> bool:
        """True when the project still holds this test as it was last read or saved here:
        no other session (a second tab, the CLI) set up a new test or saved a change since.
        A store that cannot be read counts as unchanged (the save reports its own error)."""
        if self.state is None:
            return True
        try:
            stored = self.project.get_state(STATE_KEY)
        except CamcmmError:
            return True
        stored = stored if isinstance(stored, dict) else {}
        return (stored.get("created"), stored.get("updated")) == (self.state.get("created"), self.state.get("updated"))

    def check_current(self) -> None:
        """Refuse (one line) to save over another session's change of the test: saving
        this session's copy would silently undo it (a new test set up in another tab came
        back as the old one)."""
        if not self.is_current():
            raise InputError(
                "another window changed the acceptance test in this project meanwhile; nothing was saved here "
                "(this page now shows the project's test: repeat the step if it still applies)"
            )

    def save(self) -> None:
        state = self.running
        state["updated"] = utcnow()
        self.project.set_state(STATE_KEY, state)
