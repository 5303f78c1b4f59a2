"""The "Inspect" page: the project's items in the 3D view, any plugin run from its form.

``page.py`` holds the state and handlers (:class:`~.page.InspectPage`), ``form.py``
the plugin form's fields, inputs and run arguments, ``results.py`` how a result reads
(table, JSON, new items), ``layout.py`` the widgets (the drawer; the 3D view with its
colour field and the result panel, shared with the pages that do not fill the area).
"""

from __future__ import annotations

from .. import Page
from .layout import build, drawer
from .page import mount

PAGE = Page("inspect", "Inspect", "mdi-cube-scan", mount, build, order=0, full=False, drawer=drawer)
