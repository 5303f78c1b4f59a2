"""Laser interferometer positions (thesis ch. 3.2.3: the scale factor against a
Renishaw XL-80 watching the linear stage) — over a serial line, from the CSV the
laser's own software writes, or simulated.

Serial line protocol (documented here, simple enough for a small adapter script or a
microcontroller next to the laser to speak): lines end with ``\\n`` (``\\r\\n``
accepted); the host sends ``POS?``, the device answers ``POS <value> [<unit>]`` or a
bare ``<value> [<unit>]``; ``ZERO`` sets the datum (answer ``OK``); ``ERR <reason>`` is
an error. Units: ``mm`` (default), ``um``/``µm``, ``nm``, ``m``, ``in``. In ``stream``
mode the device sends such a line on its own, continuously, and a read takes the newest.
"""

from __future__ import annotations

import csv
import io
import math
import random
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Device, DeviceDisconnected, DeviceTimeout, InputError, port_errors
from camcmm.api import device_param as param

UNITS = {
    "mm": 1.0,
    "um": 1e-3,
    "µm": 1e-3,
    "μm": 1e-3,
    "micron": 1e-3,
    "microns": 1e-3,
    "nm": 1e-6,
    "m": 1e3,
    "in": 25.4,
    "inch": 25.4,
}
_VALUE = re.compile(r"^(?:POS\s+)?([-+]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-zµμ]+)?\s*$")


def parse_position(line: str) -> float:
    """A reply line (``POS 12.5 mm``, ``12500 um``, ``0.0125``) to mm; ValueError otherwise."""
    m = _VALUE.match(line.strip())
    if not m:
        raise ValueError(f"not a position: {line.strip()[:60]!r}")
    unit = m.group(2) or "mm"
    if unit.lower() not in UNITS and unit not in UNITS:
        raise ValueError(f"unknown unit {unit!r} in {line.strip()[:60]!r}")
    return float(m.group(1).replace(",", ".")) * UNITS.get(unit, UNITS.get(unit.lower(), 1.0))


class Interferometer(Device):
    """A length reading in mm. ``read()`` one reading; ``read_mean(n)`` the mean,
    standard deviation and all ``n`` readings."""

    kind = "interferometer"
    unit = "mm"
    can_zero = True
    settings_schema = (param("samples", "int", 1, min=1, max=10000, help="Readings averaged per read_mean()."),)

    def read(self) -> float:
        with self.guard("reading"):
            self.require()
            value = float(self._read())
        self._set_status("ready", "", position=value)
        return value

    def read_mean(self, n: int | None = None) -> dict[str, Any]:
        n = int(n or self._settings["samples"])
        values = [self.read() for _ in range(n)]
        return {
            "mean": float(np.mean(values)),
            "std": float(np.std(values, ddof=1)) if n > 1 else 0.0,
            "n": n,
            "values": values,
            "unit": "mm",
        }

    def zero(self) -> None:
        with self.guard("setting the datum"):
            self.require()
            self._zero()

    def _ping(self) -> None:
        self._read()

    def _read(self) -> float:
        raise NotImplementedError

    def _zero(self) -> None:
        raise self.error("cannot set the datum on this interferometer")


class SerialInterferometer(Interferometer):
    """The line protocol above over pyserial (``port`` may be ``socket://host:port``)."""

    def __init__(
        self,
        port: str,
        name: str = "interferometer",
        baudrate: int = 115200,
        timeout: float = 1.0,
        mode: str = "query",
        query: str = "POS?",
        **settings: Any,
    ):
        if mode not in ("query", "stream"):
            raise ValueError(f"interferometer {name!r}: mode must be query or stream, got {mode!r}")
        self.baudrate, self.timeout, self.mode, self.query = int(baudrate), float(timeout), mode, query
        self._ser: Any = None
        self._buf = b""
        super().__init__(name, port, **settings)

    def _open(self) -> None:
        import serial

        try:
            self._ser = serial.serial_for_url(self.port, baudrate=self.baudrate, timeout=0.05)
            self._ser.reset_input_buffer()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise self.error(f"cannot open the port ({' '.join(str(exc).split())[:160]})", DeviceDisconnected) from None
        self._buf = b""

    def _close(self) -> None:
        if self._ser is not None:
            self._ser.close()
            self._ser = None

    def _line(self, deadline: float) -> str:
        try:
            while b"\n" not in self._buf:
                if time.monotonic() > deadline:
                    raise self.error(f"no reading within {self.timeout:g} s", DeviceTimeout)
                self._buf += self._ser.read(self._ser.in_waiting or 1)
        except port_errors() as exc:
            raise self.error(f"port lost ({' '.join(str(exc).split())[:160]})", DeviceDisconnected) from None
        line, _, self._buf = self._buf.partition(b"\n")
        return line.decode("ascii", "replace").strip()

    def _command(self, text: str) -> str:
        try:
            self._ser.reset_input_buffer()
            self._buf = b""
            self._ser.write((text + "\n").encode("ascii"))
        except port_errors() as exc:
            raise self.error(f"port lost ({' '.join(str(exc).split())[:160]})", DeviceDisconnected) from None
        deadline = time.monotonic() + self.timeout
        while True:
            line = self._line(deadline)
            if line:
                return line

    def _read(self) -> float:
        if self.mode == "stream":
            # the newest complete line: drop what queued up since the last read
            try:
                waiting = self._ser.in_waiting
                self._buf += self._ser.read(waiting) if waiting else b""
            except port_errors() as exc:
                raise self.error(f"port lost ({' '.join(str(exc).split())[:160]})", DeviceDisconnected) from None
            lines = self._buf.split(b"\n")
            self._buf = lines[-1]
            done = [x.strip() for x in lines[:-1] if x.strip()]
            line = done[-1].decode("ascii", "replace") if done else self._line(time.monotonic() + self.timeout)
        else:
            line = self._command(self.query)
        if line.upper().startswith("ERR"):
            raise self.error(f"refused: {line[:80]}")
        try:
            return parse_position(line)
        except ValueError as exc:
            raise self.error(f"garbled reading: {exc}") from None

    def _zero(self) -> None:
        line = self._command("ZERO")
        if line.upper() != "OK":
            raise self.error(f"ZERO refused: {line[:80]}")


class SimulatedInterferometer(Interferometer):
    """In-process: ``source()`` gives the true position (mm), or ``follow`` a stage (its
    ``position`` events, so a reading never talks to the stage); each reading adds
    normal noise ``noise`` (mm, 1 sigma) from ``seed``. For the real serial code against
    a simulated laser use the stage simulator's interferometer port instead."""

    def __init__(
        self,
        source: Callable[[], float] | None = None,
        name: str = "sim-interferometer",
        noise: float = 0.0,
        seed: int = 0,
        follow: Any = None,
        **settings: Any,
    ):
        if source is None:
            if follow is None:
                raise ValueError(f"interferometer {name!r}: give a source or a stage to follow")
            last = [0.0]
            follow.events.on("position", lambda pos: last.__setitem__(0, float(pos)))
            source = lambda: last[0]  # noqa: E731
        self.source, self.noise = source, float(noise)
        self._rng = random.Random(seed)
        self._datum = 0.0
        super().__init__(name, "", **settings)

    def _read(self) -> float:
        return float(self.source()) - self._datum + (self._rng.gauss(0.0, self.noise) if self.noise else 0.0)

    def _zero(self) -> None:
        self._datum = float(self.source())


# -- CSV written by the laser's own software ---------------------------------------------------
_POS_WORDS = ("position", "reading", "measured", "displacement", "distance", "laser", "value", "actual")


def read_interferometer_csv(
    path: str | Path, column: str | int | None = None, unit: str | None = None
) -> dict[str, Any]:
    """Read readings from a CSV export: leading report lines are skipped, the delimiter
    (``,`` ``;`` tab) and a decimal comma are detected, the column is ``column`` (name,
    case-insensitive, or 0-based index) or else the first whose header names a
    position/reading (not a target or time), or else the last numeric one. The unit
    comes from ``unit``, else from the header (``Reading (um)``, ``Position [mm]``),
    else mm. Returns ``positions`` (mm, ndarray), ``column``, ``unit``, ``header``,
    ``targets`` (mm, if a target column exists) and ``times`` (text, if present)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig", errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    lines = [ln for ln in text.splitlines() if ln.strip()]
    delim = max((",", ";", "\t"), key=lambda d: sum(ln.count(d) for ln in lines[-20:]))
    rows = list(csv.reader(io.StringIO("\n".join(lines)), delimiter=delim))
    decimal_comma = delim != ","

    def num(cell: str) -> float | None:
        c = cell.strip().replace(",", ".") if decimal_comma else cell.strip()
        try:
            v = float(c)
        except ValueError:
            return None
        return v if math.isfinite(v) else None

    first = next(
        (i for i, r in enumerate(rows) if sum(num(c) is not None for c in r) >= 1 and len(r) == len(rows[-1])), None
    )
    if first is None:
        raise InputError(f"{path}: no numeric rows found; is this the laser software's CSV export?")
    header = [h.strip() for h in rows[first - 1]] if first > 0 and len(rows[first - 1]) == len(rows[first]) else []
    data = [r for r in rows[first:] if len(r) == len(rows[first])]
    ncol = len(rows[first])
    lower = [h.lower() for h in header]
    if isinstance(column, int) or (isinstance(column, str) and column.strip().lstrip("-").isdigit()):
        idx = int(column)
    elif column:
        matches = [i for i, h in enumerate(lower) if str(column).lower() in h]
        if not matches:
            raise InputError(f"{path}: no column named {column!r}; columns: {', '.join(header) or 'none (no header)'}")
        idx = matches[0]
    else:
        cand = [
            i
            for i, h in enumerate(lower)
            if any(w in h for w in _POS_WORDS)
            and not any(w in h for w in ("target", "time", "date", "nominal", "index", "error"))
        ]
        numeric = [i for i in range(ncol) if all(num(r[i]) is not None for r in data)]
        cand = [i for i in cand if i in numeric]
        if not cand and not numeric:
            raise InputError(f"{path}: no column holds numbers in every row")
        idx = cand[0] if cand else numeric[-1]
    if not -ncol <= idx < ncol:
        raise InputError(f"{path}: column {idx} does not exist; the file has {ncol} columns")
    name = header[idx] if header else f"column {idx}"
    unit_text = unit or _unit_of(name) or "mm"
    if unit_text not in UNITS:
        raise InputError(f"{path}: unknown unit {unit_text!r}; use one of mm, um, nm, m, in")
    values = [num(r[idx]) for r in data]
    bad = [k for k, v in enumerate(values) if v is None]
    if bad:
        raise InputError(f"{path}: row {first + bad[0] + 1}, column {name!r}: {data[bad[0]][idx]!r} is not a number")
    out: dict[str, Any] = {
        "positions": np.asarray(values, float) * UNITS[unit_text],
        "column": name,
        "unit": unit_text,
        "header": header,
        "path": str(path),
    }
    tcol = next((i for i, h in enumerate(lower) if "target" in h or "nominal" in h), None)
    if tcol is not None and all(num(r[tcol]) is not None for r in data):
        out["targets"] = np.asarray([num(r[tcol]) for r in data], float) * UNITS.get(
            _unit_of(header[tcol]) or unit_text, 1.0
        )
    time_col = next((i for i, h in enumerate(lower) if "time" in h or "date" in h), None)
    if time_col is not None:
        out["times"] = [r[time_col].strip() for r in data]
    return out


def _unit_of(header: str) -> str | None:
    m = re.search(r"[\(\[]\s*([A-Za-zµμ]+)\s*[\)\]]", header)
    return m.group(1) if m else None


class CsvInterferometer(Interferometer):
    """Readings imported from the laser software's CSV, handed out in file order: the
    n-th ``read()`` returns the n-th reading (a scale run taken with the laser software
    recording one reading per stage target). ``reset()`` starts again."""

    def __init__(
        self,
        path: str,
        name: str = "interferometer-csv",
        column: str | int | None = None,
        unit: str | None = None,
        **settings: Any,
    ):
        self.path, self.column, self.csv_unit = str(path), column, unit
        self.table: dict[str, Any] = {}
        self._next = 0
        super().__init__(name, str(path), **settings)

    can_zero = False

    def _open(self) -> None:
        # a reconnect re-reads the file but keeps the place: readings already handed
        # out belong to targets already done
        self.table = read_interferometer_csv(self.path, self.column, self.csv_unit)

    def reset(self) -> None:
        self.seek(0)

    def seek(self, k: int) -> None:
        """The next read() returns reading ``k`` (0-based)."""
        self._next = int(k)

    def _read(self) -> float:
        pos = self.table["positions"]
        if self._next >= len(pos):
            raise self.error(f"all {len(pos)} readings of the file are used")
        self._next += 1
        return float(pos[self._next - 1])

    def _ping(self) -> None:
        pass
