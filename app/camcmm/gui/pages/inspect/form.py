"""The Inspect page's plugin form: its fields from the plugin's declaration, its input
selects from the project's items, and the arguments of a run from what the operator
filled in. Pure functions of a plugin spec and plain data (no state, no widgets)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ....errors import PluginError, one_line
from ....host import to_jsonable
from ....params import form_schema, validate
from ...session import kind_of
from .results import fmt_value

#: Input port types the form can fill from the project's items: port type -> item kinds.
ITEM_TYPES = {"pointcloud": ("pointcloud",), "mesh": ("mesh",), "geometry": ("pointcloud", "mesh"), "image": ("image",)}


def _initial(f: dict[str, Any]) -> Any:
    """The value a field starts with: its default as the widget shows it."""
    default = f.get("default")
    if f["widget"] == "switch":
        return bool(default)
    if default is None:
        return ""
    if f["type"] == "vector":  # a text field: "1, 2, 3"
        return ", ".join(fmt_value(x) for x in default)
    return to_jsonable(default)


def fields_of(spec: Any) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """``(fields, values)`` of the plugin's parameters: the list the form draws (see
    :func:`camcmm.gui.widgets.param_form`; a required field's label ends in ``*``) and
    the values it starts with, by parameter name."""
    fields, values = [], {}
    for f in form_schema(spec.parameters):
        d = {k: to_jsonable(v) for k, v in f.items()}
        d.update(
            unit=f.get("unit", ""),
            min=f.get("min"),
            max=f.get("max"),
            choices=list(f.get("choices") or []),
            help=f.get("help", ""),
        )
        d["label"] = f["label"] if f.get("required") is not True else f["label"] + " *"
        values[f["name"]] = _initial(f)
        fields.append(d)
    return fields, values


def inputs_of(
    spec: Any, items: list[dict[str, Any]], current: dict[str, Any], preferred: Any
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """``(inputs, values)``: one select per input port the items can fill (options: the
    items of a fitting kind), a text field for any other port. A port keeps the item
    chosen in ``current`` while it exists; else it takes the ``preferred`` item (the one
    the user last picked) if it fits, else the newest fitting item the user imported
    (not one a run derived), else the newest fitting one (an optional port: none)."""
    inputs, values = [], {}
    for port in spec.inputs:
        kinds = ITEM_TYPES.get(port.type)
        entry = {
            "name": port.name,
            "type": port.type,
            "optional": port.optional,
            "label": f"{port.name} ({port.type})" + ("" if port.optional else " *"),
            "help": port.help or f"the input {port.name!r} ({port.type})",
            "supported": kinds is not None,
            "options": [],
        }
        if kinds is not None:
            fitting = [it for it in items if it["kind"] in kinds]
            opts = [{"title": it["name"], "value": it["id"]} for it in fitting]
            entry["options"] = opts
            ids = [o["value"] for o in opts]
            chosen = current.get(port.name)
            if chosen not in ids:
                imported = [it["id"] for it in fitting if not it.get("derived")]
                newest = (imported or ids)[-1] if ids else None
                chosen = preferred if preferred in ids else (None if port.optional else newest)
            values[port.name] = chosen
        else:
            values[port.name] = current.get(port.name, "")
        inputs.append(entry)
    return inputs, values


def run_blocker(spec: Any, params: dict[str, Any], chosen: dict[str, Any], items: list[dict[str, Any]]) -> str:
    """Why a run of ``spec`` with these form values cannot start, in one line ("" when
    it can): a missing or unknown input item, or a parameter its declaration refuses.
    Cheap (no item is loaded): the page shows it next to Run as the user edits."""
    try:
        _checked_params(spec, params)
    except Exception as exc:
        return one_line(exc)
    kinds_of = {it["id"]: it["kind"] for it in items}
    for port in spec.inputs:
        key = chosen.get(port.name)
        if port.type not in ITEM_TYPES:
            if key in (None, "") and not port.optional:
                return f"input {port.name!r} ({port.type}) is needed: type its path"
            continue
        if key in (None, ""):
            if not port.optional:
                return f"input {port.name!r} ({port.type}) is needed: import a file or choose an item"
            continue
        if str(key) not in kinds_of:
            return f"input {port.name!r}: item {key!r} is not in the project (deleted or hidden?)"
        if kinds_of[str(key)] not in ITEM_TYPES[port.type]:
            return f"input {port.name!r} must be a {port.type}, the chosen item is a {kinds_of[str(key)]}"
    return ""


def _checked_params(spec: Any, params: dict[str, Any]) -> dict[str, Any]:
    """The parameters checked by their declaration (an empty field means the default)."""
    declared = {p.name: p for p in spec.parameters}
    raw = {}
    for k, v in params.items():
        p = declared.get(k)
        if p is not None and p.type != "str" and (v is None or (isinstance(v, str) and v.strip() == "")):
            continue
        raw[k] = v
    return validate(spec.parameters, raw, owner=f"plugin {spec.id!r}")


def run_arguments(
    spec: Any,
    params: dict[str, Any],
    chosen: dict[str, Any],
    load: Callable[[str], Any],
    record: Callable[[str], dict | None],
) -> tuple[dict[str, Any], dict[str, Any], list]:
    """``(values, inputs, measurement_ids)`` of a run: the parameters checked by their
    declaration (an empty field means the default), the input objects (items loaded
    with ``load(key)``, other ports as given) and the ids of the items used
    (``record(key)["id"]``). Raises a one-line :class:`~camcmm.errors.CamcmmError`."""
    pid = spec.id
    if spec.kind == "device":
        raise PluginError(f"plugin {pid!r} is a device; devices are connected, not run")
    values = _checked_params(spec, params)
    objs, mids = {}, []
    for port in spec.inputs:
        key = chosen.get(port.name)
        if port.type in ITEM_TYPES:
            if key in (None, ""):
                if port.optional:
                    continue
                raise PluginError(
                    f"plugin {pid!r} needs input {port.name!r} ({port.type}): import a file or choose an item"
                )
            obj = load(str(key))
            if kind_of(obj) not in ITEM_TYPES[port.type]:
                raise PluginError(
                    f"plugin {pid!r}: input {port.name!r} must be a {port.type}, "
                    f"item {getattr(obj, 'name', key)!r} is a {kind_of(obj)}"
                )
            objs[port.name] = obj
            mids.append((record(str(key)) or {}).get("id", key))
        elif key not in (None, ""):
            objs[port.name] = key
        elif not port.optional:
            raise PluginError(
                f"plugin {pid!r} needs input {port.name!r} ({port.type}), "
                "which this form cannot provide yet; use the CLI"
            )
    return values, objs, mids
