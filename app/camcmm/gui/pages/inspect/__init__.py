"""The "Inspect" page: the project's items in the 3D view, any plugin run from its form."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from .page import mount

    return mount(server, session)


def _build(page: Any) -> None:
    from .layout import build

    build(page)


def _drawer(page: Any) -> None:
    from .layout import drawer

    drawer(page)


PAGE = Page("inspect", "Inspect", "mdi-cube-scan", _mount, _build, order=0, full=False, drawer=_drawer)
