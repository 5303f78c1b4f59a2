"""The acceptance page's widgets around a :class:`~camcmm.gui.pages.acceptance.WizardPage`.

Three steps in tabs: **1 Setup** (:mod:`.setup_view`), **2 Positions**
(:mod:`.positions_view`), **3 Result** (:mod:`.result_view`). Everything a standard
contributes (parameters, artefact fields, positions, pictograms) comes from the page's
state, which the page fills from the standard's declaration.
"""

from __future__ import annotations

from typing import Any

from ...widgets import tid
from .positions_view import build_positions
from .result_view import build_result
from .setup_view import build_setup


def build(page: Any, accept: str = "") -> None:
    """The page's panel inside the current layout context (shown while
    ``page === 'acceptance'``), beside the 3D view."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(
        v_if="page === 'acceptance'",
        classes="pa-3",
        style="flex: 0 0 55%; max-width: 55%; height: calc(100vh - 48px - 24px); overflow-y: auto; "
        "border-right: 1px solid rgba(0,0,0,0.12);",
        raw_attrs=tid("wizard"),
    ):
        v.VAlert(
            v_if="wz_error",
            text=("wz_error",),
            type="error",
            density="compact",
            classes="mb-2",
            raw_attrs=tid("wz-error"),
        )
        with v.VTabs(
            v_model=("wz_step", "setup"), density="compact", color="primary", classes="mb-2", raw_attrs=tid("wz-steps")
        ):
            v.VTab(
                "1 · Setup",
                value="setup",
                title="The standard, the system, its MPEs and the artefacts",
                raw_attrs=tid("wz-tab-setup"),
            )
            v.VTab(
                "2 · Positions",
                value="positions",
                disabled=("!wz_active",),
                title="Measure each position the standard requires",
                raw_attrs=tid("wz-tab-positions"),
            )
            v.VTab(
                "3 · Result",
                value="result",
                disabled=("!wz_active",),
                title="The verdict per parameter and the report",
                raw_attrs=tid("wz-tab-result"),
            )
        build_setup(page)
        build_positions(page, accept)
        build_result(page)
