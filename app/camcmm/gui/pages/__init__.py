"""The GUI's pages: one folder per page, each exporting one :data:`PAGE`.

A page is ``gui/pages/<key>/`` with ``__init__.py`` (its :class:`Page`), ``page.py``
(state and handlers, testable without a browser), ``layout.py`` (the Vuetify widgets)
and, where it draws, ``figures.py``. :func:`registered` finds the folders here and any
page added with :func:`register`; :func:`camcmm.gui.app.build` mounts them in
``order``, puts one toolbar button per page and calls each page's ``build``. Adding a
page touches no other page and not ``app.py``.

The state variable ``page`` holds the key of the page shown; a page draws its content
inside ``v_if="page === '<key>'"`` (see :func:`shown`).
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass
from typing import Any, Callable


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


_extra: dict[str, Page] = {}


def register(page: Page) -> Page:
    """Add a page from outside this folder (a lab's own page, a test's); returns it."""
    _extra[page.key] = page
    return page


def unregister(key: str) -> None:
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


def shown(key: str) -> str:
    """The ``v_if`` expression of a page's content: true while the page is shown."""
    return f"page === '{key}'"


__all__ = ["Page", "register", "registered", "shown", "unregister"]
