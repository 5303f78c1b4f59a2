"""Step 3 of the acceptance page: the verdicts, the parameters with value, MPE, U and
both verdicts, warnings, and Report with the links to its files."""

from __future__ import annotations

from typing import Any

from ...widgets import dyn_tid, tid

VERDICT_COLORS = "{pass: 'success', fail: 'error', inconclusive: 'warning', incomplete: 'grey'}"


def verdict_color(expr: str) -> tuple[str]:
    """A Vuetify colour binding for the verdict in the JavaScript ``expr``."""
    return (f"({VERDICT_COLORS})[{expr}] || 'grey'",)


def build_result(page: Any) -> None:
    """The result step (shown while ``wz_step === 'result'``); wires it to ``page``."""
    from trame.widgets import html

    with html.Div(v_if="wz_step === 'result' && wz_active", raw_attrs=tid("wz-result")):
        # which test this is (the same line in every tab on the project)
        html.Div("{{ wz_test_name }}", classes="text-subtitle-2 mb-1", raw_attrs=tid("wz-result-name"))
        _verdicts()
        html.Div("{{ wz_progress_text }}", classes="text-caption mb-2")
        _parameter_table()
        _warnings()
        _report(page)


def _verdicts() -> None:
    """The overall verdict, simple and guarded (ISO 14253-1)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center ga-3 mb-2"):
        html.Span("Verdict", classes="text-h6")
        v.VChip(
            "{{ (wz_verdict || 'incomplete').toUpperCase() }}",
            size="large",
            variant="flat",
            color=verdict_color("wz_verdict"),
            raw_attrs=tid("wz-verdict"),
        )
        html.Span("guarded (ISO 14253-1):", classes="text-caption")
        v.VChip(
            "{{ (wz_verdict_guarded || 'incomplete').toUpperCase() }}",
            size="small",
            variant="tonal",
            color=verdict_color("wz_verdict_guarded"),
            raw_attrs=tid("wz-verdict-guarded"),
        )


def _parameter_table() -> None:
    """One row per parameter: value, MPE, U, both verdicts and n."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VTable(density="compact", raw_attrs=tid("wz-parameters")):
        with html.Thead():
            with html.Tr():
                for h, tip in (
                    ("Parameter", ""),
                    ("Value", ""),
                    ("MPE", "maximum permissible error, from the system's specification"),
                    ("U (k = 2)", "expanded uncertainty of the test, coverage factor k = 2"),
                    ("Verdict", "simple acceptance: the value against the MPE"),
                    ("Guarded", "guarded acceptance (ISO 14253-1): the value with its uncertainty U against the MPE"),
                    ("n", "measurements evaluated"),
                ):
                    html.Th(h, title=tip)
        with html.Tbody():
            with html.Tr(v_for="p in wz_parameters", key="p.key", raw_attrs=dyn_tid("'wz-param-' + p.key")):
                with html.Td(title=("p.note",)):
                    html.Div("{{ p.name }}")
                    html.Div("{{ p.note }}", v_if="p.note", classes="text-caption text-medium-emphasis")
                html.Td("{{ p.value }}", classes="text-right text-no-wrap")
                html.Td("{{ p.mpe }}", classes="text-right text-no-wrap")
                html.Td("{{ p.U }}", classes="text-right text-no-wrap")
                with html.Td():
                    v.VChip("{{ p.verdict_text }}", size="x-small", variant="flat", color=verdict_color("p.verdict"))
                with html.Td():
                    v.VChip(
                        "{{ p.guarded_text }}",
                        size="x-small",
                        variant="tonal",
                        color=verdict_color("p.verdict_guarded"),
                    )
                html.Td("{{ p.n }}")


def _warnings() -> None:
    """The summary's warnings, in a closed panel."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VExpansionPanels(v_if="wz_summary_warnings.length", classes="my-2"):
        with v.VExpansionPanel(title=("'Warnings (' + wz_summary_warnings.length + ')'",)):
            with v.VExpansionPanelText():
                html.Div("{{ w }}", v_for="(w, i) in wz_summary_warnings", key="i", classes="text-caption")


def _report(page: Any) -> None:
    """Report and the links to its files."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_report():
        await page.report_async()

    with html.Div(classes="d-flex align-center flex-wrap ga-2 mt-3"):
        v.VBtn(
            "Report",
            color="primary",
            prepend_icon="mdi-file-document-outline",
            loading=("wz_reporting",),
            disabled=("wz_reporting",),
            click=on_report,
            title="Write the test report (HTML, PDF, JSON) and store it in the project (Ctrl+Enter)",
            raw_attrs=[*tid("wz-report"), 'data-shortcut="run"'],
        )
        html.A(
            "{{ l.title }}",
            v_for="l in wz_report_links",
            key="l.kind",
            href=("l.url",),
            target="_blank",
            download=("l.kind === 'html' ? undefined : l.name",),
            classes="text-body-2 mx-2",
            raw_attrs=dyn_tid("'wz-report-' + l.kind"),
        )
    html.Div(
        "The report is stored in the project with the summary result; Report again after a redo.",
        classes="text-caption mt-1",
    )
