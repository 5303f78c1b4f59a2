"""The acceptance-test wizard's page: the Vuetify layout around a
:class:`camcmm.gui.wizard.WizardPage`.

Three steps in tabs: **1 Setup** (standard, measuring system, MPEs, artefacts from the
catalogue or entered), **2 Positions** (per test a grid of position cards: pictogram,
status, values and verdict, Import / Redo / Show, counters "7 of 10 sphere
positions"), **3 Result** (parameters with value, MPE, U and both verdicts; Report).

The pictograms on the cards are drawn by :mod:`camcmm.gui.wizard_pictograms`;
:func:`pictogram` and :func:`pictograms` stay importable from here.
"""

from __future__ import annotations

from typing import Any

from .wizard_pictograms import pictogram, pictograms

__all__ = ["VERDICT_COLORS", "build_panel", "page_switch", "pictogram", "pictograms"]

VERDICT_COLORS = ("{pass: 'success', fail: 'error', inconclusive: 'warning', incomplete: 'grey'}")


def _tid(name: str) -> list[str]:
    return [f'data-testid="{name}"']


def _dyn_tid(expr: str) -> list[str]:
    return [f':data-testid="{expr}"']


def _verdict_color(expr: str) -> tuple[str]:
    return (f"({VERDICT_COLORS})[{expr}] || 'grey'",)


def _set_form(path: str) -> str:
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


def build_panel(page: Any, accept: str = "") -> None:
    """The wizard's panel inside the current layout context (shown on the page
    ``page === 'acceptance'``); wires the widgets to ``page`` (a WizardPage)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    # -- handlers (thin: the logic is in the WizardPage) --------------------------------------
    def on_standard(std, form):
        page.choose_standard(std, form)

    def on_pick(test, choice, form):
        page.pick_artefact(test, choice, form)

    def on_start(form):
        page.start(form)

    async def on_upload(test, position, files):
        await page.upload_async(test, position, files)

    def on_redo(test, position):
        page.redo(test, position)

    def on_show(test, position):
        page.show(test, position)

    async def on_report():
        await page.report_async()

    async def on_acquire(test, position):
        await page.acquire_async(test, position)

    async def on_acquire_all():
        await page.acquire_all_async()

    def on_source(source):
        page.set_source(source)

    with html.Div(v_if="page === 'acceptance'", classes="pa-3",
                  style="flex: 0 0 55%; max-width: 55%; height: calc(100vh - 48px - 24px); overflow-y: auto; "
                        "border-right: 1px solid rgba(0,0,0,0.12);",
                  raw_attrs=_tid("wizard")):
        v.VAlert(v_if="wz_error", text=("wz_error",), type="error", density="compact", classes="mb-2",
                 raw_attrs=_tid("wz-error"))
        with v.VTabs(v_model=("wz_step", "setup"), density="compact", color="primary", classes="mb-2",
                     raw_attrs=_tid("wz-steps")):
            v.VTab("1 · Setup", value="setup", raw_attrs=_tid("wz-tab-setup"))
            v.VTab("2 · Positions", value="positions", disabled=("!wz_active",), raw_attrs=_tid("wz-tab-positions"))
            v.VTab("3 · Result", value="result", disabled=("!wz_active",), raw_attrs=_tid("wz-tab-result"))

        # -- 1 setup ------------------------------------------------------------------------
        with html.Div(v_if="wz_step === 'setup'", raw_attrs=_tid("wz-setup")):
            with v.VAlert(v_if="wz_active && wz_locked", type="info", density="compact", variant="tonal",
                          classes="mb-2"):
                html.Span("A test is running in this project: {{ wz_progress_text }}. ")
                v.VBtn("Set up a new test", size="small", variant="text", color="primary", click="wz_locked = false",
                       raw_attrs=_tid("wz-unlock"))
            v.VAlert(v_if="!wz_standards.length", type="warning", density="compact", classes="mb-2",
                     text="No standard plugin is installed (kind 'standard'); `camcmm plugins` lists what is there.")
            v.VAlert(v_if="wz_setup_error", text=("wz_setup_error",), type="error", density="compact",
                     classes="mb-2", raw_attrs=_tid("wz-setup-error"))
            with v.VRow(dense=True):
                with v.VCol(cols=12, md=7):
                    v.VSelect(model_value=("wz_form.standard",), items=("wz_standards",), label="Standard",
                              density="compact", variant="outlined", disabled=("wz_locked",), hide_details=True,
                              update_modelValue=(on_standard, "[$event, wz_form]"), raw_attrs=_tid("wz-standard"))
                with v.VCol(cols=12, md=5):
                    v.VTextField(model_value=("wz_form.system_name",), update_modelValue=_set_form("'system_name'"),
                                 label="Measuring system", density="compact",
                                 variant="outlined", disabled=("wz_locked",), hide_details=True,
                                 raw_attrs=_tid("wz-system-name"))
            html.Div("Measuring volume", classes="text-caption mt-3 mb-2")
            with v.VRow(dense=True):
                for i, axis in enumerate("xyz"):
                    with v.VCol(cols=4):
                        v.VTextField(model_value=(f"wz_form.volume[{i}]",),
                                     update_modelValue=_set_form(f"'volume' | {i}").replace(
                                         "Object.assign({}, (wz_form || {})['volume']",
                                         "Object.assign([], (wz_form || {})['volume']"),
                                     label=axis, suffix="mm",
                                     density="compact", variant="outlined", disabled=("wz_locked",),
                                     hide_details=True, raw_attrs=_tid(f"wz-volume-{axis}"))
            html.Div("Maximum permissible errors (from the system's specification)", classes="text-caption mt-3 mb-2")
            with v.VRow(dense=True):
                with v.VCol(v_for="f in wz_mpe_fields", key="f.key", cols=6, md=3):
                    v.VTextField(model_value=("wz_form.mpe[f.key]",), update_modelValue=_set_form("'mpe' | f.key"),
                                 label=("f.label",), suffix="mm",
                                 density="compact", variant="outlined", disabled=("wz_locked",), hide_details=True,
                                 raw_attrs=_dyn_tid("'wz-mpe-' + f.key"))
            html.Div("Artefacts", classes="text-caption mt-3 mb-2")
            with v.VCard(v_for="t in wz_form_tests", key="t.test", variant="outlined", classes="mb-2",
                         raw_attrs=_dyn_tid("'wz-artefact-' + t.test")):
                with v.VCardText(classes="pb-1"):
                    with html.Div(classes="d-flex align-center ga-2 mb-2"):
                        html.Span("{{ t.label }}", classes="text-subtitle-2")
                        v.VChip("{{ t.min_count }} positions{{ t.repeats > 1 ? ' × ' + t.repeats + ' repeats' : '' }}",
                                size="x-small", variant="tonal")
                        v.VCheckbox(v_if="!t.required", model_value=("wz_form.include",),
                                    update_modelValue=_set_form("'include'"), value=("t.test",), multiple=True,
                                    label="include (optional)", density="compact", hide_details=True,
                                    disabled=("wz_locked",))
                    with html.Div(v_if="t.required || (wz_form.include || []).includes(t.test)"):
                        v.VSelect(model_value=("(wz_form.artefacts[t.test] || {})._choice",), items=("t.options",),
                                  label="From the catalogue", density="compact", variant="outlined",
                                  disabled=("wz_locked",), hide_details=True, classes="mb-2",
                                  update_modelValue=(on_pick, "[t.test, $event, wz_form]"),
                                  raw_attrs=_dyn_tid("'wz-catalogue-' + t.test"))
                        with v.VRow(dense=True):
                            with v.VCol(v_for="f in t.fields", key="f.key", cols=6, md=3):
                                v.VTextField(model_value=("(wz_form.artefacts[t.test] || {})[f.key]",),
                                             update_modelValue=_set_form("'artefacts' | t.test | f.key"),
                                             label=("f.label",),
                                             suffix=("f.unit",), density="compact", variant="outlined",
                                             disabled=("wz_locked",), hide_details=True,
                                             raw_attrs=_dyn_tid("'wz-field-' + t.test + '-' + f.key"))
            with v.VExpansionPanels(classes="mb-2", raw_attrs=_tid("wz-advanced")):
                with v.VExpansionPanel(title="More plan options (YAML, docs/standards.md)"):
                    with v.VExpansionPanelText():
                        v.VTextarea(model_value=("wz_form.options",), update_modelValue=_set_form("'options'"),
                                    rows=3, auto_grow=True, density="compact", variant="outlined",
                                    disabled=("wz_locked",), hide_details=True,
                                    placeholder="outliers: vdi2634\nscaling: {sphere: radii, ball_plate: lengths}\n"
                                                "repeats: 3\nunit: mm", raw_attrs=_tid("wz-options"))
            with html.Div(classes="d-flex ga-2 mt-2"):
                v.VBtn("Start the test", color="primary", prepend_icon="mdi-play", disabled=("wz_locked",),
                       click=(on_start, "[wz_form]"), raw_attrs=_tid("wz-start"))
                v.VBtn("Go to the positions", v_if="wz_active", variant="text", click="wz_step = 'positions'",
                       raw_attrs=_tid("wz-goto-positions"))

        # -- 2 positions --------------------------------------------------------------------
        with html.Div(v_if="wz_step === 'positions' && wz_active", raw_attrs=_tid("wz-positions")):
            html.Div("{{ wz_title }}", classes="text-subtitle-2 mb-1")
            with html.Div(v_if="wz_sources.length", classes="d-flex align-center ga-2 mb-2"):
                v.VSelect(model_value=("wz_source",),
                          items=("[{title: 'Import files (measured elsewhere)', value: null}].concat(wz_sources)",),
                          label="Measure with", density="compact", variant="outlined", hide_details=True,
                          style="max-width: 420px;", update_modelValue=(on_source, "[$event]"),
                          raw_attrs=_tid("wz-source"))
                v.VBtn("Acquire all", v_if="wz_source", size="small", color="primary", prepend_icon="mdi-camera-burst",
                       loading=("wz_acquiring_all",), disabled=("wz_acquiring_all",), click=on_acquire_all,
                       raw_attrs=_tid("wz-acquire-all"))
                v.VBtn("Stop", v_if="wz_acquiring_all", size="small", variant="text", click="wz_acquiring_all = false")
            with html.Div(classes="d-flex flex-wrap ga-2 mb-2"):
                v.VChip("{{ p.text }}", v_for="p in wz_progress", key="p.test", size="small",
                        color=("p.complete ? 'success' : 'primary'",), variant=("p.complete ? 'flat' : 'tonal'",),
                        prepend_icon=("p.complete ? 'mdi-check-circle' : 'mdi-progress-clock'",),
                        raw_attrs=_dyn_tid("'wz-counter-' + p.test"))
                v.VSpacer()
                v.VBtn("Result", v_if="wz_complete", size="small", color="success", append_icon="mdi-arrow-right",
                       click="wz_step = 'result'", raw_attrs=_tid("wz-goto-result"))
            with v.VCard(v_if="wz_detail", variant="tonal", color="primary", classes="mb-2",
                         raw_attrs=_tid("wz-detail")):
                with v.VCardText(classes="py-2"):
                    html.Div("Last shown: {{ wz_detail.title }} ({{ wz_detail.file }}) — deviation colour map "
                             "in the 3D view", classes="text-subtitle-2")
                    with html.Div(classes="d-flex flex-wrap ga-1 mt-1"):
                        v.VChip("{{ r.name }}: {{ r.value }}", v_for="r in wz_detail.rows", key="r.name",
                                size="x-small", variant="outlined")
                    html.Div("{{ w }}", v_for="(w, i) in wz_detail.warnings", key="i",
                             classes="text-caption text-warning")
            with html.Div(v_for="b in wz_blocks", key="b.test", classes="mb-3",
                          raw_attrs=_dyn_tid("'wz-block-' + b.test")):
                with html.Div(classes="d-flex align-center ga-2 mb-1"):
                    html.Span("{{ b.label }}", classes="text-subtitle-1")
                    v.VChip("{{ b.progress.done }} of {{ b.progress.total }}", size="small",
                            color=("b.progress.complete ? 'success' : 'primary'",), variant="tonal")
                v.VProgressLinear(model_value=("100 * b.progress.done / Math.max(b.progress.total, 1)",),
                                  color=("b.progress.complete ? 'success' : 'primary'",), height=4, rounded=True,
                                  classes="mb-2")
                with html.Div(style="display: grid; grid-template-columns: repeat(auto-fill, minmax(185px, 1fr)); "
                                    "gap: 8px;"):
                    _card(v, html, accept, on_upload, on_redo, on_show, on_acquire)

        # -- 3 result -------------------------------------------------------------------------
        with html.Div(v_if="wz_step === 'result' && wz_active", raw_attrs=_tid("wz-result")):
            with html.Div(classes="d-flex align-center ga-3 mb-2"):
                html.Span("Verdict", classes="text-h6")
                v.VChip("{{ (wz_verdict || 'incomplete').toUpperCase() }}", size="large", variant="flat",
                        color=_verdict_color("wz_verdict"), raw_attrs=_tid("wz-verdict"))
                html.Span("guarded (ISO 14253-1):", classes="text-caption")
                v.VChip("{{ (wz_verdict_guarded || 'incomplete').toUpperCase() }}", size="small", variant="tonal",
                        color=_verdict_color("wz_verdict_guarded"), raw_attrs=_tid("wz-verdict-guarded"))
            html.Div("{{ wz_progress_text }}", classes="text-caption mb-2")
            with v.VTable(density="compact", raw_attrs=_tid("wz-parameters")):
                with html.Thead():
                    with html.Tr():
                        for h in ("Parameter", "Value", "MPE", "U (k=2)", "Simple", "Guarded", "n"):
                            html.Th(h)
                with html.Tbody():
                    with html.Tr(v_for="p in wz_parameters", key="p.key", raw_attrs=_dyn_tid("'wz-param-' + p.key")):
                        with html.Td(title=("p.note",)):
                            html.Div("{{ p.name }}")
                            html.Div("{{ p.note }}", v_if="p.note", classes="text-caption text-medium-emphasis")
                        html.Td("{{ p.value }}", classes="text-right text-no-wrap")
                        html.Td("{{ p.mpe }}", classes="text-right text-no-wrap")
                        html.Td("{{ p.U }}", classes="text-right text-no-wrap")
                        with html.Td():
                            v.VChip("{{ p.verdict }}", size="x-small", variant="flat", color=_verdict_color("p.verdict"))
                        with html.Td():
                            v.VChip("{{ p.verdict_guarded }}", size="x-small", variant="tonal",
                                    color=_verdict_color("p.verdict_guarded"))
                        html.Td("{{ p.n }}")
            with v.VExpansionPanels(v_if="wz_summary_warnings.length", classes="my-2"):
                with v.VExpansionPanel(title=("'Warnings (' + wz_summary_warnings.length + ')'",)):
                    with v.VExpansionPanelText():
                        html.Div("{{ w }}", v_for="(w, i) in wz_summary_warnings", key="i", classes="text-caption")
            with html.Div(classes="d-flex align-center flex-wrap ga-2 mt-3"):
                v.VBtn("Report", color="primary", prepend_icon="mdi-file-document-outline",
                       loading=("wz_reporting",), disabled=("wz_reporting",), click=on_report,
                       raw_attrs=_tid("wz-report"))
                html.A("{{ l.title }}", v_for="l in wz_report_links", key="l.kind", href=("l.url",),
                       target="_blank", download=("l.kind === 'html' ? undefined : l.name",),
                       classes="text-body-2 mx-2", raw_attrs=_dyn_tid("'wz-report-' + l.kind"))
            html.Div("The report is stored in the project with the summary result; Report again after a redo.",
                     classes="text-caption mt-1")


def _card(v: Any, html: Any, accept: str, on_upload, on_redo, on_show, on_acquire) -> None:
    with v.VCard(v_for="c in b.cards", key="c.key", variant="outlined",
                 color=("c.status === 'done' ? (c.verdict === 'fail' ? 'error' : 'success') : "
                        "(c.status === 'error' ? 'error' : undefined)",),
                 raw_attrs=_dyn_tid("'card-' + c.id") + [':data-status="c.status"']):
        with html.Div(classes="d-flex align-center px-2 pt-1"):
            html.Span("{{ c.label }}", classes="text-body-2 font-weight-medium text-high-emphasis")
            v.VSpacer()
            v.VChip("{{ c.verdict }}", v_if="c.status === 'done'", size="x-small", variant="flat",
                    color=_verdict_color("c.verdict"), raw_attrs=_tid("card-verdict"))
            v.VChip("to do", v_if="c.status === 'pending'", size="x-small", variant="tonal",
                    raw_attrs=_tid("card-pending"))
            v.VChip("error", v_if="c.status === 'error'", size="x-small", variant="flat", color="error")
            v.VChip("{{ c.repeats.filter(r => r.status === 'done').length }}/{{ c.n_repeats }}",
                    v_if="c.status === 'partial'", size="x-small", variant="tonal", color="primary")
        html.Div(v_html="wz_svgs[c.key]", style="height: 104px;", classes="px-2 text-center", title=("c.hint",))
        html.Div("{{ c.hint }}", classes="text-caption text-medium-emphasis px-2",
                 style="line-height: 1.2; min-height: 2.4em;")
        v.VProgressLinear(v_if="wz_busy[c.key]", indeterminate=True, color="primary", classes="mt-1")
        with html.Div(v_if="c.status === 'done' || c.status === 'partial'", classes="px-2 pt-1",
                      raw_attrs=_tid("card-values")):
            with html.Template(v_for="r in c.repeats", key="r.repeat"):
                with html.Div(v_if="r.status === 'done'", classes="d-flex flex-wrap ga-1 align-center"):
                    html.Span("#{{ r.repeat }}", v_if="c.n_repeats > 1", classes="text-caption")
                    v.VChip("{{ x.symbol }} {{ x.text }}", v_for="x in r.values", key="x.param", size="x-small",
                            variant="tonal", color=_verdict_color("x.verdict"))
                html.Div("{{ r.fit }}", v_if="r.status === 'done'", classes="text-caption text-medium-emphasis")
        v.VAlert(v_if="c.error", text=("c.error",), type="error", density="compact", variant="tonal",
                 classes="mx-2 mt-1 text-caption", raw_attrs=_tid("card-error"))
        with html.Div(v_if="(c.status !== 'done' || wz_redo === c.key) && !wz_busy[c.key]", classes="px-2 pt-2"):
            v.VBtn("Acquire", v_if="wz_source", block=True, size="small", color="primary", variant="tonal",
                   prepend_icon="mdi-camera-iris", classes="mb-1", disabled=("wz_acquiring_all",),
                   click=(on_acquire, "[c.test, c.id]"), raw_attrs=_tid("card-acquire"))
            v.VFileInput(label=("c.status === 'done' ? 'Redo: choose a file' : 'Import measurement'",),
                         accept=accept, density="compact", variant="outlined", hide_details=True,
                         prepend_icon="", prepend_inner_icon="mdi-file-import",
                         update_modelValue=(on_upload, "[c.test, c.id, $event]"),
                         raw_attrs=_tid("card-file") + [':key="c.key + \'-\' + (c.repeats.map(r => r.measurement).join())'
                                                        ' + \'-\' + c.error"'])
        with v.VCardActions(v_if="c.status === 'done' || c.status === 'partial'", classes="py-1"):
            v.VBtn("Show", size="small", variant="text", prepend_icon="mdi-palette",
                   click=(on_show, "[c.test, c.id]"), raw_attrs=_tid("card-show"))
            v.VBtn("Redo", size="small", variant="text", prepend_icon="mdi-restore", v_if="wz_redo !== c.key",
                   click=(on_redo, "[c.test, c.id]"), raw_attrs=_tid("card-redo"))
            v.VBtn("Cancel", size="small", variant="text", v_if="wz_redo === c.key", click="wz_redo = null")


def page_switch(v: Any) -> None:
    """The toolbar's page toggle: Inspect | Acceptance test (the drawer belongs to Inspect)."""
    with v.VBtnToggle(v_model=("page", "inspect"), mandatory=True, density="compact", variant="outlined",
                      divided=True, color="primary", classes="ml-4",
                      update_modelValue="main_drawer = ($event === 'inspect')", raw_attrs=_tid("page-switch")):
        v.VBtn("Inspect", value="inspect", prepend_icon="mdi-cube-scan", raw_attrs=_tid("page-inspect"))
        v.VBtn("Acceptance test", value="acceptance", prepend_icon="mdi-clipboard-check-outline",
               raw_attrs=_tid("page-acceptance"))
