"""The device interface every camera, stage, interferometer and projector offers.

A device is an object with a life cycle (:meth:`Device.connect`, :meth:`Device.disconnect`,
:meth:`Device.reconnect`), a declared set of run-time settings validated like plugin
parameters (:attr:`Device.settings_schema`, :meth:`Device.configure`), a
:class:`DeviceStatus` and :class:`Events` to subscribe to.

Threading: every method may be called from any thread; one re-entrant lock per device
serialises its I/O, so a GUI's health monitor and a running sequence can share a stage.
Event callbacks run on the thread that caused the event (a sequence's worker, a live-view
thread): a GUI must hand them over to its own loop and must not block in them. A
callback that raises is logged and dropped from that one delivery; it never breaks the
device.

Errors are :class:`DeviceError` (an ``InputError``), one line that names the device and
its port: ``stage 'x-axis' on /dev/ttyUSB0: no reply to 'get pos' within 1.0 s``.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Any

from ..errors import InputError, ParameterError
from ..jsonable import utc_now
from ..params import Param

log = logging.getLogger("camcmm.devices")

STATES = ("disconnected", "ready", "busy", "fault")


class DeviceError(InputError):
    """A device refused, failed or stopped answering; the text names device and port."""


class DeviceTimeout(DeviceError):
    """No (complete) reply within the timeout: the device may be off or hung."""


class DeviceDisconnected(DeviceError):
    """The port went away (cable pulled, process killed, USB reset)."""


def utc_iso(t: float | None = None) -> str:
    """Wall-clock time ``t`` (epoch seconds; now if None) as UTC ISO 8601 with ms: the
    device logs' name for :func:`camcmm.jsonable.utc_now`, the one clock."""
    return utc_now(t)


@dataclass(frozen=True)
class DeviceStatus:
    """A snapshot: ``state`` is one of :data:`STATES`; ``message`` the last fault or
    note; ``time`` (epoch s) when the state was entered; ``health`` free-form numbers
    the device knows (temperature_c, warnings, last_reply_s ...)."""

    device: str
    kind: str
    state: str
    port: str = ""
    message: str = ""
    time: float = field(default_factory=time.time)
    health: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "device": self.device,
            "kind": self.kind,
            "state": self.state,
            "port": self.port,
            "message": self.message,
            "time": utc_iso(self.time),
            "health": dict(self.health),
        }


class Events:
    """Named events with subscribers. ``on(name, cb)`` returns a function that
    unsubscribes. Names used: ``status`` (DeviceStatus), ``frame`` (Image), ``fault``
    (DeviceError), ``pattern`` (index) and, for sequences, ``state`` and ``progress``."""

    def __init__(self) -> None:
        self._subs: dict[str, list[Callable[..., Any]]] = {}
        self._lock = threading.Lock()

    def on(self, name: str, callback: Callable[..., Any]) -> Callable[[], None]:
        with self._lock:
            self._subs.setdefault(name, []).append(callback)

        def off() -> None:
            with self._lock:
                if callback in self._subs.get(name, []):
                    self._subs[name].remove(callback)

        return off

    def emit(self, name: str, *args: Any) -> None:
        with self._lock:
            subs = list(self._subs.get(name, ()))
        for cb in subs:
            try:
                cb(*args)
            except Exception:  # a GUI bug must not stop a stage mid-move
                log.exception("callback %r for event %r failed", cb, name)


class Device:
    """Base class of all devices. Subclasses set :attr:`kind` and
    :attr:`settings_schema` and implement ``_open``, ``_close`` and, when settings
    reach the hardware, ``_apply``; ``_ping`` checks that the device still answers."""

    kind = "device"
    settings_schema: tuple[Param, ...] = ()

    def __init__(self, name: str = "", port: str = "", **settings: Any):
        self.name = name or type(self).__name__
        self.port = str(port or "")
        self.events = Events()
        self._io = threading.RLock()
        self._settings = {p.name: p.coerce(p.default) for p in self.settings_schema}
        self._status = DeviceStatus(self.name, self.kind, "disconnected", self.port)
        self._connected = False
        if settings:
            self.configure(**settings)

    # -- naming and errors -----------------------------------------------------------
    @property
    def label(self) -> str:
        where = f" on {self.port}" if self.port else ""
        return f"{self.kind} {self.name!r}{where}"

    def error(self, reason: str, cls: type[DeviceError] = DeviceError) -> DeviceError:
        return cls(f"{self.label}: {reason}")

    @contextmanager
    def guard(self, what: str) -> Iterator[None]:
        """Hold the I/O lock; turn any failure into a DeviceError naming the device,
        record it as the status ``fault`` and emit ``fault``."""
        with self._io:
            try:
                yield
            except DeviceError as exc:
                self._fault(exc)
                raise
            except ParameterError:
                raise
            except Exception as exc:
                err = self.error(f"{what} failed: {type(exc).__name__}: {exc}")
                self._fault(err)
                raise err from exc

    def _fault(self, exc: DeviceError) -> None:
        self._set_status("fault", str(exc))
        self.events.emit("fault", exc)

    def _set_status(self, state: str, message: str = "", **health: Any) -> None:
        old = self._status
        merged = {**old.health, **health}
        if state == old.state and message == old.message and merged == old.health:
            return
        self._status = replace(
            old,
            state=state,
            message=message,
            port=self.port,
            time=time.time() if state != old.state else old.time,
            health=merged,
        )
        self.events.emit("status", self._status)

    # -- life cycle -----------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        return self._connected

    def connect(self) -> Device:
        """Open the port and apply the settings; returns self. Idempotent."""
        with self.guard("connecting"):
            if not self._connected:
                self._open()
                self._connected = True
                self._apply(dict(self._settings))
            self._set_status("ready", "")
        return self

    def disconnect(self) -> None:
        """Close the port (idempotent; never raises for a port already gone)."""
        with self._io:
            if self._connected:
                try:
                    self._close()
                except Exception as exc:  # a dead port is closed all the same
                    log.debug("%s: close failed: %s", self.label, exc)
            self._connected = False
            self._set_status("disconnected", self._status.message if self._status.state == "fault" else "")

    def release(self) -> None:
        """Disconnect and free what the device itself started (a simulator's process): the
        session that held it ends. A device that starts nothing only disconnects."""
        self.disconnect()

    def reconnect(self, port: str | None = None) -> Device:
        """Close and open again (after a fault), optionally on another port."""
        self.disconnect()
        if port is not None:
            self.port = str(port)
        return self.connect()

    def __enter__(self) -> Device:
        return self.connect()

    def __exit__(self, *exc: Any) -> None:
        self.disconnect()

    def require(self) -> None:
        if not self._connected:
            raise self.error("not connected; connect it first", DeviceDisconnected)

    # -- settings ---------------------------------------------------------------------
    def settings(self) -> dict[str, Any]:
        return dict(self._settings)

    def configure(self, **values: Any) -> dict[str, Any]:
        """Validate and apply settings (exposure_ms=20, roi=[0, 0, 640, 480] ...);
        an unknown name or a value outside its limits raises ParameterError naming the
        device. Returns all settings."""
        known = {p.name: p for p in self.settings_schema}
        new = {}
        for name, value in values.items():
            if name not in known:
                raise ParameterError(f"{self.label}: no setting {name!r}; settings: {', '.join(known) or 'none'}")
            try:
                new[name] = known[name].coerce(value)
            except ParameterError as exc:
                raise ParameterError(f"{self.label}: {exc}") from None
        self._check(new)
        with self.guard("applying settings"):
            if self._connected and new:
                self._apply(new)
            self._settings.update(new)
        return self.settings()

    def capabilities(self) -> dict[str, Any]:
        """What the device offers: kind, settings (as parameter declarations for a
        form), and subclass specifics (units, travel range, image size ...)."""
        return {
            "kind": self.kind,
            "name": self.name,
            "port": self.port,
            "settings": [p.to_dict() for p in self.settings_schema],
        }

    # -- status and health --------------------------------------------------------------
    def status(self) -> DeviceStatus:
        return self._status

    def ping(self) -> DeviceStatus:
        """Ask the device whether it still answers (cheap; for a health monitor).
        A failure sets the status to ``fault``; the status is returned either way."""
        if not self._connected:
            return self._status
        try:
            with self.guard("health check"):
                self._ping()
                if self._status.state == "fault":
                    self._set_status("ready", "")
        except DeviceError:
            pass
        return self._status

    # -- for subclasses -------------------------------------------------------------------
    def _open(self) -> None:
        pass

    def _close(self) -> None:
        pass

    def _apply(self, changed: dict[str, Any]) -> None:
        pass

    def _check(self, new: dict[str, Any]) -> None:
        """Cross-setting checks before anything reaches the device."""

    def _ping(self) -> None:
        pass


class DeviceMonitor:
    """Pings devices every ``interval`` s on a daemon thread so that one that stops
    answering while idle is reported through its ``status`` event (within one
    interval plus its reply timeout). ``stop()`` ends the thread."""

    def __init__(self, devices: list[Device], interval: float = 0.5):
        self.devices = list(devices)
        self.interval = float(interval)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camcmm-device-monitor", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            for d in self.devices:
                # a device busy in a sequence is watched by the sequence itself
                if d.connected and d._io.acquire(blocking=False):
                    try:
                        d.ping()
                    finally:
                        d._io.release()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)


def port_errors() -> tuple[type[BaseException], ...]:
    """The exceptions a vanished serial port raises (pyserial's, the OS's, termios')."""
    import serial

    errs: tuple[type[BaseException], ...] = (serial.SerialException, OSError)
    try:
        import termios

        errs += (termios.error,)
    except ImportError:  # Windows
        pass
    return errs


def param(name: str, type: str = "float", default: Any = None, **kw: Any) -> Param:
    """Shorthand for a setting declaration (same fields as a manifest parameter)."""
    d = {"name": name, "type": type, "default": default, **kw}
    return Param.from_dict(d)
