"""Step 1 of the acceptance page: the setup card (standard, measuring system, MPEs,
artefacts with the fields the standard declares, more plan options, Start)."""

from __future__ import annotations

from typing import Any

from ...widgets import dyn_tid, tid


def set_form(path: str) -> str:
    """A JS statement that replaces ``wz_form`` by a copy with ``$event`` at ``path``.

    trame's template state hands out plain objects: writing into a nested property
    (``v-model="wz_form.x"``) would neither re-render nor reach the server, and a field
    would fall back to the old value on blur. Assigning a new top-level object does
    both. ``path`` items are JS expressions for the keys (``"'mpe'"``, ``"f.key"``)."""

    def build(obj: str, keys: list[str]) -> str:
        if not keys:
            return "$event"
        k = keys[0]
        return f"Object.assign({{}}, {obj}, {{[{k}]: {build(f'({obj} || {{}})[{k}]', keys[1:])}}})"

    return "wz_form = " + build("wz_form", [p.strip() for p in path.split("|")])


def build_setup(page: Any) -> None:
    """The setup step (shown while ``wz_step === 'setup'``); wires it to ``page``; every
    change of the form runs the standard's artefact rules on it."""
    from trame.widgets import html

    page.state.change("wz_form")(lambda wz_form=None, **_: page.check_artefacts(wz_form))

    with html.Div(v_if="wz_step === 'setup'", raw_attrs=tid("wz-setup")):
        _alerts(page)
        _standard_row(page)
        _volume_row()
        _mpe_row()
        _artefact_cards(page)
        _more_options(page)
        _artefact_warnings()  # right above Start, below the fields: no field moves while one types
        _start_buttons(page)
        _earlier_tests()


def _alerts(page: Any) -> None:
    """The test in the project (named, where it stands, with Set up a new test), the
    question before a new test replaces it, no standard installed, the setup error."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VAlert(v_if="wz_active && wz_locked", type="info", density="compact", variant="tonal", classes="mb-2"):
        # named (standard, system, when) and where it stands: never "running" for a finished test
        html.Div("Current test: {{ wz_test_name }}", classes="font-weight-medium", raw_attrs=tid("wz-test-name"))
        html.Span("{{ wz_test_status }} · {{ wz_progress_text }}. ", raw_attrs=tid("wz-test-status"))
        v.VBtn(
            "Set up a new test",
            size="small",
            variant="text",
            color="primary",
            click=page.ask_new_test,
            title="Fill in the form for a new test; the current test stays until you start the new one, "
            "and stays in the project after",
            raw_attrs=tid("wz-unlock"),
        )
    _supersede_dialog(page)
    v.VAlert(
        v_if="!wz_standards.length",
        type="warning",
        density="compact",
        classes="mb-2",
        text="No acceptance-test standard is installed: the command camcmm plugins, in a terminal, lists what is.",
    )
    v.VAlert(
        v_if="wz_setup_error",
        text=("wz_setup_error",),
        type="error",
        density="compact",
        classes="mb-2",
        raw_attrs=tid("wz-setup-error"),
    )


def _supersede_dialog(page: Any) -> None:
    """Asked before a new test replaces one with work in it (``wz_supersede``): which test,
    its verdict, where it stays findable; Keep it or go on."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_confirm(test_id, form):
        page.confirm_supersede(test_id, form)

    with v.VDialog(
        model_value=("!!wz_supersede",), update_modelValue="!$event && (wz_supersede = null)", max_width=560
    ):
        with v.VCard(v_if="wz_supersede", raw_attrs=tid("wz-supersede")):
            v.VCardTitle("Replace the current acceptance test?")
            with v.VCardText():
                html.Div("{{ wz_supersede.name }}", classes="font-weight-medium", raw_attrs=tid("wz-supersede-name"))
                html.Div("{{ wz_supersede.status }}", classes="mb-2", raw_attrs=tid("wz-supersede-status"))
                html.Div(
                    "A new test becomes the project's current test; the one above is kept: {{ wz_supersede.kept }}.",
                    classes="text-body-2",
                )
            with v.VCardActions():
                v.VSpacer()
                v.VBtn(
                    "Keep the current test",
                    click=page.cancel_supersede,
                    title="Nothing changes",
                    raw_attrs=tid("wz-supersede-keep"),
                )
                v.VBtn(
                    "{{ wz_supersede.action === 'start' ? 'Start the new test' : 'Set up a new test' }}",
                    color="primary",
                    click=(on_confirm, "[wz_supersede.id, wz_form]"),
                    title="The current test stays in the project (results list, Earlier tests)",
                    raw_attrs=tid("wz-supersede-confirm"),
                )


def _earlier_tests() -> None:
    """The tests set up before the current one, newest first, with their reports."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VExpansionPanels(v_if="wz_earlier.length", classes="mb-2", raw_attrs=tid("wz-earlier")):
        with v.VExpansionPanel(title=("'Earlier tests in this project (' + wz_earlier.length + ')'",)):
            with v.VExpansionPanelText():
                with html.Div(
                    v_for="e in wz_earlier", key="e.key", classes="mb-1", raw_attrs=dyn_tid("'wz-earlier-' + e.key")
                ):
                    html.Div("{{ e.name }}", classes="text-body-2")
                    with html.Div(classes="text-caption text-medium-emphasis"):
                        html.Span("{{ e.status }}")
                        html.A(
                            "{{ l.title }}",
                            v_for="l in e.links",
                            key="l.kind",
                            href=("l.url",),
                            target="_blank",
                            download=("l.kind === 'html' ? undefined : l.name",),
                            classes="mx-2",
                        )


def _artefact_warnings() -> None:
    """The standard's artefact rules the setup breaks, always in view (not in a closed
    panel), with the "start anyway" switch Start waits for; or why they are not checked yet."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VAlert(
        v_if="wz_artefact_warnings.length",
        type="warning",
        density="compact",
        variant="tonal",
        classes="mb-2",
        raw_attrs=tid("wz-artefact-warnings"),
    ):
        html.Div(
            "This setup breaks {{ wz_artefact_warnings.length }} artefact rule(s) of the standard: the "
            "evaluation runs, but the test deviates from the standard and its report says so.",
            classes="font-weight-medium",
        )
        with html.Ul(classes="ml-4"):
            html.Li("{{ w }}", v_for="(w, i) in wz_artefact_warnings", key="i")
        v.VSwitch(
            v_if="!wz_locked",
            v_model=("wz_confirm_violations", False),
            label="Start anyway (a test that deviates from the standard)",
            color="warning",
            density="compact",
            hide_details=True,
            title="Start although the artefacts break the rules listed above; the report says so",
            raw_attrs=tid("wz-confirm-violations"),
        )
    html.Div(
        "{{ wz_artefact_note }}",
        v_if="wz_artefact_note && !wz_locked",
        classes="text-caption text-medium-emphasis mb-2",
        raw_attrs=tid("wz-artefact-note"),
    )


def _standard_row(page: Any) -> None:
    """The standard and the measuring system's name."""
    from trame.widgets import vuetify3 as v

    def on_standard(std, form):
        page.choose_standard(std, form)

    with v.VRow(dense=True):
        with v.VCol(cols=12, md=7):
            v.VSelect(
                model_value=("wz_form.standard",),
                items=("wz_standards",),
                label="Standard",
                density="compact",
                variant="outlined",
                disabled=("wz_locked",),
                hide_details=True,
                update_modelValue=(on_standard, "[$event, wz_form]"),
                title="The acceptance test to run (each standard plugin declares its own)",
                raw_attrs=tid("wz-standard"),
            )
        with v.VCol(cols=12, md=5):
            v.VTextField(
                model_value=("wz_form.system_name",),
                update_modelValue=set_form("'system_name'"),
                label="Measuring system",
                density="compact",
                variant="outlined",
                disabled=("wz_locked",),
                hide_details=True,
                title="The name of the measuring system under test, as the report names it",
                raw_attrs=tid("wz-system-name"),
            )


def _volume_row() -> None:
    """The measuring volume, x y z in mm."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("Measuring volume", classes="text-caption mt-3 mb-2")
    with v.VRow(dense=True):
        for i, axis in enumerate("xyz"):
            with v.VCol(cols=4):
                v.VTextField(
                    model_value=(f"wz_form.volume[{i}]",),
                    update_modelValue=set_form(f"'volume' | {i}").replace(
                        "Object.assign({}, (wz_form || {})['volume']", "Object.assign([], (wz_form || {})['volume']"
                    ),
                    label=f"{axis} [mm]",
                    density="compact",
                    variant="outlined",
                    disabled=("wz_locked",),
                    hide_details=True,
                    title=f"The measuring volume's size along {axis}",
                    raw_attrs=tid(f"wz-volume-{axis}"),
                )


def _field_grid(fields: str, value: str, path: str, testid: str, md: int = 3) -> None:
    """A grid of number fields, one per declared field ``f`` of the list ``fields``
    (label and unit from the declaration), each bound to ``value`` in the setup form
    (written back at ``path``, see :func:`set_form`); ``md``: columns of 12 per field on a
    wide screen (an artefact's labels, "Flatness (calibrated) [mm]", need 4 to be read whole
    in the page's 55 % at 1366 px)."""
    from trame.widgets import vuetify3 as v

    with v.VRow(dense=True):
        with v.VCol(v_for=f"f in {fields}", key="f.key", cols=6, md=md):
            v.VTextField(
                model_value=(value,),
                update_modelValue=set_form(path),
                label=("f.unit ? f.label + ' [' + f.unit + ']' : f.label",),
                density="compact",
                variant="outlined",
                disabled=("wz_locked",),
                hide_details=True,
                title=("f.help || f.label",),
                raw_attrs=dyn_tid(testid),
            )


def _mpe_row() -> None:
    """One field per MPE the standard's tests evaluate."""
    from trame.widgets import html

    html.Div("Maximum permissible errors (from the system's specification)", classes="text-caption mt-3 mb-2")
    _field_grid("wz_mpe_fields", "wz_form.mpe[f.key]", "'mpe' | f.key", "'wz-mpe-' + f.key")


def _artefact_cards(page: Any) -> None:
    """One card per test of the standard: its artefact from the catalogue and its fields."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("Artefacts", classes="text-caption mt-3 mb-2")
    with v.VCard(
        v_for="t in wz_form_tests",
        key="t.test",
        variant="outlined",
        classes="mb-2",
        raw_attrs=dyn_tid("'wz-artefact-' + t.test"),
    ):
        with v.VCardText(classes="pb-1"):
            _artefact_header()
            with html.Div(v_if="t.required || (wz_form.include || []).includes(t.test)"):
                _artefact_fields(page)


def _artefact_header() -> None:
    """The test's name, its count of positions and repeats, include for an optional one."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center ga-2 mb-2"):
        html.Span("{{ t.label }}", classes="text-subtitle-2")
        v.VChip(
            "{{ t.min_count }} positions{{ t.repeats > 1 ? ' × ' + t.repeats + ' repeats' : '' }}",
            size="x-small",
            variant="tonal",
        )
        v.VCheckbox(
            v_if="!t.required",
            model_value=("wz_form.include",),
            update_modelValue=set_form("'include'"),
            value=("t.test",),
            multiple=True,
            label="include (optional)",
            density="compact",
            hide_details=True,
            disabled=("wz_locked",),
            title="This test is optional in the standard: run it too",
        )


def _artefact_fields(page: Any) -> None:
    """The catalogue choice and the fields the standard declares for the artefact."""
    from trame.widgets import vuetify3 as v

    def on_pick(test, choice, form):
        page.pick_artefact(test, choice, form)

    v.VSelect(
        model_value=("(wz_form.artefacts[t.test] || {})._choice",),
        items=("t.options",),
        label="From the catalogue",
        density="compact",
        variant="outlined",
        disabled=("wz_locked",),
        hide_details=True,
        classes="mb-2",
        update_modelValue=(on_pick, "[t.test, $event, wz_form]"),
        title="Fill the artefact's values from the catalogue (calibrated artefacts; edit them below if yours differ)",
        raw_attrs=dyn_tid("'wz-catalogue-' + t.test"),
    )
    _field_grid(
        "t.fields",
        "(wz_form.artefacts[t.test] || {})[f.key]",
        "'artefacts' | t.test | f.key",
        "'wz-field-' + t.test + '-' + f.key",
        md=4,
    )


def _more_options(page: Any) -> None:
    """More plan options in a closed panel: a form built from what the standard declares
    (``wz_option_fields``), the set ones downloadable as plan YAML, and YAML read in."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VExpansionPanels(classes="mb-2", raw_attrs=tid("wz-advanced")):
        with v.VExpansionPanel(title="More plan options"):
            with v.VExpansionPanelText():
                html.Div(
                    "Each option keeps the standard's default unless set here.",
                    classes="text-caption text-medium-emphasis mb-2",
                )
                with v.VRow(dense=True):
                    with v.VCol(v_for="f in wz_option_fields", key="f.key", cols=12, md=6):
                        common = dict(
                            model_value=("(wz_form.options || {})[f.key]",),
                            update_modelValue=set_form("'options' | f.key"),
                            label=("f.label",),
                            density="compact",
                            disabled=("wz_locked",),
                            hide_details=True,
                            title=("f.help",),
                            raw_attrs=dyn_tid("'wz-option-' + f.key"),
                        )
                        v.VSwitch(v_if="f.widget === 'switch'", color="primary", **common)
                        v.VSelect(v_else_if="f.widget === 'select'", items=("f.items",), variant="outlined", **common)
                        v.VTextField(v_else=True, variant="outlined", **common)
                html.A(
                    "Download these options as YAML",
                    v_if="wz_options_yaml",
                    href=("'data:text/yaml;charset=utf-8,' + encodeURIComponent(wz_options_yaml)",),
                    download="plan-options.yaml",
                    classes="text-body-2 d-inline-block mt-2",
                    title="The options set above as plan keys (docs/standards.md), to keep or to reuse",
                    raw_attrs=tid("wz-options-export"),
                )
                _options_import(page)


def _options_import(page: Any) -> None:
    """Plan options read from YAML (pasted), in a closed panel inside the options."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_import(text, form):
        page.import_options(text, form)

    with v.VExpansionPanels(classes="mt-2", variant="accordion"):
        with v.VExpansionPanel(title="Read options from YAML (a plan file's keys)"):
            with v.VExpansionPanelText():
                v.VTextarea(
                    v_model=("wz_options_import", ""),
                    rows=3,
                    auto_grow=True,
                    density="compact",
                    variant="outlined",
                    disabled=("wz_locked",),
                    hide_details=True,
                    placeholder="unit: mm\noutliers: {sphere: 'percent:5'}",
                    raw_attrs=tid("wz-options"),
                )
                v.VBtn(
                    "Read",
                    size="small",
                    variant="tonal",
                    classes="mt-2",
                    disabled=("wz_locked || !wz_options_import",),
                    click=(on_import, "[wz_options_import, wz_form]"),
                    title="Fill the options above from this YAML (the keys the form above owns are left out)",
                    raw_attrs=tid("wz-options-read"),
                )
                html.Div(
                    "{{ wz_options_note }}",
                    v_if="wz_options_note",
                    classes="text-caption text-medium-emphasis mt-1",
                    raw_attrs=tid("wz-options-note"),
                )
                html.Div(
                    "{{ wz_options_error }}",
                    v_if="wz_options_error",
                    classes="text-caption text-error mt-1",
                    raw_attrs=tid("wz-options-error"),
                )


def _start_buttons(page: Any) -> None:
    """Start the test (held while artefact rules are broken and "start anyway" is off);
    Go to the positions while one runs."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_start(form):
        page.start(form)

    with html.Div(classes="d-flex ga-2 mt-2"):
        v.VBtn(
            "Start the test",
            color="primary",
            prepend_icon="mdi-play",
            disabled=("wz_locked || (wz_artefact_warnings.length > 0 && !wz_confirm_violations)",),
            click=(on_start, "[wz_form]"),
            title="Set the test up from this form and go to its positions (Ctrl+Enter)",
            raw_attrs=[*tid("wz-start"), 'data-shortcut="run"'],
        )
        v.VBtn(
            "Go to the positions",
            v_if="wz_active",
            variant="text",
            click="wz_step = 'positions'",
            title="Back to the positions of the test in the project",
            raw_attrs=tid("wz-goto-positions"),
        )
