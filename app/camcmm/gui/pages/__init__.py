"""The GUI's pages: one folder per page, each exporting one :data:`PAGE`.

A page is ``gui/pages/<key>/`` with ``__init__.py`` (its :class:`Page`), ``page.py``
(state and handlers, testable without a browser), ``layout.py`` (the Vuetify widgets)
and, where it draws, ``figures.py``. :func:`registered` finds the folders here and any
page added with :func:`register`; :func:`camcmm.gui.app.build` mounts them in
``order``, puts one toolbar button per page and calls each page's ``build``. Adding a
page touches no other page and not ``app.py``.

The state variable ``page`` holds the key of the page shown; a page draws its content
inside ``v_if="page === '<key>'"`` (see :func:`shown`).

A page from outside camcmm (a lab's own, a browser test's) is registered by a module
the server imports before it builds the app: ``$CAMCMM_GUI_PRELOAD`` names such
modules (:func:`preload`; ``GuiProcess(preload=...)`` sets it).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class Page:
    """What a page contributes to the app.

    Attributes
    ----------
    key
        The value of the state variable ``page`` while it is shown; the toolbar
        button's test id is ``page-<key>``.
    title, icon
        The toolbar button's text and its Material Design icon (``mdi-…``).
    mount
        ``mount(server, session) -> page object``: the page's state and handlers, made
        once per server; it may add routes. The object is ``server.pages[key]``; a
        ``close()`` method, if it has one, is called when the server stops.
    build
        ``build(page_object)``: the page's widgets, inside the main area's layout
        context; they show only while ``page === key`` (:func:`shown`).
    order
        Place of the button in the toolbar (smaller first; ties by key).
    full
        True: the page fills the main area. False: it shares it with the 3D view.
    drawer
        ``drawer(page_object)``: widgets of the side drawer, which is open only on
        a page that has one (None: no drawer).
    """

    key: str
    title: str
    icon: str
    mount: Callable[[Any, Any], Any]
    build: Callable[[Any], None]
    order: int = 100
    full: bool = True
    drawer: Callable[[Any], None] | None = None

    def package(self) -> str:
        """Where the page's code lives: ``camcmm.gui.pages.<folder>`` for a page of this
        folder, else the module of its ``mount`` (a lab's or a test's page). A message a
        module under it raises belongs to this page (:meth:`Session.page_of_caller`)."""
        module = getattr(self.mount, "__module__", "") or ""
        if module.startswith(__name__ + "."):
            return ".".join(module.split(".")[: len(__name__.split(".")) + 1])
        return module


_extra: dict[str, Page] = {}


def register(page: Page) -> Page:
    """Add a page from outside this folder (a lab's own page, a test's); returns it."""
    _extra[page.key] = page
    return page


def unregister(key: str) -> None:
    """Remove a :func:`register`-ed page (a test's, after it)."""
    _extra.pop(key, None)


def registered() -> list[Page]:
    """Every page: the folders beside this file, then :func:`register`-ed ones, by order."""
    found: dict[str, Page] = {}
    for info in pkgutil.iter_modules(__path__):
        if not info.ispkg:
            continue
        page = getattr(importlib.import_module(f"{__name__}.{info.name}"), "PAGE", None)
        if isinstance(page, Page):
            found[page.key] = page
    found.update(_extra)
    return sorted(found.values(), key=lambda p: (p.order, p.key))


PRELOAD = "CAMCMM_GUI_PRELOAD"


def preload(entries: str | None = None) -> list[str]:
    """Import the modules of ``entries`` (default ``$CAMCMM_GUI_PRELOAD``; names or
    ``.py`` paths separated by ``os.pathsep``); returns their names. A module that
    cannot be imported raises (the server must not start without a page it was told of)."""
    text = os.environ.get(PRELOAD, "") if entries is None else entries
    names = []
    for entry in filter(None, (e.strip() for e in text.split(os.pathsep))):
        if entry.endswith(".py"):
            path = Path(entry)
            spec = importlib.util.spec_from_file_location(f"camcmm_preload_{path.stem}", path)
            if spec is None or spec.loader is None:
                raise ImportError(f"{PRELOAD}: cannot load {entry}")
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            names.append(spec.name)
        else:
            names.append(importlib.import_module(entry).__name__)
    return names


def shown(key: str) -> str:
    """The ``v_if`` expression of a page's content: true while the page is shown."""
    return f"page === '{key}'"


__all__ = ["PRELOAD", "Page", "preload", "register", "registered", "shown", "unregister"]
