"""The "Devices" page: cameras, stages and projectors, real or simulated, and acquisition sequences.

``page.py`` (state and handlers), ``layout.py`` (widgets, one function per card),
``wiring.py`` (what a device plugin declares: role, simulated, needs), ``actions.py``
(a device action's I/O), ``live.py`` (a frame as a PNG), ``projector.py`` (the
``/projector`` page shown full-screen on the projector's display).
"""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from .page import mount

    return mount(server, session)


def _build(page: Any) -> None:
    from .layout import build

    build(page)


PAGE = Page("devices", "Devices", "mdi-camera-iris", _mount, _build, order=50)
