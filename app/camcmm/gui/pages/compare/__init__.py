"""The "Compare with CAD" page: a measured cloud against its nominal, deviation maps and charts."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from ... import inspect_panel

    return inspect_panel.mount(server, session, session.view.display_limit)


def _build(page: Any) -> None:
    from ... import inspect_layout

    inspect_layout.build_panel(page)


PAGE = Page("compare", "Compare with CAD", "mdi-vector-difference", _mount, _build, order=20)
