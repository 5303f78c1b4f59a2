"""The "Fuse" page: CSI height maps registered onto a photogrammetry cloud and merged
with it, by the plugin that provides ``csi-fusion`` (thesis ch. 6.1).

``page.py`` holds the state and handlers, ``layout.py`` the widgets; ``run.py`` checks
the request, runs the plugin and stores the result, ``figures.py`` draws the matches,
the difference map, its histogram and Abbott-Firestone curve, ``scene.py`` the fused
cloud with the CSI footprints.
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


PAGE = Page("fuse", "Fuse", "mdi-layers-triple-outline", _mount, _build, order=47)
