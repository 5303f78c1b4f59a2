"""Zaber ASCII protocol stages over a serial port (pyserial).

The protocol (Zaber ASCII Protocol Manual; zaber.com/protocol-manual): a command is a
text line ``/<device> <axis> [<id>] <command> [<data>][:<checksum>]``, a reply is
``@<device:02> <axis> [<id>] <OK|RJ> <BUSY|IDLE> <warning> <data>[:<checksum>]``, e.g.::

    /1 1 7 move abs 21000        @01 1 7 OK BUSY -- 0
    /1 1 8 get pos               @01 1 8 OK BUSY -- 14233
    /1 1 9                       @01 1 9 OK IDLE -- 0
    /1 1 10 move abs -5          @01 1 10 RJ IDLE -- BADDATA

Lines starting ``#`` (info) and ``!`` (alerts) are not replies. The warning ``--`` means
none; ``WR`` means the axis has no reference position (it must be homed). Positions are
microsteps (or encoder counts); ``resolution`` converts them to mm or degrees. Speeds
are sent as ``maxspeed`` data = microsteps/s x 1.6384 (the manual's velocity unit).

Message ids (0..99) are sent with every command so that a reply arriving after its
command timed out is never taken for the reply to the next command. They also sort out
line noise: an unreadable line that carries this command's id is its reply, garbled
(an error, or a retry for a query); any other unreadable line (a truncated reply to
another id, junk after a cable was jiggled) is counted, reported in the status' health
(``garbled_lines``, ``last_garbled``) and skipped, as are alerts (``!``, counted in
``alerts``) and info lines (``#``). A reply glued to the remains of a truncated line is
recovered from its ``@``. The checksum is the
manual's: the two's complement of the byte sum of the text between the leading ``/``
or ``@`` and the ``:``, as two upper-case hex digits.
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from camcmm.api import DeviceDisconnected, DeviceError, DeviceTimeout, port_errors

from .stage import Stage

VELOCITY_UNIT = 1.6384  # Zaber: speed data = microsteps per second x 1.6384
MAX_LINE = 4096  # bytes without a line end that count as one unreadable line

_REPLY = re.compile(r"^@(\d{2}) (\d+) (?:(\d{1,2}) )?(OK|RJ) (BUSY|IDLE) (\S\S) ?(.*)$")
_HEAD = re.compile(r"^@(\d{2}) (\d+)(?: (\d{1,2})\b)?")  # what a garbled reply may still tell
log = logging.getLogger("camcmm.devices")


def checksum(body: str) -> str:
    """Zaber ASCII checksum of the text between the start character and ':'."""
    return f"{(-sum(body.encode('ascii'))) & 0xFF:02X}"


def format_command(
    device: int, axis: int, command: str, msg_id: int | None = None, with_checksum: bool = False
) -> bytes:
    """One command line, e.g. ``format_command(1, 1, 'move abs 1000', 7)`` ->
    ``b'/1 1 7 move abs 1000\\n'``."""
    parts = [str(int(device)), str(int(axis))]
    if msg_id is not None:
        parts.append(str(int(msg_id)))
    if command:
        parts.append(command)
    body = " ".join(parts)
    if with_checksum:
        body = f"{body}:{checksum(body)}"
    return f"/{body}\n".encode("ascii")


@dataclass(frozen=True)
class Reply:
    """A parsed reply line. ``busy`` is True for BUSY; ``warning`` the two-letter flag."""

    device: int
    axis: int
    msg_id: int | None
    ok: bool
    busy: bool
    warning: str
    data: str

    @property
    def value(self) -> int:
        return int(self.data.split()[0])


def parse_reply(line: str) -> Reply | None:
    """Parse one received line: a :class:`Reply`, None for an info/alert line, or
    ValueError for a line that is neither (garbled, truncated, bad checksum)."""
    text = line.strip()
    if not text or text[0] in "#!":
        return None
    if ":" in text[1:]:
        body, _, cc = text[1:].rpartition(":")
        if len(cc) == 2 and all(c in "0123456789ABCDEF" for c in cc):
            if checksum(body) != cc:
                raise ValueError(f"bad checksum in {line.strip()!r}")
            text = "@" + body
    m = _REPLY.match(text)
    if not m:
        raise ValueError(f"not a Zaber reply: {line.strip()!r}")
    dev, axis, mid, flag, state, warn, data = m.groups()
    return Reply(
        int(dev), int(axis), None if mid is None else int(mid), flag == "OK", state == "BUSY", warn, data.strip()
    )


class ZaberLink:
    """The serial link: sends commands and matches replies by device, axis and message
    id. ``url`` is anything ``serial.serial_for_url`` opens (``/dev/ttyUSB0``, ``COM3``,
    ``socket://host:port``, a pseudo-terminal). ``error`` builds the device's errors."""

    def __init__(
        self,
        url: str,
        baudrate: int,
        timeout: float,
        error: Callable[..., DeviceError],
        message_ids: bool = True,
        checksums: bool = False,
    ):
        self.url, self.baudrate, self.timeout = url, int(baudrate), float(timeout)
        self.error, self.message_ids, self.checksums = error, message_ids, checksums
        self._ser: Any = None
        self._buf = b""
        self._next_id = 0
        self.last_reply = 0.0
        self.garbled = self.alerts = 0  # unreadable lines and alerts skipped since open
        self.last_garbled = self.last_alert = ""

    def open(self) -> None:
        import serial  # pyserial; imported here so that the manifest loads without it

        try:
            self._ser = serial.serial_for_url(
                self.url, baudrate=self.baudrate, timeout=0.05, write_timeout=self.timeout
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise self.error(f"cannot open the port ({_short(exc)})", DeviceDisconnected) from None
        try:
            self._ser.reset_input_buffer()
        except Exception:
            pass
        self._buf = b""

    def close(self) -> None:
        if self._ser is not None:
            try:
                self._ser.close()
            finally:
                self._ser = None

    def request(self, device: int, axis: int, command: str, timeout: float | None = None, retries: int = 0) -> Reply:
        """Send one command; return its reply. A garbled reply is retried ``retries``
        times (give retries only for commands that are safe to repeat); no reply within
        ``timeout`` raises DeviceTimeout, a vanished port DeviceDisconnected."""
        for attempt in range(retries + 1):
            try:
                return self._request_once(device, axis, command, self.timeout if timeout is None else timeout)
            except _Garbled as exc:
                if attempt == retries:
                    raise self.error(f"garbled reply to {command!r}: {exc}") from None
        raise AssertionError("unreachable")

    def _request_once(self, device: int, axis: int, command: str, timeout: float) -> Reply:
        if self._ser is None:
            raise self.error("port is closed", DeviceDisconnected)
        mid = None
        if self.message_ids:
            mid, self._next_id = self._next_id, (self._next_id + 1) % 100
        line = format_command(device, axis, command, mid, self.checksums)
        deadline = time.monotonic() + timeout
        skipped = self.garbled
        try:
            self._ser.write(line)
            self._ser.flush()
            while True:
                # a device flooding lines must not keep us here past the deadline
                raw = self._readline(deadline) if time.monotonic() < deadline else None
                if raw is None:
                    n = self.garbled - skipped
                    noise = f" ({n} unreadable line{'s' * (n != 1)} meanwhile, last {self.last_garbled})" if n else ""
                    raise self.error(f"no reply to {command or 'status'!r} within {timeout:g} s{noise}", DeviceTimeout)
                text = raw.decode("ascii", "replace").strip()
                try:
                    reply, junk = _salvage(text)
                except ValueError as exc:
                    if _is_reply_to(text[max(text.rfind("@"), 0) :], device, axis, mid):
                        raise _Garbled(str(exc)) from None
                    self._skip_garbled(text)
                    continue
                if junk:
                    self._skip_garbled(junk)
                if reply is None:
                    if text.startswith("!"):
                        self.alerts, self.last_alert = self.alerts + 1, text[:60]
                    continue  # info or alert line
                if reply.device != device or (axis and reply.axis not in (0, axis)):
                    continue  # another device on the daisy chain
                if mid is not None and reply.msg_id != mid:
                    continue  # a late reply to an earlier, timed-out command (or another client's)
                self.last_reply = time.monotonic()
                return reply
        except port_errors() as exc:
            raise self.error(f"port lost ({_short(exc)})", DeviceDisconnected) from None

    def _skip_garbled(self, text: str) -> None:
        self.garbled += 1
        self.last_garbled = repr(text[:40])
        if self.garbled <= 3 or self.garbled % 100 == 0:  # a noisy line must not flood the log
            log.warning("%s: skipped unreadable line no. %d: %s", self.url, self.garbled, self.last_garbled)

    def _readline(self, deadline: float) -> bytes | None:
        while b"\n" not in self._buf:
            if len(self._buf) > MAX_LINE:  # junk without line ends: one unreadable line
                line, self._buf = self._buf, b""
                return line
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self._ser.timeout = min(left, 0.1)
            chunk = self._ser.read(self._ser.in_waiting or 1)
            self._buf += chunk
        line, _, self._buf = self._buf.partition(b"\n")
        return line.rstrip(b"\r")


def _salvage(text: str) -> tuple[Reply | None, str]:
    """(reply or None, junk in front of it) for one received line; a reply glued to the
    remains of a truncated line is recovered from its last '@'. ValueError if unreadable."""
    at = text.rfind("@")
    if at > 0:
        try:
            return parse_reply(text[at:]), text[:at]
        except ValueError:
            if _HEAD.match(text[at:]):  # a garbled reply behind junk: not an alert or info line
                raise
    return parse_reply(text), ""


def _is_reply_to(text: str, device: int, axis: int, msg_id: int | None) -> bool:
    """Whether an unreadable line still shows that it is the reply to this command."""
    m = _HEAD.match(text)
    if not m or int(m.group(1)) != device or (axis and int(m.group(2)) not in (0, axis)):
        return False
    return msg_id is None or (m.group(3) is not None and int(m.group(3)) == msg_id)


class _Garbled(Exception):
    pass


def _short(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:160] or type(exc).__name__


class ZaberStage(Stage):
    """A Zaber axis speaking the ASCII protocol. ``resolution`` is the size of one
    microstep (or encoder count) in ``unit`` — e.g. 0.000047625 mm for a 0.047625 um
    linear stage, 0.000234375 deg for a rotary one (from the product's data sheet).

    ``timeout`` (s) is how long a reply may take: a Zaber device answers within
    milliseconds, so 1 s catches a dead device well inside the 2 s the operator is
    promised. ``travel`` (lo, hi) limits moves in ``unit``; by default the device's
    ``limit.min``/``limit.max`` are read on connect (none for a rotary axis)."""

    def __init__(
        self,
        port: str,
        name: str = "",
        address: int = 1,
        axis: int = 1,
        resolution: float = 0.001,
        unit: str = "mm",
        baudrate: int = 115200,
        timeout: float = 1.0,
        message_ids: bool = True,
        checksums: bool = False,
        travel: tuple[float, float] | list[float] | None = None,
        position_setting: str = "pos",
        **settings: Any,
    ):
        if not resolution or resolution <= 0:
            raise DeviceError(f"stage {name or port!r}: resolution must be > 0, got {resolution!r}")
        if unit not in ("mm", "deg"):
            raise DeviceError(f"stage {name or port!r}: unit must be mm or deg, got {unit!r}")
        self.unit = unit
        self.address, self.axis, self.resolution = int(address), int(axis), float(resolution)
        self.position_setting = position_setting
        self._travel_given = travel is not None and len(travel) == 2 and travel[0] != travel[1]
        self._link = ZaberLink(port, baudrate, timeout, self.error, message_ids, checksums)
        span = sorted(float(x) for x in travel) if travel is not None and self._travel_given else None
        super().__init__(
            name or f"zaber-{address}-{axis}",
            port,
            (span[0], span[1]) if span else None,
            **settings,
        )

    # -- protocol helpers ---------------------------------------------------------------
    def request(self, command: str, retries: int = 0, timeout: float | None = None) -> Reply:
        """Send a raw command to this axis and return its reply (RJ raises)."""
        with self.guard(f"{command!r}"):
            self.require()
            reply = self._ask(command, retries, timeout)
            if not reply.ok:
                raise self.error(f"refused {command!r}: {reply.data or 'rejected'}")
            return reply

    def _ask(self, command: str, retries: int = 1, timeout: float | None = None) -> Reply:
        try:
            reply = self._link.request(self.address, self.axis, command, timeout, retries)
        finally:
            self._note_link()
        self._note(reply)
        return reply

    def _note(self, reply: Reply) -> None:
        if reply.warning == "WR":
            self.homed = False
        if reply.warning not in ("--", "NI"):
            self._status_health(warning=reply.warning)

    def _note_link(self) -> None:
        # line noise and alerts are skipped, not hidden: the counts go into the health
        link, health = self._link, self._status.health
        if link.garbled != health.get("garbled_lines", 0) or link.alerts != health.get("alerts", 0):
            self._status_health(
                garbled_lines=link.garbled,
                last_garbled=link.last_garbled,
                alerts=link.alerts,
                last_alert=link.last_alert,
            )

    def _status_health(self, **health: Any) -> None:
        self._set_status(self._status.state, self._status.message, **health)

    def _steps(self, value: float) -> int:
        return int(round(value / self.resolution))

    # -- Device ---------------------------------------------------------------------------
    def _open(self) -> None:
        self._link.url = self.port
        self._link.open()
        try:
            self.homed = self._referenced()
            if not self._travel_given and self.unit == "mm":
                lo = self._link.request(self.address, self.axis, "get limit.min", retries=1)
                hi = self._link.request(self.address, self.axis, "get limit.max", retries=1)
                if lo.ok and hi.ok:
                    self.limits = (lo.value * self.resolution, hi.value * self.resolution)
        except BaseException:
            self._link.close()
            raise

    def _close(self) -> None:
        self._link.close()

    def _apply(self, changed: dict[str, Any]) -> None:
        speed = changed.get("speed")
        if speed:
            data = int(round(speed / self.resolution * VELOCITY_UNIT))
            self.request(f"set maxspeed {max(data, 1)}")

    # -- Stage primitives --------------------------------------------------------------------
    def _home(self) -> None:
        self.request("home")

    def _move_abs(self, value: float) -> None:
        self.request(f"move abs {self._steps(value)}")

    def _poll(self) -> tuple[bool, float]:
        reply = self.request(f"get {self.position_setting}", retries=1)
        return reply.busy, reply.value * self.resolution

    def _stop(self) -> None:
        self.request("stop")

    def _referenced(self) -> bool:
        # 'warnings' lists every flag; a reply's warning field shows only the most urgent
        reply = self._ask("warnings")
        return "WR" not in (reply.data.split()[1:] if reply.ok else [reply.warning])

    def capabilities(self) -> dict[str, Any]:
        return {
            **super().capabilities(),
            "protocol": "zaber-ascii",
            "address": self.address,
            "axis": self.axis,
            "resolution": self.resolution,
        }


class ZaberLinearStage(ZaberStage):
    """A linear Zaber axis in mm."""

    def __init__(self, port: str, **kw: Any):
        kw.setdefault("resolution", 0.000047625)
        super().__init__(port, unit="mm", **kw)


class ZaberRotaryStage(ZaberStage):
    """A rotary Zaber axis in degrees (no travel limits unless given)."""

    def __init__(self, port: str, **kw: Any):
        kw.setdefault("resolution", 0.000234375)
        super().__init__(port, unit="deg", **kw)
