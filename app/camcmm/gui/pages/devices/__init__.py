"""The "Devices" page: cameras, stages and projectors, real or simulated, and acquisition sequences."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from ... import devices_page

    return devices_page.mount(server, session)


def _build(page: Any) -> None:
    from ... import devices_layout

    devices_layout.build_panel(page)


PAGE = Page("devices", "Devices", "mdi-camera-iris", _mount, _build, order=50)
