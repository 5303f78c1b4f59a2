"""The "Fuse" page's widgets around a :class:`.page.FusePage`.

Three columns (the page fills the main area): **left** the inputs (the photogrammetry
cloud and the CSI height maps, project items), Run (``data-shortcut="run"``) and Cancel
with the progress, the numbers of the chosen map and the warnings, then the plugin's
declared parameters; **centre** the fused cloud coloured by source with the CSI
footprints outlined in the page's own 3-D view, with its toolbar; **right** the grey
images with the inlier matches, the difference map, its Abbott-Firestone curve with the
95 % band and its histogram. The page's errors stand in its alert and the footer.
"""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...viewtools import view_toolbar
from ...widgets import dyn_tid, param_form, run_buttons, run_progress, tid, warning_alerts
from .. import shown

COLUMN = "height: calc(100vh - 48px - 24px); overflow-y: auto;"
CLOUDS = "items.filter(i => i.kind === 'pointcloud')"
MAPS = "items.filter(i => i.kind === 'heightmap')"


def build(page: Any) -> None:
    """The page inside the current layout context (shown while ``page === 'fuse'``)."""
    from trame.widgets import html

    with html.Div(v_if=shown("fuse"), classes="d-flex", style="flex: 1 1 0; min-width: 0;", raw_attrs=tid("fu-page")):
        with html.Div(
            classes="pa-3",
            style=f"flex: 0 0 360px; max-width: 360px; border-right: 1px solid rgba(0,0,0,0.12); {COLUMN}",
            raw_attrs=tid("fu-panel"),
        ):
            _inputs(page)
            _run(page)
            _results(page)
            _parameters()
        rview = _centre(page)
        _figures()
    page.view.on_update = lambda reset_camera: rview.update()
    page.server.controller.fu_view_update = rview.update


def _inputs(page: Any) -> None:
    """The error, the cloud, the height maps, the sample pair."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    v.VAlert(
        v_if="fu_error",
        text=("fu_error",),
        type="error",
        density="compact",
        closable=True,
        classes="mb-2",
        click_close="fu_error = ''",
        raw_attrs=tid("fu-error"),
    )
    html.Div("CSI height maps onto a photogrammetry cloud (ch. 6.1)", classes="text-subtitle-2 mb-2")
    v.VSelect(
        v_model=("fu_cloud",),
        items=(CLOUDS,),
        item_title="name",
        item_value="id",
        label="Photogrammetry cloud",
        no_data_text="no point clouds: reconstruct one (Photogrammetry) or import a .ply",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("fu_running",),
        title="The cloud of the whole part; its grey image (colour, or shaded heights) is matched with each map's",
        raw_attrs=tid("fu-cloud"),
    )
    v.VSelect(
        v_model=("fu_maps",),
        items=(MAPS,),
        item_title="name",
        item_value="id",
        multiple=True,
        chips=True,
        closable_chips=True,
        label="CSI height maps",
        no_data_text="no height maps: import .dat/.opd/.plu/.x3p/.sdf (Import in the toolbar)",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("fu_running",),
        title="One or more height maps of the same part; several give one mean scale with its spread",
        raw_attrs=tid("fu-maps"),
    )

    def on_sample():
        page.load_sample()

    v.VBtn(
        "Load the sample pair",
        click=on_sample,
        variant="text",
        size="small",
        color="primary",
        prepend_icon="mdi-database-import-outline",
        disabled=("fu_running",),
        classes="mb-2",
        title="A photogrammetry cloud and a CSI height map of a synthetic coin, known by construction, "
        "that fuse at the default parameters (added to the project as two items and chosen here)",
        raw_attrs=tid("fu-sample"),
    )


def _run(page: Any) -> None:
    """Run, Cancel, the progress and the message."""

    def on_run(params):
        in_background(page.run_async(params), page.state)  # returns at once: Cancel must reach the server

    def on_cancel():
        page.cancel()

    run_buttons("fu", on_run, "[fu_params]", on_cancel, "Register the maps, fix the scale, fuse and compare")
    run_progress("fu")


def _results(page: Any) -> None:
    """The chosen map, its numbers and the run's, the warnings."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_map(k):
        page.show_map(k)

    with v.VCard(v_if="fu_numbers.length", variant="outlined", classes="mt-3", raw_attrs=tid("fu-result")):
        v.VCardTitle("{{ fu_title }}", classes="text-subtitle-2", style="white-space: normal;")
        with v.VCardText():
            warning_alerts("fu")
            v.VSelect(
                v_if="fu_map_names.length > 1",
                model_value=("fu_map",),
                items=("fu_map_names",),
                item_title="title",
                item_value="value",
                label="Height map shown",
                density="compact",
                variant="outlined",
                hide_details=True,
                classes="mb-2",
                update_modelValue=(on_map, "[$event]"),
                raw_attrs=tid("fu-map"),
            )
            with v.VTable(density="compact", raw_attrs=tid("fu-numbers")):
                with html.Tbody():
                    with html.Tr(v_for="r in fu_numbers", key="r.name"):
                        html.Td("{{ r.label }}", classes="font-weight-medium")
                        html.Td("{{ r.value }}", classes="text-right", raw_attrs=dyn_tid("'fu-num-' + r.name"))


def _parameters() -> None:
    """The plugin's declared parameters and the result's name."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("Parameters", classes="text-subtitle-2 mb-1 mt-3")
    param_form("fu_fields", "fu_params", "fu-param", disabled="fu_running", numbers=True)
    v.VTextField(
        v_model=("fu_name",),
        label="Name of the result (optional)",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2 mt-1",
        disabled=("fu_running",),
        title="The fused cloud and the result are named after it (default: the cloud's name, the map count, date)",
        raw_attrs=tid("fu-name"),
    )


def _centre(page: Any) -> Any:
    """Colour by, the note, the view's toolbar, the empty state and the view."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v
    from trame.widgets.vtk import VtkRemoteView

    def on_colour(name):
        page.set_colour(name)

    with html.Div(classes="d-flex flex-column", style=f"flex: 1 1 0; min-width: 0; {COLUMN}"):
        with html.Div(classes="d-flex align-center flex-wrap ga-2 px-3 py-1", style="min-height: 48px;"):
            v.VSelect(
                model_value=("fu_colour",),
                items=("fu_colours",),
                item_title="title",
                item_value="value",
                label="Colour by",
                density="compact",
                variant="outlined",
                hide_details=True,
                disabled=("!fu_colours.length",),
                style="max-width: 220px;",
                update_modelValue=(on_colour, "[$event]"),
                title="source: 0 photogrammetry, k = CSI map k; or the measured colour, x/y/z",
                raw_attrs=tid("fu-colour"),
            )
            html.Span(
                "{{ fu_note }}", classes="text-caption", raw_attrs=tid("fu-note") + [':data-outlines="fu_outlines"']
            )
        view_toolbar(page.tools, labels=False)
        with v.VCard(v_if="!fu_numbers.length", variant="tonal", classes="ma-3", raw_attrs=tid("fu-empty")):
            v.VCardText("{{ fu_empty_hint }}")
        with html.Div(style="flex: 1 1 auto; min-height: 300px; position: relative;", raw_attrs=tid("fu-view")):
            rview = VtkRemoteView(
                page.view.plotter.render_window, interactive_ratio=0.5, interactive_quality=60, still_ratio=1
            )
        html.Div(
            "The fused cloud (in the first map's frame); orange: each CSI map's footprint."
            " Drag to turn, wheel to zoom.",
            classes="text-caption px-3 pb-1 text-medium-emphasis",
        )
    return rview


def _figures() -> None:
    """The matches, the difference map, the Abbott-Firestone curve, the histogram."""
    from trame.widgets import html

    with html.Div(
        v_show="fu_numbers.length",
        classes="pa-2",
        style=f"flex: 1 1 0; min-width: 0; border-left: 1px solid rgba(0,0,0,0.12); {COLUMN}",
        raw_attrs=tid("fu-figures"),
    ):
        _chart("height: 34vh; min-height: 240px;", "fu-matches", "fu_fig_matches")
        _chart("height: 34vh; min-height: 240px;", "fu-difference", "fu_fig_diff")
        _chart("height: 30vh; min-height: 220px;", "fu-abbott", "fu_fig_abbott")
        _chart("height: 26vh; min-height: 200px;", "fu-histogram", "fu_fig_hist")


def _chart(style: str, testid: str, figure: str) -> None:
    """A plotly chart bound to the state variable ``figure``."""
    from trame.widgets import html
    from trame.widgets import plotly as tplotly

    with html.Div(style=style, raw_attrs=tid(testid)):
        tplotly.Figure(state_variable_name=figure, display_mode_bar=False, display_logo=False)
