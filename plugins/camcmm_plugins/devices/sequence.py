"""The acquisition-sequence engine: a plan of steps run on a worker thread, every frame
stored as it arrives, a device fault pausing the run until the operator resumes or
aborts.

States: ``idle`` -> ``running`` -> ``done``; ``running`` -> ``paused`` (a device fault,
or :meth:`Sequence.pause`) -> ``resuming`` -> ``running`` (:meth:`Sequence.resume`) or ``aborted``
(:meth:`Sequence.abort`); ``failed`` for a bug (not a device fault). A step that
failed half-way is run again on resume; frames it already stored are not taken again
(each capture has a key ``<step>:<camera>``), so nothing is lost and nothing doubled.

The store is the project (anything with ``add_file(path) -> hash`` and
``add_measurement(name, hash, kind=, meta=) -> id``, optionally ``set_state`` and
``get_state``), or a callable ``sink(image, meta) -> id``. With ``set_state`` the
progress is saved under ``devices.sequence.<name>`` after every capture, so a new
sequence of the same name continues where a crashed one stopped.
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
import tempfile
import threading
import time
import uuid
from collections.abc import Sequence as Seq
from pathlib import Path
from typing import Any

from camcmm.api import Device, DeviceError, Events, Image, to_jsonable, utc_iso, write

log = logging.getLogger(__name__)

TERMINAL = ("done", "aborted", "failed")


class Sequence:
    """Base class: subclasses build :meth:`plan` (a list of dicts, each with a
    ``label``) and run one step in :meth:`run_step`, calling :meth:`capture`."""

    kind = "sequence"

    def __init__(self, store: Any, devices: Seq[Device], name: str = "sequence", restore: bool = True):
        self.store, self.devices, self.name = store, list(devices), name
        self.events = Events()
        self.state, self.reason = "idle", ""
        self.steps: list[dict[str, Any]] = []
        self.step = 0
        self.done_keys: set[str] = set()
        self.measurement_ids: list[int] = []
        self.frames = 0
        self.run_id = uuid.uuid4().hex[:12]
        self.started = self.finished = ""
        self.fault_time: float | None = None
        self.state_time = time.monotonic()
        self._published = "idle"
        self._cond = threading.Condition()
        self._command: str | None = None
        self._thread: threading.Thread | None = None
        self._tmp = Path(tempfile.gettempdir())  # a folder of its own from start() on
        self._restore = restore

    # -- operator API -------------------------------------------------------------------------
    def start(self) -> Sequence:
        if self._thread is not None:
            raise DeviceError(f"sequence {self.name!r} was already started")
        self.steps = self.plan()
        self._tmp = Path(tempfile.mkdtemp(prefix="camcmm-seq-"))
        if self._restore:
            self._load_progress()
        self._thread = threading.Thread(target=self._run, name=f"camcmm-seq-{self.name}", daemon=True)
        self._set_state("running", "")
        self.started = utc_iso()
        self._thread.start()
        return self

    def pause(self) -> None:
        """Pause after the current step."""
        self._signal("pause")

    def resume(self) -> None:
        """Continue a paused run; devices in fault are reconnected first (a failure
        leaves the run paused with the new reason). The state is ``resuming`` until
        the worker has reconnected them."""
        with self._cond:
            if self.state != "paused":
                return
            self.state = "resuming"
            self._command = "resume"
            self._cond.notify_all()
        self.events.emit("state", self.snapshot())
        self._publish("resuming")

    def abort(self) -> None:
        """Stop after the current step (at once when paused); stored frames stay."""
        with self._cond:
            aborting = self.state in ("paused", "resuming")
            if aborting:
                self.state = "aborting"
        self._signal("abort")
        if aborting:
            self.events.emit("state", self.snapshot())
            self._publish("aborting")

    def wait(self, timeout: float | None = None, states: Seq[str] = ("paused", *TERMINAL)) -> str:
        """Block until the state is one of ``states`` (default: paused or finished)."""
        with self._cond:
            self._cond.wait_for(lambda: self._published == self.state and self.state in states, timeout)
            return self.state

    def snapshot(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "run_id": self.run_id,
            "state": self.state,
            "reason": self.reason,
            "step": self.step,
            "steps": len(self.steps),
            "label": self.steps[self.step]["label"] if self.step < len(self.steps) else "",
            "frames": self.frames,
            "measurement_ids": list(self.measurement_ids),
            "done": sorted(self.done_keys),
            "started": self.started,
            "finished": self.finished,
            "plan": self._plan_key(),
        }

    def _plan_key(self) -> str:
        """A digest of the plan: progress saved for another plan is not taken over."""
        text = json.dumps(to_jsonable(self.steps), sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    # -- for subclasses --------------------------------------------------------------------------
    def plan(self) -> list[dict[str, Any]]:
        raise NotImplementedError

    def run_step(self, i: int, step: dict[str, Any]) -> None:
        raise NotImplementedError

    def finish(self) -> None:
        """After the last step (e.g. write a table, switch a laser off)."""

    def capture(self, camera: Any, i: int, meta: dict[str, Any] | None = None) -> int | None:
        """Grab a frame from ``camera`` for step ``i`` and store it at once; skipped if
        this step's frame from this camera is already stored. Returns the measurement id."""
        key = f"{i}:{camera.name}"
        if key in self.done_keys:
            return None
        frame = camera.grab()
        return self.store_frame(frame, i, key, meta)

    def store_frame(self, frame: Image, i: int, key: str, meta: dict[str, Any] | None = None) -> int | None:
        step = self.steps[i]
        info = to_jsonable(
            {
                **frame.metadata,
                **(meta or {}),
                "sequence": self.name,
                "sequence_kind": self.kind,
                "run_id": self.run_id,
                "step": i,
                "label": step["label"],
            }
        )
        name = f"{self.name} {step['label']} {frame.metadata.get('camera', '')}".strip()
        if hasattr(self.store, "add_file"):
            ext = ".tif" if frame.data.dtype.kind == "f" else ".png"
            path = self._tmp / f"{self.run_id}-{i:04d}-{uuid.uuid4().hex[:8]}{ext}"  # cameras write at once
            write(frame, path)
            try:
                h = self.store.add_file(path)
                mid = self.store.add_measurement(name, h, kind="image", meta=info)
            finally:
                path.unlink(missing_ok=True)
        else:
            mid = self.store(frame, info)
        with self._cond:
            self.done_keys.add(key)
            self.frames += 1
            if mid is not None:
                self.measurement_ids.append(int(mid))
        self._save_progress()
        self.events.emit("frame", frame, {**info, "measurement_id": mid})
        return mid

    def progress(self, message: str = "") -> None:
        self.events.emit("progress", self.step / max(len(self.steps), 1), message)

    # -- machinery ------------------------------------------------------------------------------
    def _signal(self, command: str) -> None:
        with self._cond:
            if self.state in TERMINAL:
                return
            self._command = command
            self._cond.notify_all()

    def _set_state(self, state: str, reason: str) -> None:
        with self._cond:
            self.state, self.reason = state, reason
            self.state_time = time.monotonic()
        self._save_progress()
        self.events.emit("state", self.snapshot())
        self._publish(state)

    def _publish(self, state: str) -> None:
        # wait() returns only once the state event went out: a caller then sees what a GUI saw
        with self._cond:
            self._published = state
            self._cond.notify_all()

    def _take(self) -> str | None:
        with self._cond:
            cmd, self._command = self._command, None
            return cmd

    def _run(self) -> None:
        try:
            while self.step < len(self.steps):
                cmd = self._take()
                if cmd == "abort":
                    return self._end("aborted", "aborted by the operator")
                if cmd == "pause" and not self._paused("paused by the operator"):
                    return
                try:
                    self.progress(self.steps[self.step]["label"])
                    self.run_step(self.step, self.steps[self.step])
                    self.step += 1
                except DeviceError as exc:
                    self.fault_time = time.monotonic()
                    self.events.emit("fault", exc)
                    if not self._paused(str(exc)):
                        return
            self.progress("finishing")
            self.finish()
            self.events.emit("progress", 1.0, "done")
            self._end("done", "")
        except Exception as exc:  # a bug, not a device fault: stop and say where
            log.exception("sequence %s failed", self.name)
            self._end("failed", f"sequence {self.name!r} failed: {type(exc).__name__}: {exc}")

    def _paused(self, reason: str) -> bool:
        """Wait in ``paused`` for resume (True) or abort (False)."""
        self._set_state("paused", reason)
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._command in ("resume", "abort"))
            if self._take() == "abort":
                self._end("aborted", f"aborted by the operator ({reason})")
                return False
            try:
                for d in self.devices:
                    if not d.connected or d.status().state == "fault":
                        d.reconnect()
            except DeviceError as exc:
                self._set_state("paused", str(exc))
                continue
            self._set_state("running", "")
            return True

    def _end(self, state: str, reason: str) -> None:
        self.finished = utc_iso()
        if self._tmp.name.startswith("camcmm-seq-"):
            shutil.rmtree(self._tmp, ignore_errors=True)
        self._set_state(state, reason)

    def _key(self) -> str:
        return f"devices.sequence.{self.name}"

    def _save_progress(self) -> None:
        if hasattr(self.store, "set_state"):
            try:
                self.store.set_state(self._key(), self.snapshot())
            except Exception as exc:  # progress is a convenience; the frames are stored already
                log.warning("sequence %s: cannot save progress: %s", self.name, exc)

    def _load_progress(self) -> None:
        if not hasattr(self.store, "get_state"):
            return
        old = self.store.get_state(self._key())
        if old and old.get("state") not in TERMINAL and old.get("plan") == self._plan_key():
            self.run_id = old["run_id"]
            self.done_keys = set(old.get("done", []))
            self.measurement_ids = list(old.get("measurement_ids", []))
            self.frames = int(old.get("frames", 0))
            self.step = int(old.get("step", 0))


def grab_all(seq: Sequence, cameras: Seq[Any], i: int, meta: dict[str, Any]) -> list[int | None]:
    """Capture from every camera for step ``i``: two or more cameras expose together
    (one thread each), as a stereo pair must; each frame is stored as it arrives."""
    if len(cameras) == 1:
        return [seq.capture(cameras[0], i, meta)]
    out: list[Any] = [None] * len(cameras)

    def one(k: int) -> None:
        try:
            out[k] = seq.capture(cameras[k], i, meta)
        except BaseException as exc:
            out[k] = exc

    threads = [threading.Thread(target=one, args=(k,)) for k in range(len(cameras))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in out:
        if isinstance(r, BaseException):
            raise r
    return out
