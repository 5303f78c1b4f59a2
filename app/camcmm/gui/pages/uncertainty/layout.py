"""The "Uncertainty" page's widgets around its
:class:`~camcmm.gui.pages.uncertainty.page.UncertaintyPage`.

Two tabs. **GUM budget**: the quantity, unit and coverage probability, an editable
table of contributions (name, entered as u / half-width a / expanded U, value,
distribution, k, c, dof; then the u the plugin made of it and the conversion in words)
evaluated as one types, the result (u_c, ν_eff, k, U and each share) and a bar chart;
Store & export. **Monte Carlo**: the stereo system as the plugin's declared fields
(cameras, stereo pair, grid, error sources; :func:`~camcmm.gui.widgets.param_form`) or a
loaded YAML file instead, the run's parameters (iterations, seed, triangulation, an
optional Dask scheduler), the studies to tick; Run (``data-shortcut="run"``) with
progress and Cancel; the table of contributions in x, y, z (thesis table 3.2), the
bar chart, the convergence, sweep and spatial plots, and the measuring volume in 3D
(distortion arrows or per-point uncertainty); the exports as links.
"""

from __future__ import annotations

from typing import Any

from ...widgets import tid
from .. import shown
from . import texts
from .budget_view import budget_tab
from .mc_form import mc_form


def _mc_tab(v: Any, html: Any, tplotly: Any, page: Any) -> None:
    with html.Div(v_if="unc_tab === 'montecarlo'", raw_attrs=tid("unc-mc")):
        html.Div(texts.MC_SOURCE, classes="text-caption text-medium-emphasis mb-2", raw_attrs=tid("unc-mc-source"))
        with html.Div(classes="d-flex ga-3"):
            with html.Div(style="flex: 0 0 440px; max-width: 440px;"):
                mc_form(v, html, page)
            with html.Div(style="flex: 1 1 0; min-width: 0;"):
                _mc_table(v, html, tplotly)
        with html.Div(classes="d-flex ga-3 mt-2"):
            with html.Div(style="flex: 1 1 50%; min-width: 0;"):
                _mc_studies(v, tplotly, page)
            with html.Div(style="flex: 1 1 50%; min-width: 0;"):
                _mc_volume(v, html, page)


def _mc_table(v: Any, html: Any, tplotly: Any) -> None:
    """The contributions in x, y, z (thesis table 3.2) and their bar chart."""
    with v.VTable(density="compact", v_if="unc_mc_rows.length", raw_attrs=tid("unc-mc-table")):
        with html.Thead():
            with html.Tr():
                html.Th("Influence factor")
                for a in ("x", "y", "z"):
                    html.Th(f"u{a} / {{{{ unc_mc_summary.unit }}}}", classes="text-right")
                html.Th("dof", classes="text-right")
                html.Th("distribution")
        with html.Tbody():
            with html.Tr(v_for="r in unc_mc_rows", key="r.factor", classes=("r.total ? 'font-weight-bold' : ''",)):
                html.Td("{{ r.factor }}")
                for a in ("x", "y", "z"):
                    html.Td(f"{{{{ r.{a} }}}}", classes="text-right")
                html.Td("{{ r.dof }}", classes="text-right")
                html.Td("{{ r.distribution }}")
    tplotly.Figure(
        state_variable_name="unc_mc_fig_contrib",
        display_mode_bar=True,
        style="height: 300px;",
        raw_attrs=tid("unc-mc-chart"),
    )


def _mc_studies(v: Any, tplotly: Any, page: Any) -> None:
    """Convergence (on the chosen axis), the feature-location sweep and the spatial variation."""

    def on_axis(axis):
        page.set_axis(axis)

    with v.VBtnToggle(
        model_value=("unc_mc_axis",),
        density="compact",
        mandatory=True,
        color="primary",
        update_modelValue=(on_axis, "[$event]"),
        title="the axis whose convergence is plotted",
    ):
        for a in ("x", "y", "z"):
            v.VBtn(a, value=a, size="small", title=f"convergence of the {a} contributions")
    tplotly.Figure(
        state_variable_name="unc_mc_fig_conv",
        display_mode_bar=True,
        style="height: 280px;",
        raw_attrs=tid("unc-mc-convergence"),
    )
    tplotly.Figure(
        state_variable_name="unc_mc_fig_sweep",
        display_mode_bar=True,
        style="height: 240px;",
        raw_attrs=tid("unc-mc-sweep"),
    )
    tplotly.Figure(
        state_variable_name="unc_mc_fig_spatial",
        display_mode_bar=True,
        style="height: 240px;",
        raw_attrs=tid("unc-mc-spatial"),
    )


def _mc_volume(v: Any, html: Any, page: Any) -> None:
    """The measuring volume in 3D: the chosen map and its one-line note."""
    from trame.widgets.vtk import VtkRemoteView

    def on_map(choice):
        page.show_map(choice)

    v.VSelect(
        model_value=("unc_mc_map",),
        items=("unc_mc_maps",),
        item_title="title",
        item_value="value",
        label="Measuring volume",
        density="compact",
        variant="outlined",
        hide_details=True,
        disabled=("!unc_mc_maps.length",),
        update_modelValue=(on_map, "[$event]"),
        title="what the 3D view shows of the measuring volume: distortion arrows or per-point uncertainty",
        raw_attrs=tid("unc-mc-map"),
    )
    html.Div("{{ unc_mc_map_note }}", classes="text-caption my-1", raw_attrs=tid("unc-mc-map-note"))
    with html.Div(style="height: 480px; position: relative;", raw_attrs=tid("unc-mc-view")):
        rview = VtkRemoteView(
            page.view.plotter.render_window, interactive_ratio=0.5, interactive_quality=60, still_ratio=1
        )

    def view_changed(reset_camera: bool) -> None:
        if reset_camera:
            page.view.plotter.reset_camera()
        rview.update()

    page.view.on_update = view_changed


def build(page: Any) -> None:
    """The page inside the current layout context (shown when ``page === 'uncertainty'``)."""
    from trame.widgets import html
    from trame.widgets import plotly as tplotly
    from trame.widgets import vuetify3 as v

    ctrl = page.server.controller
    with html.Div(
        v_if=shown("uncertainty"),
        classes="pa-3",
        raw_attrs=tid("uncertainty"),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); overflow-y: auto;",
    ):
        v.VAlert(
            v_if="unc_error",
            text=("unc_error",),
            type="error",
            density="compact",
            closable=True,
            close_label="dismiss this message",
            classes="mb-2",
            click_close="unc_error = ''",
            raw_attrs=tid("unc-error"),
        )
        with v.VTabs(v_model=("unc_tab", "budget"), density="compact", color="primary", classes="mb-2"):
            v.VTab(
                "GUM budget",
                value="budget",
                title="a GUM uncertainty budget (JCGM 100:2008): u_c, effective dof, k and U",
                raw_attrs=tid("unc-tab-budget"),
            )
            v.VTab(
                "Monte Carlo: stereo system",
                value="montecarlo",
                title="the Monte Carlo study of a stereo camera system (thesis ch. 3)",
                raw_attrs=tid("unc-tab-montecarlo"),
            )
        budget_tab(v, html, tplotly, page, ctrl)
        _mc_tab(v, html, tplotly, page)
