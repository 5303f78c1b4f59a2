"""Motion stages: the common interface (home, absolute and relative moves, position
read-back, wait until idle) in user units, mm for linear and degrees for rotary axes.

A concrete stage implements four primitives in its own units: ``_home``,
``_move_abs(value)``, ``_poll() -> (busy, position)`` and ``_stop``; the base class adds
the waiting, the time-outs, limit checks, the homing guard and the status/position
events. A stage whose controller can tell whether it holds a reference position also
implements ``_referenced() -> bool``, asked before every move.

Moves need a reference: a stage that is not homed (after power-up, or since its
controller reset and lost the position) refuses ``move_abs`` and ``move_rel`` with a
one-line :class:`NotHomed` (a :class:`DeviceError`) until it is homed, unless the caller
confirms with ``allow_unhomed=True`` (the Devices page's "Move without homing", asked
first). Relative moves are refused too: the travel limits are checked in the
controller's count, which without a reference no longer says where the carriage is, so a
relative move can drive into the end stop as well as an absolute one.
"""

from __future__ import annotations

import math
import time
from typing import Any

from .base import Device, DeviceError, DeviceTimeout, param


class NotHomed(DeviceError):
    """A move refused because the axis holds no reference position (home it, or confirm
    the move without one)."""


class Stage(Device):
    """One motion axis. ``unit`` is ``"mm"`` or ``"deg"``. Moves wait for the end of the
    motion unless ``wait=False``; a motion that takes longer than the setting
    ``move_timeout_s`` raises :class:`DeviceTimeout` (the stage is then told to stop).

    ``homed`` is True once the axis holds a reference position; a subclass sets it
    False when the controller reports that it lost it (a reset, a power cycle)."""

    kind = "stage"
    unit = "mm"
    settings_schema = (
        param("speed", "float", None, min=0, help="Maximum speed in unit/s (empty: the device's own)."),
        param("move_timeout_s", "float", 120.0, unit="s", min=0.1, help="Longest a single move or homing may take."),
        param("settle_s", "float", 0.0, unit="s", min=0, help="Wait after a move ends before it counts as done."),
    )

    def __init__(self, name: str = "", port: str = "", limits: tuple[float, float] | None = None, **settings: Any):
        self.limits: tuple[float, float] | None = tuple(limits) if limits is not None else None  # type: ignore[assignment]
        self._homed = False
        self._unhomed_since = ""  # why the reference is missing, for the refusal
        super().__init__(name, port, **settings)

    @property
    def homed(self) -> bool:
        return self._homed

    @homed.setter
    def homed(self, value: bool) -> None:
        if self._homed and not value:
            self._unhomed_since = "since the controller reset"
        self._homed = bool(value)

    # -- public API ---------------------------------------------------------------------
    def home(self, wait: bool = True) -> float | None:
        """Find the reference position; returns the position afterwards when waiting."""
        with self.guard("homing"):
            self.require()
            self._set_status("busy", "homing")
            self._homed = False  # the old reference is void from here on (no "reset" reason)
            self._home()
        if wait:
            pos = self.wait_idle()
            with self.guard("checking the reference position"):
                known = self._referenced()
                if known is False:
                    raise self.error("homing ended without a reference position")
            self.homed = True
            self._unhomed_since = ""
            return pos
        return None

    def move_abs(self, position: float, wait: bool = True, allow_unhomed: bool = False) -> float | None:
        """Move to ``position`` (unit). Returns the read-back position when waiting.
        Refused while the stage is not homed unless ``allow_unhomed`` (the operator
        confirmed that the axis may move without a reference)."""
        value = float(position)
        if not math.isfinite(value):
            raise self.error(f"target position {position!r} is not a finite number")
        if self.limits is not None and not (self.limits[0] - 1e-9 <= value <= self.limits[1] + 1e-9):
            raise self.error(
                f"target {value:g} {self.unit} is outside the travel "
                f"{self.limits[0]:g} .. {self.limits[1]:g} {self.unit}"
            )
        if not allow_unhomed:
            self.require_homed()
        with self.guard(f"moving to {value:g} {self.unit}"):
            self.require()
            self._set_status("busy", f"moving to {value:g} {self.unit}")
            self._move_abs(value)
        return self.wait_idle() if wait else None

    def move_rel(self, distance: float, wait: bool = True, allow_unhomed: bool = False) -> float | None:
        """Move by ``distance`` (unit) from the current position; refused while not
        homed, as :meth:`move_abs`."""
        if not allow_unhomed:
            self.require_homed()
        return self.move_abs(self.position() + float(distance), wait=wait, allow_unhomed=True)

    def require_homed(self) -> None:
        """Raise a one-line DeviceError unless the axis holds a reference position
        (asking the controller when it can tell). Not a device fault: the status stays."""
        with self.guard("checking the reference position"):
            self.require()
            known = self._referenced()
        if known is not None:
            self.homed = known
        if not self.homed:
            why = self._unhomed_since or "yet"
            raise self.error(f"not homed {why}; home it first (or confirm a move without homing)", NotHomed)

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
        axis and raises DeviceTimeout; a stage that lost its reference during the motion
        (a controller reset) raises DeviceError. Each poll emits ``position`` (float)."""
        limit = float(self._settings["move_timeout_s"] if timeout is None else timeout)
        deadline = time.monotonic() + limit
        was_homed = self.homed
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
        if was_homed and not self.homed:
            # the controller reset mid-move: it stopped and counts from 0, so the end
            # position is no answer to the move
            err = self.error(
                f"lost its reference during the motion (the controller reset) at {pos:g} {self.unit}; home it again"
            )
            self._fault(err)
            raise err
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
        return {
            **super().capabilities(),
            "unit": self.unit,
            "limits": list(self.limits) if self.limits is not None else None,
            "homed": self.homed,
        }

    def _ping(self) -> None:
        busy, pos = self._poll()
        self._set_status("busy" if busy else "ready", "", position=pos)

    # -- primitives -------------------------------------------------------------------------
    def _referenced(self) -> bool | None:
        """Whether the controller holds a reference position (None: it cannot tell;
        then :attr:`homed` as set by :meth:`home` decides)."""
        return None

    def _home(self) -> None:
        raise NotImplementedError

    def _move_abs(self, value: float) -> None:
        raise NotImplementedError

    def _poll(self) -> tuple[bool, float]:
        raise NotImplementedError

    def _stop(self) -> None:
        raise NotImplementedError
