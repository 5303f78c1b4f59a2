"""The Inspect page's main area: the plugin panel (:mod:`.form_view`) and beside it the
colour field, the 3D view and the result panel. The drawer (the project's items with
the tidy, its results) is :mod:`.drawer`."""

from __future__ import annotations

from typing import Any

from ...clientview import attach_scene_view, client_views, cloud_view, render_switch
from ...viewtools import mount_view_tools, view_toolbar
from ...widgets import dyn_tid, tid
from .cloudedit import cloudedit_panel
from .drawer import drawer
from .form_view import plugin_panel

CV = "cv_inspect"  # the client view's state key


def _colour_bar() -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center ga-3 px-3 py-1", style="min-height: 52px;"):
        v.VSelect(
            v_model=("color_field", None),
            items=("color_fields", []),
            item_title="title",
            item_value="value",
            label="Colour by",
            density="compact",
            variant="outlined",
            hide_details=True,
            disabled=("!color_fields.length",),
            style="max-width: 300px;",
            title="The field the points are coloured by; the legend in the view follows",
            raw_attrs=tid("color-field"),
        )
        v.VChip(
            "legend: {{ legend_title }}",
            v_if="legend_title",
            size="small",
            prepend_icon="mdi-palette",
            title="The colour legend's field and unit",
            raw_attrs=tid("legend-title"),
        )
        html.Span(  # not when the browser-drawn view writes the same at its foot (the count twice)
            "{{ display_note }}",
            v_show=f"display_note && ({CV}_mode === 'server' || !{CV} || {CV}.note !== display_note)",
            classes="text-caption",
            title="How many points the view draws",
            raw_attrs=tid("display-note"),
        )
        html.Span(
            "{{ cv_inspect_picked }}",
            v_if="cv_inspect_picked",
            classes="text-caption",
            title="The point clicked in the view",
            raw_attrs=tid("view-picked"),
        )


def _view(page: Any) -> None:
    """The view: drawn in the browser (:mod:`camcmm.gui.clientview`) or, switched to the
    server, the remote view of the plotter (images)."""
    from trame.widgets import html
    from trame.widgets.vtk import VtkRemoteView

    ctrl, view = page.server.controller, page.session.view
    cv = client_views(page.server).add(CV, view)
    with html.Div(style="flex: 1 1 auto; min-height: 300px; position: relative;", raw_attrs=tid("view")):
        cloud_view(CV)
        html.Div(  # the empty view of the page shown says what would appear in it (gui/scenes.py)
            "{{ view_hint }}",
            v_if="view_hint",
            classes="cmm-view-hint text-body-2 text-medium-emphasis",
            style="position: absolute; left: 50%; top: 40%; transform: translate(-50%, -50%); max-width: 70%; "
            "text-align: center; pointer-events: none; z-index: 2;",
            raw_attrs=tid("view-hint"),
        )
        with html.Div(v_if=f"{CV}_mode === 'server'", style="position: absolute; inset: 0;"):
            # trame-vtk's view on the render window, not trame-pyvista's: that one pushes an
            # image on every pyvista render() (about five per scene change); this one pushes
            # once, when the scene's on_update calls ctrl.view_update for a complete scene.
            rview = VtkRemoteView(
                view.plotter.render_window, interactive_ratio=0.5, interactive_quality=60, still_ratio=1
            )
        ctrl.view_update = rview.update
        ctrl.view_reset_camera = rview.reset_camera
    attach_scene_view(page, cv, ctrl.view_update)


def _report_table() -> None:
    """The result as a report reads (state ``report_rows``): the label, then the value
    with its unit and, below it, its standard uncertainty u (k = 1)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VTable(density="compact", v_if="report_rows.length", raw_attrs=tid("report-table")):
        with html.Tbody():
            with html.Tr(v_for="r in report_rows", key="r.name", raw_attrs=[':title="r.help"']):
                html.Td("{{ r.label }}", classes="font-weight-medium", style="white-space: nowrap;")
                with html.Td(classes="text-right", raw_attrs=dyn_tid("'report-' + r.name")):
                    html.Span("{{ r.value }} {{ r.unit }}", style="white-space: nowrap;")
                    html.Div(
                        "u = {{ r.u }} (standard uncertainty, k = 1)",
                        v_if="r.u",
                        classes="text-caption text-medium-emphasis",
                        raw_attrs=[':title="r.u_what"', *dyn_tid("'report-u-' + r.name")],
                    )


def _all_outputs() -> None:
    """Every output as the plugin returned it, and the stored JSON: folded away."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VExpansionPanels(classes="mt-2", raw_attrs=tid("all-outputs")):
        with v.VExpansionPanel(title="All outputs", raw_attrs=tid("all-outputs-panel")):
            v.VTooltip(activator="parent", text="Every output of the run, unformatted", open_delay=600)
            with v.VExpansionPanelText():
                with v.VTable(density="compact", raw_attrs=tid("result-table")):
                    with html.Tbody():
                        with html.Tr(v_for="r in result_rows", key="r.name"):
                            html.Td("{{ r.label || r.name }}", classes="font-weight-medium")
                            html.Td("{{ r.value }}", classes="text-right", raw_attrs=dyn_tid("'result-' + r.name"))
                            html.Td("{{ r.unit }}")
        with v.VExpansionPanel(title="Result JSON (as stored)"):
            v.VTooltip(activator="parent", text="The record kept in the project", open_delay=600)
            with v.VExpansionPanelText():
                html.Pre("{{ JSON.stringify(result, null, 2) }}", style="font-size: 11px; white-space: pre-wrap;")


def _result_panel() -> None:
    """At the bottom of the view, on the Inspect page only: toasts appear elsewhere
    (errors at the top right, infos in the footer), so none covers a result."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VCard(
        v_if="page === 'inspect' && (result || result_warnings.length)",
        classes="ma-2",
        variant="outlined",
        style="max-height: 36vh; overflow: auto; flex: 0 0 auto;",
        raw_attrs=tid("result-panel"),
    ):
        v.VCardTitle("{{ result_title }}", classes="text-subtitle-1")
        v.VCardSubtitle("{{ result_params }}", v_if="result_params", raw_attrs=tid("result-params"))
        with v.VCardText():
            v.VAlert(
                v_for="(w, i) in result_warnings",
                key="i",
                text=("w",),
                type="warning",
                density="compact",
                classes="mb-1",
                raw_attrs=tid("result-warning"),
            )
            _report_table()
            html.Div(
                "This plugin declares no outputs to report; all of them are below.",
                v_if="!report_rows.length",
                classes="text-caption",
            )
            _all_outputs()


def build(page: Any) -> None:
    """The main area: the plugin panel, then the 3D view with its colour field and the
    result panel. The view stays alive on every page (hidden, not removed, on pages
    that fill the area) and sits right of the pages that share the area with it."""
    from trame.widgets import html

    with html.Div(
        classes=("full_pages.includes(page) ? 'd-none' : 'd-flex flex-row'",),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); order: 1;",
    ):
        plugin_panel(page)
        with html.Div(classes="d-flex flex-column", style="flex: 1 1 0; min-width: 0;"):
            cloudedit_panel(page)
            _colour_bar()
            with html.Div(classes="d-flex align-center flex-wrap"):
                view_toolbar(mount_view_tools(page.server, page.session.view, "vt"), labels=False)
                render_switch(CV)
            _view(page)
            _result_panel()


__all__ = ["build", "drawer"]
