"""Projectors: the pattern projector of a fringe system (thesis ch. 5) and the laser
speckle projector of the turntable system (thesis ch. 4.2).

The pattern projector is a MODEL the app's web page shows: it holds the loaded
patterns and the index on display. The page (opened full-screen on the projector's
display) subscribes to ``pattern`` events, fetches :meth:`PatternProjector.png` and
calls :meth:`PatternProjector.acknowledge` with the version it has drawn; a sequence
waits for that acknowledgement before the cameras expose, so captures stay in step with
the display whatever the browser's latency.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Device, DeviceError, DeviceTimeout, checked_path, get_algorithm
from camcmm.api import device_param as param


class PatternProjector(Device):
    """``size`` (width, height) px of the projector. Patterns are (H, W) arrays (uint8,
    uint16 or float in [0, 1]); ``show(i)`` puts pattern ``i`` on display and, with
    ``require_ack``, waits until the page acknowledges it (``ack_timeout_s``), then
    ``settle_s`` more (the projector's own frame latency)."""

    kind = "projector"
    settings_schema = (
        param("settle_s", "float", 0.05, unit="s", min=0, help="Wait after the page drew a pattern before exposing."),
        param("ack_timeout_s", "float", 2.0, unit="s", min=0.05, help="Longest wait for the page to show a pattern."),
    )

    def __init__(
        self,
        name: str = "projector",
        size: Sequence[int] = (1920, 1080),
        display: str = "",
        require_ack: bool = True,
        **settings: Any,
    ):
        self.size = (int(size[0]), int(size[1]))
        self.require_ack = bool(require_ack)
        self.patterns: list[np.ndarray] = []
        self.names: list[str] = []
        self.index: int | None = None
        self.version = 0
        self._acked = 0
        self._cond = threading.Condition()
        super().__init__(name, display or "browser page", **settings)

    # -- patterns ----------------------------------------------------------------------------
    def load(self, patterns: Sequence[np.ndarray] | np.ndarray, names: Sequence[str] | None = None) -> int:
        """Load a pattern sequence; returns how many. Each must be (H, W) or (H, W, 3)."""
        pats = [np.asarray(p) for p in patterns]
        for k, p in enumerate(pats):
            if p.ndim not in (2, 3) or p.shape[0] < 1 or p.shape[1] < 1:
                raise self.error(f"pattern {k} has shape {p.shape}; expected (H, W) or (H, W, 3)")
        self.patterns = pats
        self.names = list(names) if names is not None else [f"pattern {k}" for k in range(len(pats))]
        if pats and (pats[0].shape[1], pats[0].shape[0]) != self.size:
            self.size = (int(pats[0].shape[1]), int(pats[0].shape[0]))
        self.index = None
        self.events.emit("patterns", len(pats))
        return len(pats)

    def load_sequence(self, sequence: Any, algorithm: str | Callable[..., dict] = "fringe.patterns") -> int:
        """Patterns from a pattern-generating plugin (by id, default the fringe
        plugin's ``fringe.patterns``, or a callable with the same contract). ``sequence``
        is a mapping or a sequence file; in a run the web server confines, a file outside
        its folders is refused before it is read (api.checked_path)."""
        if isinstance(sequence, (str, Path)):
            sequence = str(checked_path(sequence, "sequence file"))
        fn = get_algorithm(algorithm) if isinstance(algorithm, str) else algorithm
        out = fn(sequence=sequence)
        names = [
            f.get("name", f"pattern {k}") if isinstance(f, dict) else str(f)
            for k, f in enumerate(out.get("frames") or [])
        ] or None
        return self.load(out["patterns"], names)

    def current(self) -> np.ndarray | None:
        """The pattern on display (None when blank)."""
        return None if self.index is None else self.patterns[self.index]

    def png(self, i: int | None = None) -> bytes:
        """Pattern ``i`` (default: the one on display) as PNG bytes, for the page."""
        import cv2

        k = self.index if i is None else int(i)
        img = np.zeros((self.size[1], self.size[0]), np.uint8) if k is None else self.patterns[k]
        if img.dtype.kind == "f":
            img = np.clip(np.rint(img * 255.0), 0, 255).astype(np.uint8)
        ok, buf = cv2.imencode(".png", img)
        if not ok:
            raise self.error(f"cannot encode pattern {k} as PNG")
        return buf.tobytes()

    # -- display ------------------------------------------------------------------------------
    def show(self, i: int | None) -> int:
        """Display pattern ``i`` (None: blank); returns the display version. Waits for
        the page's acknowledgement when ``require_ack``."""
        with self.guard(f"showing pattern {i}"):
            self.require()
            if i is not None and not 0 <= int(i) < len(self.patterns):
                raise self.error(f"no pattern {i}; {len(self.patterns)} are loaded")
            with self._cond:
                self.index = None if i is None else int(i)
                self.version += 1
                version = self.version
            self._set_status("busy", f"showing {self.names[self.index] if self.index is not None else 'blank'}")
            self.events.emit("pattern", self.index, version)
            if self.require_ack:
                timeout = float(self._settings["ack_timeout_s"])
                with self._cond:
                    if not self._cond.wait_for(lambda: self._acked >= version, timeout):
                        raise self.error(
                            f"the projector page did not show pattern {i} within {timeout:g} s "
                            "(is it open on the projector's display?)",
                            DeviceTimeout,
                        )
            else:
                self.acknowledge(version)
            settle = float(self._settings["settle_s"])
            if settle:
                time.sleep(settle)
            self._set_status("ready", "", index=self.index, version=version)
        return version

    def blank(self) -> int:
        return self.show(None)

    def acknowledge(self, version: int) -> None:
        """Called by the page once it has drawn display ``version``."""
        with self._cond:
            self._acked = max(self._acked, int(version))
            self._cond.notify_all()

    def capabilities(self) -> dict[str, Any]:
        return {
            **super().capabilities(),
            "size": list(self.size),
            "patterns": len(self.patterns),
            "require_ack": self.require_ack,
        }


class SimulatedProjector(PatternProjector):
    """The same model with no page: every pattern counts as shown at once."""

    def __init__(self, name: str = "sim-projector", size: Sequence[int] = (1280, 800), **settings: Any):
        settings.setdefault("settle_s", 0.0)
        super().__init__(name, size, "simulated", require_ack=False, **settings)


class SpeckleProjector(Device):
    """A laser speckle projector switched through a serial relay, or by the operator.

    With a ``port`` the relay gets ``on_command``/``off_command``: hex bytes (default:
    the common CH340 "LCUS-1" USB relay, ``A0 01 01 A2`` / ``A0 01 00 A1``) or, with
    ``encoding='text'``, a text line. Without a port the switching is a manual step:
    ``prompt(message) -> bool`` (set by the GUI, may block until the operator answers)
    is asked to do it; False or no prompt is a DeviceError."""

    kind = "speckle"
    settings_schema = (param("settle_s", "float", 0.5, unit="s", min=0, help="Wait after switching (laser warm-up)."),)

    def __init__(
        self,
        port: str = "",
        name: str = "speckle",
        baudrate: int = 9600,
        on_command: str = "A00101A2",
        off_command: str = "A00100A1",
        encoding: str = "hex",
        prompt: Callable[[str], bool] | None = None,
        **settings: Any,
    ):
        if encoding not in ("hex", "text"):
            raise DeviceError(f"speckle {name!r}: encoding must be hex or text, got {encoding!r}")
        self.baudrate, self.encoding, self.prompt = int(baudrate), encoding, prompt
        self._cmd = {True: self._bytes(on_command, name), False: self._bytes(off_command, name)}
        self.is_on: bool | None = None
        self._ser: Any = None
        super().__init__(name, port, **settings)

    def _bytes(self, command: str, name: str) -> bytes:
        if self.encoding == "text":
            return (command.rstrip("\n") + "\n").encode("ascii")
        try:
            return bytes.fromhex(command.replace(" ", ""))
        except ValueError:
            raise DeviceError(f"speckle {name!r}: relay command {command!r} is not hex bytes") from None

    @property
    def manual(self) -> bool:
        return not self.port

    def _open(self) -> None:
        if self.manual:
            return
        import serial

        try:
            self._ser = serial.serial_for_url(self.port, baudrate=self.baudrate, timeout=0.5, write_timeout=1.0)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise self.error(f"cannot open the relay port ({' '.join(str(exc).split())[:160]})") from None

    def _close(self) -> None:
        if self._ser is not None:
            self._ser.close()
            self._ser = None

    def switch(self, on: bool) -> None:
        """Switch the laser on or off (through the relay, or by asking the operator)."""
        with self.guard(f"switching {'on' if on else 'off'}"):
            self.require()
            if self.manual:
                if self.prompt is None:
                    raise self.error("switched by hand, but no operator prompt is set")
                if not self.prompt(f"Switch the laser speckle projector {'ON' if on else 'OFF'}, then confirm."):
                    raise self.error(f"the operator did not confirm switching it {'on' if on else 'off'}")
            else:
                self._ser.write(self._cmd[bool(on)])
                self._ser.flush()
            self.is_on = bool(on)
            time.sleep(float(self._settings["settle_s"]))
            self._set_status("ready", "", on=self.is_on)
        self.events.emit("speckle", self.is_on)

    def on(self) -> None:
        self.switch(True)

    def off(self) -> None:
        self.switch(False)

    def capabilities(self) -> dict[str, Any]:
        return {**super().capabilities(), "manual": self.manual}
