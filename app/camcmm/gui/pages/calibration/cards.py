"""The Calibration page's cards shown once there is a calibration (see :mod:`.layout`).

Left, under the inputs, "Save and use": where it is stored, the downloads and the
measuring systems. Right, the results: the summary, the image list with the selected
image, the per-view error chart and the numbers, the projection-uncertainty heat map,
and for a pair its pose and the rectified pair. One function per card or section of a
card, each with the handlers it wires.
"""

from __future__ import annotations

from typing import Any

from ...widgets import dyn_tid, tid

CARD = "mb-3"
#: a number row's value with its unit, and its standard deviation with its own (µm for a
#: length's below 1 mm: the number rule); the degree sign follows the number unspaced
VALUE = "{{ n.value + (n.unit === '°' ? '°' : (n.unit ? ' ' + n.unit : '')) }}"
STD = "{{ n.std ? '± ' + n.std + (n.std_unit === '°' ? '°' : (n.std_unit ? ' ' + n.std_unit : '')) : '' }}"
STATUS_COLOURS = "({'used': 'success', 'left out': 'warning', 'not found': 'error'})[r.status]"
MAP_TEXT = (
    "The map gives, for a point at the working distance seen at each pixel, the standard deviation of its "
    "projection that the calibration's own uncertainty causes (worst direction, propagated from the "
    "covariance of the intrinsics and the board poses as mrcal does). It is small where the boards were "
    "(white dots) and grows where they never reached: take more views there, or measure only inside."
)


# -- left, under the inputs: save and use ----------------------------------------------------------


def save(v: Any, html: Any, page: Any) -> None:
    """The "Save and use" card: where it is stored, the downloads, the measuring systems."""
    with v.VCard(v_if="cal_summary", variant="outlined", classes=CARD, raw_attrs=tid("cal-save")):
        v.VCardTitle("Save and use", classes="text-subtitle-2 pb-0")
        with v.VCardText():
            html.Div(
                "Stored in the project as result #{{ cal_summary.result }}: “{{ cal_summary.name }}”.",
                classes="text-caption mb-1",
            )
            _downloads(v, html)
            _use_for_system(v, page)
            _systems_table(v, html)


def _downloads(v: Any, html: Any) -> None:
    """A download button per file of the calibration."""
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
            title=("l.title || 'Download ' + l.name",),
            raw_attrs=[':download="l.name"'],
        )


def _use_for_system(v: Any, page: Any) -> None:
    """The measuring system (or a new one, named) that is to use this calibration."""

    def on_use(target, name):
        page.use_calibration(target, name)

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
        title="The measuring system that is to use this calibration, or a new one",
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
        title="The name of the measuring system to make",
        raw_attrs=tid("cal-system-name"),
    )
    v.VBtn(
        "Use this calibration",
        color="primary",
        variant="tonal",
        prepend_icon="mdi-link-variant",
        click=(on_use, "[cal_system_target, cal_system_name]"),
        title="Link this calibration to the measuring system (acceptance tests and measurements use it)",
        raw_attrs=tid("cal-use"),
    )


def _systems_table(v: Any, html: Any) -> None:
    """The project's measuring systems and the calibration each uses."""
    with v.VTable(v_if="cal_systems.length", density="compact", classes="mt-2", raw_attrs=tid("cal-systems")):
        with html.Thead():
            with html.Tr():
                html.Th("Measuring system")
                html.Th("uses calibration")
        with html.Tbody():
            with html.Tr(v_for="sy in cal_systems", key="sy.id", classes=("sy.current ? 'font-weight-bold' : ''",)):
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


# -- right: the results ----------------------------------------------------------------------------


def results(v: Any, html: Any, tplotly: Any, page: Any) -> None:
    """The results of the calibration shown, or what to do to get one."""
    with html.Div(v_if="cal_summary", raw_attrs=tid("cal-results")):
        _summary(v, html, page)
        _warnings(v, html)
        _image_list(v, html, page)
        _chart_and_numbers(v, html, tplotly)
        with html.Div(classes="d-flex ga-3 mb-3"):
            _heat_map(v, html, tplotly, page)
            with html.Div(style="flex: 1 1 0; min-width: 0;"):
                _stereo(v, html)
                with v.VCard(variant="tonal", classes="mt-3"):
                    v.VCardText(MAP_TEXT, classes="text-caption")
        _rectified(v, html, page)
    with html.Div(v_else=True, classes="text-body-2 text-medium-emphasis pa-6"):
        html.Div(
            "Choose the board images on the left and press Calibrate: the image list with the detected "
            "corners, each view's reprojection error, the numbers with their standard deviations and the "
            "projection uncertainty across the image appear here."
        )


def _summary(v: Any, html: Any, page: Any) -> None:
    """RMS, views, image size, baseline, board and model; for a pair, the camera shown."""

    @page.state.change("cal_side")
    def on_side(cal_side=None, **_):
        if page.doc is not None and cal_side and cal_side != page.shown_side:
            page.show_side(cal_side)

    with html.Div(classes="d-flex flex-wrap align-center ga-2 mb-3", raw_attrs=tid("cal-summary")):
        v.VChip("RMS {{ cal_summary.rms }} px", color="primary", variant="flat", size="small", raw_attrs=tid("cal-rms"))
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
            v.VBtn(
                "Left camera",
                value="left",
                size="small",
                title="Show the left camera's results",
                raw_attrs=tid("cal-side-left"),
            )
            v.VBtn(
                "Right camera",
                value="right",
                size="small",
                title="Show the right camera's results",
                raw_attrs=tid("cal-side-right"),
            )


def _warnings(v: Any, html: Any) -> None:
    """The run's warnings, one line each."""
    with v.VAlert(
        v_if="cal_warnings.length",
        type="warning",
        variant="tonal",
        density="compact",
        classes="mb-3",
        raw_attrs=tid("cal-warnings"),
    ):
        html.Div("{{ w }}", v_for="(w, i) in cal_warnings", key="i", classes="text-body-2")


def _image_list(v: Any, html: Any, page: Any) -> None:
    """The images (thumbnail, status, RMS, reason) and the one selected, its board drawn."""

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
                            title="Show this image with its detected corners and residuals",
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


def _chart_and_numbers(v: Any, html: Any, tplotly: Any) -> None:
    """The per-view error chart and the shown camera's intrinsics with their σ."""
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
                        for h, cls in (("", ""), ("value", "text-right"), ("σ (standard deviation)", "text-right")):
                            html.Th(h, classes=cls)
                with html.Tbody():
                    with html.Tr(v_for="n in cal_numbers", key="n.name", raw_attrs=dyn_tid("'cal-num-' + n.name")):
                        html.Td("{{ n.name }}", classes="font-weight-medium")
                        html.Td(VALUE, classes="text-right")
                        html.Td(STD, classes="text-right text-medium-emphasis")


def _heat_map(v: Any, html: Any, tplotly: Any, page: Any) -> None:
    """The projection-uncertainty map at the working distance typed above it."""

    async def on_distance(d):
        await page.set_distance_async(d)

    with v.VCard(variant="outlined", style="flex: 0 1 680px; min-width: 0;", raw_attrs=tid("cal-heatmap")):
        with html.Div(classes="d-flex align-center ga-2 px-3 pt-2"):
            v.VTextField(
                v_model=("cal_distance", 1000.0),
                label="Working distance [mm]",
                type="number",
                min=0,
                density="compact",
                variant="outlined",
                hide_details=True,
                style="max-width: 190px;",
                change=(on_distance, "[cal_distance]"),
                title="The distance from the camera at which the uncertainty map is drawn",
                raw_attrs=tid("cal-distance"),
            )
            html.Span("{{ cal_map_note }}", classes="text-caption", raw_attrs=tid("cal-map-note"))
        tplotly.Figure(
            state_variable_name="cal_fig_map",
            display_mode_bar=True,
            style="height: 470px;",
            raw_attrs=tid("cal-map"),
        )


def _stereo(v: Any, html: Any) -> None:
    """For a pair: the right camera's pose in the left one's frame, with σ."""
    with v.VCard(v_if="cal_stereo_rows.length", variant="outlined", raw_attrs=tid("cal-stereo")):
        v.VCardTitle("Right camera in the left: x_r = R x_l + T", classes="text-subtitle-2 pb-0")
        with v.VTable(density="compact"):
            with html.Tbody():
                with html.Tr(v_for="n in cal_stereo_rows", key="n.name"):
                    html.Td("{{ n.name }}", classes="font-weight-medium")
                    html.Td(VALUE, classes="text-right")
                    html.Td(STD, classes="text-right text-medium-emphasis")


def _rectified(v: Any, html: Any, page: Any) -> None:
    """For a pair: the chosen rectified image pair with its epipolar lines."""

    async def on_pair(i):
        await page.show_pair_async(i)

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
                title="The image pair to show rectified, with epipolar lines",
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
