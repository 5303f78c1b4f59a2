"""Widgets every page shares: test ids and the form of a plugin's declared parameters.

A plugin's parameters are declared once, in its manifest; :func:`camcmm.params.form_schema`
turns them into ``fields`` (name, label, widget, unit, min, max, choices, help) and
:func:`param_form` draws them — the same way on every page. Import inside a layout
function: this module loads trame's widgets.
"""

from __future__ import annotations

from typing import Any


def tid(name: str) -> list[str]:
    """``raw_attrs`` giving a widget the fixed ``data-testid`` ``name`` (for the browser tests)."""
    return [f'data-testid="{name}"']


def accepted_extensions() -> str:
    """The file input's ``accept`` list: every extension camcmm.io reads."""
    from ..io import FORMATS

    return ",".join(sorted(ext for ext, f in FORMATS.items() if f.get("readable", True)))


def dyn_tid(expr: str) -> list[str]:
    """``raw_attrs`` giving a widget a ``data-testid`` computed by the JavaScript ``expr``."""
    return [f':data-testid="{expr}"']


def assign(var: str, key: str) -> str:
    """A JavaScript handler that replaces the dict ``var`` with one where ``key`` is the
    event's value: trame syncs a changed top-level variable, not a changed member."""
    return f"{var} = Object.assign({{}}, {var}, {{[{key}]: $event}})"


# Client-side check of a number field against its declared limits (a Vuetify rule); the
# server checks again with camcmm.params, this only tells the operator early.
_NUMBER_RULE = (
    "[v => (v === '' || v === null || v === undefined) || !isNaN(Number(v)) || 'not a number',"
    " v => (v === '' || v === null || v === undefined || {f}.min == null || Number(v) >= {f}.min)"
    " || ('at least ' + {f}.min + ' ' + ({f}.unit || '')),"
    " v => (v === '' || v === null || v === undefined || {f}.max == null || Number(v) <= {f}.max)"
    " || ('at most ' + {f}.max + ' ' + ({f}.unit || ''))]"
)


def declared_fields(parameters: Any) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """``(fields, values)`` for :func:`param_form` from a plugin's declared parameters:
    the fields it draws (unit, help, choices) and the values it starts with (a switch's
    default as a bool, no default as "")."""
    from ..jsonable import to_jsonable
    from ..params import form_schema

    fields, values = [], {}
    for f in form_schema(parameters):
        d = to_jsonable(f)
        d["unit"], d["help"] = f.get("unit", ""), f.get("help", "")
        d["choices"] = list(f.get("choices") or [])
        default = f.get("default")
        values[f["name"]] = bool(default) if f["widget"] == "switch" else ("" if default is None else default)
        fields.append(d)
    return fields, values


def form_values(spec: Any, raw: dict[str, Any] | None, roots: Any = None) -> dict[str, Any]:
    """A form's values (``raw``, as the browser sent them) validated against the plugin's
    declared parameters: keys it does not declare are dropped, never passed on; an empty
    optional field means its default. With ``roots`` (the session's
    :class:`~camcmm.gui.roots.Roots`) a path parameter must lie in its folders (made
    absolute) and an address parameter be one of its schedulers. Raises the one-line
    InputError of camcmm.params or of the refused path or address."""
    from ..params import validate

    declared = {p.name: p for p in spec.parameters}
    values: dict[str, Any] = {}
    for k, v in dict(raw or {}).items():
        p = declared.get(str(k))
        if p is None:
            continue
        if p.type != "str" and (v is None or (isinstance(v, str) and not v.strip())):
            continue
        values[p.name] = v
    values = validate(spec.parameters, values, owner=f"plugin {spec.id!r}")
    return values if roots is None else roots.check_params(spec.parameters, values)


def param_form(
    fields: str,
    values: str,
    testid: str,
    *,
    disabled: str = "false",
    numbers: bool = True,
    sync: bool = False,
    hide_details: str | bool = "auto",
) -> None:
    """Draw the fields of the state list ``fields`` bound to the state dict ``values``.

    Each widget has ``data-testid`` ``<testid>-<name>``. ``numbers``: a number widget
    with the declared limits as client-side rules (else a text field). ``sync``: write
    a whole new dict on each change (for dicts the server reads back while the page
    is open, e.g. a device's settings) instead of ``v_model`` on a member.
    ``disabled``: a JavaScript expression.
    """
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    f = "field"
    # the unit is in the label ("exposure [ms]", camcmm.params.label), once: no suffix beside
    # the value (Vuetify hides a suffix while the field is empty, so it could not stand alone)
    ident = dyn_tid(f"'{testid}-' + {f}.name")
    # a hint of two lines reaches into the next outlined field, whose label floats ~8 px
    # above its outline: keep that much more room below a field that shows hints
    gap = "mb-1" if hide_details is True else "mb-3"

    def bind(**kw: Any) -> dict[str, Any]:
        # A hint shown only while a field has focus folds away on blur and moves what lies
        # below it: a click on a button there, right after typing, would land on nothing.
        # Shown always, the form keeps its shape (hide_details=True hides hints entirely).
        kw.setdefault("persistent_hint", True)
        # the declared help as the field's tooltip too: it stays readable with hide_details
        kw.setdefault("title", (f"{f}.help",))
        if sync:
            kw.update(model_value=(f"{values}[{f}.name]",), update_modelValue=assign(values, f"{f}.name"))
        else:
            kw["v_model"] = f"{values}[{f}.name]"
        return dict(kw, disabled=(disabled,), raw_attrs=ident)

    with html.Template(v_for=f"{f} in {fields}", key=f"{f}.name"):
        if numbers:
            v.VTextField(
                **bind(
                    v_if=f"{f}.widget === 'number'",
                    type="number",
                    label=(f"{f}.label",),
                    hint=(f"{f}.help",),
                    min=(f"{f}.min",),
                    max=(f"{f}.max",),
                    step="any",
                    rules=(_NUMBER_RULE.format(f=f),),
                    density="compact",
                    variant="outlined",
                    hide_details=hide_details,
                    classes=gap,
                )
            )
        v.VSwitch(
            **bind(
                **{"v_else_if" if numbers else "v_if": f"{f}.widget === 'switch'"},
                label=(f"{f}.label",),
                hint=(f"{f}.help",),
                color="primary",
                density="compact",
                hide_details=hide_details,
                classes=gap,  # its hint, too, reaches the next field's floating label
            )
        )
        v.VSelect(
            **bind(
                v_else_if=f"{f}.widget === 'select'",
                items=(f"{f}.items || {f}.choices",),  # items: the choices in words (params.choice_title)
                label=(f"{f}.label",),
                hint=(f"{f}.help",),
                density="compact",
                variant="outlined",
                hide_details=hide_details,
                classes=gap,
            )
        )
        v.VTextField(
            **bind(
                v_else=True,
                label=(f"{f}.label",),
                hint=(f"{f}.help",),
                density="compact",
                variant="outlined",
                hide_details=hide_details,
                classes=gap,
            )
        )


def run_buttons(prefix: str, on_run: Any, run_args: str, on_cancel: Any, title: str) -> None:
    """Run (Ctrl+Enter) and Cancel of a page whose state has ``<prefix>_running`` and
    ``<prefix>_fields``; ``run_args`` the JavaScript arguments of ``on_run``."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex ga-2"):
        v.VBtn(
            "Run",
            color="primary",
            prepend_icon="mdi-play",
            click=(on_run, run_args),
            disabled=(f"{prefix}_running || !{prefix}_fields.length",),
            loading=(f"{prefix}_running",),
            title=f"{title} (Ctrl+Enter)",
            raw_attrs=[*tid(f"{prefix}-run"), 'data-shortcut="run"'],
        )
        v.VBtn("Cancel", v_if=f"{prefix}_running", variant="text", click=on_cancel, raw_attrs=tid(f"{prefix}-cancel"))


def run_progress(prefix: str) -> None:
    """The progress bar and the one-line message (red after a failure) of a run whose
    state has ``<prefix>_running``, ``_progress`` (0-100), ``_error`` and ``_message``."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    p = prefix
    with v.VProgressLinear(
        v_show=f"{p}_running || {p}_progress > 0",
        model_value=(f"{p}_progress",),
        indeterminate=(f"{p}_running && {p}_progress <= 0",),
        height=18,
        rounded=True,
        color=(f"{p}_running ? 'primary' : ({p}_error ? 'error' : 'success')",),
        classes="mt-2",
        raw_attrs=tid(f"{p}-progress"),
    ):
        html.Span(f"{{{{ Math.round({p}_progress) }}}} %", classes="text-caption")
    html.Div(
        f"{{{{ {p}_message }}}}",
        classes=(f"{p}_error && !{p}_running ? 'text-caption text-error mt-1' : 'text-caption mt-1'",),
        title=(f"{p}_message",),
        raw_attrs=tid(f"{p}-message"),
    )


def warning_alerts(prefix: str) -> None:
    """One compact warning alert per line of the state list ``<prefix>_warnings``."""
    from trame.widgets import vuetify3 as v

    v.VAlert(
        v_for=f"(w, i) in {prefix}_warnings",
        key="i",
        text=("w",),
        type="warning",
        density="compact",
        classes="mb-1",
        raw_attrs=tid(f"{prefix}-warning"),
    )
