"""The "Photogrammetry" page's widgets around a :class:`.page.PhotogrammetryPage`.

Three columns (the page fills the main area): **left** the image series (a server
folder or the project's image items), the run form from the plugin's declared
parameters, Run (``data-shortcut="run"``) and Cancel with the stage and progress, the
figures and warnings, and "send to"; **centre** the page's own 3-D view (the cloud,
dense or sparse, with the registered cameras) and its toolbar; **right** the series as
thumbnails with the feature and match counts, unregistered images flagged with the
reason. The page's errors stand in its alert and the footer.
"""

from __future__ import annotations

from typing import Any

from ...viewtools import view_toolbar
from ...widgets import dyn_tid, param_form, run_buttons, run_progress, tid, warning_alerts
from .. import shown
from . import links
from .images_view import images_column

COLUMN = "height: calc(100vh - 48px - 24px); overflow-y: auto;"
# the inputs as the browser has them, sent with Show and Run: a click right after typing
# must not find the server's copy of a field one update behind (the page checks them all)
REQUEST = "{source: pg_source, folder: pg_folder, pattern: pg_pattern, items: pg_items, name: pg_name}"


def build(page: Any) -> None:
    """The page inside the current layout context (shown while ``page === 'photogrammetry'``)."""
    from trame.widgets import html

    with html.Div(
        v_if=shown("photogrammetry"),
        classes="d-flex",
        style="flex: 1 1 0; min-width: 0;",
        raw_attrs=tid("pg-page"),
    ):
        with html.Div(
            classes="pa-3",
            style=f"flex: 0 0 360px; max-width: 360px; border-right: 1px solid rgba(0,0,0,0.12); {COLUMN}",
            raw_attrs=tid("pg-panel"),
        ):
            _series(page)
            _run(page)
            _results(page)
            _parameters(page)
        rview = _centre(page)
        images_column()
    _wire(page, rview)


def _wire(page: Any, rview: Any) -> None:
    def changed(reset_camera: bool) -> None:
        rview.update()

    page.view.on_update = changed
    page.server.controller.pg_view_update = rview.update


def _series(page: Any) -> None:
    """The error, where the images come from, Show."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_list(req):
        page.start(page.list_async(req if isinstance(req, dict) else None))

    def on_all_items():
        page.pick_all_items()

    v.VAlert(
        v_if="pg_error",
        text=("pg_error",),
        type="error",
        density="compact",
        closable=True,
        classes="mb-2",
        click_close="pg_error = ''",
        raw_attrs=tid("pg-error"),
    )
    html.Div("Multi-view reconstruction from an image series", classes="text-subtitle-2 mb-2")
    with v.VBtnToggle(
        v_model=("pg_source",),
        mandatory=True,
        density="compact",
        variant="outlined",
        divided=True,
        color="primary",
        classes="mb-2",
        disabled=("pg_running",),
    ):
        v.VBtn("Server folder", value="folder", raw_attrs=tid("pg-source-folder"))
        v.VBtn("Project images", value="items", raw_attrs=tid("pg-source-items"))
    with html.Div(v_if="pg_source === 'folder'"):
        v.VTextField(
            v_model=("pg_folder",),
            label="Folder on the server",
            density="compact",
            variant="outlined",
            hide_details=True,
            classes="mb-2",
            disabled=("pg_running",),
            title="A folder inside the project folder or a --data-root of the server",
            raw_attrs=tid("pg-folder"),
        )
        v.VTextField(
            v_model=("pg_pattern",),
            label="Names (glob; ';' between several)",
            density="compact",
            variant="outlined",
            hide_details=True,
            classes="mb-2",
            disabled=("pg_running",),
            title="Which image files of the folder make the series, e.g. *.jpg or templeR00*",
            raw_attrs=tid("pg-pattern"),
        )
    with html.Div(v_else=True):
        v.VSelect(
            v_model=("pg_items",),
            items=("items.filter(i => i.kind === 'image')",),
            item_title="name",
            item_value="id",
            multiple=True,
            chips=True,
            closable_chips=True,
            label="Image items",
            no_data_text="no image items: import the photographs (Import in the toolbar)",
            density="compact",
            variant="outlined",
            hide_details=True,
            classes="mb-2",
            disabled=("pg_running",),
            title="The project's images that make the series",
            raw_attrs=tid("pg-items"),
        )
        v.VBtn(
            "All image items",
            size="small",
            variant="text",
            click=on_all_items,
            disabled=("pg_running",),
            title="Choose every image item of the project",
            raw_attrs=tid("pg-all-items"),
        )
    with html.Div(classes="d-flex align-center ga-2 mb-3"):
        v.VBtn(
            "Show",
            size="small",
            variant="tonal",
            prepend_icon="mdi-image-multiple",
            click=(on_list, f"[{REQUEST}]"),
            loading=("pg_listing",),
            disabled=("pg_running || pg_listing",),
            title="List the series with thumbnails (before running)",
            raw_attrs=tid("pg-list"),
        )
        html.Span("{{ pg_list_note }}", classes="text-caption", raw_attrs=tid("pg-list-note"))


def _run(page: Any) -> None:
    """Run (above the form, so it and the progress stay in view), Cancel, the stages and progress."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_run(params, req):  # started, not awaited: Cancel must reach the server meanwhile
        page.start(page.run_async(params, req if isinstance(req, dict) else None))

    def on_cancel():
        page.cancel()

    run_buttons("pg", on_run, f"[pg_params, {REQUEST}]", on_cancel, "Reconstruct the series")
    # not v_show: Vuetify's d-flex is "display: flex !important" and beats v-show's "display: none"
    with html.Div(classes=("pg_running || pg_progress > 0 ? 'd-flex flex-wrap ga-1 mt-2' : 'd-none'",)):
        v.VChip(
            "{{ st.name }}",
            v_for="st in pg_stages",
            key="st.name",
            size="x-small",
            color=("st.state === 'now' ? 'primary' : (st.state === 'done' ? 'success' : 'grey')",),
            variant=("st.state === 'todo' ? 'outlined' : 'flat'",),
            raw_attrs=dyn_tid("'pg-stage-' + st.name") + [':data-state="st.state"'],
        )
    run_progress("pg")


def _results(page: Any) -> None:
    """The figures, the warnings, send to."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_send(target):
        page.send_to(target)

    with v.VCard(v_if="pg_summary.length", variant="outlined", classes="mt-3", raw_attrs=tid("pg-result")):
        v.VCardTitle("{{ pg_title }}", classes="text-subtitle-2", style="white-space: normal;")
        with v.VCardText():
            warning_alerts("pg")
            with v.VTable(density="compact", raw_attrs=tid("pg-summary")):
                with html.Tbody():
                    with html.Tr(v_for="r in pg_summary", key="r.name"):
                        html.Td("{{ r.label }}", classes="font-weight-medium")
                        html.Td("{{ r.value }}", classes="text-right", raw_attrs=dyn_tid("'pg-num-' + r.name"))
            html.Div("Send the cloud to", classes="text-caption mt-2")
            with html.Div(classes="d-flex flex-wrap ga-1"):
                for b in links.buttons():
                    v.VBtn(
                        b["title"],
                        size="small",
                        variant="tonal",
                        append_icon="mdi-arrow-right",
                        click=(on_send, f"['{b['value']}']"),
                        disabled=("pg_running || !(pg_items_made.cloud || pg_items_made.sparse)",),
                        title=b["tip"],
                        raw_attrs=tid(f"pg-send-{b['value']}"),
                    )


def _centre(page: Any) -> Any:
    """The display (dense / sparse), the view's toolbar, the note and the view."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v
    from trame.widgets.vtk import VtkRemoteView

    def on_display(which):
        page.show_cloud(which)

    def on_colour(name):
        page.set_colour(name)

    with html.Div(classes="d-flex flex-column", style=f"flex: 1 1 0; min-width: 0; {COLUMN}"):
        with html.Div(classes="d-flex align-center flex-wrap ga-2 px-3 py-1", style="min-height: 48px;"):
            with v.VBtnToggle(
                model_value=("pg_display",),
                mandatory=True,
                density="compact",
                variant="outlined",
                divided=True,
                color="primary",
                update_modelValue=(on_display, "[$event]"),
                raw_attrs=tid("pg-display"),
            ):
                v.VBtn("Dense", value="cloud", disabled=("!pg_items_made.cloud",), raw_attrs=tid("pg-display-cloud"))
                v.VBtn(
                    "Sparse", value="sparse", disabled=("!pg_items_made.sparse",), raw_attrs=tid("pg-display-sparse")
                )
            v.VSelect(
                model_value=("pg_colour",),
                items=("pg_colours",),
                item_title="title",
                item_value="value",
                label="Colour by",
                density="compact",
                variant="outlined",
                hide_details=True,
                disabled=("!pg_colours.length",),
                style="max-width: 220px;",
                update_modelValue=(on_colour, "[$event]"),
                title="The field the points are coloured by: measured colour, views per point, quality, x/y/z",
                raw_attrs=tid("pg-colour"),
            )
            html.Span(
                "{{ pg_note }}",
                classes="text-caption",
                raw_attrs=tid("pg-note") + [':data-cameras="pg_cameras"'],
            )
        view_toolbar(page.tools, labels=False)
        with v.VCard(
            v_if="!pg_summary.length && !pg_images.length",
            variant="tonal",
            classes="ma-3",
            raw_attrs=tid("pg-empty"),
        ):
            v.VCardText("{{ pg_empty_hint }}")
        with html.Div(style="flex: 1 1 auto; min-height: 300px; position: relative;", raw_attrs=tid("pg-view")):
            rview = VtkRemoteView(
                page.view.plotter.render_window, interactive_ratio=0.5, interactive_quality=60, still_ratio=1
            )
        html.Div(
            "Orange: the registered cameras (apex at the centre, open towards what each saw)."
            " Drag to turn, wheel to zoom.",
            classes="text-caption px-3 pb-1 text-medium-emphasis",
        )
    return rview


def _parameters(page: Any) -> None:
    """The plugin's declared parameters, the calibration switch, the result's name."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("Parameters", classes="text-subtitle-2 mb-1 mt-3")
    param_form("pg_fields", "pg_params", "pg-param", disabled="pg_running", numbers=True)
    v.VSwitch(
        v_if="pg_cal_note",
        v_model=("pg_use_cal",),
        label=("'Camera fixed to ' + pg_cal_note",),
        color="primary",
        density="compact",
        hide_details=True,
        disabled=("pg_running",),
        title="Hold the camera to the project's calibration instead of self-calibrating it",
        raw_attrs=tid("pg-use-cal"),
    )
    v.VTextField(
        v_model=("pg_name",),
        label="Name of the result (optional)",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2 mt-1",
        disabled=("pg_running",),
        title="The items and the result are named after it (default: photogrammetry N images, date)",
        raw_attrs=tid("pg-name"),
    )
