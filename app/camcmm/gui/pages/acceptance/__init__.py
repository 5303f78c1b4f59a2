"""The "Acceptance test" page: an operator-guided test of a standard plugin, beside the 3D view."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from ... import wizard

    return wizard.mount(server, session)


def _build(page: Any) -> None:
    from ... import wizard_layout
    from ...widgets import accepted_extensions

    wizard_layout.build_panel(page, accepted_extensions())


PAGE = Page("acceptance", "Acceptance test", "mdi-clipboard-check-outline", _mount, _build, order=10, full=False)
