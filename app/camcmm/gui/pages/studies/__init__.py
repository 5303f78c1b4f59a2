"""The "Studies" page: the case studies of thesis ch. 6 run on a study file — the
light-field scale study (ch. 6.3: table 6.3, figs. 6.15 and 6.16, plugin providing
``lightfield-study``) and the speckle on/off study (ch. 6.2: tables 6.1, 6.2, the area
coverage and the deviation maps side by side, plugin ``studies.speckle``).

``page.py`` holds the state and handlers, ``layout.py`` the widgets; ``run.py`` checks
the study file against the server's roots, runs the plugin and stores the result,
``figures.py`` draws the depth-vs-lambda scatter, the gradient-vs-focal-length fit and
the deviation maps, ``tables.py`` turns the outputs into the page's tables.
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


PAGE = Page("studies", "Studies", "mdi-flask-outline", _mount, _build, order=48)
