"""The "Series" page's widgets around a :class:`.page.SeriesPage`.

Two columns (the page fills the main area): **left** the plan (a file on the server, or
empty for the project's plan), the parts (project clouds in a multiple select, files on
the server one a line, in production order), the alignment, Run (``data-shortcut="run"``)
and Cancel with the progress and the warnings; **right** the parts × characteristics
table (each cell the value, coloured by its verdict; a click shows that part and that
characteristic), the characteristic's run chart with Cp/Cpk beside it, the part's labels.
"""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...widgets import dyn_tid, run_progress, tid, warning_alerts
from .. import shown

COLUMN = "height: calc(100vh - 48px - 24px); overflow-y: auto;"


def build(page: Any) -> None:
    """The page inside the current layout context (shown while ``page === 'series'``)."""
    from trame.widgets import html

    with html.Div(v_if=shown("series"), classes="d-flex", style="flex: 1 1 0; min-width: 0;", raw_attrs=tid("se-page")):
        with html.Div(
            classes="pa-3",
            style=f"flex: 0 0 360px; max-width: 360px; border-right: 1px solid rgba(0,0,0,0.12); {COLUMN}",
            raw_attrs=tid("se-panel"),
        ):
            _inputs(page)
        with html.Div(classes="pa-3", style=f"flex: 1 1 0; min-width: 0; {COLUMN}", raw_attrs=tid("se-results")):
            _results(page)


def _inputs(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_run(plan, clouds, files, align, nominal):
        # the fields as the browser has them (one typed just before the click may not be synced yet)
        in_background(page.run_async(plan, clouds, files, align, nominal or ""), page.state)

    def on_cancel():
        page.cancel()

    v.VAlert(
        v_if="se_error", text=("se_error",), type="error", density="compact", closable=True, classes="mb-2",
        click_close="se_error = ''", raw_attrs=tid("se-error"),
    )  # fmt: skip
    html.Div("One plan over several parts", classes="text-subtitle-2 mb-2")
    v.VTextField(
        v_model=("se_plan",), label="Plan file on the server (empty: the project's plan)", density="compact",
        variant="outlined", hide_details=True, classes="mb-2", disabled=("se_running",),
        title="A .yaml/.json plan inside the project folder or a --data-root; empty: the plan of the Compare page",
        raw_attrs=tid("se-plan"),
    )  # fmt: skip
    v.VSelect(
        v_model=("se_clouds",), items=("items.filter(i => i.kind === 'pointcloud')",), item_title="name",
        item_value="id", label="Parts: project clouds", multiple=True, chips=True, closable_chips=True,
        density="compact", variant="outlined", hide_details=True, classes="mb-2", disabled=("se_running",),
        raw_attrs=tid("se-clouds"),
    )  # fmt: skip
    v.VTextarea(
        v_model=("se_files",), label="Parts: cloud files on the server, one a line", rows=4, density="compact",
        variant="outlined", hide_details=True, classes="mb-2", disabled=("se_running",),
        title="Paths inside the project folder or a --data-root (relative: from the project folder), in order",
        raw_attrs=tid("se-files"),
    )  # fmt: skip
    v.VSelect(
        v_model=("se_nominal",), items=("items.filter(i => i.kind !== 'image')",), item_title="name",
        item_value="id", label="Nominal (optional: CAD, mesh or reference cloud)", clearable=True,
        density="compact", variant="outlined", hide_details=True, classes="mb-2", disabled=("se_running",),
        raw_attrs=tid("se-nominal"),
    )  # fmt: skip
    v.VSelect(
        v_model=("se_align",), items=("se_aligns",), item_title="title", item_value="value", label="Alignment",
        density="compact", variant="outlined", hide_details=True, classes="mb-2", disabled=("se_running",),
        raw_attrs=tid("se-align"),
    )  # fmt: skip
    with html.Div(classes="d-flex ga-2"):
        v.VBtn(
            "Run", color="primary", prepend_icon="mdi-play",
            click=(on_run, "[se_plan, se_clouds, se_files, se_align, se_nominal]"),
            disabled=("se_running",), loading=("se_running",), title="Evaluate the plan on every part (Ctrl+Enter)",
            raw_attrs=[*tid("se-run"), 'data-shortcut="run"'],
        )  # fmt: skip
        v.VBtn("Cancel", v_if="se_running", variant="text", click=on_cancel, raw_attrs=tid("se-cancel"))
    run_progress("se")
    with html.Div(classes="mt-2"):
        warning_alerts("se")


def _results(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import plotly as tplotly
    from trame.widgets import vuetify3 as v

    def on_cell(part, cid):
        page.open_cell(part, cid)

    with v.VCard(v_if="!se_rows.length", variant="tonal", raw_attrs=tid("se-empty")):
        v.VCardText("{{ se_empty_hint }}")
    html.Div("{{ se_title }}", v_if="se_rows.length", classes="text-subtitle-1 mb-2", raw_attrs=tid("se-title"))
    with v.VTable(v_if="se_rows.length", density="compact", classes="mb-3", raw_attrs=tid("se-table")):
        with html.Thead():
            with html.Tr():
                html.Th("part")
                html.Th("{{ id }}", v_for="id in se_ids", key="id", classes="text-right")
        with html.Tbody():
            with html.Tr(v_for="r in se_rows", key="r.part", raw_attrs=dyn_tid("'se-row-' + r.part")):
                html.Td(
                    "{{ r.part }}", classes="font-weight-medium",
                    title=("r.status === 'failed' ? 'failed: ' + r.reason : 'evaluated'",),
                )  # fmt: skip
                html.Td(
                    "{{ c.text }}",
                    v_for="c in r.cells",
                    key="c.id",
                    classes="text-right",
                    style=(
                        "{cursor: 'pointer', background: c.colour, color: 'white', "
                        "outline: se_cell && se_cell.part === r.part && se_cell.id === c.id "
                        "? '3px solid #212121' : ''}",
                    ),
                    title=("c.id + ': ' + c.verdict",),
                    click=(on_cell, "[r.part, c.id]"),
                    raw_attrs=[*dyn_tid("'se-cell-' + r.part + '-' + c.id"), ':data-verdict="c.verdict"'],
                )
    with html.Div(v_if="se_rows.length", classes="d-flex flex-wrap ga-3"):
        with html.Div(style="flex: 2 1 460px; height: 360px;", raw_attrs=tid("se-chart")):
            tplotly.Figure(state_variable_name="se_fig_chart", display_mode_bar=False, display_logo=False)
        with v.VTable(density="compact", style="flex: 1 1 260px;", raw_attrs=tid("se-capability")):
            with html.Tbody():
                with html.Tr(v_for="r in se_capability", key="r.name + r.value"):
                    html.Td("{{ r.label }}", classes="font-weight-medium")
                    html.Td("{{ r.value }}", classes="text-right", raw_attrs=dyn_tid("'se-cap-' + r.name"))
    with html.Div(v_if="se_rows.length", classes="d-flex flex-wrap ga-3 mt-3"):
        with html.Div(style="flex: 1 1 260px;", raw_attrs=tid("se-part")):
            html.Div("{{ se_part_title }}", classes="text-subtitle-2 mb-1", raw_attrs=tid("se-part-title"))
            with v.VTable(density="compact"):
                with html.Tbody():
                    with html.Tr(v_for="c in se_part_rows", key="c.id", raw_attrs=dyn_tid("'se-label-' + c.id")):
                        html.Td("{{ c.id }}", classes="font-weight-medium")
                        html.Td("{{ c.title }}")
                        html.Td("{{ c.value }} (U = {{ c.U }})", classes="text-right")
                        with html.Td():
                            v.VChip("{{ c.verdict }}", size="small", color=("c.colour",), variant="flat")
        with html.Div(style="flex: 2 1 420px; height: 380px;", raw_attrs=tid("se-labels")):
            tplotly.Figure(state_variable_name="se_fig_labels", display_mode_bar=False, display_logo=False)
