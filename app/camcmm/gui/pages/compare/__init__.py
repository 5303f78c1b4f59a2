"""The "Compare with CAD" page: a measured cloud against its nominal, deviation maps and charts."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from .page import mount

    return mount(server, session, session.view.display_limit)


def _build(page: Any) -> None:
    from .layout import build

    build(page)


PAGE = Page("compare", "Compare with CAD", "mdi-vector-difference", _mount, _build, order=20)
