"""The "Uncertainty" page's widgets around its
:class:`~camcmm.gui.pages.uncertainty.page.UncertaintyPage`.

Two tabs. **GUM budget**: the quantity, unit and coverage probability, an editable
table of contributions (name, u, c, dof, distribution) evaluated as one types, the
result (u_c, ν_eff, k, U and each share) and a bar chart; Store & export.
**Monte Carlo**: the stereo system as YAML (cameras, stereo, grid, uncertainties),
the plugin's declared parameters (iterations, seed, triangulation, an optional Dask
scheduler; :func:`~camcmm.gui.widgets.param_form`), the studies to tick; Run with
progress and Cancel; the table of contributions in x, y, z (thesis table 3.2), the
bar chart, the convergence, sweep and spatial plots, and the measuring volume in 3D
(distortion arrows or per-point uncertainty); the exports as links.
"""

from __future__ import annotations

from typing import Any

from ...widgets import param_form, tid
from .. import shown


def _row_update(field: str) -> str:
    """Replace ``unc_b_rows`` by a copy with ``$event`` in row ``i``'s ``field``: a
    nested write would neither re-render nor reach the server (see wizard_layout)."""
    return f"unc_b_rows = unc_b_rows.map((r, j) => j === i ? Object.assign({{}}, r, {{{field}: $event}}) : r)"


def _links(v: Any, html: Any, key: str, testid: str) -> None:
    with html.Div(v_if=f"{key}.length", classes="d-flex flex-wrap ga-1 mt-2", raw_attrs=tid(testid)):
        v.VBtn(
            "{{ l.name }}",
            v_for=f"l in {key}",
            key="l.url",
            href=("l.url",),
            target="_blank",
            size="small",
            variant="tonal",
            prepend_icon="mdi-download",
            raw_attrs=[':download="l.name"'],
        )


def _budget_tab(v: Any, html: Any, tplotly: Any, page: Any, ctrl: Any) -> None:
    """The GUM budget: quantity, contributions and actions; the result and its chart.
    Every field, on blur, sends the whole budget to the page (``call``)."""

    def on_change(quantity, unit, p, rows):
        page.set_budget(quantity, unit, p, rows or [])

    change = ctrl.trigger_name(on_change)
    call = f"trigger('{change}', [unc_b_quantity, unc_b_unit, unc_b_p, unc_b_rows])"

    with html.Div(v_if="unc_tab === 'budget'", classes="d-flex ga-3", raw_attrs=tid("unc-budget")):
        with html.Div(style="flex: 1 1 58%; min-width: 0;"):
            _budget_quantity(v, html, call)
            _budget_table(v, html, page, call)
            _budget_actions(v, html, page)
            v.VAlert(
                v_if="unc_b_error",
                text=("unc_b_error",),
                type="warning",
                density="compact",
                classes="mt-2",
                raw_attrs=tid("unc-b-error"),
            )
            _links(v, html, "unc_b_links", "unc-b-links")
        with html.Div(style="flex: 1 1 42%; min-width: 0;"):
            _budget_result(v, html)
            tplotly.Figure(
                state_variable_name="unc_b_fig",
                display_mode_bar=True,
                style="height: 330px;",
                raw_attrs=tid("unc-b-chart"),
            )


def _budget_quantity(v: Any, html: Any, call: str) -> None:
    """The quantity, its unit and the coverage probability."""
    with html.Div(classes="d-flex ga-2 mb-2"):
        v.VTextField(
            v_model=("unc_b_quantity", ""),
            label="Quantity",
            density="compact",
            variant="outlined",
            hide_details=True,
            blur=call,
            raw_attrs=tid("unc-b-quantity"),
        )
        v.VTextField(
            v_model=("unc_b_unit", ""),
            label="Unit",
            density="compact",
            variant="outlined",
            hide_details=True,
            style="max-width: 90px;",
            blur=call,
            raw_attrs=tid("unc-b-unit"),
        )
        v.VTextField(
            v_model=("unc_b_p", 0.95),
            label="Coverage probability",
            density="compact",
            variant="outlined",
            hide_details=True,
            style="max-width: 170px;",
            blur=call,
            raw_attrs=tid("unc-b-p"),
        )


def _budget_table(v: Any, html: Any, page: Any, call: str) -> None:
    """The contributions, one editable row each (name, u, c, dof, distribution, remove)."""

    def on_remove(i):
        page.remove_row(i)

    with v.VTable(density="compact", raw_attrs=tid("unc-b-table")):
        with html.Thead():
            with html.Tr():
                for h in ("Contribution", "u (standard)", "c (sensitivity)", "dof (∞: inf)", "Distribution", ""):
                    html.Th(h)
        with html.Tbody():
            with html.Tr(v_for="(r, i) in unc_b_rows", key="i", raw_attrs=tid("unc-b-row")):
                for field, width in (("name", "220px"), ("u", "95px"), ("c", "95px"), ("dof", "85px")):
                    with html.Td(style=f"min-width: {width};"):
                        v.VTextField(
                            model_value=(f"r.{field}",),
                            density="compact",
                            variant="plain",
                            hide_details=True,
                            update_modelValue=_row_update(field),
                            blur=call,
                            raw_attrs=[f":data-testid=\"'unc-b-{field}-' + i\"", f'@keydown.enter="{call}"'],
                        )
                with html.Td(style="min-width: 140px;"):
                    v.VSelect(
                        model_value=("r.distribution",),
                        items=("unc_b_distributions",),
                        density="compact",
                        variant="plain",
                        hide_details=True,
                        update_modelValue=_row_update("distribution") + "; " + call,
                    )
                with html.Td():
                    v.VBtn(
                        icon="mdi-delete-outline",
                        size="x-small",
                        variant="text",
                        click=(on_remove, "[i]"),
                        title="remove this contribution",
                    )


def _budget_actions(v: Any, html: Any, page: Any) -> None:
    """Add a contribution, load a budget from a file, Store & export."""

    def on_add():
        page.add_row()

    def on_store():
        page.save_budget()

    def on_file(files):
        if files:
            f = files[0] if isinstance(files, list) else files
            page.load_budget(f.get("content", b""), f.get("name", "budget.yaml"))
        page.state.unc_b_file = None

    page.state.change("unc_b_file")(lambda unc_b_file=None, **_: on_file(unc_b_file))
    with html.Div(classes="d-flex ga-2 mt-1 align-center"):
        v.VBtn(
            "Add contribution",
            prepend_icon="mdi-plus",
            size="small",
            variant="tonal",
            click=on_add,
            raw_attrs=tid("unc-b-add"),
        )
        v.VFileInput(
            v_model=("unc_b_file", None),
            label="Load a budget (YAML)",
            accept=".yaml,.yml,.json",
            density="compact",
            variant="outlined",
            hide_details=True,
            prepend_icon="mdi-file-upload",
            style="max-width: 280px;",
            raw_attrs=tid("unc-b-load"),
        )
        v.VSpacer()
        v.VBtn(
            "Store & export",
            prepend_icon="mdi-content-save",
            color="primary",
            size="small",
            click=on_store,
            disabled=("!unc_b_result",),
            raw_attrs=tid("unc-b-store"),
        )


def _budget_result(v: Any, html: Any) -> None:
    """The result: u_c, ν_eff, k (with the coverage probability) and U."""
    with v.VCard(v_if="unc_b_result", variant="tonal", color="primary", classes="mb-2", raw_attrs=tid("unc-b-result")):
        with v.VCardText(classes="py-2"):
            with html.Div(classes="d-flex flex-wrap ga-4 text-body-2"):
                html.Div(
                    "u<sub>c</sub> = <b>{{ unc_b_result.combined }}</b> {{ unc_b_result.unit }}",
                    raw_attrs=tid("unc-b-combined"),
                )
                html.Div("ν<sub>eff</sub> = <b>{{ unc_b_result.dof_eff }}</b>", raw_attrs=tid("unc-b-dof"))
                html.Div("k = <b>{{ unc_b_result.k }}</b> ({{ unc_b_result.p }})", raw_attrs=tid("unc-b-k"))
                html.Div(
                    "U = <b>{{ unc_b_result.expanded }}</b> {{ unc_b_result.unit }}",
                    raw_attrs=tid("unc-b-expanded"),
                )


def _mc_tab(v: Any, html: Any, tplotly: Any, page: Any) -> None:
    with html.Div(v_if="unc_tab === 'montecarlo'", raw_attrs=tid("unc-mc")):
        with html.Div(classes="d-flex ga-3"):
            with html.Div(style="flex: 0 0 360px; max-width: 360px;"):
                _mc_form(v, html, page)
            with html.Div(style="flex: 1 1 0; min-width: 0;"):
                _mc_table(v, html, tplotly)
        with html.Div(classes="d-flex ga-3 mt-2"):
            with html.Div(style="flex: 1 1 50%; min-width: 0;"):
                _mc_studies(v, tplotly, page)
            with html.Div(style="flex: 1 1 50%; min-width: 0;"):
                _mc_volume(v, html, page)


def _mc_form(v: Any, html: Any, page: Any) -> None:
    """The system (YAML), the run's parameters, Run / Cancel, progress and the exports."""

    async def on_run(spec, params, studies):
        await page.run_montecarlo_async(spec, {**(params or {}), "studies": studies})

    def on_cancel():
        page.cancel()

    v.VTextarea(
        v_model=("unc_mc_spec", ""),
        label="Stereo system (YAML: cameras, stereo, grid, uncertainties)",
        rows=14,
        density="compact",
        variant="outlined",
        hide_details=True,
        style="font-family: monospace; font-size: 11px;",
        disabled=("unc_mc_running",),
        raw_attrs=tid("unc-mc-spec"),
    )
    with html.Div(classes="mt-2"):
        # no hints or messages under the fields: one appearing on focus and going on blur
        # moves the Run button under the pointer between mouse down and up (the click is
        # lost); the server checks the values and names a wrong one in one line
        param_form("unc_mc_fields", "unc_mc_params", "unc-mc", disabled="unc_mc_running", hide_details=True)
    v.VSelect(
        v_model=("unc_mc_studies", []),
        items=("unc_mc_study_options",),
        label="Studies",
        multiple=True,
        chips=True,
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mt-2",
        disabled=("unc_mc_running",),
        raw_attrs=tid("unc-mc-studies"),
    )
    with html.Div(classes="d-flex ga-2 mt-2"):
        v.VBtn(
            "Run",
            color="primary",
            prepend_icon="mdi-play",
            loading=("unc_mc_running",),
            disabled=("unc_mc_running",),
            click=(on_run, "[unc_mc_spec, unc_mc_params, unc_mc_studies]"),
            raw_attrs=tid("unc-mc-run"),
        )
        v.VBtn("Cancel", v_if="unc_mc_running", variant="text", click=on_cancel, raw_attrs=tid("unc-mc-cancel"))
    with v.VProgressLinear(
        v_show="unc_mc_running || unc_mc_progress > 0",
        model_value=("unc_mc_progress",),
        height=18,
        rounded=True,
        classes="mt-2",
        color=("unc_mc_running ? 'primary' : 'success'",),
        raw_attrs=tid("unc-mc-progress"),
    ):
        html.Span("{{ Math.round(unc_mc_progress) }} %", classes="text-caption")
    html.Div("{{ unc_mc_message }}", classes="text-caption mt-1", raw_attrs=tid("unc-mc-message"))
    _links(v, html, "unc_mc_links", "unc-mc-links")


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
    ):
        for a in ("x", "y", "z"):
            v.VBtn(a, value=a, size="small")
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
            classes="mb-2",
            click_close="unc_error = ''",
            raw_attrs=tid("unc-error"),
        )
        with v.VTabs(v_model=("unc_tab", "budget"), density="compact", color="primary", classes="mb-2"):
            v.VTab("GUM budget", value="budget", raw_attrs=tid("unc-tab-budget"))
            v.VTab("Monte Carlo: stereo system", value="montecarlo", raw_attrs=tid("unc-tab-montecarlo"))
        _budget_tab(v, html, tplotly, page, ctrl)
        _mc_tab(v, html, tplotly, page)
