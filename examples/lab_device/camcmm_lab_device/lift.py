"""A lab's own stage: a motorised lift (z axis) with a lead screw, simulated.

A driver for the real controller would talk to it in the five primitives below
(``_open`` a port, ``_home``, ``_move_abs``, ``_poll``, ``_stop``); :class:`camcmm.api.Stage`
adds the rest: waiting for the end of a move, time-outs, travel limits, the homing
guard, status and ``position`` events. This one computes where the carriage is from
the time since the move began, so it runs without hardware.
"""

from __future__ import annotations

import math
import time
from typing import Any

from camcmm.api import Stage


class LabLift(Stage):
    """A lift whose motor moves in whole steps of ``step_um`` µm over 0..``travel_mm`` mm;
    it moves at the setting ``speed`` (mm/s, default 5)."""

    unit = "mm"

    def __init__(self, name: str = "lab-lift", step_um: float = 2.5, travel_mm: float = 50.0, **settings: Any):
        self.step_mm = float(step_um) / 1000.0
        self._from = self._to = 0.0  # the move under way: from, to (mm)
        self._t0 = 0.0  # when it began (time.monotonic(), s)
        super().__init__(name, "", (0.0, float(travel_mm)), **settings)

    def _where(self) -> tuple[bool, float]:
        """(still moving, position in mm) at this moment."""
        speed = float(self._settings.get("speed") or 5.0)
        span, done = self._to - self._from, (time.monotonic() - self._t0) * speed
        if done >= abs(span):
            return False, self._to
        return True, self._from + math.copysign(done, span)

    def _go(self, target_mm: float) -> None:
        self._from, self._to, self._t0 = self._where()[1], target_mm, time.monotonic()

    def _home(self) -> None:
        self._go(0.0)  # the reference switch sits at 0 mm

    def _move_abs(self, value: float) -> None:
        self._go(round(value / self.step_mm) * self.step_mm)  # the motor stops on a whole step

    def _poll(self) -> tuple[bool, float]:
        return self._where()

    def _stop(self) -> None:
        self._from = self._to = self._where()[1]

    def capabilities(self) -> dict[str, Any]:
        return {**super().capabilities(), "step_um": self.step_mm * 1000.0}
