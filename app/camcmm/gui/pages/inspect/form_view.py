"""The Inspect page's plugin panel: the installed plugins (a list of its own, scrolled
on its own) and the chosen plugin's form.

Run sits ABOVE the form, in a row of fixed height with Cancel and one line saying why a
run cannot start (``run_reason``) or how the last one ended (``run_status``): nothing
the form does — a hint, a rule message, a switch — can move Run under the pointer. The
form's values are sent to the server as they change (``sync``), so the reason follows
the form and a click right after a change runs with that change.
"""

from __future__ import annotations

from typing import Any

from ...widgets import assign, dyn_tid, param_form, tid


def _plugins(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VList(density="compact", nav=True, style="max-height: 32vh; overflow-y: auto;", raw_attrs=tid("plugins")):
        v.VListSubheader("Plugins ({{ plugins.length }})")
        with v.VListItem(
            v_for="p in plugins",
            key="p.id",
            active=("p.id === selected_plugin",),
            color="primary",
            disabled=("!p.runnable && p.ok",),
            click=(page.select_plugin, "[p.id]"),
            classes="plugin-row",
            raw_attrs=tid("plugin") + [':data-plugin-id="p.id"'],
        ):
            v.VTooltip(activator="parent", text=("p.summary || p.status",), location="end", open_delay=600)
            v.VListItemTitle("{{ p.name }}")
            with html.Div(classes="d-flex align-center ga-1"):
                # the version only: the id is the command line's name (camcmm run <id>), not a word
                # to read here (issue 30); data-plugin-id keeps it for scripts and tests
                html.Span("v{{ p.version }}", classes="text-caption text-medium-emphasis")
                v.VChip("{{ p.kind }}", size="x-small", variant="tonal", color="secondary")
                v.VChip("failed", v_if="!p.ok", size="x-small", variant="flat", color="error")
            html.Div("{{ p.status }}", v_if="!p.ok", classes="text-caption text-error", raw_attrs=tid("plugin-error"))
        v.VListItem(v_if="!plugins.length", subtitle="No plugins installed.")


def _run_row(page: Any) -> None:
    """Run, Cancel and the one-line reason or status: fixed height, above the form."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center ga-2 mb-1", style="height: 40px;", raw_attrs=tid("run-row")):
        v.VBtn(
            "Run",
            color="primary",
            prepend_icon="mdi-play",
            click=(page.run_clicked, "[selected_plugin, form_values, input_values]"),
            disabled=("running",),
            loading=("running",),
            title="Run the plugin with the values below (Ctrl+Enter)",
            raw_attrs=tid("run-button") + ['data-shortcut="run"'],
        )
        v.VBtn(
            "Cancel",
            variant="text",
            disabled=("!running",),
            click=page.cancel,
            title="Stop the running plugin (its partial work is discarded)",
            raw_attrs=tid("cancel-button"),
        )
        html.Span(
            "{{ run_reason }}",
            v_if="run_reason",
            classes=("running ? 'text-caption text-medium-emphasis' : 'text-caption text-error'",),
            style="flex: 1 1 auto; min-width: 0; overflow: hidden; text-overflow: ellipsis; white-space: nowrap;",
            title=("run_reason",),
            raw_attrs=tid("run-reason"),
        )
        html.Span(
            "{{ run_status }}",
            v_else=True,
            # a failed run's reason in the error colour: green would read as "done"
            classes=("progress_message === 'failed' ? 'text-caption text-error' : 'text-caption text-success'",),
            style="flex: 1 1 auto; min-width: 0; overflow: hidden; text-overflow: ellipsis; white-space: nowrap;",
            title=("run_status",),
            raw_attrs=tid("run-status"),
        )
    with v.VProgressLinear(
        model_value=("progress",),
        indeterminate=("running && progress <= 0",),
        height=16,
        color=("running ? 'primary' : progress_message === 'failed' ? 'error' : 'success'",),
        bg_opacity=0.15,
        classes="mb-2",
        rounded=True,
        title="Progress of the run",
        raw_attrs=tid("progress"),
    ):
        html.Span("{{ progress_message }} {{ Math.round(progress) }} %", classes="text-caption")


def _inputs() -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Template(v_for="inp in form_inputs", key="inp.name"):
        v.VSelect(
            v_if="inp.supported",
            model_value=("input_values[inp.name]",),
            update_modelValue=assign("input_values", "inp.name"),
            items=("inp.options",),
            label=("inp.label",),
            hint=("inp.help",),
            persistent_hint=True,
            density="compact",
            variant="outlined",
            classes="mb-1",
            title=("inp.help",),
            raw_attrs=dyn_tid("'input-' + inp.name"),
        )
        v.VTextField(
            v_else=True,
            model_value=("input_values[inp.name]",),
            update_modelValue=assign("input_values", "inp.name"),
            label=("inp.label + ' — path on the server'",),
            hint=("inp.help",),
            persistent_hint=True,
            density="compact",
            variant="outlined",
            classes="mb-1",
            title=("inp.help",),
            raw_attrs=dyn_tid("'input-' + inp.name"),
        )


def _form(page: Any) -> None:
    from trame.widgets import html

    with html.Div(v_if="selected_plugin", classes="px-3 pb-3", raw_attrs=tid("plugin-form")):
        html.Div("{{ plugin_title }}", classes="text-subtitle-2 text-truncate", title=("plugin_title",))
        html.Div(
            "{{ plugin_summary }}",
            classes="text-caption mb-1",
            style="height: 3em; overflow: hidden;",  # fixed: a long summary never moves Run
            title=("plugin_summary",),
        )
        _run_row(page)
        _inputs()
        param_form("form_fields", "form_values", "param", sync=True)
    html.Div(
        "Choose an algorithm or standard plugin above to see its form.",
        v_else=True,
        classes="pa-3 text-caption",
        raw_attrs=tid("no-plugin"),
    )


def plugin_panel(page: Any) -> None:
    """The panel of its own: plugins above, the chosen one's form below, one scroll."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(
        # not v_show: Vuetify's d-flex is "display: flex !important" and beats v-show's
        # inline "display: none", so the panel showed on the Acceptance page too
        classes=("page === 'inspect' ? 'd-flex flex-column' : 'd-none'",),
        style="flex: 0 0 340px; width: 340px; border-right: 1px solid rgba(0,0,0,0.12); overflow-y: auto;",
        raw_attrs=tid("plugin-panel"),
    ):
        _plugins(page)
        v.VDivider()
        _form(page)
