"""The "Calibration" page's widgets, around a :class:`.page.CalibrationPage`.

Left, the inputs: one camera or a stereo pair; the board images from the project's
image items, an upload (which becomes image items) or a folder on the server; the board
spec with its one-line explanation, the distortion model and the outlier factor; Run
with progress and Cancel; then the downloads and "use this calibration" for a measuring
system with the project's systems and their calibrations. Right, the results: the
summary, the image list (thumbnails with the board drawn, found / not found / left out
with the reason and each view's RMS), the selected image with its detected board, the
per-view error chart, the numbers with standard deviations, the projection-uncertainty
heat map at a working distance, and for a pair its pose, the epipolar statistics and
the rectified pair with horizontal epipolar lines.
"""

from __future__ import annotations

from typing import Any

from ...widgets import dyn_tid, tid
from .. import shown
from .inputs import IMAGE_EXTS

RUN_ARGS = (
    "[{mode: cal_mode, source: cal_source, left: cal_left_items, right: cal_right_items, folder: cal_folder, "
    "left_pattern: cal_left_pattern, right_pattern: cal_right_pattern, board: cal_board, model: cal_model, "
    "outlier_factor: cal_outlier, name: cal_name}]"
)
BOARD_HINT = "cal_board_hints[(cal_board || '').split(':')[0].trim().toLowerCase()] || cal_board_hints['']"
STATUS_COLOURS = "({'used': 'success', 'left out': 'warning', 'not found': 'error'})[r.status]"
CARD = "mb-3"
MAP_TEXT = (
    "The map gives, for a point at the working distance seen at each pixel, the standard deviation of its "
    "projection that the calibration's own uncertainty causes (worst direction, propagated from the "
    "covariance of the intrinsics and the board poses as mrcal does). It is small where the boards were "
    "(white dots) and grows where they never reached: take more views there, or measure only inside."
)


def _image_select(v: Any, html: Any, model: str, label: str, testid: str) -> None:
    """A multiple choice among the project's image items; ``label`` is a JS expression."""
    with v.VSelect(
        v_model=(model, []),
        items=("items.filter(i => i.kind === 'image')",),
        item_title="name",
        item_value="id",
        label=(label,),
        multiple=True,
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("cal_running",),
        raw_attrs=tid(testid),
    ):
        with v.Template(v_slot_selection="{ item, index }"):
            v.VChip("{{ item.title }}", v_if="index < 2", size="small")
            html.Span(f"(+{{{{ {model}.length - 2 }}}} more)", v_if="index === 2", classes="text-caption ml-1")


def _inputs(v: Any, html: Any, page: Any) -> None:
    async def on_run(req):
        await page.run_async(req or {})

    def on_cancel():
        page.cancel()

    def on_pick():
        page.pick_by_name()

    def uploaded(side):
        def handler(**kw):
            files = kw.get(f"cal_upload_{side}")
            if files:
                page.add_uploads(files, side)
                page.state[f"cal_upload_{side}"] = None

        return handler

    page.state.change("cal_upload_left")(uploaded("left"))
    page.state.change("cal_upload_right")(uploaded("right"))
    stereo = "cal_mode === 'stereo'"
    with v.VCard(variant="outlined", classes=CARD, raw_attrs=tid("cal-inputs")):
        with v.VCardText():
            with v.VBtnToggle(
                v_model=("cal_mode", "camera"),
                mandatory=True,
                density="compact",
                color="primary",
                divided=True,
                classes="mb-3",
                disabled=("cal_running",),
            ):
                v.VBtn("One camera", value="camera", prepend_icon="mdi-camera", raw_attrs=tid("cal-mode-camera"))
                v.VBtn("Stereo pair", value="stereo", prepend_icon="mdi-camera-burst", raw_attrs=tid("cal-mode-stereo"))
            with v.VBtnToggle(
                v_model=("cal_source", "items"),
                mandatory=True,
                density="compact",
                divided=True,
                variant="outlined",
                color="primary",
                classes="mb-3 d-flex",
                disabled=("cal_running",),
            ):
                v.VBtn(
                    "Project",
                    value="items",
                    prepend_icon="mdi-image-multiple-outline",
                    size="small",
                    title="the project's image items",
                    raw_attrs=tid("cal-source-items"),
                )
                v.VBtn(
                    "Upload",
                    value="upload",
                    prepend_icon="mdi-upload",
                    size="small",
                    raw_attrs=tid("cal-source-upload"),
                )
                v.VBtn(
                    "Folder",
                    value="folder",
                    prepend_icon="mdi-folder-outline",
                    size="small",
                    title="a folder on the server",
                    raw_attrs=tid("cal-source-folder"),
                )
            with html.Div(v_if="cal_source === 'items'"):
                _image_select(v, html, "cal_left_items", f"{stereo} ? 'Left images' : 'Images'", "cal-left-items")
                with html.Div(v_if=stereo):
                    _image_select(v, html, "cal_right_items", "'Right images (same order)'", "cal-right-items")
                v.VBtn(
                    (
                        "{{ " + stereo + " ? 'Split the image items by name: left… / right…' : "
                        "'All image items of the project' }}"
                    ),
                    size="small",
                    variant="tonal",
                    prepend_icon="mdi-auto-fix",
                    click=on_pick,
                    disabled=("cal_running",),
                    raw_attrs=tid("cal-pick"),
                )
            with html.Div(v_if="cal_source === 'upload'"):
                html.Div("Uploaded images become image items of the project.", classes="text-caption mb-2")
                for side, label in (("left", f"{stereo} ? 'Left images' : 'Images'"), ("right", "'Right images'")):
                    extra = {"v_if": stereo} if side == "right" else {}
                    v.VFileInput(
                        v_model=(f"cal_upload_{side}", None),
                        **extra,
                        label=(label,),
                        multiple=True,
                        accept=",".join(IMAGE_EXTS),
                        density="compact",
                        variant="outlined",
                        hide_details=True,
                        classes="mb-2",
                        prepend_icon="mdi-image-multiple",
                        disabled=("cal_running",),
                        raw_attrs=tid(f"cal-upload-{side}"),
                    )
            with html.Div(v_if="cal_source === 'folder'"):
                v.VTextField(
                    v_model=("cal_folder", ""),
                    label="Folder on the server",
                    density="compact",
                    variant="outlined",
                    hide_details=True,
                    classes="mb-2",
                    disabled=("cal_running",),
                    placeholder="/data/calibration/2024-05-02",
                    raw_attrs=tid("cal-folder"),
                )
                with html.Div(classes="d-flex ga-2 mb-2"):
                    v.VTextField(
                        v_model=("cal_left_pattern", "*"),
                        label=(f"{stereo} ? 'Left images (glob)' : 'Images (glob)'",),
                        density="compact",
                        variant="outlined",
                        hide_details=True,
                        disabled=("cal_running",),
                        raw_attrs=tid("cal-left-pattern"),
                    )
                    v.VTextField(
                        v_if=stereo,
                        v_model=("cal_right_pattern", "right*"),
                        label="Right images (glob)",
                        density="compact",
                        variant="outlined",
                        hide_details=True,
                        disabled=("cal_running",),
                        raw_attrs=tid("cal-right-pattern"),
                    )
            v.VTextField(
                v_model=("cal_board", "chessboard:9x6:25"),
                label="Board",
                density="compact",
                variant="outlined",
                persistent_hint=True,
                hint=(BOARD_HINT,),
                classes="mt-1 mb-2",
                disabled=("cal_running",),
                raw_attrs=tid("cal-board"),
            )
            with html.Div(classes="d-flex ga-2 mb-2"):
                v.VSelect(
                    v_model=("cal_model", "standard"),
                    items=("cal_models",),
                    item_title="title",
                    item_value="value",
                    label="Distortion model",
                    density="compact",
                    variant="outlined",
                    hide_details=True,
                    disabled=("cal_running",),
                    raw_attrs=tid("cal-model"),
                )
                v.VTextField(
                    v_model=("cal_outlier", 3.0),
                    label="Outlier × median",
                    type="number",
                    min=0,
                    step="0.5",
                    density="compact",
                    variant="outlined",
                    hide_details=True,
                    style="max-width: 130px;",
                    disabled=("cal_running",),
                    title="Leave out views whose RMS exceeds this times the median (0 keeps all)",
                    raw_attrs=tid("cal-outlier"),
                )
            v.VTextField(
                v_model=("cal_name", ""),
                label="Name of the calibration (optional)",
                density="compact",
                variant="outlined",
                hide_details=True,
                disabled=("cal_running",),
                raw_attrs=tid("cal-name"),
            )
            with html.Div(classes="d-flex ga-2 mt-3"):
                v.VBtn(
                    "Calibrate",
                    color="primary",
                    prepend_icon="mdi-play",
                    loading=("cal_running",),
                    disabled=("cal_running",),
                    click=(on_run, RUN_ARGS),
                    raw_attrs=tid("cal-run"),
                )
                v.VBtn("Cancel", v_if="cal_running", variant="text", click=on_cancel, raw_attrs=tid("cal-cancel"))
            with v.VProgressLinear(
                v_show="cal_running || cal_progress > 0",
                model_value=("cal_progress",),
                height=18,
                rounded=True,
                classes="mt-2",
                color=("cal_running ? 'primary' : 'success'",),
                raw_attrs=tid("cal-progress"),
            ):
                html.Span("{{ Math.round(cal_progress) }} %", classes="text-caption")
            html.Div("{{ cal_message }}", classes="text-caption mt-1", raw_attrs=tid("cal-message"))


def _save(v: Any, html: Any, page: Any) -> None:
    def on_use(target, name):
        page.use_calibration(target, name)

    with v.VCard(v_if="cal_summary", variant="outlined", classes=CARD, raw_attrs=tid("cal-save")):
        v.VCardTitle("Save and use", classes="text-subtitle-2 pb-0")
        with v.VCardText():
            html.Div(
                "Stored in the project as result #{{ cal_summary.result }}: “{{ cal_summary.name }}”.",
                classes="text-caption mb-1",
            )
            with html.Div(v_if="cal_links.length", classes="d-flex flex-wrap ga-1 mb-3", raw_attrs=tid("cal-links")):
                v.VBtn(
                    "{{ l.name }}",
                    v_for="l in cal_links",
                    key="l.url",
                    href=("l.url",),
                    target="_blank",
                    size="x-small",
                    variant="tonal",
                    prepend_icon="mdi-download",
                    raw_attrs=[':download="l.name"'],
                )
            v.VSelect(
                v_model=("cal_system_target", "new"),
                items=("cal_system_options",),
                item_title="title",
                item_value="value",
                label="Use this calibration for",
                density="compact",
                variant="outlined",
                hide_details=True,
                classes="mb-2",
                raw_attrs=tid("cal-system-target"),
            )
            v.VTextField(
                v_if="cal_system_target === 'new'",
                v_model=("cal_system_name", ""),
                label="Name of the new measuring system",
                density="compact",
                variant="outlined",
                hide_details=True,
                classes="mb-2",
                raw_attrs=tid("cal-system-name"),
            )
            v.VBtn(
                "Use this calibration",
                color="primary",
                variant="tonal",
                prepend_icon="mdi-link-variant",
                click=(on_use, "[cal_system_target, cal_system_name]"),
                raw_attrs=tid("cal-use"),
            )
            with v.VTable(v_if="cal_systems.length", density="compact", classes="mt-2", raw_attrs=tid("cal-systems")):
                with html.Thead():
                    with html.Tr():
                        html.Th("Measuring system")
                        html.Th("uses calibration")
                with html.Tbody():
                    with html.Tr(
                        v_for="sy in cal_systems", key="sy.id", classes=("sy.current ? 'font-weight-bold' : ''",)
                    ):
                        html.Td("#{{ sy.id }} {{ sy.name }}", classes="text-body-2")
                        with html.Td(classes="text-body-2"):
                            with html.Div():
                                html.Span("{{ sy.calibration || '—' }}")
                                v.VChip(
                                    "shown",
                                    v_if="sy.current",
                                    size="x-small",
                                    color="primary",
                                    classes="ml-1",
                                    title="the calibration shown on this page",
                                )
                            html.Div(
                                "{{ sy.file }}",
                                v_if="sy.file",
                                classes="text-caption text-medium-emphasis",
                                style="font-family: monospace;",
                                title="the calibration file's hash",
                            )


def _image_list(v: Any, html: Any, page: Any) -> None:
    async def on_select(name):
        await page.select_image_async(name)

    with html.Div(classes="d-flex ga-3 mb-3", style="min-height: 0;"):
        with v.VCard(variant="outlined", style="flex: 0 0 430px; max-width: 430px;", raw_attrs=tid("cal-images")):
            v.VCardTitle("Images ({{ cal_rows.length }})", classes="text-subtitle-2 pb-0")
            with html.Div(style="max-height: 470px; overflow-y: auto;"):
                with v.VTable(density="compact", hover=True):
                    with html.Tbody():
                        with html.Tr(
                            v_for="r in cal_rows",
                            key="r.name",
                            click=(on_select, "[r.name]"),
                            style="cursor: pointer;",
                            classes=("r.name === cal_selected ? 'bg-blue-lighten-5' : ''",),
                            raw_attrs=tid("cal-image-row") + [':data-status="r.status"'],
                        ):
                            with html.Td(style="width: 104px; padding: 4px;"):
                                html.Img(v_if="r.thumb", src=("r.thumb",), style="width: 96px; display: block;")
                            with html.Td():
                                html.Div("{{ r.name }}", classes="text-body-2")
                                v.VChip(
                                    "{{ r.status }}",
                                    size="x-small",
                                    color=(STATUS_COLOURS,),
                                    variant="flat",
                                    classes="mr-1",
                                )
                                html.Span("{{ r.rms_text }} px", v_if="r.rms !== null", classes="text-caption")
                                html.Div("{{ r.reason }}", v_if="r.reason", classes="text-caption text-medium-emphasis")
        with v.VCard(variant="outlined", style="flex: 1 1 0; min-width: 0;", raw_attrs=tid("cal-overlay")):
            v.VCardTitle("{{ cal_selected || 'Image' }}", classes="text-subtitle-2 pb-0")
            with v.VCardText():
                html.Img(
                    v_if="cal_overlay",
                    src=("cal_overlay",),
                    style="max-width: 100%; max-height: 430px;",
                    raw_attrs=tid("cal-overlay-img"),
                )
                html.Div("{{ cal_overlay_note }}", classes="text-caption", raw_attrs=tid("cal-overlay-note"))


def _results(v: Any, html: Any, tplotly: Any, page: Any) -> None:
    @page.state.change("cal_side")
    def on_side(cal_side=None, **_):
        if page.doc is not None and cal_side and cal_side != page.shown_side:
            page.show_side(cal_side)

    async def on_distance(d):
        await page.set_distance_async(d)

    async def on_pair(i):
        await page.show_pair_async(i)

    with html.Div(v_if="cal_summary", raw_attrs=tid("cal-results")):
        with html.Div(classes="d-flex flex-wrap align-center ga-2 mb-3", raw_attrs=tid("cal-summary")):
            v.VChip(
                "RMS {{ cal_summary.rms }} px", color="primary", variant="flat", size="small", raw_attrs=tid("cal-rms")
            )
            v.VChip("{{ cal_summary.views }}", size="small", variant="tonal")
            v.VChip("{{ cal_summary.image_size }} px", size="small", variant="tonal")
            v.VChip(
                "baseline {{ cal_summary.baseline }}",
                v_if="cal_summary.baseline",
                size="small",
                variant="tonal",
                color="secondary",
                raw_attrs=tid("cal-baseline"),
            )
            v.VChip("{{ cal_summary.board }} · {{ cal_summary.model }}", size="small", variant="outlined")
            v.VSpacer()
            with v.VBtnToggle(
                v_if="cal_sides.length > 1",
                v_model=("cal_side", "left"),
                mandatory=True,
                density="compact",
                color="primary",
                variant="outlined",
                divided=True,
            ):
                v.VBtn("Left camera", value="left", size="small", raw_attrs=tid("cal-side-left"))
                v.VBtn("Right camera", value="right", size="small", raw_attrs=tid("cal-side-right"))
        with v.VAlert(
            v_if="cal_warnings.length",
            type="warning",
            variant="tonal",
            density="compact",
            classes="mb-3",
            raw_attrs=tid("cal-warnings"),
        ):
            html.Div("{{ w }}", v_for="(w, i) in cal_warnings", key="i", classes="text-body-2")
        _image_list(v, html, page)
        with html.Div(classes="d-flex align-start ga-3 mb-3"):
            with v.VCard(variant="outlined", style="flex: 1 1 0; min-width: 0;"):
                tplotly.Figure(
                    state_variable_name="cal_fig_views",
                    display_mode_bar=True,
                    style="height: 440px;",
                    raw_attrs=tid("cal-chart"),
                )
            with v.VCard(
                variant="outlined",
                style="flex: 0 0 400px; max-height: 440px; overflow-y: auto;",
                raw_attrs=tid("cal-numbers"),
            ):
                v.VCardTitle(
                    "Intrinsics, {{ (cal_sides.find(x => x.value === cal_side) || {}).title }}",
                    classes="text-subtitle-2 pb-0",
                )
                with v.VTable(density="compact"):
                    with html.Thead():
                        with html.Tr():
                            for h, cls in (("", ""), ("value", "text-right"), ("σ", "text-right"), ("", "")):
                                html.Th(h, classes=cls)
                    with html.Tbody():
                        with html.Tr(v_for="n in cal_numbers", key="n.name", raw_attrs=dyn_tid("'cal-num-' + n.name")):
                            html.Td("{{ n.name }}", classes="font-weight-medium")
                            html.Td("{{ n.value }}", classes="text-right")
                            html.Td("{{ n.std ? '± ' + n.std : '' }}", classes="text-right text-medium-emphasis")
                            html.Td("{{ n.unit }}")
        with html.Div(classes="d-flex ga-3 mb-3"):
            with v.VCard(variant="outlined", style="flex: 0 1 680px; min-width: 0;", raw_attrs=tid("cal-heatmap")):
                with html.Div(classes="d-flex align-center ga-2 px-3 pt-2"):
                    v.VTextField(
                        v_model=("cal_distance", 1000.0),
                        label="Working distance",
                        suffix="mm",
                        type="number",
                        min=0,
                        density="compact",
                        variant="outlined",
                        hide_details=True,
                        style="max-width: 190px;",
                        change=(on_distance, "[cal_distance]"),
                        raw_attrs=tid("cal-distance"),
                    )
                    html.Span("{{ cal_map_note }}", classes="text-caption", raw_attrs=tid("cal-map-note"))
                tplotly.Figure(
                    state_variable_name="cal_fig_map",
                    display_mode_bar=True,
                    style="height: 470px;",
                    raw_attrs=tid("cal-map"),
                )
            with html.Div(style="flex: 1 1 0; min-width: 0;"):
                _stereo(v, html)
                with v.VCard(variant="tonal", classes="mt-3"):
                    v.VCardText(MAP_TEXT, classes="text-caption")
        with v.VCard(v_if="cal_pairs.length", variant="outlined", classes=CARD, raw_attrs=tid("cal-rectified")):
            with html.Div(classes="d-flex align-center ga-2 px-3 pt-2"):
                html.Span("Rectified pair", classes="text-subtitle-2")
                v.VSelect(
                    model_value=("cal_pair",),
                    items=("cal_pairs",),
                    item_title="title",
                    item_value="value",
                    density="compact",
                    variant="outlined",
                    hide_details=True,
                    style="max-width: 320px;",
                    update_modelValue=(on_pair, "[$event]"),
                    raw_attrs=tid("cal-pair"),
                )
            with v.VCardText():
                html.Img(
                    v_if="cal_rectified",
                    src=("cal_rectified",),
                    style="max-width: 100%;",
                    raw_attrs=tid("cal-rectified-img"),
                )
                html.Div("{{ cal_rectified_note }}", classes="text-caption", raw_attrs=tid("cal-rectified-note"))
    with html.Div(v_else=True, classes="text-body-2 text-medium-emphasis pa-6"):
        html.Div(
            "Choose the board images on the left and press Calibrate: the image list with the detected "
            "corners, each view's reprojection error, the numbers with their standard deviations and the "
            "projection uncertainty across the image appear here."
        )


def _stereo(v: Any, html: Any) -> None:
    with v.VCard(v_if="cal_stereo_rows.length", variant="outlined", raw_attrs=tid("cal-stereo")):
        v.VCardTitle("Right camera in the left: x_r = R x_l + T", classes="text-subtitle-2 pb-0")
        with v.VTable(density="compact"):
            with html.Tbody():
                with html.Tr(v_for="n in cal_stereo_rows", key="n.name"):
                    html.Td("{{ n.name }}", classes="font-weight-medium")
                    html.Td("{{ n.value }}", classes="text-right")
                    html.Td("{{ n.std ? '± ' + n.std : '' }}", classes="text-right text-medium-emphasis")
                    html.Td("{{ n.unit }}")


def build(page: Any) -> None:
    """The page inside the current layout context (shown while it is the page shown)."""
    from trame.widgets import html
    from trame.widgets import plotly as tplotly
    from trame.widgets import vuetify3 as v

    with html.Div(
        v_if=shown("calibration"),
        classes="pa-3 d-flex ga-3",
        raw_attrs=tid("calibration"),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); overflow-y: auto;",
    ):
        with html.Div(style="flex: 0 0 380px; max-width: 380px;"):
            _inputs(v, html, page)
            _save(v, html, page)
        with html.Div(style="flex: 1 1 0; min-width: 0;"):
            v.VAlert(
                v_if="cal_error",
                text=("cal_error",),
                type="error",
                density="compact",
                closable=True,
                classes="mb-2",
                click_close="cal_error = ''",
                raw_attrs=tid("cal-error"),
            )
            _results(v, html, tplotly, page)
