"""The client views of one GUI server in trame: the served folder of their buffers
(route ``__camcmm_cv``, one sub-folder per view, removed with the server), the three
triggers the browser calls (``cv_pick``, ``cv_camera``, ``cv_select``: first argument the
view's NAME, every argument checked, anything wrong ignored without a word — a browser
can send anything), the element cloudview.js binds to and the toggle "Render in browser
/ on server".
"""

from __future__ import annotations

import logging
import shutil
import tempfile
import weakref
from pathlib import Path
from typing import Any

from .client import MODES, ClientView
from .store import BufferStore

log = logging.getLogger("camcmm.gui")

ROUTE = "__camcmm_cv"


class ClientViews:
    """The client views of ``server`` by NAME (one registry per server: :func:`client_views`)."""

    def __init__(self, server: Any):
        self.server = server
        self.folder = Path(tempfile.mkdtemp(prefix="camcmm-cv-"))
        self._cleanup = weakref.finalize(self, shutil.rmtree, str(self.folder), True)
        server.enable_module({"serve": {ROUTE: str(self.folder)}})
        self.views: dict[str, ClientView] = {}
        ctrl = server.controller
        ctrl.trigger("cv_pick")(self.on_pick)
        ctrl.trigger("cv_camera")(self.on_camera)
        ctrl.trigger("cv_select")(self.on_select)
        ctrl.trigger("cv_tool")(self.on_tool)

        @server.state.change("page")
        def _page_shown(**_: Any) -> None:  # a page may have drawn its scene without pushing (show_inputs(push=False))
            for cv in self.views.values():
                if cv.mode == "browser":
                    self._guarded(cv.publish)

    def add(self, name: str, scene: Any) -> ClientView:
        """The client view ``name`` of ``scene`` (its state keys ``name``, ``name_mode``)."""
        if not name.isidentifier() or name in self.views:
            raise ValueError(f"client view {name!r}: a new identifier is needed")
        cv = ClientView(name, scene, self.server.state, BufferStore(self.folder / name), f"{ROUTE}/{name}/")
        self.views[name] = cv

        @self.server.state.change(f"{name}_mode")
        def _mode(**changes: Any) -> None:
            self._guarded(cv.set_mode, changes.get(f"{name}_mode"))

        return cv

    def close(self) -> None:
        self._cleanup()

    # -- triggers ----------------------------------------------------------------------
    def _view(self, name: Any) -> ClientView | None:
        return self.views.get(name) if isinstance(name, str) else None

    def _guarded(self, fn: Any, *args: Any) -> Any:
        """Run a handler; a failure is logged (one line), never raised into trame."""
        try:
            return fn(*args)
        except Exception as exc:  # the page's own errors reach its message; this is the rest
            log.warning("client view: %s", str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
            return None

    def on_pick(self, name: Any = None, layer_id: Any = None, index: Any = None, point: Any = None, *_: Any) -> Any:
        cv = self._view(name)
        return None if cv is None else self._guarded(cv.pick, layer_id, index, point)

    def on_camera(self, name: Any = None, camera: Any = None, viewport: Any = None, *_: Any) -> Any:
        cv = self._view(name)
        return None if cv is None else self._guarded(cv.camera, camera, viewport)

    def on_select(self, name: Any = None, selection: Any = None, *_: Any) -> Any:
        cv = self._view(name)
        return None if cv is None else self._guarded(cv.select, selection)

    def on_tool(self, name: Any = None, tool: Any = None, *_: Any) -> Any:
        cv = self._view(name)
        return None if cv is None else self._guarded(cv.set_tool, tool)


def client_views(server: Any) -> ClientViews:
    """The registry of ``server`` (made at its first use)."""
    reg = getattr(server, "camcmm_client_views", None)
    if reg is None:
        reg = ClientViews(server)
        server.camcmm_client_views = reg
    return reg


def cloud_view(name: str) -> None:
    """The element cloudview.js draws in (shown in browser mode; fills its parent)."""
    from trame.widgets import html

    from ..widgets import tid

    html.Div(
        v_if=f"{name}_mode !== 'server'",
        classes="cmm-cloudview",
        style="position: absolute; inset: 0;",
        raw_attrs=[f'data-cv="{name}"', *tid(f"{name}-canvas")],
    )


def render_switch(name: str) -> None:
    """The toggle: render in the browser (this client view) or on the server (the
    remote view of earlier versions, for a browser without WebGL or canvas)."""
    from trame.widgets import vuetify3 as v

    from ..widgets import tid

    with v.VBtnToggle(
        v_model=(f"{name}_mode", MODES[0]),
        mandatory=True,
        density="compact",
        variant="outlined",
        divided=True,
        color="primary",
        classes="ml-1",
        style="height: 26px;",
        raw_attrs=tid(f"{name}-mode"),
    ):
        for mode, icon, tip in (
            ("browser", "mdi-web", "Render in the browser: turns at screen rate, all points drawn"),
            ("server", "mdi-server", "Render on the server and send images (where the browser cannot draw)"),
        ):
            with v.VBtn(value=mode, size="x-small", raw_attrs=tid(f"{name}-mode-{mode}")):
                v.VIcon(icon, size="small")
                v.VTooltip(activator="parent", location="bottom", text=tip)
