"""The plan keys besides the setup form's ("more plan options": outlier rule, file unit,
repeats, scaling ...) as a form built from what the standard declares, with YAML as an
import and an export.

A standard declares them with the optional protocol method ``plan_options()``: a list of
parameter declarations as a plugin manifest writes them (:class:`camcmm.params.Param`
keys), where ``name`` is the plan key (a dotted name is nested: ``options.extract_sphere``
is ``options: {extract_sphere: ...}``), plus ``label`` (the field's words) and ``labels``
(``{choice: words}``). The values travel as a flat dict keyed by those names (the form's
``options``); :func:`nest` turns it into plan keys. A key without a value is left out of
the plan, so the standard's default holds. Keys the declaration does not name (from an
imported YAML, e.g. an outlier rule per test) are kept as they are.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import yaml

from camcmm.errors import InputError, ParameterError
from camcmm.params import Param, label

#: What a form field becomes per declared type (as :func:`camcmm.params.form_schema`).
WIDGETS = {"bool": "switch", "choice": "select", "int": "number", "float": "number"}


@dataclass(frozen=True)
class PlanOption:
    """One declared plan key: its parameter, the words of the field and of each choice."""

    param: Param
    title: str
    choice_titles: dict[str, str]

    @property
    def key(self) -> str:
        return self.param.name


def declared_options(std: Any, sid: str = "") -> list[PlanOption]:
    """The plan options standard object ``std`` declares (``plan_options()``; [] when it
    declares none). A bad declaration is one line naming the standard and the key."""
    declare = getattr(std, "plan_options", None)
    if not callable(declare):
        return []
    out = []
    for d in declare() or []:
        if not isinstance(d, dict):
            raise InputError(f"standard plugin {sid!r}: plan_options() gives {d!r}, not a parameter declaration")
        d = dict(d)
        title, titles = d.pop("label", None), d.pop("labels", None) or {}
        try:
            p = Param.from_dict(d)
        except ParameterError as exc:
            raise InputError(f"standard plugin {sid!r}: plan option: {exc}") from None
        short = Param(p.name.rsplit(".", 1)[-1], p.type, unit=p.unit)
        out.append(PlanOption(p, str(title or label(short)), {str(k): str(v) for k, v in dict(titles).items()}))
    return out


def form_fields(options: list[PlanOption]) -> list[dict[str, Any]]:
    """The form's fields: ``{key, label, widget, items, help, unit}``; a select's items
    are ``{title, value}`` with the standard's words and a first "the standard's default"."""
    fields = []
    for o in options:
        p = o.param
        items: list[dict[str, Any]] = []
        if p.type == "choice":
            items = [{"title": "(the standard's default)", "value": ""}]
            items += [{"title": o.choice_titles.get(c, c), "value": c} for c in p.choices]
        fields.append(
            {
                "key": p.name,
                "label": o.title + (f" [{p.unit}]" if p.unit else ""),
                "widget": WIDGETS.get(p.type, "text"),
                "items": items,
                "help": p.help or o.title,
            }
        )
    return fields


def _blank(v: Any) -> bool:
    return v is None or (isinstance(v, str) and not v.strip())


def coerce(values: dict[str, Any], options: list[PlanOption]) -> dict[str, Any]:
    """The form's flat values checked against the declaration (a typed number becomes an
    int, a limit is enforced: one line naming the field); blank ones dropped; undeclared
    keys kept as they are."""
    declared = {o.key: o for o in options}
    out: dict[str, Any] = {}
    for key, v in (values or {}).items():
        o = declared.get(key)
        if o is None:
            out[key] = v
            continue
        if _blank(v) or (o.param.type == "bool" and v is False and o.param.default in (None, False)):
            continue  # unset: the standard's default holds (a switch left off is that default)
        if o.param.type == "choice" and not isinstance(v, str):
            out[key] = v  # e.g. an outlier rule per test from an imported YAML
            continue
        try:
            out[key] = o.param.coerce(v)
        except ParameterError as exc:
            raise InputError(f"plan option '{o.title}': {str(exc).split(': ', 1)[-1]}") from None
    return out


def nest(flat: dict[str, Any]) -> dict[str, Any]:
    """``{"options.extract_sphere": True, "unit": "mm"}`` -> ``{"options": {"extract_sphere":
    True}, "unit": "mm"}`` (the plan's keys)."""
    out: dict[str, Any] = {}
    for key, v in (flat or {}).items():
        parts = str(key).split(".")
        node = out
        for part in parts[:-1]:
            nxt = node.get(part)
            if not isinstance(nxt, dict):
                nxt = node[part] = {}
            node = nxt
        if isinstance(v, dict) and isinstance(node.get(parts[-1]), dict):
            node[parts[-1]].update(v)
        else:
            node[parts[-1]] = v
    return out


def flatten(plan_keys: dict[str, Any], options: list[PlanOption]) -> dict[str, Any]:
    """The plan's extra keys as the form's flat values: each declared (dotted) key that
    the plan sets becomes one value; the rest stays nested under its own key."""
    rest = copy.deepcopy(dict(plan_keys or {}))
    out: dict[str, Any] = {}
    for o in options:
        parts = o.key.split(".")
        node: Any = rest
        for part in parts[:-1]:
            node = node.get(part) if isinstance(node, dict) else None
        if isinstance(node, dict) and parts[-1] in node:
            out[o.key] = node.pop(parts[-1])
    for key, v in rest.items():
        if not (isinstance(v, dict) and not v):  # a nested key emptied above
            out[key] = v
    return out


def to_yaml(flat: dict[str, Any], options: list[PlanOption]) -> str:
    """The set options as plan YAML (the export; :func:`camcmm.tasks.acceptance.parse_options`
    reads it back)."""
    plan_keys = nest(coerce(flat, options))
    return yaml.safe_dump(plan_keys, sort_keys=False, default_flow_style=False, allow_unicode=True) if plan_keys else ""
