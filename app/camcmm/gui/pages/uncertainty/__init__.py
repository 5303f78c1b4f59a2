"""The "Uncertainty" page: Monte Carlo and GUM uncertainty of a measuring system."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from ... import uncertainty_page

    return uncertainty_page.mount(server, session)


def _build(page: Any) -> None:
    from ... import uncertainty_layout

    uncertainty_layout.build_panel(page)


PAGE = Page("uncertainty", "Uncertainty", "mdi-sigma", _mount, _build, order=30)
