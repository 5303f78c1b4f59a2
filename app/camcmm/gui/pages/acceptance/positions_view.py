"""Step 2 of the acceptance page: per test a grid of position cards (pictogram, status,
values and verdict, Import / Acquire / Redo / Show), the counters and the last fit shown."""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...widgets import dyn_tid, param_form, tid
from .result_view import verdict_color


def build_positions(page: Any, accept: str) -> None:
    """The positions step (shown while ``wz_step === 'positions'``); wires it to ``page``."""
    from trame.widgets import html

    with html.Div(v_if="wz_step === 'positions' && wz_active", raw_attrs=tid("wz-positions")):
        html.Div("{{ wz_title }}", classes="text-subtitle-2 mb-1")
        _source_bar(page)
        _counters()
        _detail_card()
        _blocks(page, accept)


def _source_bar(page: Any) -> None:
    """Measure with (import, or a source that acquires), Acquire all and Stop."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_acquire_all():
        in_background(page.acquire_all_async(), page.state)  # returns at once: Stop must reach the server

    def on_source(source):
        page.set_source(source)

    with html.Div(v_if="wz_sources.length", classes="d-flex align-center ga-2 mb-2"):
        v.VSelect(
            model_value=("wz_source",),
            items=("[{title: 'Import files (measured elsewhere)', value: null}].concat(wz_sources)",),
            label="Measure with",
            density="compact",
            variant="outlined",
            hide_details=True,
            style="max-width: 420px;",
            update_modelValue=(on_source, "[$event]"),
            title="Import files measured elsewhere, or let a measuring system acquire each position",
            raw_attrs=tid("wz-source"),
        )
        v.VBtn(
            "Acquire all",
            v_if="wz_source",
            size="small",
            color="primary",
            prepend_icon="mdi-camera-burst",
            loading=("wz_acquiring_all",),
            disabled=("wz_acquiring_all",),
            click=on_acquire_all,
            title="Acquire every position not yet measured, one after the other",
            raw_attrs=tid("wz-acquire-all"),
        )
        v.VBtn(
            "Stop",
            v_if="wz_acquiring_all",
            size="small",
            variant="text",
            click="wz_acquiring_all = false",
            title="Stop after the position being acquired",
        )
    _source_settings()


def _source_settings() -> None:
    """The chosen system's declared parameters (images, resolution, speckle ...), folded."""
    from trame.widgets import vuetify3 as v

    with v.VExpansionPanels(v_if="wz_source && wz_source_fields.length", classes="mb-2", raw_attrs=tid("wz-sys")):
        with v.VExpansionPanel(raw_attrs=tid("wz-sys-panel")):
            v.VExpansionPanelTitle(
                "Settings of the measuring system",
                title="The parameters the system declares; each acquisition uses them as they stand",
            )
            with v.VExpansionPanelText():
                param_form("wz_source_fields", "wz_source_params", "wz-sys", disabled="wz_acquiring_all", sync=True)


def _counters() -> None:
    """One counter per test, and Result once every position is done."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex flex-wrap ga-2 mb-2"):
        v.VChip(
            "{{ p.text }}",
            v_for="p in wz_progress",
            key="p.test",
            size="small",
            color=("p.complete ? 'success' : 'primary'",),
            variant=("p.complete ? 'flat' : 'tonal'",),
            prepend_icon=("p.complete ? 'mdi-check-circle' : 'mdi-progress-clock'",),
            raw_attrs=dyn_tid("'wz-counter-' + p.test"),
        )
        v.VSpacer()
        v.VBtn(
            "Result",
            v_if="wz_complete",
            size="small",
            color="success",
            append_icon="mdi-arrow-right",
            click="wz_step = 'result'",
            title="Every position is measured: see the verdict",
            raw_attrs=tid("wz-goto-result"),
        )


def _detail_card() -> None:
    """The last fit shown in the 3D view: its values and warnings."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VCard(v_if="wz_detail", variant="tonal", color="primary", classes="mb-2", raw_attrs=tid("wz-detail")):
        with v.VCardText(classes="py-2"):
            html.Div(
                "Last shown: {{ wz_detail.title }} ({{ wz_detail.file }}) — deviation colour map in the 3D view",
                classes="text-subtitle-2",
            )
            with html.Div(classes="d-flex flex-wrap ga-1 mt-1"):
                v.VChip(
                    "{{ r.name }}: {{ r.value }}",
                    v_for="r in wz_detail.rows",
                    key="r.name",
                    size="x-small",
                    variant="outlined",
                )
            html.Div("{{ w }}", v_for="(w, i) in wz_detail.warnings", key="i", classes="text-caption text-warning")


def _blocks(page: Any, accept: str) -> None:
    """Per test: its name, done of total, a progress bar and the grid of position cards."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(v_for="b in wz_blocks", key="b.test", classes="mb-3", raw_attrs=dyn_tid("'wz-block-' + b.test")):
        with html.Div(classes="d-flex align-center ga-2 mb-1"):
            html.Span("{{ b.label }}", classes="text-subtitle-1")
            v.VChip(
                "{{ b.progress.done }} of {{ b.progress.total }}",
                size="small",
                color=("b.progress.complete ? 'success' : 'primary'",),
                variant="tonal",
            )
        v.VProgressLinear(
            model_value=("100 * b.progress.done / Math.max(b.progress.total, 1)",),
            color=("b.progress.complete ? 'success' : 'primary'",),
            height=4,
            rounded=True,
            classes="mb-2",
        )
        with html.Div(style="display: grid; grid-template-columns: repeat(auto-fill, minmax(185px, 1fr)); gap: 8px;"):
            _card(page, accept)


def _card(page: Any, accept: str) -> None:
    """One position card (inside ``v_for`` over ``b.cards``)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VCard(
        v_for="c in b.cards",
        key="c.key",
        variant="outlined",
        color=(
            "c.status === 'done' ? (c.verdict === 'fail' ? 'error' : 'success') : "
            "(c.status === 'error' ? 'error' : undefined)",
        ),
        raw_attrs=dyn_tid("'card-' + c.id") + [':data-status="c.status"'],
    ):
        _card_header()
        html.Div(v_html="wz_svgs[c.key]", style="height: 104px;", classes="px-2 text-center", title=("c.hint",))
        html.Div(
            "{{ c.hint }}",
            classes="text-caption text-medium-emphasis px-2",
            style="line-height: 1.2; min-height: 2.4em;",
        )
        v.VProgressLinear(v_if="wz_busy[c.key]", indeterminate=True, color="primary", classes="mt-1")
        _card_values()
        v.VAlert(
            v_if="c.error",
            text=("c.error",),
            type="error",
            density="compact",
            variant="tonal",
            classes="mx-2 mt-1 text-caption",
            raw_attrs=tid("card-error"),
        )
        _card_inputs(page, accept)
        _card_actions(page)


def _card_header() -> None:
    """The position's label and its status: verdict, to do, error or repeats done."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center px-2 pt-1"):
        html.Span("{{ c.label }}", classes="text-body-2 font-weight-medium text-high-emphasis")
        v.VSpacer()
        v.VChip(
            "{{ c.verdict }}",
            v_if="c.status === 'done'",
            size="x-small",
            variant="flat",
            color=verdict_color("c.verdict"),
            raw_attrs=tid("card-verdict"),
        )
        v.VChip("to do", v_if="c.status === 'pending'", size="x-small", variant="tonal", raw_attrs=tid("card-pending"))
        v.VChip("error", v_if="c.status === 'error'", size="x-small", variant="flat", color="error")
        v.VChip(
            "{{ c.repeats.filter(r => r.status === 'done').length }}/{{ c.n_repeats }}",
            v_if="c.status === 'partial'",
            size="x-small",
            variant="tonal",
            color="primary",
        )


def _card_values() -> None:
    """Per repeat done: the values with their verdicts and the fit."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(
        v_if="c.status === 'done' || c.status === 'partial'", classes="px-2 pt-1", raw_attrs=tid("card-values")
    ):
        with html.Template(v_for="r in c.repeats", key="r.repeat"):
            with html.Div(v_if="r.status === 'done'", classes="d-flex flex-wrap ga-1 align-center"):
                html.Span("#{{ r.repeat }}", v_if="c.n_repeats > 1", classes="text-caption")
                v.VChip(
                    "{{ x.symbol }} {{ x.text }}",
                    v_for="x in r.values",
                    key="x.param",
                    size="x-small",
                    variant="tonal",
                    color=verdict_color("x.verdict"),
                )
            html.Div("{{ r.fit }}", v_if="r.status === 'done'", classes="text-caption text-medium-emphasis")


def _card_inputs(page: Any, accept: str) -> None:
    """Acquire (with a source) and Import a file, while the position is to do or redone."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_acquire(test, position):
        in_background(page.acquire_async(test, position), page.state)

    async def on_upload(test, position, files):
        await page.upload_async(test, position, files)

    with html.Div(v_if="(c.status !== 'done' || wz_redo === c.key) && !wz_busy[c.key]", classes="px-2 pt-2"):
        v.VBtn(
            "Acquire",
            v_if="wz_source",
            block=True,
            size="small",
            color="primary",
            variant="tonal",
            prepend_icon="mdi-camera-iris",
            classes="mb-1",
            disabled=("wz_acquiring_all",),
            click=(on_acquire, "[c.test, c.id]"),
            title="Measure this position with the chosen system now",
            raw_attrs=tid("card-acquire"),
        )
        v.VFileInput(
            label=("c.status === 'done' ? 'Redo: choose a file' : 'Import measurement'",),
            accept=accept,
            density="compact",
            variant="outlined",
            hide_details=True,
            prepend_icon="",
            prepend_inner_icon="mdi-file-import",
            update_modelValue=(on_upload, "[c.test, c.id, $event]"),
            title="The measured cloud of this position (it is evaluated as soon as it is chosen)",
            raw_attrs=tid("card-file")
            + [":key=\"c.key + '-' + (c.repeats.map(r => r.measurement).join()) + '-' + c.error\""],
        )


def _card_actions(page: Any) -> None:
    """Show (the deviation colour map) and Redo / Cancel, once a position has values."""
    from trame.widgets import vuetify3 as v

    def on_show(test, position):
        page.show(test, position)

    def on_redo(test, position):
        page.redo(test, position)

    with v.VCardActions(v_if="c.status === 'done' || c.status === 'partial'", classes="py-1"):
        v.VBtn(
            "Show",
            size="small",
            variant="text",
            prepend_icon="mdi-palette",
            click=(on_show, "[c.test, c.id]"),
            title="Show this position's deviations as a colour map in the 3D view, and its fit",
            raw_attrs=tid("card-show"),
        )
        v.VBtn(
            "Redo",
            size="small",
            variant="text",
            prepend_icon="mdi-restore",
            v_if="wz_redo !== c.key",
            click=(on_redo, "[c.test, c.id]"),
            title="Measure this position again (the new file replaces the old one)",
            raw_attrs=tid("card-redo"),
        )
        v.VBtn(
            "Cancel",
            size="small",
            variant="text",
            v_if="wz_redo === c.key",
            click="wz_redo = null",
            title="Keep the position as it was measured",
        )
