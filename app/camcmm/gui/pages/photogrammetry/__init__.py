"""The "Photogrammetry" page: an image series (a turntable series, photographs of one
object from one camera) reconstructed by the plugin that provides ``photogrammetry``.

``page.py`` holds the state and handlers, ``layout.py`` the widgets; ``inputs.py`` says
where the images come from and makes their thumbnails, ``run.py`` runs the plugin and
stores the result, ``display.py`` shows it, ``scene.py`` draws the cloud with the registered cameras,
``links.py`` sends the cloud to Inspect, Compare with CAD or the Acceptance test.
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


PAGE = Page("photogrammetry", "Photogrammetry", "mdi-camera-burst", _mount, _build, order=45)
