"""The "Calibration" page: one camera or a stereo pair from images of a target.

``page.py`` holds the state and handlers, ``layout.py`` the widgets (the inputs card;
``cards.py`` the cards of a calibration: save, results); a run is
``run.py`` (in a worker), what is shown of it ``show.py`` with ``results.py`` (tables),
``figures.py`` (charts), ``pictures.py`` and ``draw.py`` (images), ``links.py``
(downloads); ``inputs.py`` says where the board images come from, ``systems.py`` which
measuring systems use a calibration.
"""

from __future__ import annotations

from .. import Page
from .layout import build
from .page import mount

PAGE = Page("calibration", "Calibration", "mdi-checkerboard", mount, build, order=40)
