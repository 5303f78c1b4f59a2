"""Motion stages: the common interface (home, absolute and relative moves, position
read-back, wait until idle) in user units, mm for linear and degrees for rotary axes.

A concrete stage implements four primitives in its own units: ``_home``,
``_move_abs(value)``, ``_poll() -> (busy, position)`` and ``_stop``; the base class adds
the waiting, the time-outs, limit checks and the status/position events.
"""

from __future__ import annotations

import math
import time
from typing import Any

from .base import Device, DeviceTimeout, param


class Stage(Device):
    """One motion axis. ``unit`` is ``"mm"`` or ``"deg"``. Moves wait for the end of the
    motion unless ``wait=False``; a motion that takes longer than the setting
    ``move_timeout_s`` raises :class:`DeviceTimeout` (the stage is then told to stop)."""

    kind = "stage"
    unit = "mm"
    settings_schema = (
        param("speed", "float", None, min=0, help="Maximum speed in unit/s (empty: the device's own)."),
        param("move_timeout_s", "float", 120.0, unit="s", min=0.1, help="Longest a single move or homing may take."),
        param("settle_s", "float", 0.0, unit="s", min=0, help="Wait after a move ends before it counts as done."),
    )

    def __init__(self, name: str = "", port: str = "", limits: tuple[float, float] | None = None, **settings: Any):
        self.limits: tuple[float, float] | None = tuple(limits) if limits is not None else None  # type: ignore[assignment]
        self.homed = False
        super().__init__(name, port, **settings)

    # -- public API ---------------------------------------------------------------------
    def home(self, wait: bool = True) -> float | None:
        """Find the reference position; returns the position afterwards when waiting."""
        with self.guard("homing"):
            self.require()
            self._set_status("busy", "homing")
            self._home()
        if wait:
            pos = self.wait_idle()
            self.homed = True
            return pos
        return None

    def move_abs(self, position: float, wait: bool = True) -> float | None:
        """Move to ``position`` (unit). Returns the read-back position when waiting."""
        value = float(position)
        if not math.isfinite(value):
            raise self.error(f"target position {position!r} is not a finite number")
        if self.limits is not None and not (self.limits[0] - 1e-9 <= value <= self.limits[1] + 1e-9):
            raise self.error(f"target {value:g} {self.unit} is outside the travel "
                             f"{self.limits[0]:g} .. {self.limits[1]:g} {self.unit}")
        with self.guard(f"moving to {value:g} {self.unit}"):
            self.require()
            self._set_status("busy", f"moving to {value:g} {self.unit}")
            self._move_abs(value)
        return self.wait_idle() if wait else None

    def move_rel(self, distance: float, wait: bool = True) -> float | None:
        """Move by ``distance`` (unit) from the current position."""
        return self.move_abs(self.position() + float(distance), wait=wait)

    def position(self) -> float:
        """The position read back from the device (unit)."""
        with self.guard("reading the position"):
            self.require()
            return self._poll()[1]

    def is_busy(self) -> bool:
        with self.guard("reading the state"):
            self.require()
            return self._poll()[0]

    def wait_idle(self, timeout: float | None = None, poll_s: float = 0.05) -> float:
        """Poll until the axis stops; returns the final position. A time-out stops the
        axis and raises DeviceTimeout. Each poll emits ``position`` (float)."""
        limit = float(self._settings["move_timeout_s"] if timeout is None else timeout)
        deadline = time.monotonic() + limit
        while True:
            with self.guard("waiting for the end of the motion"):
                busy, pos = self._poll()
            self.events.emit("position", pos)
            if not busy:
                break
            if time.monotonic() > deadline:
                try:
                    self.stop()
                finally:
                    err = self.error(f"still moving after {limit:g} s; stopped", DeviceTimeout)
                    self._fault(err)
                raise err
            time.sleep(poll_s)
        settle = float(self._settings.get("settle_s") or 0.0)
        if settle:
            time.sleep(settle)
        self._set_status("ready", "", position=pos)
        return pos

    def stop(self) -> None:
        with self.guard("stopping"):
            self.require()
            self._stop()

    def capabilities(self) -> dict[str, Any]:
        return {**super().capabilities(), "unit": self.unit,
                "limits": list(self.limits) if self.limits is not None else None,
                "homed": self.homed}

    def _ping(self) -> None:
        busy, pos = self._poll()
        self._set_status("busy" if busy else "ready", "", position=pos)

    # -- primitives -------------------------------------------------------------------------
    def _home(self) -> None:
        raise NotImplementedError

    def _move_abs(self, value: float) -> None:
        raise NotImplementedError

    def _poll(self) -> tuple[bool, float]:
        raise NotImplementedError

    def _stop(self) -> None:
        raise NotImplementedError
