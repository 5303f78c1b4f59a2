"""The Inspect page's widgets: the drawer (items, plugins, the plugin's form, results)
and the main area (colour field, the 3D view, the result panel)."""

from __future__ import annotations

from typing import Any

from ...widgets import dyn_tid, param_form, tid


def _items(page: Any) -> None:
    from trame.widgets import vuetify3 as v

    with v.VList(density="compact", nav=True, raw_attrs=tid("items")):
        v.VListSubheader("Items in the project ({{ items.length }})")
        v.VListItem(
            v_for="item in items",
            key="item.id",
            title=("item.name",),
            subtitle=("item.subtitle",),
            active=("item.id === selected_item",),
            color="primary",
            prepend_icon=(
                "item.kind === 'mesh' ? 'mdi-vector-triangle' : "
                "(item.kind === 'image' ? 'mdi-image' : 'mdi-dots-hexagon')",
            ),
            click=(page.select_item, "[item.id]"),
            classes="item-row",
            raw_attrs=tid("item"),
        )
        v.VListItem(v_if="!items.length", subtitle="No items yet: import a file above.")


def _plugins(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VList(density="compact", nav=True, raw_attrs=tid("plugins")):
        v.VListSubheader("Plugins ({{ plugins.length }})")
        with v.VListItem(
            v_for="p in plugins",
            key="p.id",
            active=("p.id === selected_plugin",),
            color="primary",
            disabled=("!p.runnable && p.ok",),
            click=(page.select_plugin, "[p.id]"),
            classes="plugin-row",
            raw_attrs=tid("plugin") + [':data-plugin-id="p.id"'],
        ):
            v.VListItemTitle("{{ p.name }}")
            v.VListItemSubtitle("{{ p.id }} · v{{ p.version }}")
            with html.Div(classes="d-flex ga-1 mt-1"):
                v.VChip("{{ p.kind }}", size="x-small", variant="tonal", color="secondary")
                v.VChip(
                    "{{ p.ok ? 'ok' : 'failed' }}",
                    size="x-small",
                    variant="flat",
                    color=("p.ok ? 'success' : 'error'",),
                )
            html.Div("{{ p.status }}", v_if="!p.ok", classes="text-caption text-error", raw_attrs=tid("plugin-error"))
        v.VListItem(v_if="!plugins.length", subtitle="No plugins installed.")


def _form(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(v_if="selected_plugin", classes="pa-3", raw_attrs=tid("plugin-form")):
        html.Div("{{ plugin_title }}", classes="text-subtitle-2")
        html.Div("{{ plugin_summary }}", classes="text-caption mb-2")
        with html.Template(v_for="inp in form_inputs", key="inp.name"):
            v.VSelect(
                v_if="inp.supported",
                v_model="input_values[inp.name]",
                items=("inp.options",),
                label=("inp.label",),
                hint=("inp.help",),
                density="compact",
                variant="outlined",
                classes="mb-1",
                raw_attrs=dyn_tid("'input-' + inp.name"),
            )
            v.VTextField(
                v_else=True,
                v_model="input_values[inp.name]",
                label=("inp.label + ' — path on the server'",),
                density="compact",
                variant="outlined",
                raw_attrs=dyn_tid("'input-' + inp.name"),
            )
        param_form("form_fields", "form_values", "param")
        with html.Div(classes="d-flex ga-2 mt-1"):
            v.VBtn(
                "Run",
                color="primary",
                prepend_icon="mdi-play",
                click=(page.run_form, "[selected_plugin, form_values, input_values]"),
                disabled=("running",),
                loading=("running",),
                raw_attrs=tid("run-button"),
            )
            v.VBtn("Cancel", v_if="running", variant="text", click=page.cancel, raw_attrs=tid("cancel-button"))
        with v.VProgressLinear(
            v_show="running || progress > 0",
            model_value=("progress",),
            indeterminate=("running && progress <= 0",),
            height=18,
            color=("running ? 'primary' : 'success'",),
            classes="mt-2",
            rounded=True,
            raw_attrs=tid("progress"),
        ):
            html.Span("{{ progress_message }} {{ Math.round(progress) }} %", classes="text-caption")
    html.Div("Choose an algorithm or standard plugin above to see its form.", v_else=True, classes="pa-3 text-caption")


def _results(page: Any) -> None:
    from trame.widgets import vuetify3 as v

    with v.VList(density="compact", nav=True, raw_attrs=tid("results")):
        v.VListSubheader("Results in the project ({{ results.length }})")
        v.VListItem(
            v_for="r in results",
            key="r.id",
            title=("'#' + r.id + ' ' + r.plugin",),
            subtitle=("r.time",),
            click=(page.show_result, "[r.id]"),
            classes="result-row",
            raw_attrs=tid("result-row"),
        )


def drawer(page: Any) -> None:
    """The side drawer: items, plugins, the selected plugin's form, results."""
    from trame.widgets import vuetify3 as v

    _items(page)
    v.VDivider()
    _plugins(page)
    v.VDivider()
    _form(page)
    v.VDivider()
    _results(page)


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
            raw_attrs=tid("color-field"),
        )
        v.VChip(
            "legend: {{ legend_title }}",
            v_if="legend_title",
            size="small",
            prepend_icon="mdi-palette",
            raw_attrs=tid("legend-title"),
        )
        html.Span("{{ display_note }}", classes="text-caption", raw_attrs=tid("display-note"))


def _view(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets.vtk import VtkRemoteView

    ctrl, view = page.server.controller, page.session.view
    with html.Div(style="flex: 1 1 auto; min-height: 300px; position: relative;", raw_attrs=tid("view")):
        # trame-vtk's view on the render window, not trame-pyvista's: that one pushes an
        # image on every pyvista render() (about five per scene change); this one pushes
        # once, when view_changed below calls ctrl.view_update for a complete scene.
        rview = VtkRemoteView(view.plotter.render_window, interactive_ratio=0.5, interactive_quality=60, still_ratio=1)
        ctrl.view_update = rview.update
        ctrl.view_reset_camera = rview.reset_camera

    def view_changed(reset_camera: bool) -> None:
        if reset_camera:
            view.plotter.reset_camera()
        ctrl.view_update()

    view.on_update = view_changed


def _result_panel() -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VCard(
        v_if="result || result_warnings.length",
        classes="ma-2",
        variant="outlined",
        style="max-height: 34vh; overflow: auto;",
        raw_attrs=tid("result-panel"),
    ):
        v.VCardTitle("{{ result_title }}", classes="text-subtitle-1")
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
            with v.VTable(density="compact", raw_attrs=tid("result-table")):
                with html.Tbody():
                    with html.Tr(v_for="r in result_rows", key="r.name"):
                        html.Td("{{ r.name }}", classes="font-weight-medium")
                        html.Td("{{ r.value }}", classes="text-right", raw_attrs=dyn_tid("'result-' + r.name"))
                        html.Td("{{ r.unit }}")
            with v.VExpansionPanels(classes="mt-2"):
                with v.VExpansionPanel(title="Result JSON (as stored)"):
                    with v.VExpansionPanelText():
                        html.Pre(
                            "{{ JSON.stringify(result, null, 2) }}", style="font-size: 11px; white-space: pre-wrap;"
                        )


def build(page: Any) -> None:
    """The main area: the 3D view with its colour field and the result panel. The view
    stays alive on every page (hidden, not removed, on pages that fill the area) and
    sits right of the pages that share the area with it."""
    from trame.widgets import html

    with html.Div(
        classes=("full_pages.includes(page) ? 'd-none' : 'd-flex flex-column'",),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); order: 1;",
    ):
        _colour_bar()
        _view(page)
        _result_panel()
