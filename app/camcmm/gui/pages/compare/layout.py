"""The "Compare with CAD" page: the Vuetify layout around a :class:`.page.ComparePage`.

Three columns (the drawer is closed on this page): **left** the comparison's setup
(measured cloud, nominal, alignment, tolerance, point pairs, more parameters, Run),
the alignment's verdict, the statistics, a picked point, Export and Report; **centre**
the page's own 3D view (server-side rendering) with the display mode (colour map,
tolerance bands, inputs) and the legend; **right** the histogram, the
Abbott-Firestone curve and the section as interactive plotly charts.

A click in the view (a press and release without dragging) is sent to the server as
fractions of the view's size and picked there; dragging still turns the view.

One function per card or section; the handlers are thin (the logic is in the
ComparePage) and sit next to the card that uses them.
"""

from __future__ import annotations

from typing import Any

from ...clientview import attach_compare, client_views, cloud_view, render_switch
from ...jobs import in_background
from ...viewtools import view_toolbar
from ...widgets import dyn_tid, param_form, tid
from .. import shown

CV = "cv_compare"  # the client view's state key

# The side columns' widths. At 1366×768 the fixed 350 px and 34 % left the 3D view about
# 540×300 px (issue 30): the setup column narrows to 24 vw (328 px at 1366, where its tables'
# values are still whole; 350 px from 1459 px), the charts to 30 % (410 px at 1366, 480 px at
# 1600; the charts' annotations are placed for such widths, see figures.py).
LEFT = "clamp(320px, 24vw, 350px)"
RIGHT = "clamp(340px, 30%, 520px)"

_FIELD = (
    "[v => (v === '' || v === null || v === undefined) || !isNaN(Number(v)) || 'not a number',"
    " v => (v === '' || v === null || v === undefined || Number(v) >= 0) || 'at least 0 mm']"
)


def build(page: Any) -> None:
    """The page inside the current layout context (shown when ``page === 'compare'``);
    wires the widgets to ``page`` (a ComparePage) and its view to a remote view."""
    from trame.widgets import html

    page.session.server.state.client_only("ins_down")

    def on_mode(mode):
        page.set_mode(mode)

    with html.Div(
        v_if=shown("compare"),
        classes="d-flex",
        raw_attrs=tid("inspect"),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px);",
    ):
        _left_column(page, on_mode)
        rview = _centre_column(page, on_mode)
        _charts_column(page)
    _wire_view(page, rview)


def _wire_view(page: Any, rview: Any) -> None:
    """The page's view is drawn in the browser (its client view publishes the scene) or
    pushes its image through the remote view; the controller can update and reset it."""
    ctrl = page.session.server.controller

    attach_compare(page, client_views(page.session.server).views[CV], rview.update)
    ctrl.ins_view_update = rview.update
    ctrl.ins_view_reset_camera = rview.reset_camera


# -- left: setup, verdict, numbers, pick, export/report ----------------------------------------


def _left_column(page: Any, on_mode: Any) -> None:
    from trame.widgets import html

    with html.Div(
        classes="pa-3",
        raw_attrs=tid("ins-panel"),
        style=f"flex: 0 0 {LEFT}; max-width: {LEFT}; overflow-y: auto; border-right: 1px solid rgba(0,0,0,0.12);",
    ):
        _setup_inputs(page)
        _pairs_card(page, on_mode)
        _run_controls(page)
        _verdict()
        _results(page)


def _setup_inputs(page: Any) -> None:
    """The error, the measured cloud, the nominal, the alignment and the tolerance."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_inputs(measured, nominal):
        page.set_inputs(measured, nominal)

    def on_align(method):
        page.set_align(method)

    v.VAlert(
        v_if="ins_error",
        text=("ins_error",),
        type="error",
        density="compact",
        closable=True,
        classes="mb-2",
        click_close="ins_error = ''",
        raw_attrs=tid("ins-error"),
    )
    html.Div("Compare a measured cloud with its CAD nominal", classes="text-subtitle-2 mb-2")
    _input_select(
        "ins_measured",
        "items.filter(i => i.kind === 'pointcloud')",
        "Measured cloud",
        "no point cloud yet: import one (Inspect page)",
        (on_inputs, "[$event, null]"),
        "ins-measured",
    )
    _input_select(
        "ins_nominal",
        "items.filter(i => i.kind === 'cad' || i.kind === 'mesh' || i.kind === 'pointcloud')",
        "Nominal (CAD model or mesh, or a reference cloud)",
        "no nominal yet: import a STEP/IGES, STL/OBJ/PLY (Inspect page)",
        (on_inputs, "[null, $event]"),
        "ins-nominal",
    )
    v.VSelect(
        model_value=("ins_align",),
        items=("ins_align_options",),
        label="Alignment",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("ins_running",),
        update_modelValue=(on_align, "[$event]"),
        raw_attrs=tid("ins-align"),
    )
    _tolerance_field(page)


def _input_select(model: str, items: str, label: str, no_data: str, update: Any, testid: str) -> None:
    """A select of the project's items (the measured cloud or the nominal)."""
    from trame.widgets import vuetify3 as v

    v.VSelect(
        model_value=(model,),
        items=(items,),
        item_title="name",
        item_value="id",
        label=label,
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("ins_running",),
        no_data_text=no_data,
        update_modelValue=update,
        raw_attrs=tid(testid),
    )


def _tolerance_field(page: Any) -> None:
    """The tolerance, sent on blur and on Enter."""
    from trame.widgets import vuetify3 as v

    def on_tolerance(value):
        page.set_tolerance(value)

    tol = page.session.server.controller.trigger_name(on_tolerance)
    v.VTextField(
        v_model=("ins_tolerance",),
        label="Tolerance ± (colours, bands, share within)",
        suffix="mm",
        type="number",
        step="any",
        min=0,
        rules=(_FIELD,),
        density="compact",
        variant="outlined",
        hide_details="auto",
        classes="mb-2",
        disabled=("ins_running",),
        blur=f"trigger('{tol}', [ins_tolerance])",
        raw_attrs=tid("ins-tolerance") + [f"@keydown.enter=\"trigger('{tol}', [ins_tolerance])\""],
    )


def _pairs_card(page: Any, on_mode: Any) -> None:
    """The point pairs of a 'pairs' alignment: the list, Show inputs, Undo, Clear."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_clear_pairs():
        page.clear_pairs()

    def on_undo_pair():
        page.undo_pair_point()

    with v.VCard(
        v_if="(ins_align || '').startsWith('pairs')",
        variant="tonal",
        color="primary",
        classes="mb-2",
        raw_attrs=tid("ins-pairs"),
    ):
        with v.VCardText(classes="py-2"):
            html.Div("Point pairs (coarse alignment)", classes="text-subtitle-2")
            html.Div("{{ ins_pick_hint }}", classes="text-caption mb-1", raw_attrs=tid("ins-pick-hint"))
            with v.VTable(density="compact", v_if="ins_pairs.length", style="background: transparent;"):
                with html.Tbody():
                    with html.Tr(v_for="p in ins_pairs", key="p.i", raw_attrs=tid("ins-pair")):
                        html.Td("{{ p.i }}", classes="text-caption")
                        html.Td("M {{ p.measured }}", classes="text-caption", style="color: #c62828;")
                        html.Td("N {{ p.nominal }}", classes="text-caption", style="color: #1565c0;")
            with html.Div(classes="d-flex ga-1 mt-1"):
                v.VBtn(
                    "Show inputs",
                    size="x-small",
                    variant="text",
                    click=(on_mode, "['inputs']"),
                    v_if="ins_mode !== 'inputs'",
                )
                for text, handler, testid in (
                    ("Undo", on_undo_pair, "ins-pairs-undo"),
                    ("Clear", on_clear_pairs, "ins-pairs-clear"),
                ):
                    v.VBtn(
                        text,
                        size="x-small",
                        variant="text",
                        click=handler,
                        disabled=("!ins_pairs.length",),
                        raw_attrs=tid(testid),
                    )


def _run_controls(page: Any) -> None:
    """More parameters (from the manifest), Run, Cancel and the progress bar."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_run(params):
        in_background(page.run_async(params), page.state)  # returns at once: Cancel must reach the server

    def on_cancel():
        page.cancel()

    with v.VExpansionPanels(classes="mb-2", raw_attrs=tid("ins-more")):
        with v.VExpansionPanel(title="More parameters"):
            with v.VExpansionPanelText():
                param_form("ins_fields", "ins_params", "ins-param", numbers=False)
    with html.Div(classes="d-flex ga-2"):
        v.VBtn(
            "Run",
            color="primary",
            prepend_icon="mdi-play",
            click=(on_run, "[ins_params]"),
            disabled=("ins_running || !ins_measured || !ins_nominal",),
            loading=("ins_running",),
            raw_attrs=tid("ins-run"),
        )
        v.VBtn("Cancel", v_if="ins_running", variant="text", click=on_cancel, raw_attrs=tid("ins-cancel"))
    with v.VProgressLinear(
        v_show="ins_running || ins_progress > 0",
        model_value=("ins_progress",),
        indeterminate=("ins_running && ins_progress <= 0",),
        height=18,
        rounded=True,
        color=("ins_running ? 'primary' : (ins_failed ? 'error' : 'success')",),
        classes="mt-2",
        raw_attrs=tid("ins-progress"),
    ):
        html.Span(
            "{{ ins_progress_message }} {{ Math.round(ins_progress) }} %",
            classes="text-caption",
            raw_attrs=[":class=\"ins_failed && !ins_running ? 'text-white' : ''\""],
        )


def _verdict() -> None:
    """The verdict of the alignment when it failed."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VAlert(
        v_if="ins_has_result && ins_failed",
        type="error",
        variant="flat",
        prominent=True,
        classes="mt-3",
        title="Alignment failed",
        raw_attrs=tid("ins-failed"),
    ):
        html.Div("{{ ins_failed_reason }}", raw_attrs=tid("ins-failed-reason"))
        html.Div(
            "No deviations are shown: they would rest on a wrong alignment. Try point pairs or "
            "the automatic coarse alignment, a larger max distance, or check the inputs.",
            classes="text-caption mt-1",
        )


def _results(page: Any) -> None:
    """The result: its title, Export and Report with their links, the warnings, the tables."""
    from trame.widgets import html

    with html.Div(v_if="ins_has_result", classes="mt-3", raw_attrs=tid("ins-results")):
        html.Div("{{ ins_title }}", classes="text-caption text-medium-emphasis mb-1")
        _export_report(page)
        _warnings_and_tables()


def _export_report(page: Any) -> None:
    """Export PLY and Report, then the links to what they wrote."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_export():
        await page.export_async()

    async def on_report():
        await page.report_async()

    with html.Div(classes="d-flex flex-wrap ga-2 mb-1"):
        v.VBtn(
            "Export PLY",
            prepend_icon="mdi-download",
            variant="outlined",
            size="small",
            click=on_export,
            loading=("ins_busy === 'export'",),
            disabled=("!!ins_busy || ins_running || ins_failed",),
            title="The cloud coloured as shown, with the field 'deviation' (mm); added to the project",
            raw_attrs=tid("ins-export"),
        )
        v.VBtn(
            "Report",
            prepend_icon="mdi-file-document-outline",
            color="primary",
            size="small",
            click=on_report,
            loading=("ins_busy === 'report'",),
            disabled=("!!ins_busy || ins_running",),
            title="HTML, PDF and JSON by the inspection plugin's report writer; added to the project",
            raw_attrs=tid("ins-report"),
        )
    with html.Div(classes="d-flex flex-column mb-2"):
        html.A(
            "{{ l.title }}",
            v_for="l in ins_export_links",
            key="l.name",
            href=("l.url",),
            download=("l.name",),
            classes="text-body-2",
            raw_attrs=dyn_tid("'ins-export-' + l.kind"),
        )
        html.A(
            "{{ l.title }}",
            v_for="l in ins_report_links",
            key="l.kind",
            href=("l.url",),
            target="_blank",
            download=("l.kind === 'html' ? undefined : l.name",),
            classes="text-body-2",
            raw_attrs=dyn_tid("'ins-report-' + l.kind"),
        )


def _warnings_and_tables() -> None:
    """The warnings (folded), the deviations' statistics and the alignment's numbers."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VExpansionPanels(v_if="ins_warnings.length", classes="mb-2"):
        with v.VExpansionPanel(title=("'Warnings (' + ins_warnings.length + ')'",)):
            with v.VExpansionPanelText():
                html.Div("{{ w }}", v_for="(w, i) in ins_warnings", key="i", classes="text-caption")
    html.Div("Deviations", v_if="!ins_failed", classes="text-subtitle-2")
    with v.VTable(v_if="!ins_failed", density="compact", raw_attrs=tid("ins-stats")):
        with html.Tbody():
            with html.Tr(v_for="r in ins_stats", key="r.key"):
                html.Td("{{ r.name }}", classes="text-caption")
                html.Td(
                    "{{ r.value }}",
                    classes="text-right text-body-2",
                    raw_attrs=dyn_tid("'ins-stat-' + r.key") + [":class=\"r.value.length < 24 ? 'text-no-wrap' : ''\""],
                )
    html.Div("Alignment", classes="text-subtitle-2 mt-2")
    with v.VTable(density="compact", raw_attrs=tid("ins-alignment")):
        with html.Tbody():
            with html.Tr(v_for="r in ins_alignment", key="r.key"):
                html.Td("{{ r.name }}", classes="text-caption")
                html.Td(
                    "{{ r.value }}",
                    classes="text-right text-body-2",
                    raw_attrs=dyn_tid("'ins-align-' + r.key"),
                )


# -- centre: the 3D view -----------------------------------------------------------------------


def _centre_column(page: Any, on_mode: Any) -> Any:
    """The display mode and legend, the view's tools, the note, the view, the picked point;
    returns the remote view. The rows above the view are kept few and tight: every pixel they
    take is the view's (at 1366×768 they took 218 of its 696 px)."""
    from trame.widgets import html

    with html.Div(classes="d-flex flex-column", style="flex: 1 1 0; min-width: 0;"):
        _mode_bar(page, on_mode)
        view_toolbar(page.tools)
        _legend_line()
        # the page's note where the view does not show it already (the browser's view writes its
        # note at its bottom: the same text twice took a line)
        html.Div(
            "{{ ins_note }}",
            v_show=f"ins_note && ({CV}_mode === 'server' || !{CV} || {CV}.note !== ins_note)",
            classes="text-caption px-3",
            raw_attrs=tid("ins-note"),
        )
        # server-side times (epoch s) of the last run's stages, for benchmarks/bench_gui_colourmap.py
        html.Span(
            v_if="ins_timing && ins_timing.result",
            style="display: none;",
            raw_attrs=tid("ins-timing")
            + [
                ':data-result="ins_timing.result"',
                ':data-loop="ins_timing.loop"',
                ':data-drawn="ins_timing.drawn"',
                ':data-numbers="ins_timing.numbers"',
                ':data-flushed="ins_timing.flushed"',
            ],
        )
        rview = _view(page)
        _picked_card()
        html.Div(
            "Click a point for its deviation; drag to turn, wheel to zoom."
            " With a 'pairs' alignment the Inputs view takes the point pairs.",
            classes="text-caption px-3 pb-1 text-medium-emphasis text-truncate",
            title="Click a point for its deviation; drag to turn, wheel to zoom."
            " With a 'pairs' alignment the Inputs view takes the point pairs.",
        )
    return rview


def _mode_bar(page: Any, on_mode: Any) -> None:
    """The display mode (colour map, tolerance bands, inputs, GD&T) and the colour legend's
    kind: one row."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center flex-wrap ga-2 px-3 py-1", raw_attrs=tid("ins-mode-bar")):
        with v.VBtnToggle(
            model_value=("ins_mode",),
            density="compact",
            variant="outlined",
            divided=True,
            color="primary",
            update_modelValue=(on_mode, "[$event]"),
            raw_attrs=tid("ins-mode"),
        ):
            # "GD&T", not "Characteristics": the longer word was clipped beside the three others
            # at 1400 px (the right column's toggle keeps the long name); words as written, not
            # capitals: the row keeps the legend's controls beside it at 1366 px
            for text, value, disabled in (
                ("Colour map", "colour", "!ins_has_result || ins_failed"),
                ("Tolerance bands", "bands", "!ins_has_result || ins_failed || !(Number(ins_tolerance) > 0)"),
                ("Inputs", "inputs", None),
                ("GD&T", "gdt", "!gdt_results.length"),
            ):
                v.VBtn(
                    text,
                    value=value,
                    size="small",
                    classes="text-none",
                    disabled=(disabled,) if disabled else False,
                    raw_attrs=tid(f"ins-mode-{value}"),
                )
        _legend_controls(page)


def _legend_line() -> None:
    """Where the view is drawn (browser or server) and what the colours mean: the colour map's
    title and limit, or the tolerance bands."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center flex-wrap ga-1 px-2 pt-1", raw_attrs=tid("ins-legend-line")):
        render_switch(CV)
        v.VChip(
            "{{ ins_legend_title }} · {{ ins_limit_text }}",
            v_if="ins_mode === 'colour'",
            size="small",
            prepend_icon="mdi-palette",
            raw_attrs=tid("ins-legend"),
        )
        with html.Div(v_if="ins_mode === 'bands'", classes="d-flex flex-wrap ga-1", raw_attrs=tid("ins-bands")):
            with v.VChip(
                v_for="b in ins_bands",
                key="b.key",
                size="small",
                variant="outlined",
                raw_attrs=dyn_tid("'ins-band-' + b.key"),
            ):
                html.Span(
                    style=(
                        "{display: 'inline-block', width: '10px', height: '10px', "
                        "marginRight: '6px', background: b.colour}",
                    )
                )
                html.Span("{{ b.text }}")
        v.VChip("alignment failed", v_if="ins_mode === 'failed'", size="small", color="error", variant="flat")


def _legend_controls(page: Any) -> None:
    """The colour map's legend: continuous, stepped (n bands) or n bands over ±tolerance with
    out-of-tolerance colours. Always in place (disabled without a colour map): nothing moves."""
    from trame.widgets import vuetify3 as v

    def on_legend(kind, n):
        page.set_legend(kind, n)

    v.VSelect(
        model_value=("ins_legend_kind",),
        items=(
            [
                {"title": "continuous", "value": "continuous"},
                {"title": "stepped", "value": "stepped"},
                {"title": "stepped ± tolerance", "value": "tolerance"},
            ],
        ),
        label="Legend",
        density="compact",
        variant="outlined",
        hide_details=True,
        style="max-width: 170px; min-width: 140px;",
        classes="ml-1",
        disabled=("ins_mode !== 'colour'",),
        update_modelValue=(on_legend, "[$event, null]"),
        title="Colour legend: continuous, stepped in n bands over ± the colour limit, or n bands over "
        "± tolerance with deviations beyond it in the out-of-tolerance colours",
        raw_attrs=tid("ins-legend-kind"),
    )
    v.VTextField(
        model_value=("ins_legend_n",),
        label="bands",
        type="number",
        min=2,
        max=32,
        density="compact",
        variant="outlined",
        hide_details=True,
        style="max-width: 76px;",
        disabled=("ins_mode !== 'colour' || ins_legend_kind === 'continuous'",),
        update_modelValue=(on_legend, "[null, $event]"),
        title="Number of colour bands of a stepped legend (2 to 32)",
        raw_attrs=tid("ins-legend-n"),
    )


def _view(page: Any) -> Any:
    """The 3D view; a click (press and release without dragging) picks at its fractions of the view."""
    from trame.widgets import html
    from trame.widgets.vtk import VtkRemoteView

    def on_pick(fx, fy):
        page.pick_at(fx, fy)

    pick = page.session.server.controller.trigger_name(on_pick)
    client_views(page.session.server).add(CV, page.view)
    with html.Div(
        style="flex: 1 1 auto; min-height: 300px; position: relative;",
        classes="cmm-compare-view",
        raw_attrs=tid("ins-view")
        + [
            '@pointerdown="ins_down = [$event.clientX, $event.clientY, $event.button]"',
            # in the browser's rendering the click comes as cv_pick from the client view
            f"@pointerup=\"{CV}_mode === 'server' && ins_down && $event.button === 0 && ins_down[2] === 0 && "
            "Math.abs($event.clientX - ins_down[0]) + Math.abs($event.clientY - ins_down[1]) < 5 && "
            f"trigger('{pick}', [($event.clientX - $event.currentTarget.getBoundingClientRect().left)"
            " / $event.currentTarget.getBoundingClientRect().width, "
            "($event.clientY - $event.currentTarget.getBoundingClientRect().top)"
            ' / $event.currentTarget.getBoundingClientRect().height])"',
        ],
    ):
        cloud_view(CV)
        with html.Div(v_if=f"{CV}_mode === 'server'", style="position: absolute; inset: 0;"):
            # trame-vtk's view on the plotter's render window, not trame-pyvista's: that one
            # pushes an image on every pyvista render() (five per scene change); this page
            # pushes one when its scene is complete.
            return VtkRemoteView(
                page.view.plotter.render_window, interactive_ratio=0.5, interactive_quality=60, still_ratio=1
            )


def _picked_card() -> None:
    """The picked point and its deviation, coloured by its band."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VCard(v_if="ins_picked", variant="tonal", classes="ma-2", raw_attrs=tid("ins-picked")):
        with v.VCardText(classes="py-2 d-flex align-center ga-2"):
            v.VIcon("mdi-target", size="small")
            html.Span("{{ ins_picked.text }}", raw_attrs=tid("ins-picked-text"))
            v.VChip(
                "{{ ins_picked.deviation }}",
                v_if="ins_picked.found",
                size="small",
                variant="flat",
                color=(
                    "ins_picked.band === 'above' ? 'red-darken-2' : (ins_picked.band === 'below' ? "
                    "'blue-darken-2' : (ins_picked.band === 'within' ? 'green-darken-2' : "
                    "'grey-darken-2'))",
                ),
                raw_attrs=tid("ins-picked-deviation"),
            )


# -- right: charts -----------------------------------------------------------------------------


def _charts_column(page: Any) -> None:
    """The charts (histogram, Abbott-Firestone curve, section) or the characteristics
    panel (:mod:`.characteristics_view`), by the toggle on top."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    from .characteristics_view import build_panel

    with html.Div(
        classes="pa-2 d-flex flex-column ga-2",
        style=f"flex: 0 0 {RIGHT}; max-width: {RIGHT}; overflow-y: auto; border-left: 1px solid rgba(0,0,0,0.12);",
    ):
        with v.VBtnToggle(
            v_model=("ins_right",),
            mandatory=True,
            density="compact",
            variant="outlined",
            divided=True,
            color="primary",
            style="flex: 0 0 auto; align-self: flex-start;",
            raw_attrs=tid("ins-right"),
        ):
            v.VBtn("Charts", value="charts", size="small", raw_attrs=tid("ins-right-charts"))
            v.VBtn("Characteristics", value="gdt", size="small", raw_attrs=tid("ins-right-gdt"))
        with html.Div(v_show="ins_right === 'gdt'", style="flex: 0 0 auto;"):
            build_panel(page)
        # v-show on a wrapper: Vuetify's d-flex (display: flex !important) would defeat it
        with html.Div(v_show="ins_right !== 'gdt'", style="flex: 0 0 auto;"):
            with html.Div(classes="d-flex flex-column ga-2", raw_attrs=tid("ins-charts")):
                _charts(page)


def _charts(page: Any) -> None:
    """The histogram, the Abbott-Firestone curve and the section with its controls."""
    from trame.widgets import html

    _chart("height: 30vh; min-height: 200px;", "ins-histogram", "ins_fig_hist")
    _chart("height: 32vh; min-height: 220px;", "ins-af", "ins_fig_af")
    _section_controls(page)
    html.Div(
        "{{ ins_section_axis }} = {{ Number(ins_section_pos).toFixed(3) }} mm: the nominal cut (black) "
        "with deviation whiskers (magnified as the legend says; red outward, blue inward) of the "
        "measured points within ± half their spacing of the plane",
        v_if="ins_has_result",
        classes="text-caption text-medium-emphasis",
    )
    _chart("height: 34vh; min-height: 220px;", "ins-section", "ins_fig_section")


def _chart(style: str, testid: str, figure: str) -> None:
    """A plotly chart bound to the state variable ``figure``."""
    from trame.widgets import html
    from trame.widgets import plotly as tplotly

    with html.Div(style=style, raw_attrs=tid(testid)):
        tplotly.Figure(state_variable_name=figure, display_mode_bar=False, display_logo=False)


def _section_controls(page: Any) -> None:
    """The section's axis, its position and Cut."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_section(axis, position):
        page.set_section(axis, position)

    cut = page.session.server.controller.trigger_name(on_section)
    with html.Div(classes="d-flex align-center ga-2", raw_attrs=tid("ins-section-controls")):
        html.Span("Section", classes="text-subtitle-2")
        with v.VBtnToggle(
            model_value=("ins_section_axis",),
            mandatory=True,
            density="compact",
            variant="outlined",
            divided=True,
            disabled=("!ins_has_result",),
            # the clicked axis shows at once (it waited for the cut's round trip, about a second
            # after a run: the click looked ignored and was made again), then the server cuts
            raw_attrs=tid("ins-section-axis")
            + [f"@update:modelValue=\"ins_section_axis = $event; trigger('{cut}', [$event, null])\""],
        ):
            for a in ("x", "y", "z"):
                v.VBtn(a, value=a, size="small", raw_attrs=tid(f"ins-section-{a}"))
        v.VSlider(
            v_model=("ins_section_pos",),
            min=("ins_section_range[0]",),
            max=("ins_section_range[1]",),
            step=("ins_section_range[2]",),
            density="compact",
            hide_details=True,
            disabled=("!ins_has_result",),
            thumb_label=True,
            color="primary",
            end=(on_section, "[ins_section_axis, $event]"),
            raw_attrs=tid("ins-section-pos"),
        )
        v.VBtn(
            "Cut",
            size="small",
            variant="tonal",
            disabled=("!ins_has_result",),
            click=(on_section, "[ins_section_axis, ins_section_pos]"),
            raw_attrs=tid("ins-section-cut"),
        )
