"""An in-process simulated stage (no port). The interface (:class:`camcmm.api.Stage`)
is in the core; the Zaber-ASCII stages are in :mod:`.zaber`.
"""

from __future__ import annotations

import math
import time
from typing import Any

from camcmm.api import Stage


class SimulatedStage(Stage):
    """An in-process stage that moves at ``speed`` (unit/s, default 100) with no
    port; for the devices panel and quick scripts. The serial-protocol simulator
    (:mod:`.simulator`) is what tests of the real stage code use."""

    def __init__(self, name: str = "sim-stage", unit: str = "mm", limits=None, **settings: Any):
        self.unit = unit
        self._pos = 0.0
        self._from = 0.0
        self._target = 0.0
        self._t0 = 0.0
        super().__init__(name, "", limits, **settings)

    def _speed(self) -> float:
        return float(self._settings.get("speed") or 100.0)

    def _now_pos(self) -> tuple[bool, float]:
        travelled = (time.monotonic() - self._t0) * self._speed()
        span = self._target - self._from
        if travelled >= abs(span):
            self._pos = self._target
            return False, self._pos
        self._pos = self._from + math.copysign(travelled, span)
        return True, self._pos

    def _home(self) -> None:
        self._move_abs(0.0)
        self.homed = True

    def _move_abs(self, value: float) -> None:
        self._from, self._target, self._t0 = self._now_pos()[1], value, time.monotonic()

    def _poll(self) -> tuple[bool, float]:
        return self._now_pos()

    def _stop(self) -> None:
        self._target = self._from = self._now_pos()[1]
