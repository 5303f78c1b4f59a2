"""The GUM budget tab's widgets: the quantity, the table of contributions (each entered
as u, a half-width a with its distribution, or an expanded U with k; the u the plugin
made of it and the conversion in words), the actions, the result and its chart."""

from __future__ import annotations

from typing import Any

from ...widgets import tid
from . import texts


def links(v: Any, html: Any, key: str, testid: str) -> None:
    """The exports offered (state list ``key`` of {name, url}) as download buttons."""
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
            title=("'download ' + l.name",),
            raw_attrs=[':download="l.name"'],
        )


def _row_update(field: str) -> str:
    """Replace ``unc_b_rows`` by a copy with ``$event`` in row ``i``'s ``field``: a
    nested write would neither re-render nor reach the server (see wizard_layout)."""
    return f"unc_b_rows = unc_b_rows.map((r, j) => j === i ? Object.assign({{}}, r, {{{field}: $event}}) : r)"


def budget_tab(v: Any, html: Any, tplotly: Any, page: Any, ctrl: Any) -> None:
    """The GUM budget: quantity, contributions and actions; the result and its chart.
    Every field, on blur, sends the whole budget to the page (``call``)."""

    def on_change(quantity, unit, p, rows):
        page.set_budget(quantity, unit, p, rows or [])

    change = ctrl.trigger_name(on_change)
    call = f"trigger('{change}', [unc_b_quantity, unc_b_unit, unc_b_p, unc_b_rows])"

    with html.Div(v_if="unc_tab === 'budget'", raw_attrs=tid("unc-budget")):
        html.Div(texts.BUDGET_SOURCE, classes="text-caption text-medium-emphasis mb-2", raw_attrs=tid("unc-b-source"))
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
        links(v, html, "unc_b_links", "unc-b-links")
        with html.Div(classes="d-flex ga-3 mt-2"):
            with html.Div(style="flex: 1 1 40%; min-width: 0;"):
                _budget_result(v, html)
            with html.Div(style="flex: 1 1 60%; min-width: 0;"):
                tplotly.Figure(
                    state_variable_name="unc_b_fig",
                    display_mode_bar=True,
                    style="height: 330px;",
                    raw_attrs=tid("unc-b-chart"),
                )


def _budget_quantity(v: Any, html: Any, call: str) -> None:
    """The quantity, its unit and the coverage probability."""
    with html.Div(classes="d-flex ga-2 mb-2"):
        for key, label, width, tip in (
            ("quantity", "Quantity", "", "the measurand the budget is for"),
            ("unit", "Unit", "max-width: 90px;", "the measurand's unit: u_c and U are in it"),
            ("p", "Coverage probability", "max-width: 170px;", "p of the expanded uncertainty U = k u_c (0.95: 95 %)"),
        ):
            v.VTextField(
                v_model=(f"unc_b_{key}", 0.95 if key == "p" else ""),
                label=label,
                density="compact",
                variant="outlined",
                hide_details=True,
                style=width,
                blur=call,
                title=tip,
                raw_attrs=tid(f"unc-b-{key}"),
            )


def _cell(v: Any, field: str, call: str, tip: str, **kw: Any) -> None:
    v.VTextField(
        model_value=(f"r.{field}",),
        density="compact",
        variant="plain",
        hide_details=True,
        update_modelValue=_row_update(field),
        blur=call,
        title=tip,
        raw_attrs=[f":data-testid=\"'unc-b-{field}-' + i\"", f'@keydown.enter="{call}"'],
        **kw,
    )


def _budget_table(v: Any, html: Any, page: Any, call: str) -> None:
    """The contributions, one editable row each: name, how it is entered (u, half-width a
    or expanded U), the value, the distribution, k, c, dof; then the standard uncertainty
    the plugin made of it and the conversion in words."""

    def on_remove(i):
        page.remove_row(i)

    # a kind's own distributions: switching to "a" from a normal row picks rectangular
    kind_update = (
        "unc_b_rows = unc_b_rows.map((r, j) => j === i ? Object.assign({}, r, {kind: $event, "
        "distribution: unc_b_distributions[$event].includes(r.distribution) ? r.distribution "
        ": unc_b_distributions[$event][0]}) : r); " + call
    )
    heads = (
        ("Contribution", "the input quantity"),
        ("Entered as", "u: a standard uncertainty; a: a half-width ±a; U: an expanded uncertainty with its k"),
        ("Value", "the number entered: u, a or U, in the input's unit"),
        ("Distribution", "a: rectangular a/√3, triangular a/√6, U-shaped a/√2; U: normal, u = U/k; u: as evaluated"),
        ("k", "the coverage factor of an expanded U (GUM 4.3.3)"),
        ("c", "sensitivity coefficient: the contribution to the measurand is |c|·u"),
        ("dof", "degrees of freedom (∞, or inf: known exactly, type B)"),
        ("u", "the standard uncertainty computed from the entry (JCGM 100:2008 4.3.3-4.3.9)"),
        ("Conversion", "how u follows from what was entered"),
        ("", ""),
    )
    with v.VTable(density="compact", raw_attrs=tid("unc-b-table")):
        with html.Thead():
            with html.Tr():
                for h, tip in heads:
                    html.Th(h, title=tip)
        with html.Tbody():
            with html.Tr(v_for="(r, i) in unc_b_rows", key="i", raw_attrs=tid("unc-b-row")):
                with html.Td(style="min-width: 220px;"):
                    _cell(v, "name", call, "the input quantity's name")
                with html.Td(style="min-width: 130px;"):
                    v.VSelect(
                        model_value=("r.kind || 'u'",),
                        items=("unc_b_kinds",),
                        item_title="title",
                        item_value="value",
                        density="compact",
                        variant="plain",
                        hide_details=True,
                        update_modelValue=kind_update,
                        title="how the value is entered: u (standard), a (half-width ±a) or U (expanded, with k)",
                        raw_attrs=[":data-testid=\"'unc-b-kind-' + i\""],
                    )
                with html.Td(style="min-width: 85px;"):
                    _cell(v, "value", call, "the value entered: u, the half-width a or the expanded U")
                with html.Td(style="min-width: 130px;"):
                    v.VSelect(
                        model_value=("r.distribution",),
                        items=("unc_b_distributions[r.kind || 'u']",),
                        density="compact",
                        variant="plain",
                        hide_details=True,
                        update_modelValue=_row_update("distribution") + "; " + call,
                        title="the distribution: for a half-width it sets the divisor (√3, √6, √2)",
                        raw_attrs=[":data-testid=\"'unc-b-distribution-' + i\""],
                    )
                with html.Td(style="min-width: 55px;"):
                    _cell(v, "k", call, "coverage factor k of the expanded U", disabled=("r.kind !== 'U'",))
                with html.Td(style="min-width: 65px;"):
                    _cell(v, "c", call, "sensitivity coefficient c")
                with html.Td(style="min-width: 60px;"):
                    _cell(v, "dof", call, "degrees of freedom (∞, or inf: exactly known)")
                html.Td(
                    "{{ unc_b_result && unc_b_result.rows[i] ? unc_b_result.rows[i].u : '' }}",
                    classes="text-right",
                    raw_attrs=[":data-testid=\"'unc-b-uout-' + i\""],
                )
                html.Td(
                    "{{ unc_b_result && unc_b_result.rows[i] ? unc_b_result.rows[i].conversion : '' }}",
                    classes="text-caption",
                    style="min-width: 200px;",
                    raw_attrs=[":data-testid=\"'unc-b-conversion-' + i\""],
                )
                with html.Td():
                    v.VBtn(
                        icon="mdi-delete-outline",
                        size="x-small",
                        variant="text",
                        click=(on_remove, "[i]"),
                        title="remove this contribution",
                        raw_attrs=[":data-testid=\"'unc-b-remove-' + i\""],
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
            title="add a row to the budget",
            raw_attrs=tid("unc-b-add"),
        )
        v.VFileInput(
            v_model=("unc_b_file", None),
            label="Load a budget (YAML)",
            accept=".yaml,.yml,.json",
            density="compact",
            variant="outlined",
            hide_details=True,
            prepend_icon="",
            prepend_inner_icon="mdi-file-upload",
            style="max-width: 280px;",
            # in words: the file's keys are in the plugin's help (camcmm uncertainty budget --help)
            title="replace the table by a budget file (YAML/JSON): each contribution as a standard "
            "uncertainty u, a half-width with its distribution, or an expanded uncertainty with its k",
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
            title="store the evaluated budget in the project and offer it as YAML, CSV, JSON and PNG",
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
