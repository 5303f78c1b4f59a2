"""The acquisition sequences of the thesis, on the engine of :mod:`.sequence`.

* :class:`TurntableSequence` — N images over an angle with the camera(s) fixed and the
  object on a rotation stage, the speckle laser on (ch. 4.2, 4.5: 30 images through
  180 degrees).
* :class:`FringeSequence` — the projector shows pattern i, one or two cameras capture
  (ch. 5.2.2-5.2.3: phase-shifted sinusoids and Gray code).
* :class:`ScaleRunSequence` — move the linear stage, read the interferometer, capture,
  repeat (ch. 3.2.3: the scale factor against a laser interferometer over ~90 mm).

Each is constructed with its devices, the store and its parameters, then ``start()``ed;
see :class:`.sequence.Sequence` for pause/resume/abort and the events.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence as Seq
from typing import Any

import numpy as np

from camcmm.api import InputError, to_jsonable

from .sequence import Sequence, grab_all


def turntable_angles(
    n_images: int, span_deg: float = 180.0, start_deg: float = 0.0, endpoint: bool = False
) -> np.ndarray:
    """The ``n_images`` stage angles (deg): ``start + k * span / n`` for k < n, or with
    ``endpoint`` ``span / (n - 1)`` steps so that the last image is at ``start + span``.
    30 images through 180 deg are 6 deg apart (0 .. 174) without endpoint."""
    if int(n_images) < 1:
        raise InputError(f"turntable: n_images must be at least 1, got {n_images}")
    if not math.isfinite(span_deg) or span_deg <= 0:
        raise InputError(f"turntable: span_deg must be > 0, got {span_deg}")
    return np.linspace(start_deg, start_deg + span_deg, int(n_images), endpoint=bool(endpoint))


def _ensure_homed(stage: Any) -> None:
    # A stage that lost power (fault, restart) lost its reference: home before moving.
    if not stage.homed:
        stage.home()


class TurntableSequence(Sequence):
    """``stage``: a rotary stage (deg); ``cameras``: one or more; ``speckle``: an
    optional SpeckleProjector switched on for the run and off after it."""

    kind = "turntable"

    def __init__(
        self,
        store: Any,
        stage: Any,
        cameras: Seq[Any],
        n_images: int = 30,
        span_deg: float = 180.0,
        start_deg: float = 0.0,
        endpoint: bool = False,
        speckle: Any = None,
        name: str = "turntable",
        restore: bool = True,
    ):
        self.stage, self.cameras, self.speckle = stage, list(cameras), speckle
        if not self.cameras:
            raise InputError(f"sequence {name!r}: needs at least one camera")
        self.angles = turntable_angles(n_images, span_deg, start_deg, endpoint)
        devices = [stage, *self.cameras] + ([speckle] if speckle is not None else [])
        super().__init__(store, devices, name, restore)

    def plan(self) -> list[dict[str, Any]]:
        steps: list[dict[str, Any]] = [{"label": "setup", "kind": "setup"}]
        width = len(str(len(self.angles)))
        steps += [
            {"label": f"view {k:0{width}d}", "kind": "view", "view": k, "angle": float(a)}
            for k, a in enumerate(self.angles)
        ]
        return steps

    def run_step(self, i: int, step: dict[str, Any]) -> None:
        if step["kind"] == "setup":
            _ensure_homed(self.stage)
            if self.speckle is not None:
                self.speckle.on()
            return
        _ensure_homed(self.stage)
        pos = self.stage.move_abs(step["angle"])
        grab_all(
            self,
            self.cameras,
            i,
            {"view": step["view"], "angle_target_deg": step["angle"], "angle_deg": pos, "n_views": len(self.angles)},
        )

    def finish(self) -> None:
        if self.speckle is not None:
            self.speckle.off()


class FringeSequence(Sequence):
    """``projector``: a PatternProjector with the patterns loaded (or give
    ``patterns``); ``cameras``: one or two. ``position`` names the artefact position
    (VDI/VDE 2634-2 asks for several) and goes into every frame's metadata."""

    kind = "fringe"

    def __init__(
        self,
        store: Any,
        projector: Any,
        cameras: Seq[Any],
        patterns: Any = None,
        position: str = "",
        name: str = "fringe",
        restore: bool = True,
    ):
        self.projector, self.cameras, self.position = projector, list(cameras), position
        if not 1 <= len(self.cameras) <= 2:
            raise InputError(f"sequence {name!r}: a fringe sequence takes one or two cameras, got {len(self.cameras)}")
        if patterns is not None:
            projector.load(patterns)
        if not projector.patterns:
            raise InputError(f"sequence {name!r}: the projector has no patterns loaded")
        super().__init__(store, [projector, *self.cameras], name, restore)

    def plan(self) -> list[dict[str, Any]]:
        width = len(str(len(self.projector.patterns)))
        return [
            {"label": f"pattern {k:0{width}d}", "pattern": k, "pattern_name": self.projector.names[k]}
            for k in range(len(self.projector.patterns))
        ]

    def run_step(self, i: int, step: dict[str, Any]) -> None:
        keys = {f"{i}:{c.name}" for c in self.cameras}
        if keys <= self.done_keys:
            return
        self.projector.show(step["pattern"])
        meta = {
            "pattern_index": step["pattern"],
            "pattern_name": step["pattern_name"],
            "n_patterns": len(self.steps),
            "cameras": [c.name for c in self.cameras],
        }
        if self.position:
            meta["position"] = self.position
        grab_all(self, self.cameras, i, meta)

    def finish(self) -> None:
        self.projector.blank()


class ScaleRunSequence(Sequence):
    """Move ``stage`` (linear, mm) through ``targets``; at each: wait for the end of
    the move, read the stage back, average ``samples`` interferometer readings, capture
    every camera. The interferometer is zeroed at the first target (if it can be).
    The table (one row per target) is stored as ``<name> table`` (JSON, kind ``table``)
    and under the state key ``devices.sequence.<name>``."""

    kind = "scale-run"

    def __init__(
        self,
        store: Any,
        stage: Any,
        interferometer: Any,
        cameras: Seq[Any] = (),
        targets: Seq[float] | None = None,
        start_mm: float = 0.0,
        stop_mm: float = 90.0,
        n_steps: int = 10,
        samples: int = 5,
        zero_interferometer: bool = True,
        name: str = "scale-run",
        restore: bool = True,
    ):
        self.stage, self.interferometer, self.cameras = stage, interferometer, list(cameras)
        if targets is None:
            if int(n_steps) < 2:
                raise InputError(f"sequence {name!r}: n_steps must be at least 2, got {n_steps}")
            self.targets = [float(t) for t in np.linspace(float(start_mm), float(stop_mm), int(n_steps))]
        else:
            self.targets = [float(t) for t in targets]
        if not self.targets or not all(math.isfinite(t) for t in self.targets):
            raise InputError(f"sequence {name!r}: targets must be finite numbers (mm)")
        self.samples, self.zero_interferometer = int(samples), bool(zero_interferometer)
        self.rows: dict[int, dict[str, Any]] = {}
        self.table_measurement: int | None = None
        super().__init__(store, [stage, interferometer, *self.cameras], name, restore)

    def plan(self) -> list[dict[str, Any]]:
        steps: list[dict[str, Any]] = [{"label": "setup", "kind": "setup"}]
        width = len(str(len(self.targets)))
        steps += [
            {"label": f"target {k:0{width}d}", "kind": "target", "index": k, "target_mm": t}
            for k, t in enumerate(self.targets)
        ]
        return steps

    def run_step(self, i: int, step: dict[str, Any]) -> None:
        _ensure_homed(self.stage)
        if step["kind"] == "setup":
            self.stage.move_abs(self.targets[0])
            if self.zero_interferometer and getattr(self.interferometer, "can_zero", True):
                self.interferometer.zero()  # a CSV import cannot: its datum is the laser software's
            return
        stage_mm = self.stage.move_abs(step["target_mm"])
        if hasattr(self.interferometer, "seek"):
            # readings recorded by the laser software, one group per target: a step run
            # again after a fault must take the same ones
            self.interferometer.seek(step["index"] * self.samples)
        reading = self.interferometer.read_mean(self.samples)
        row = {
            "index": step["index"],
            "target_mm": step["target_mm"],
            "stage_mm": stage_mm,
            "interferometer_mm": reading["mean"],
            "interferometer_std_mm": reading["std"],
            "samples": reading["n"],
            "measurement_ids": [],
        }
        meta = {k: v for k, v in row.items() if k != "measurement_ids"}
        for cam in self.cameras:
            mid = self.capture(cam, i, meta)
            if mid is not None:
                row["measurement_ids"].append(mid)
        old = self.rows.get(step["index"])
        if old:  # a step run again after a fault keeps the frames it stored before
            row["measurement_ids"] = old["measurement_ids"] + row["measurement_ids"]
        self.rows[step["index"]] = row
        self._save_progress()

    def table(self) -> list[dict[str, Any]]:
        return [self.rows[k] for k in sorted(self.rows)]

    def snapshot(self) -> dict[str, Any]:
        return {**super().snapshot(), "rows": to_jsonable(self.table()) if hasattr(self, "rows") else []}

    def _load_progress(self) -> None:
        super()._load_progress()
        old = self.store.get_state(self._key()) if hasattr(self.store, "get_state") else None
        if old and old.get("run_id") == self.run_id:
            self.rows = {int(r["index"]): r for r in old.get("rows", [])}

    def finish(self) -> None:
        if not hasattr(self.store, "add_file"):
            return
        path = self._tmp / f"{self.run_id}-scale-run.json"
        doc = {"sequence": self.name, "run_id": self.run_id, "unit": "mm", "rows": to_jsonable(self.table())}
        path.write_text(json.dumps(doc, indent=1))
        try:
            h = self.store.add_file(path)
            self.table_measurement = self.store.add_measurement(
                f"{self.name} table",
                h,
                kind="table",
                meta={"sequence": self.name, "run_id": self.run_id, "rows": len(self.rows)},
            )
        finally:
            path.unlink(missing_ok=True)
