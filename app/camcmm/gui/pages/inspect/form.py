"""The Inspect page's plugin form: its fields from the plugin's declaration, its input
selects from the project's items. Pure functions of a plugin spec and plain data (no
state, no widgets); what a run is given and refused is the task's
(:mod:`camcmm.tasks.plugin_run`: ``run_blocker``, ``run_arguments``, re-exported here)."""

from __future__ import annotations

from typing import Any

from .... import numbers
from ....host import to_jsonable
from ....params import form_schema
from ....tasks.plugin_run import ITEM_TYPES, run_arguments, run_blocker
from .results import fmt_value

__all__ = ["ITEM_TYPES", "fields_of", "inputs_of", "run_arguments", "run_blocker"]


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


#: An input port's type as a person says it (the manifest's key stays the type).
PORT_WORDS = {
    "geometry": "cloud or mesh",
    "pointcloud": "point cloud",
    "mesh": "mesh",
    "image": "image",
    "images": "images",
    "heightmap": "height map",
    "file": "file",
    "files": "files",
    "path": "file or folder",
    "json": "a document",
}


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
            "label": f"{numbers.words(port.name)} ({PORT_WORDS.get(port.type, numbers.words(port.type))})"
            + ("" if port.optional else " *"),
            "help": port.help or f"the input {numbers.words(port.name)} ({PORT_WORDS.get(port.type, port.type)})",
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
