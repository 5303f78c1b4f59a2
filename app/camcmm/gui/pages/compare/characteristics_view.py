"""The characteristics panel's widgets (the right column of the "Compare with CAD" page,
beside the charts): features picked on the nominal, datums, characteristics, Run, the
results table coloured by verdict, the plan's YAML export and import. The handlers are
thin: the logic is in :class:`.characteristics.Characteristics` (``page.gdt``)."""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...widgets import dyn_tid, tid

_SELECT = {"density": "compact", "variant": "outlined", "hide_details": True}


def build_panel(page: Any) -> None:
    """The panel, inside the current layout context."""
    from trame.widgets import html

    with html.Div(classes="d-flex flex-column ga-2", raw_attrs=tid("gdt-panel")):
        _feature_card(page)
        _plan_tables(page)
        _datum_card(page)
        _characteristic_card(page)
        _run_card(page)
        _results(page)


def _title(text: str) -> None:
    from trame.widgets import html

    html.Div(text, classes="text-subtitle-2")


def _feature_card(page: Any) -> None:
    """Pick a region (or a CAD face) on the nominal, its type and association, Add."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    g = page.gdt

    def on_pick():
        g.start_picking()

    def on_whole():
        g.pick_whole()

    def on_type(kind):
        g.set_type(kind)

    def on_add():
        g.add_feature()

    with v.VCard(variant="outlined", raw_attrs=tid("gdt-feature")):
        with v.VCardText(classes="py-2 d-flex flex-column ga-2"):
            _title("Feature — picked on the nominal")
            with html.Div(classes="d-flex ga-2"):
                v.VTextField(
                    v_model=("gdt_f_id",), label="Id", style="max-width: 90px;", raw_attrs=tid("gdt-f-id"), **_SELECT
                )
                v.VSelect(
                    model_value=("gdt_f_type",),
                    items=("gdt_feature_types",),
                    label="Type",
                    update_modelValue=(on_type, "[$event]"),
                    raw_attrs=tid("gdt-f-type"),
                    **_SELECT,
                )
                v.VSelect(
                    v_model=("gdt_f_assoc",),
                    items=("gdt_associations",),
                    label="Association",
                    raw_attrs=tid("gdt-f-assoc"),
                    **_SELECT,
                )
            with html.Div(classes="d-flex ga-2 align-center"):
                v.VBtn(
                    "Pick on nominal",
                    prepend_icon="mdi-cursor-default-click",
                    size="small",
                    variant=("gdt_picking ? 'flat' : 'tonal'",),
                    color="primary",
                    click=on_pick,
                    disabled=("!ins_nominal",),
                    title="show the nominal alone; a click on it takes the region around the point (or the CAD face)",
                    raw_attrs=tid("gdt-pick"),
                )
                v.VBtn(
                    "Whole nominal",
                    size="small",
                    variant="tonal",
                    click=on_whole,
                    disabled=("!ins_nominal",),
                    title="the whole nominal is the feature (a ball, a pin)",
                    raw_attrs=tid("gdt-whole"),
                )
                v.VTextField(
                    v_model=("gdt_f_radius",),
                    label="Region radius",
                    placeholder="auto",
                    suffix="mm",
                    style="max-width: 130px;",
                    title="the region picked: the nominal's points within this distance of the click "
                    "(empty: a quarter of the nominal's size)",
                    raw_attrs=tid("gdt-f-radius"),
                    **_SELECT,
                )
            html.Div("{{ gdt_f_picked }}", v_if="gdt_f_picked", classes="text-caption", raw_attrs=tid("gdt-f-picked"))
            html.Div(
                "nominal: {{ gdt_f_nominal }}",
                v_if="gdt_f_nominal",
                classes="text-caption",
                raw_attrs=tid("gdt-f-nominal"),
            )
            v.VBtn(
                "Add feature",
                prepend_icon="mdi-plus",
                size="small",
                color="primary",
                variant="flat",
                click=on_add,
                disabled=("!gdt_f_ready",),
                style="align-self: flex-start;",
                raw_attrs=tid("gdt-f-add"),
            )


def _plan_tables(page: Any) -> None:
    """The plan's features, datums and characteristics, each removable."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    g = page.gdt

    def on_remove(kind, key):
        {"feature": g.remove_feature, "datum": g.remove_datum, "char": g.remove_characteristic}[kind](key)

    def remove_button(kind: str, key: str) -> None:
        v.VBtn(
            icon="mdi-close",
            size="x-small",
            variant="text",
            density="compact",
            click=(on_remove, f"['{kind}', {key}]"),
            title="remove from the plan",
        )

    with v.VTable(density="compact", v_if="gdt_features.length", raw_attrs=tid("gdt-features")):
        with html.Tbody():
            with html.Tr(v_for="f in gdt_features", key="f.id", raw_attrs=dyn_tid("'gdt-feature-' + f.id")):
                html.Td("{{ f.id }}", classes="text-body-2 font-weight-medium")
                html.Td("{{ f.type }}", classes="text-caption")
                html.Td("{{ f.nominal }}", classes="text-caption")
                with html.Td():
                    remove_button("feature", "f.id")
    with v.VTable(density="compact", v_if="gdt_datums.length", raw_attrs=tid("gdt-datums")):
        with html.Tbody():
            with html.Tr(v_for="d in gdt_datums", key="d.label"):
                html.Td("datum {{ d.label }}", classes="text-body-2")
                html.Td("on {{ d.feature }}", classes="text-caption")
                with html.Td():
                    remove_button("datum", "d.label")
    with v.VTable(density="compact", v_if="gdt_chars.length", raw_attrs=tid("gdt-chars")):
        with html.Tbody():
            with html.Tr(v_for="c in gdt_chars", key="c.id", raw_attrs=dyn_tid("'gdt-char-' + c.id")):
                html.Td("{{ c.id }}", classes="text-body-2")
                html.Td("{{ c.title }}", classes="text-caption")
                html.Td("{{ c.feature }}{{ c.datums ? ' | ' + c.datums : '' }}", classes="text-caption")
                html.Td("{{ c.tolerance }}", classes="text-caption text-right")
                with html.Td():
                    remove_button("char", "c.id")


def _datum_card(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_add():
        page.gdt.add_datum()

    with html.Div(v_if="gdt_features.length", classes="d-flex ga-2 align-center", raw_attrs=tid("gdt-datum")):
        v.VTextField(
            v_model=("gdt_d_label",), label="Datum", style="max-width: 80px;", raw_attrs=tid("gdt-d-label"), **_SELECT
        )
        v.VSelect(
            v_model=("gdt_d_feature",),
            items=("gdt_feature_ids",),
            label="on feature",
            raw_attrs=tid("gdt-d-feature"),
            **_SELECT,
        )
        v.VBtn("Add datum", size="small", variant="tonal", click=on_add, raw_attrs=tid("gdt-d-add"))


def _characteristic_card(page: Any) -> None:
    """Type, feature, datums, tolerance (or a size's lower/upper), id, Add."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    g = page.gdt

    def on_char(kind, feature):
        g.set_char(kind, feature)

    def on_add():
        g.add_characteristic()

    with v.VCard(v_if="gdt_features.length", variant="outlined", raw_attrs=tid("gdt-char")):
        with v.VCardText(classes="py-2 d-flex flex-column ga-2"):
            _title("Characteristic")
            with html.Div(classes="d-flex ga-2"):
                v.VSelect(
                    model_value=("gdt_c_type",),
                    items=("gdt_char_types",),
                    label="Type",
                    update_modelValue=(on_char, "[$event, null]"),
                    raw_attrs=tid("gdt-c-type"),
                    **_SELECT,
                )
                v.VSelect(
                    model_value=("gdt_c_feature",),
                    items=("gdt_feature_ids",),
                    label="Feature",
                    style="max-width: 110px;",
                    update_modelValue=(on_char, "[null, $event]"),
                    raw_attrs=tid("gdt-c-feature"),
                    **_SELECT,
                )
                v.VSelect(
                    v_model=("gdt_c_datums",),
                    items=("gdt_datum_labels",),
                    label="Datums",
                    multiple=True,
                    chips=True,
                    style="max-width: 130px;",
                    raw_attrs=tid("gdt-c-datums"),
                    **_SELECT,
                )
            with html.Div(classes="d-flex ga-2"):
                v.VTextField(
                    v_model=("gdt_c_tol",),
                    v_if="!gdt_sizes.includes(gdt_c_type)",
                    label="Tolerance (zone)",
                    suffix="mm",
                    raw_attrs=tid("gdt-c-tol"),
                    **_SELECT,
                )
                v.VTextField(
                    v_model=("gdt_c_lower",),
                    v_if="gdt_sizes.includes(gdt_c_type)",
                    label="Lower deviation",
                    suffix="mm",
                    raw_attrs=tid("gdt-c-lower"),
                    **_SELECT,
                )
                v.VTextField(
                    v_model=("gdt_c_upper",),
                    v_if="gdt_sizes.includes(gdt_c_type)",
                    label="Upper deviation",
                    suffix="mm",
                    raw_attrs=tid("gdt-c-upper"),
                    **_SELECT,
                )
                v.VTextField(
                    v_model=("gdt_c_id",), label="Id", style="max-width: 150px;", raw_attrs=tid("gdt-c-id"), **_SELECT
                )
            v.VBtn(
                "Add characteristic",
                prepend_icon="mdi-plus",
                size="small",
                color="primary",
                variant="flat",
                click=on_add,
                style="align-self: flex-start;",
                raw_attrs=tid("gdt-c-add"),
            )


def _run_card(page: Any) -> None:
    """Alignment, Run, Show flags, the YAML export and import."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    g = page.gdt

    def on_run():
        in_background(g.run_async(), page.state)

    def on_show():
        g.show()

    def on_export():
        g.export_yaml()

    async def on_report():
        await g.report_async()

    def on_file(files):
        if files:
            f = files[0] if isinstance(files, list) else files
            g.import_yaml(f.get("content", b""), f.get("name", "plan.yaml"))
        page.state.gdt_file = None

    page.state.change("gdt_file")(lambda gdt_file=None, **_: on_file(gdt_file))
    v.VSelect(
        v_model=("gdt_align",), items=("gdt_align_options",), label="Alignment", raw_attrs=tid("gdt-align"), **_SELECT
    )
    with html.Div(classes="d-flex flex-wrap ga-2 align-center"):
        v.VBtn(
            "Run",
            color="primary",
            prepend_icon="mdi-play",
            size="small",
            click=on_run,
            loading=("gdt_running",),
            disabled=("gdt_running || !gdt_chars.length || !ins_measured",),
            raw_attrs=tid("gdt-run"),
        )
        v.VBtn(
            "Show flags",
            size="small",
            variant="tonal",
            click=on_show,
            disabled=("!gdt_results.length",),
            raw_attrs=tid("gdt-show"),
        )
        v.VBtn(
            "Report",
            prepend_icon="mdi-file-document-outline",
            size="small",
            variant="tonal",
            click=on_report,
            disabled=("gdt_running || !gdt_results.length",),
            title="the characteristics' own report (HTML, PDF, JSON) by the plugin's writer; added to the project "
            "(the Compare report carries them too)",
            raw_attrs=tid("gdt-report"),
        )
        v.VBtn(
            "Export plan (YAML)",
            prepend_icon="mdi-download",
            size="small",
            variant="outlined",
            click=on_export,
            disabled=("!gdt_features.length",),
            title="the plan as camcmm gdt evaluate reads it",
            raw_attrs=tid("gdt-export"),
        )
        v.VFileInput(
            v_model=("gdt_file", None),
            label="Import plan",
            accept=".yaml,.yml,.json,.qif,.QIF",
            prepend_icon="",
            prepend_inner_icon="mdi-file-upload",
            style="max-width: 190px;",
            title="replace the plan by a plan file (the YAML of camcmm gdt evaluate) or a QIF 3.0 file",
            raw_attrs=tid("gdt-import"),
            **_SELECT,
        )
    html.Span("{{ gdt_progress }}", v_if="gdt_progress", classes="text-caption", raw_attrs=tid("gdt-progress"))
    html.A(
        "{{ l.title }}",
        v_for="l in gdt_report_links",
        key="l.kind",
        href=("l.url",),
        target="_blank",
        download=("l.kind === 'html' ? undefined : l.name",),
        classes="text-body-2",
        raw_attrs=dyn_tid("'gdt-report-' + l.kind"),
    )
    html.A(
        "{{ l.title }}",
        v_for="l in gdt_links",
        key="l.name",
        href=("l.url",),
        download=("l.name",),
        classes="text-body-2",
        raw_attrs=tid("gdt-yaml-link"),
    )


def _results(page: Any) -> None:
    """The results table, each row coloured by its verdict."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(v_if="gdt_results.length", raw_attrs=tid("gdt-results")):
        _title("Results")
        html.Div("{{ gdt_result_note }}", classes="text-caption mb-1", raw_attrs=tid("gdt-result-note"))
        with v.VTable(density="compact", raw_attrs=tid("gdt-table")):
            with html.Thead():
                with html.Tr():
                    for head in ("Characteristic", "Value ± U", "Tolerance", "Verdict"):
                        html.Th(head, classes="text-caption")
            with html.Tbody():
                with html.Tr(
                    v_for="r in gdt_results",
                    key="r.id",
                    raw_attrs=dyn_tid("'gdt-row-' + r.id")
                    + [':data-verdict="r.verdict"', ":style=\"{background: r.colour + '26'}\""],
                ):
                    with html.Td(classes="py-1"):
                        html.Div("{{ r.title }}", classes="text-body-2")
                        html.Div(
                            "{{ r.id }} · {{ r.feature }}{{ r.datums ? ' | ' + r.datums : '' }}", classes="text-caption"
                        )
                    with html.Td(classes="text-right py-1"):
                        html.Div(
                            "{{ r.value }}",
                            classes="text-body-2 text-no-wrap",
                            raw_attrs=dyn_tid("'gdt-value-' + r.id"),
                        )
                        html.Div(
                            "U {{ r.U }}",
                            classes="text-caption text-no-wrap",
                            title=("r.u_method",),
                            raw_attrs=dyn_tid("'gdt-u-' + r.id"),
                        )
                    html.Td(
                        "{{ r.tolerance }}",
                        classes="text-caption text-right text-no-wrap",
                        raw_attrs=dyn_tid("'gdt-tol-' + r.id"),
                    )
                    with html.Td():
                        v.VChip(
                            "{{ r.verdict }}",
                            size="x-small",
                            variant="flat",
                            color=("r.colour",),
                            title=("'simple: ' + r.simple + '; ISO 14253-1 (guard band U): ' + r.verdict",),
                            raw_attrs=dyn_tid("'gdt-verdict-' + r.id"),
                        )
        with v.VExpansionPanels(v_if="gdt_warnings.length", classes="mt-1"):
            with v.VExpansionPanel(title=("'Warnings (' + gdt_warnings.length + ')'",)):
                with v.VExpansionPanelText():
                    html.Div("{{ w }}", v_for="(w, i) in gdt_warnings", key="i", classes="text-caption")
