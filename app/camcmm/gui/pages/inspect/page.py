"""The Inspect page's state and handlers (the session holds them for now)."""

from __future__ import annotations

from typing import Any

from ....errors import CamcmmError


class InspectPage:
    """Handlers of the Inspect page: select items and plugins, run a plugin's form."""

    def __init__(self, server: Any, session: Any):
        self.server = server
        self.session = session
        self.state = session.state

    def select_item(self, key: Any) -> None:
        self.session.select_item(key)

    def select_plugin(self, pid: Any) -> None:
        self.session.select_plugin(pid)

    def show_result(self, rid: Any) -> None:
        self.session.show_result(rid)

    def cancel(self) -> None:
        self.session.cancel_run()

    async def run(self, pid: Any, form_values: Any, input_values: Any) -> None:
        from ...session import _ITEM_TYPES

        session = self.session
        if not pid:
            session.error("choose a plugin first")
            return
        try:  # a parameter or input naming a file or folder: only inside the roots (the run also
            # takes inputs from the state, which the client writes too: check those as well)
            inputs = {**dict(self.state.input_values or {}), **dict(input_values or {})}
            form_values, input_values = session.roots.check_run(session.host.get(pid), form_values, inputs,
                                                                _ITEM_TYPES)
        except CamcmmError as exc:
            session.error(str(exc))
            return
        await session.run_plugin_async(pid, form_values or {}, input_values or {})


def mount(server: Any, session: Any) -> InspectPage:
    page = InspectPage(server, session)
    server.controller.run_plugin_form = page.run  # for tests

    @server.state.change("color_field")
    def _field_changed(color_field: Any = None, **_: Any) -> None:
        session.set_color_field(color_field)

    return page
