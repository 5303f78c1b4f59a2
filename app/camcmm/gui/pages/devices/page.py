"""The "Devices" page's state and handlers: add device plugins (real or simulated),
connect them, see their status and health, change their settings, watch a camera live,
move a stage, and run an acquisition sequence (turntable, fringe, scale run) whose
frames are stored in the project as they arrive. State keys ``dev_*``.

Devices are made by the host from their manifest (``host.device(id, config,
**objects)``): the page knows the device interface of :mod:`camcmm.devices` and what a
manifest declares (:mod:`.wiring`: role, simulated, needs), not any particular device.
Device I/O runs in the page's :class:`~camcmm.gui.jobs.Job` (two workers: a Stop must
not wait behind the move it stops). Device events arrive on the device's own threads (a
sequence worker, a live view); the page hands them to the server loop with
``session.post`` and never blocks in them. A :class:`~camcmm.devices.DeviceMonitor`
pings idle devices so that one that stops answering shows as ``fault`` within about
two seconds.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from ....devices import DeviceMonitor
from ....devices.stage import NotHomed
from ....errors import CamcmmError, one_line
from ....params import form_schema
from ...jobs import Job
from . import wiring
from .actions import cause, perform
from .live import frame_data_url, frame_note
from .projector import add_routes

ACTIVE = ("running", "paused", "resuming")
"""Sequence states in which another sequence may not start."""

SEQUENCE = "sequence"
"""The cause of a sequence's pause message (it goes when the sequence goes on)."""


class DevicesPage:
    """The page object (``server.pages["devices"]``); every handler the layout calls."""

    def __init__(self, session: Any):
        self.session = session
        self.state = session.state
        self.host = session.host
        self.project = session.project
        self.devices: dict[str, Any] = {}  # key -> device object
        self.plugin_of: dict[str, str] = {}  # key -> plugin id
        self.sequence: Any = None
        self.monitor: DeviceMonitor | None = None
        self.io = Job("device I/O", state=session.state, workers=2)
        self._unsub: list[Callable[[], None]] = []
        self._counter = 0
        self._lock = threading.Lock()
        s = self.state
        s.dev_error = ""
        s.dev_unhomed = None  # {key, action, arg, label}: a refused move the operator may confirm
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
        """Every device plugin the host knows (sequences too), by role, real first."""
        try:
            rows = [wiring.catalogue_entry(p) for p in self.host.all() if p.kind == "device"]
        except Exception as exc:
            self.state.dev_error = one_line(exc)
            return []
        return sorted(rows, key=wiring.catalogue_order)

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
    def add(self, plugin_id: str, values: dict[str, Any] | None = None) -> str | None:
        """Make a device from its plugin and the form's ``values``; returns its key, or
        None with the reason shown. No device I/O: connect it with ``await act(key, "connect")``.

        The objects it declares it ``needs`` come from the devices added before it (a
        simulated camera renders the simulated projector's pattern and the stages' positions).
        """
        try:
            spec = self.host.get(plugin_id)
            if wiring.role(spec) == "sequence":
                raise CamcmmError(f"{plugin_id} is a sequence: set it up under Sequences")
            values = dict(values or {})
            if values.pop("_plugin", plugin_id) != plugin_id:
                values = {}  # the form of another plugin: take this one's defaults
            config = self._checked(spec, values)
            objects = wiring.objects_for(spec, self.devices.values())
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
        self._restart_monitor()
        self.select(key)
        self.publish()
        return key

    def _checked(self, spec: Any, values: dict[str, Any]) -> dict[str, Any]:
        """The form's values without the empty ones; a file it reads must be in the browser's folders."""
        config = {k: v for k, v in values.items() if v not in ("", None)}
        if getattr(self.session, "roots", None) is not None:  # None: a session without a browser
            config, _ = self.session.roots.check_run(spec, config, {})
        return config

    async def disconnect(self, key: str) -> None:
        """Stop a camera's live view and close the device (in the device job)."""
        await self.act(key, "disconnect")

    async def remove(self, key: str) -> None:
        await self.disconnect(key)
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

    async def apply_settings(self, key: str, values: dict[str, Any]) -> bool:
        """Change the settings the form gives (empty fields left as they are); False with
        the reason shown when the device refuses one."""
        changed = {k: v for k, v in (values or {}).items() if v not in ("", None)}
        return await self.act(key, "configure", changed) is not None

    # -- device actions ----------------------------------------------------------------------------
    async def act(self, key: str, action: str, arg: Any = None, unhomed: bool = False) -> Any:
        """Do ``action`` (:data:`.actions.ACTIONS`: connect, disconnect, configure, grab, home,
        abs, rel, stop, load, show) in the device job's worker; its result (True for None),
        or None with the reason shown when it fails. A sequence file to ``load`` must lie
        in the browser's folders: refused before it is read (empty: the one camcmm ships).
        ``unhomed``: a move the operator confirmed without homing (:meth:`move_unhomed`).

        The reason belongs to what failed (:func:`.actions.cause`): it goes when the same
        action, or for a stage any motion, then succeeds (a stage homed after "move before
        homing"). A move refused for want of a reference offers "Move without homing"
        (state ``dev_unhomed``: the move to do after the operator confirms)."""
        dev = self.devices.get(key)
        if dev is None:
            self._error(f"no device {key!r}: it was removed")
            return None
        try:
            roots = getattr(self.session, "roots", None)
            if action == "load" and roots is not None and arg is not None and str(arg).strip():
                arg = str(roots.check(arg, "sequence file"))
            out = await self.io.call(perform, dev, action, arg, unhomed)
        except Exception as exc:
            self._error(exc, cause(key, action))
            if isinstance(exc, NotHomed) and action in ("abs", "rel"):
                self.state.dev_unhomed = {"key": key, "action": action, "arg": arg, "label": dev.label}
            self.publish()
            return None
        self._resolved(cause(key, action))
        if action == "grab":
            self._show_frame(out)
        elif action == "load":
            self.session.info(f"{dev.label}: {out} patterns loaded")
        elif action == "configure":
            self.state.dev_settings_values = dict(out)
            self.session.info(f"{dev.label}: settings applied")
        self.publish()
        return True if out is None else out

    def _show_frame(self, frame: Any) -> None:
        self.state.dev_live = frame_data_url(frame.data)
        self.state.dev_live_note = frame_note(frame)

    def live(self, key: str, on: bool, fps: float = 4.0) -> None:
        """Start (``fps`` frames/s at most) or stop a camera's live view."""
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

    def start_sequence(self, plugin_id: str, values: dict[str, Any] | None = None) -> Any:
        """Start a sequence on the connected devices it declares it needs; it stores its
        frames in the project (``store``) on its own thread. Returns it, or None with the reason."""
        if self.sequence is not None and self.sequence.snapshot()["state"] in ACTIVE:
            self._error("a sequence is under way: pause, resume or abort it first")
            return None
        try:
            spec = self.host.get(plugin_id)
            connected = [d for d in self.devices.values() if d.connected]
            objects = {"store": self.project, **wiring.objects_for(spec, connected)}
            seq = self.host.device(plugin_id, self._checked(spec, dict(values or {})), **objects)
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
        """``pause``, ``resume`` or ``abort`` the sequence (it acts on its own thread)."""
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
        self.state.dev_seq = {
            "name": snap.get("name"),
            "state": snap.get("state"),
            "reason": snap.get("reason", ""),
            "label": snap.get("label", ""),
            "frames": snap.get("frames", 0),
            "progress": round(100.0 * min(int(snap.get("step") or 0), steps) / steps, 1),
        }
        if snap.get("state") == "paused" and snap.get("reason"):
            line = one_line(f"sequence paused: {snap['reason']}")
            if self.session.page_error("devices") != line:
                self._error(line, SEQUENCE)
        elif snap.get("state") in ACTIVE:  # resumed: the pause's reason is no longer the news
            self._resolved(SEQUENCE)

    # -- publishing ------------------------------------------------------------------------------
    def _row(self, key: str) -> dict[str, Any]:
        dev = self.devices[key]
        st = dev.status()
        row = {
            "key": key,
            "plugin": self.plugin_of.get(key, ""),
            "name": dev.name,
            "kind": dev.kind,
            "label": dev.label,
            "state": st.state,
            "message": st.message,
            "connected": dev.connected,
            "live": bool(getattr(dev, "live", False)),
        }
        if dev.kind == "projector":
            row["patterns"] = len(getattr(dev, "patterns", []) or [])
            row["index"] = getattr(dev, "index", None)
        if dev.kind == "stage":
            try:
                pos = dev.position() if dev.connected and st.state != "fault" else None
            except Exception:  # the monitor shows the fault; the list just leaves the position out
                pos = None
            row["position"] = "" if pos is None else f"{pos:.4f} {getattr(dev, 'unit', '')}"
            row["unit"] = str(getattr(dev, "unit", "") or "")
        return row

    def _publish_one(self, key: str) -> None:
        if key in self.devices:
            self.publish()

    def publish(self) -> None:
        self.state.dev_list = [self._row(k) for k in self.devices]

    def _error(self, msg: BaseException | str, why: str = "") -> None:
        """The page's one line (its alert and the footer), about ``why`` (a cause key)."""
        line = one_line(msg)
        self.state.dev_error = line
        self.state.dev_unhomed = None  # offered again only by the refusal it answers
        self.session.error(line, cause=why)

    def _resolved(self, why: str) -> None:
        """``why`` succeeded now: its message goes from the page (and the offer to move
        unhomed); the alert shows the page's message that is left, if any."""
        self.session.resolve(why)
        self.state.dev_error = self.session.page_error("devices")
        if why.endswith(": motion"):
            self.state.dev_unhomed = None

    async def move_unhomed(self) -> Any:
        """The move refused for want of a reference, confirmed by the operator: done with
        ``allow_unhomed`` (the travel limits are then the controller's count only)."""
        ask, self.state.dev_unhomed = self.state.dev_unhomed, None
        if not isinstance(ask, dict) or ask.get("key") not in self.devices:
            return None
        return await self.act(str(ask["key"]), str(ask["action"]), ask.get("arg"), unhomed=True)

    def reloaded(self) -> None:
        """A tab connected (a reload): the page's line of a past action goes with the
        session's messages; the device list is read afresh."""
        self.state.dev_error = ""
        self.state.dev_unhomed = None
        self.publish()

    def pattern_projector(self) -> Any:
        """The projector the projector page shows: the first pattern projector added."""
        for dev in list(self.devices.values()):
            if getattr(dev, "kind", "") == "projector" and hasattr(dev, "acknowledge"):
                return dev
        return None

    def close(self) -> None:
        """Stop the sequence, the monitor, the device job and every device (the server stops)."""
        for off in self._unsub:
            try:
                off()
            except Exception:  # a device already gone: nothing left to unsubscribe from
                pass
        if self.sequence is not None:
            try:
                self.sequence.abort()
            except Exception:
                pass
        if self.monitor is not None:
            self.monitor.stop()
        self.io.close()
        for dev in list(self.devices.values()):
            try:
                perform(dev, "disconnect")
            except Exception:  # closing: one device's failure must not keep the others open
                pass
            try:  # and what a device started itself (a simulated stage's simulator process)
                release = getattr(dev, "release", None)
                if callable(release):
                    release()
            except Exception:
                pass


def mount(server: Any, session: Any) -> DevicesPage:
    """The page, and the projector page's routes (``/projector``) on the same server."""
    page = DevicesPage(session)
    add_routes(server, page.pattern_projector)
    session.watch_reload(page.reloaded)
    return page
