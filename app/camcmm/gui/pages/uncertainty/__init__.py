"""The "Uncertainty" page: a GUM budget editor and a Monte Carlo study of a stereo system.

Modules: :mod:`.page` (state and handlers), :mod:`.budget` (the budget editor's
documents and exports), :mod:`.study` (the Monte Carlo form, storage, table and
exports), :mod:`.figures` (charts as plotly JSON and PNG), :mod:`.view` (the measuring
volume in 3D) and :mod:`.layout` (the widgets). The numbers are the uncertainty
plugins'; the page finds them by task (``uncertainty-budget``,
``monte-carlo-uncertainty``).
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


PAGE = Page("uncertainty", "Uncertainty", "mdi-sigma", _mount, _build, order=30)
