"""The Monte Carlo tab's form: the stereo system as the plugin's declared fields (or a
loaded YAML file instead), the run's fields, the studies, Run / Cancel."""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...widgets import param_form, tid
from .budget_view import links


def _mc_fields(html: Any, fields: str, title: str, disabled: str) -> None:
    """One group of the plugin's declared fields, two to a row; the help is each field's
    tooltip (no hints under the fields: one appearing on focus and going on blur moves
    the Run button under the pointer; the server checks the values and names a wrong one)."""
    html.Div(title, classes="text-subtitle-2 mt-2 mb-1")
    with html.Div(style="display: grid; grid-template-columns: 1fr 1fr; column-gap: 8px;"):
        param_form(fields, "unc_mc_params", "unc-mc", disabled=disabled, hide_details=True)


def _mc_system_file(v: Any, html: Any, page: Any) -> None:
    """The "load YAML" option: a system file instead of the fields, and the way back."""

    def on_file(files):
        if files:
            f = files[0] if isinstance(files, list) else files
            page.load_system(f.get("content", b""), f.get("name", "system.yaml"))
        page.state.unc_mc_file = None

    page.state.change("unc_mc_file")(lambda unc_mc_file=None, **_: on_file(unc_mc_file))
    # a fixed-height slot: loading a file or going back moves nothing below
    with html.Div(classes="d-flex ga-2 align-center", style="height: 44px;"):
        v.VFileInput(
            v_if="!unc_mc_loaded",
            v_model=("unc_mc_file", None),
            label="Load a system (YAML) instead",
            accept=".yaml,.yml,.json",
            density="compact",
            variant="outlined",
            hide_details=True,
            prepend_icon="",
            prepend_inner_icon="mdi-file-upload",
            disabled=("unc_mc_running",),
            title="optional: a system file (cameras, stereo, grid, uncertainties, or a stereo calibration) "
            "used instead of the fields below",
            raw_attrs=tid("unc-mc-load"),
        )
        html.Div(
            "System from {{ unc_mc_loaded }}: the fields below are not used",
            v_if="unc_mc_loaded",
            classes="text-body-2 flex-grow-1",
            raw_attrs=tid("unc-mc-loaded"),
        )
        v.VBtn(
            "Use the fields",
            v_if="unc_mc_loaded",
            size="small",
            variant="tonal",
            click=page.use_fields,
            disabled=("unc_mc_running",),
            title="simulate the system of the fields below again, not the loaded file",
            raw_attrs=tid("unc-mc-use-fields"),
        )


def mc_form(v: Any, html: Any, page: Any) -> None:
    """The system (the plugin's declared fields, or a loaded file), the run's parameters,
    the studies, Run / Cancel, progress and the exports."""

    def on_run(params, studies):
        # returns at once: Cancel must reach the server while the study runs
        in_background(page.run_montecarlo_async({**(params or {}), "studies": studies}), page.state)

    def on_cancel():
        page.cancel()

    _mc_system_file(v, html, page)
    fixed = "unc_mc_running || !!unc_mc_loaded"
    _mc_fields(html, "unc_mc_fields_system", "Cameras, stereo pair and grid", fixed)
    _mc_fields(html, "unc_mc_fields_errors", "Error sources: standard uncertainties and dof", fixed)
    _mc_fields(html, "unc_mc_fields_run", "Run", "unc_mc_running")
    v.VSelect(
        v_model=("unc_mc_studies", []),
        items=("unc_mc_study_options",),
        label="Studies",
        multiple=True,
        chips=True,
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mt-2",
        disabled=("unc_mc_running",),
        title="extra studies: convergence with iterations, feature-location sweep, volume maps, spatial variation",
        raw_attrs=tid("unc-mc-studies"),
    )
    with html.Div(classes="d-flex ga-2 mt-2"):
        v.VBtn(
            "Run",
            color="primary",
            prepend_icon="mdi-play",
            loading=("unc_mc_running",),
            disabled=("unc_mc_running",),
            click=(on_run, "[unc_mc_params, unc_mc_studies]"),
            title="run the Monte Carlo study (Ctrl+Enter)",
            raw_attrs=tid("unc-mc-run") + ['data-shortcut="run"'],
        )
        v.VBtn(
            "Cancel",
            v_if="unc_mc_running",
            variant="text",
            click=on_cancel,
            title="stop the run; nothing is stored",
            raw_attrs=tid("unc-mc-cancel"),
        )
    with v.VProgressLinear(
        v_show="unc_mc_running || unc_mc_progress > 0",
        model_value=("unc_mc_progress",),
        height=18,
        rounded=True,
        classes="mt-2",
        color=("unc_mc_running ? 'primary' : 'success'",),
        raw_attrs=tid("unc-mc-progress"),
    ):
        html.Span("{{ Math.round(unc_mc_progress) }} %", classes="text-caption")
    html.Div("{{ unc_mc_message }}", classes="text-caption mt-1", raw_attrs=tid("unc-mc-message"))
    links(v, html, "unc_mc_links", "unc-mc-links")
