"""The "Studies" page's widgets around a :class:`.page.StudiesPage`.

Two columns (the page fills the main area): **left** the study (kind, study file,
"Make a virtual-lab study"), Run (``data-shortcut="run"``) and Cancel with the progress,
the warnings, Export report with its links, then the plugin's declared parameters;
**right** the result: the tables (6.3, or 6.1, 6.2 and the coverage), the fit's numbers
or the study's summary, and the figures — depth vs λ of a chosen view and gradient vs
focal length (light field), or the deviation maps without/with speckle side by side.
"""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...widgets import dyn_tid, param_form, run_buttons, run_progress, tid, warning_alerts
from .. import shown

COLUMN = "height: calc(100vh - 48px - 24px); overflow-y: auto;"


def build(page: Any) -> None:
    """The page inside the current layout context (shown while ``page === 'studies'``)."""
    from trame.widgets import html

    whole = "flex: 1 1 0; min-width: 0;"
    with html.Div(v_if=shown("studies"), classes="d-flex", style=whole, raw_attrs=tid("st-page")):
        with html.Div(
            classes="pa-3",
            style=f"flex: 0 0 380px; max-width: 380px; border-right: 1px solid rgba(0,0,0,0.12); {COLUMN}",
            raw_attrs=tid("st-panel"),
        ):
            _inputs(page)
            _run(page)
            _report(page)
            _parameters()
        with html.Div(classes="pa-3", style=f"flex: 1 1 0; min-width: 0; {COLUMN}", raw_attrs=tid("st-results")):
            _results(page)


def _inputs(page: Any) -> None:
    """The error, the kind, the study file, the virtual-lab button."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_kind(kind):
        page.set_kind(kind)

    def on_virtual():
        in_background(page.make_virtual_async(), page.state)

    v.VAlert(
        v_if="st_error", text=("st_error",), type="error", density="compact", closable=True, classes="mb-2",
        click_close="st_error = ''", raw_attrs=tid("st-error"),
    )  # fmt: skip
    html.Div("Case studies of chapter 6", classes="text-subtitle-2 mb-2")
    v.VSelect(
        model_value=("st_kind",),
        items=("st_kinds",),
        item_title="title",
        item_value="value",
        label="Study",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("st_running",),
        update_modelValue=(on_kind, "[$event]"),
        raw_attrs=tid("st-kind"),
    )
    v.VTextField(
        v_model=("st_file",),
        label="Study file on the server (.yaml/.json)",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("st_running",),
        title="A path inside the project folder or a --data-root; relative paths from the project folder",
        raw_attrs=tid("st-file"),
    )
    v.VBtn(
        "Make a virtual-lab study",
        variant="tonal",
        prepend_icon="mdi-flask-plus-outline",
        block=True,
        classes="mb-2",
        click=on_virtual,
        disabled=("st_running",),
        title="Write the virtual lab's study of this kind into the project folder and choose it",
        raw_attrs=tid("st-virtual"),
    )


def _run(page: Any) -> None:
    def on_run(params, file=None):
        # the file as the browser has it (a field typed just before the click may not be synced yet)
        in_background(page.run_async(params, file), page.state)  # returns at once: Cancel must reach the server

    def on_cancel():
        page.cancel()

    run_buttons("st", on_run, "[st_params, st_file]", on_cancel, "Run the study on its file")
    run_progress("st")


def _report(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_report():
        await page.report_async()

    with html.Div(v_if="st_tables.length", classes="mt-3"):
        warning_alerts("st")
        v.VBtn(
            "Export report", prepend_icon="mdi-file-document-outline", variant="tonal", block=True,
            click=on_report, disabled=("st_running",), raw_attrs=tid("st-report"),
        )  # fmt: skip
        with html.Div(v_if="st_links.length", classes="d-flex flex-wrap ga-1 mt-2", raw_attrs=tid("st-links")):
            v.VBtn(
                "{{ l.name }}", v_for="l in st_links", key="l.url", href=("l.url",), target="_blank", size="small",
                variant="tonal", prepend_icon="mdi-download", raw_attrs=[':download="l.name"'],
            )  # fmt: skip


def _parameters() -> None:
    from trame.widgets import html

    html.Div("Parameters", classes="text-subtitle-2 mb-1 mt-3")
    param_form("st_fields", "st_params", "st-param", disabled="st_running", numbers=True)


def _results(page: Any) -> None:
    """The title, the tables, the figures and the numbers of the shown run."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_view(value):
        page.show_view(value)

    def on_pair(value):
        page.show_pair(value)

    with v.VCard(v_if="!st_tables.length", variant="tonal", raw_attrs=tid("st-empty")):
        v.VCardText("{{ st_empty_hint }}")
    html.Div("{{ st_title }}", v_if="st_tables.length", classes="text-subtitle-1 mb-2", raw_attrs=tid("st-title"))
    with html.Div(v_for="t in st_tables", key="t.key", classes="mb-3", raw_attrs=dyn_tid("'st-table-' + t.key")):
        html.Div("{{ t.title }}", classes="text-subtitle-2")
        with v.VTable(density="compact"):
            with html.Thead():
                with html.Tr():
                    html.Th("{{ h }}", v_for="(h, j) in t.header", key="j", classes=("j ? 'text-right' : ''",))
            with html.Tbody():
                with html.Tr(v_for="(r, i) in t.rows", key="i"):
                    cls = "j ? 'text-right' : 'font-weight-medium'"
                    html.Td("{{ c }}", v_for="(c, j) in r", key="j", classes=(cls,))
    with html.Div(v_show="st_shown_kind === 'lightfield'"):
        v.VSelect(
            v_if="st_views.length", model_value=("st_view",), items=("st_views",), item_title="title",
            item_value="value", label="View shown", density="compact", variant="outlined", hide_details=True,
            classes="mb-2", style="max-width: 480px;", update_modelValue=(on_view, "[$event]"),
            raw_attrs=tid("st-view"),
        )  # fmt: skip
        with html.Div(classes="d-flex flex-wrap"):
            _chart("flex: 1 1 420px; height: 380px;", "st-scatter", "st_fig_scatter")
            _chart("flex: 1 1 420px; height: 380px;", "st-focal", "st_fig_focal")
    with html.Div(v_show="st_shown_kind === 'speckle'"):
        v.VSelect(
            v_if="st_pairs.length", model_value=("st_pair",), items=("st_pairs",), item_title="title",
            item_value="value", label="Artefact · material", density="compact", variant="outlined",
            hide_details=True, classes="mb-2", style="max-width: 480px;", update_modelValue=(on_pair, "[$event]"),
            raw_attrs=tid("st-pair"),
        )  # fmt: skip
        with html.Div(classes="d-flex flex-wrap"):
            _chart("flex: 1 1 420px; height: 420px;", "st-map-off", "st_fig_off")
            _chart("flex: 1 1 420px; height: 420px;", "st-map-on", "st_fig_on")

    with v.VTable(v_if="st_numbers.length", density="compact", classes="mt-3 mb-3", raw_attrs=tid("st-numbers")):
        with html.Tbody():
            with html.Tr(v_for="r in st_numbers", key="r.name"):
                html.Td("{{ r.label }}", classes="font-weight-medium")
                html.Td("{{ r.value }}", classes="text-right", raw_attrs=dyn_tid("'st-num-' + r.name"))


def _chart(style: str, testid: str, figure: str) -> None:
    """A plotly chart bound to the state variable ``figure``."""
    from trame.widgets import html
    from trame.widgets import plotly as tplotly

    with html.Div(style=style, raw_attrs=tid(testid)):
        tplotly.Figure(state_variable_name=figure, display_mode_bar=False, display_logo=False)
