"""The "Devices" page's logic: add device plugins (real or simulated), connect them,
see their status and health, change their settings, watch a camera live, move a
stage, and run an acquisition sequence (turntable, fringe, scale run) whose frames
are stored in the project as they arrive. State keys ``dev_*``.

Devices are made by the host from their manifest (``host.device(id, config,
**objects)``): the page knows the device interface of :mod:`camcmm.devices`, not any
particular device. Device events arrive on the device's own threads (a sequence
worker, a live view); the page hands them to the server loop with ``session.post``
and never blocks in them. A :class:`~camcmm.devices.DeviceMonitor` pings idle devices
so that one that stops answering shows as ``fault`` within about two seconds.
"""

from __future__ import annotations

import asyncio
import base64
import logging
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

from ..devices import DeviceMonitor
from ..errors import CamcmmError
from ..params import form_schema

log = logging.getLogger("camcmm.gui.devices")

ROLES = ("camera", "projector", "stage", "interferometer", "speckle", "sequence")
#: which objects a sequence takes from the connected devices, by role
SEQUENCE_OBJECTS = {
    "devices.sequence.turntable": {"stage": "stage", "cameras": "camera*", "speckle": "speckle?"},
    "devices.sequence.fringe": {"projector": "projector", "cameras": "camera*"},
    "devices.sequence.scale-run": {"stage": "stage", "interferometer": "interferometer", "cameras": "camera*?"},
}
LIVE_MAX_PX = 640


def _one_line(exc: BaseException | str) -> str:
    msg = str(exc) if isinstance(exc, (CamcmmError, str)) else f"{type(exc).__name__}: {exc}"
    return " ".join(msg.split()) or "unknown error"


def frame_data_url(data: Any, max_px: int = LIVE_MAX_PX) -> str:
    """A camera frame (H, W) or (H, W, 3) as a PNG data URL, downscaled to ``max_px``."""
    import cv2
    import numpy as np

    img = np.asarray(data)
    if img.dtype != np.uint8:
        top = float(img.max()) or 1.0
        img = np.clip(img.astype(np.float32) * (255.0 / top), 0, 255).astype(np.uint8)
    h, w = img.shape[:2]
    s = max_px / max(h, w)
    if s < 1:
        img = cv2.resize(img, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".png", img)
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode() if ok else ""


class DevicesPage:
    def __init__(self, session: Any):
        self.session = session
        self.state = session.state
        self.host = session.host
        self.project = session.project
        self.devices: dict[str, Any] = {}       # key -> device object
        self.plugin_of: dict[str, str] = {}     # key -> plugin id
        self.sequence: Any = None
        self._unsub: list[Callable[[], None]] = []
        self._counter = 0
        self.monitor: DeviceMonitor | None = None
        self._lock = threading.Lock()
        # device I/O waits (a move, an acknowledged pattern, a grab): never on the server
        # loop, which also serves the projector page's acknowledgement
        self._executor = ThreadPoolExecutor(max_workers=2, thread_name_prefix="camcmm-devices")
        s = self.state
        s.dev_error = ""
        s.dev_catalogue = self._catalogue()
        s.dev_add_id = None
        s.dev_add_fields = []
        s.dev_add_values = {}
        s.dev_list = []
        s.dev_selected = None
        s.dev_settings_fields = []
        s.dev_settings_values = {}
        s.dev_live = ""
        s.dev_live_note = ""
        s.dev_seq_id = None
        s.dev_seq_fields = []
        s.dev_seq_values = {}
        s.dev_seq = None

    # -- catalogue ----------------------------------------------------------------------------
    def _catalogue(self) -> list[dict[str, Any]]:
        out = []
        try:
            specs = [p for p in self.host.all() if p.kind == "device"]
        except Exception as exc:
            self.state.dev_error = _one_line(exc)
            return []
        for p in specs:
            role = str(p.extra.get("role", "device"))
            sim = bool(p.extra.get("simulated", False))
            out.append({"id": p.id, "title": f"{p.name}{' (simulated)' if sim else ''}", "role": role,
                        "simulated": sim, "summary": p.summary})
        order = {r: i for i, r in enumerate(ROLES)}
        return sorted(out, key=lambda d: (order.get(d["role"], 9), d["simulated"], d["title"]))

    def choose_plugin(self, plugin_id: str | None) -> None:
        s = self.state
        s.dev_add_id = plugin_id
        if not plugin_id:
            s.dev_add_fields, s.dev_add_values = [], {}
            return
        spec = self.host.get(plugin_id)
        s.dev_add_fields = form_schema(spec.parameters)
        # tagged with the plugin: a click on Add that races the new form sends the old values
        s.dev_add_values = {"_plugin": plugin_id, **{p.name: p.default for p in spec.parameters}}

    # -- devices --------------------------------------------------------------------------------
    def add(self, plugin_id: str, values: dict[str, Any] | None = None, connect: bool = True) -> str | None:
        """Create (and connect) a device; returns its key, or None with the reason shown."""
        try:
            spec = self.host.get(plugin_id)
            if spec.extra.get("role") == "sequence":
                raise CamcmmError(f"{plugin_id} is a sequence: set it up under Sequences")
            values = dict(values or {})
            if values.pop("_plugin", plugin_id) != plugin_id:
                values = {}  # the form of another plugin: take this one's defaults
            config = {k: v for k, v in values.items() if v not in ("", None)}
            if getattr(self.session, "roots", None) is not None:  # a file it reads: in the browser's folders only
                config, _ = self.session.roots.check_run(spec, config, {})
            objects = self._objects_for(plugin_id)
            dev = self.host.device(plugin_id, config, **objects)
        except Exception as exc:
            self._error(exc)
            return None
        with self._lock:
            self._counter += 1
            key = f"d{self._counter}"
        self.devices[key], self.plugin_of[key] = dev, plugin_id
        for event in ("status", "fault", "position"):
            self._unsub.append(dev.events.on(event, lambda *a, k=key: self.session.post(self._publish_one, k)))
        if connect:
            self.connect(key)
        self._restart_monitor()
        self.select(key)
        self.publish()
        return key

    def _objects_for(self, plugin_id: str) -> dict[str, Any]:
        """A simulated camera sees the simulated projector and stages already added."""
        if plugin_id != "devices.camera.simulated":
            return {}
        out: dict[str, Any] = {}
        projectors = [d for d in self.devices.values() if getattr(d, "kind", "") == "projector"]
        stages = [d for d in self.devices.values() if getattr(d, "kind", "") == "stage"]
        if projectors:
            out["projector"] = projectors[0]
        if stages:
            out["stages"] = stages
        return out

    def connect(self, key: str) -> bool:
        return self.act(key, "connect") is not None

    def disconnect(self, key: str) -> None:
        dev = self.devices.get(key)
        if dev is not None:
            if getattr(dev, "live", False):
                dev.stop_live()
            dev.disconnect()
        self.publish()

    def remove(self, key: str) -> None:
        self.disconnect(key)
        self.devices.pop(key, None)
        self.plugin_of.pop(key, None)
        if self.state.dev_selected == key:
            self.select(None)
        self._restart_monitor()
        self.publish()

    def _restart_monitor(self) -> None:
        if self.monitor is not None:
            self.monitor.stop()
        self.monitor = DeviceMonitor(list(self.devices.values()), interval=0.5) if self.devices else None

    def select(self, key: str | None) -> None:
        s = self.state
        s.dev_selected = key
        dev = self.devices.get(key) if key else None
        s.dev_settings_fields = form_schema(list(getattr(dev, "settings_schema", ()))) if dev else []
        s.dev_settings_values = dict(dev.settings()) if dev else {}
        s.dev_live, s.dev_live_note = "", ""

    def apply_settings(self, key: str, values: dict[str, Any]) -> bool:
        dev = self.devices.get(key)
        if dev is None:
            return False
        changed = {k: v for k, v in (values or {}).items() if v not in ("", None)}
        try:
            dev.configure(**changed)
        except Exception as exc:
            self._error(exc)
            return False
        self.state.dev_settings_values = dict(dev.settings())
        self.session.info(f"{dev.label}: settings applied")
        self.publish()
        return True

    # -- device actions ----------------------------------------------------------------------------
    # An action is its device I/O (``_io``: may wait for a move, a frame, the projector
    # page's acknowledgement; any thread) and what it shows (``_done``: the server loop).
    # The GUI awaits ``act_async``, which waits in the page's worker, never on the loop:
    # the loop also serves the projector page whose acknowledgement a ``show`` awaits.
    @staticmethod
    def _io(dev: Any, action: str, arg: Any = None) -> Any:
        if action == "connect":
            return dev.connect()
        if action == "grab":
            return dev.grab()
        if action in ("home", "stop"):
            return getattr(dev, action)()
        if action in ("abs", "rel"):
            try:
                x = float(arg)
            except (TypeError, ValueError):
                raise CamcmmError(f"{dev.label}: move {action}: {arg!r} is not a number") from None
            return (dev.move_abs if action == "abs" else dev.move_rel)(x)
        if action == "load":
            from .wizard import resources_dir

            path = str(arg).strip() if arg and str(arg).strip() else str(resources_dir() / "fringe" / "sequence.yaml")
            return dev.load_sequence(path)
        if action == "show":
            return dev.show(None if arg in (None, "", "blank") else int(arg))
        raise CamcmmError(f"{dev.label}: unknown action {action!r}")

    def _done(self, dev: Any, action: str, out: Any) -> None:
        if action == "grab":
            self._show_frame(out)
        elif action == "load":
            self.session.info(f"{dev.label}: {out} patterns loaded")
        self.publish()

    def act(self, key: str, action: str, arg: Any = None) -> Any:
        """An action in the calling thread (tests, scripts); None with the reason shown
        when it fails. Actions: connect, grab, home, abs, rel, stop, load, show."""
        dev = self.devices[key]
        try:
            out = self._io(dev, action, arg)
        except Exception as exc:
            self._error(exc)
            self.publish()
            return None
        self._done(dev, action, out)
        return True if out is None else out

    async def act_async(self, key: str, action: str, arg: Any = None) -> Any:
        dev = self.devices[key]
        loop = asyncio.get_running_loop()
        try:
            out = await loop.run_in_executor(self._executor, self._io, dev, action, arg)
        except Exception as exc:
            self._error(exc)
            self.publish()
            return None
        self._done(dev, action, out)
        return True if out is None else out

    def _show_frame(self, frame: Any) -> None:
        meta = getattr(frame, "metadata", {}) or {}
        self.state.dev_live = frame_data_url(frame.data)
        self.state.dev_live_note = " · ".join(str(x) for x in (
            f"#{meta.get('frame')}", meta.get("time", ""), f"{meta.get('exposure_ms', '')} ms",
            f"{frame.data.shape[1]}×{frame.data.shape[0]} px") if x)

    def live(self, key: str, on: bool, fps: float = 4.0) -> None:
        dev = self.devices[key]
        try:
            if on:
                self._unsub.append(dev.events.on("frame", lambda fr, *a: self.session.post(self._show_frame, fr)))
                dev.start_live(fps)
            else:
                dev.stop_live()
        except Exception as exc:
            self._error(exc)
        self.publish()

    # -- sequences ---------------------------------------------------------------------------------
    def choose_sequence(self, plugin_id: str | None) -> None:
        s = self.state
        s.dev_seq_id = plugin_id
        spec = self.host.get(plugin_id) if plugin_id else None
        s.dev_seq_fields = form_schema(spec.parameters) if spec else []
        s.dev_seq_values = {p.name: p.default for p in spec.parameters} if spec else {}

    def _sequence_objects(self, plugin_id: str) -> dict[str, Any]:
        need = SEQUENCE_OBJECTS.get(plugin_id, {})
        out: dict[str, Any] = {"store": self.project}
        connected = [d for d in self.devices.values() if d.connected]
        for arg, role in need.items():
            base, many, optional = role.rstrip("*?"), "*" in role, role.endswith("?")
            found = [d for d in connected if getattr(d, "kind", "") == base]
            if not found and not optional:
                raise CamcmmError(f"{plugin_id}: connect a {base} first")
            if many:
                out[arg] = found
            elif found:
                out[arg] = found[0]
        return out

    def start_sequence(self, plugin_id: str, values: dict[str, Any] | None = None) -> Any:
        if self.sequence is not None and self.sequence.snapshot()["state"] in ("running", "paused", "resuming"):
            self._error("a sequence is under way: pause, resume or abort it first")
            return None
        try:
            objects = self._sequence_objects(plugin_id)
            config = {k: v for k, v in (values or {}).items() if v not in ("", None)}
            if getattr(self.session, "roots", None) is not None:
                config, _ = self.session.roots.check_run(self.host.get(plugin_id), config, {})
            seq = self.host.device(plugin_id, config, **objects)
        except Exception as exc:
            self._error(exc)
            return None
        self.sequence = seq
        for event in ("state", "progress", "fault"):
            self._unsub.append(seq.events.on(event, lambda *a: self.session.post(self._publish_sequence)))
        self._unsub.append(seq.events.on("frame", lambda *a: self.session.post(self.session.refresh_items)))
        seq.start()
        self._publish_sequence()
        return seq

    def sequence_action(self, action: str) -> None:
        seq = self.sequence
        if seq is None or action not in ("pause", "resume", "abort"):
            return
        try:
            getattr(seq, action)()
        except Exception as exc:
            self._error(exc)
        self._publish_sequence()

    def _publish_sequence(self) -> None:
        seq = self.sequence
        if seq is None:
            self.state.dev_seq = None
            return
        snap = seq.snapshot()
        steps = max(int(snap.get("steps") or 0), 1)
        self.state.dev_seq = {"name": snap.get("name"), "state": snap.get("state"), "reason": snap.get("reason", ""),
                              "label": snap.get("label", ""), "frames": snap.get("frames", 0),
                              "progress": round(100.0 * min(int(snap.get("step") or 0), steps) / steps, 1)}
        if snap.get("state") == "paused" and snap.get("reason"):
            self.state.dev_error = f"sequence paused: {snap['reason']}"

    # -- publishing ------------------------------------------------------------------------------
    def _row(self, key: str) -> dict[str, Any]:
        dev = self.devices[key]
        st = dev.status()
        row = {"key": key, "plugin": self.plugin_of.get(key, ""), "name": dev.name, "kind": dev.kind,
               "label": dev.label, "state": st.state, "message": st.message, "connected": dev.connected,
               "live": bool(getattr(dev, "live", False))}
        if dev.kind == "projector":
            row["patterns"] = len(getattr(dev, "patterns", []) or [])
            row["index"] = getattr(dev, "index", None)
        if dev.kind == "stage":
            try:
                pos = dev.position() if dev.connected and st.state != "fault" else None
            except Exception:
                pos = None
            row["position"] = "" if pos is None else f"{pos:.4f} {getattr(dev, 'unit', '')}"
        return row

    def _publish_one(self, key: str) -> None:
        if key in self.devices:
            self.publish()

    def publish(self) -> None:
        self.state.dev_list = [self._row(k) for k in self.devices]

    def _error(self, msg: Any) -> None:
        line = _one_line(msg)
        self.state.dev_error = line
        self.session.error(line)

    def close(self) -> None:
        for u in self._unsub:
            try:
                u()
            except Exception:
                pass
        if self.sequence is not None:
            try:
                self.sequence.abort()
            except Exception:
                pass
        if self.monitor is not None:
            self.monitor.stop()
        self._executor.shutdown(wait=False, cancel_futures=True)
        for dev in list(self.devices.values()):
            try:
                if getattr(dev, "live", False):
                    dev.stop_live()
                dev.disconnect()
            except Exception:
                pass


    def pattern_projector(self) -> Any:
        """The projector the projector page shows: the first pattern projector added."""
        for dev in list(self.devices.values()):
            if getattr(dev, "kind", "") == "projector" and hasattr(dev, "acknowledge"):
                return dev
        return None


def mount(server: Any, session: Any) -> DevicesPage:
    """The page, and the projector page's routes (``/projector``) on the same server."""
    from .projector_route import add_routes

    page = DevicesPage(session)
    add_routes(server, page.pattern_projector)
    return page
