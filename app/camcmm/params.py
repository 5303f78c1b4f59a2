"""Parameter declarations: declared once in a plugin manifest, used three ways.

A :class:`Param` carries type, unit, default, limits and help. From that one
declaration the host builds the GUI form (:func:`form_schema`), the CLI options
(:func:`add_cli_options`) and validates JSON or CLI values (:func:`validate`).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import Any

from .errors import ParameterError

TYPES = ("float", "int", "bool", "str", "choice", "vector")


@dataclass(frozen=True)
class Param:
    """One declared parameter.

    type: ``float``, ``int``, ``bool``, ``str``, ``choice`` (one of ``choices``) or
    ``vector`` (a list of ``length`` floats). ``unit`` is informative text shown beside
    the value (``mm``, ``um``, ``deg``, ``px``...). ``minimum``/``maximum`` are inclusive.
    A ``default`` of ``None`` with ``required`` false means "not given".
    """

    name: str
    type: str = "float"
    default: Any = None
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] = ()
    length: int | None = None
    required: bool = False
    help: str = ""

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Param":
        if "name" not in d:
            raise ParameterError(f"parameter declaration without a name: {d!r}")
        kind = d.get("type", "float")
        if kind not in TYPES:
            raise ParameterError(f"parameter {d['name']!r}: unknown type {kind!r}; use one of {', '.join(TYPES)}")
        choices = tuple(str(c) for c in d.get("choices", ()))
        if kind == "choice" and not choices:
            raise ParameterError(f"parameter {d['name']!r}: type choice needs 'choices'")
        p = cls(
            name=str(d["name"]),
            type=kind,
            default=d.get("default"),
            unit=str(d.get("unit", "")),
            minimum=d.get("min"),
            maximum=d.get("max"),
            choices=choices,
            length=d.get("length"),
            required=bool(d.get("required", False)),
            help=str(d.get("help", "")),
        )
        if p.default is not None:
            p.coerce(p.default)  # a bad default is a bad manifest
        return p

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "type": self.type, "default": self.default}
        for key, value in (("unit", self.unit), ("min", self.minimum), ("max", self.maximum),
                           ("length", self.length), ("help", self.help)):
            if value not in (None, ""):
                d[key] = value
        if self.choices:
            d["choices"] = list(self.choices)
        if self.required:
            d["required"] = True
        return d

    def coerce(self, value: Any) -> Any:
        """Convert ``value`` (from JSON, CLI text or a GUI field) to the declared type
        and check its limits; raise ParameterError naming the parameter otherwise."""
        if value is None or (isinstance(value, str) and value.strip() == "" and self.type != "str"):
            if self.required:
                raise ParameterError(f"parameter {self.name!r} is required")
            return None
        try:
            out = _COERCE[self.type](self, value)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"parameter {self.name!r}: {value!r} is not a valid {self.type} ({exc})") from None
        for x in out if isinstance(out, list) else [out]:
            if isinstance(x, float) and not math.isfinite(x):
                raise ParameterError(f"parameter {self.name!r}: {value!r} is not finite")
            if isinstance(x, (int, float)) and not isinstance(x, bool):
                if self.minimum is not None and x < self.minimum:
                    raise ParameterError(f"parameter {self.name!r} = {x} is below its minimum {self.minimum} {self.unit}".rstrip())
                if self.maximum is not None and x > self.maximum:
                    raise ParameterError(f"parameter {self.name!r} = {x} is above its maximum {self.maximum} {self.unit}".rstrip())
        return out


def _to_bool(p: Param, v: Any) -> bool:
    if isinstance(v, bool):
        return v
    text = str(v).strip().lower()
    if text in ("1", "true", "yes", "on"):
        return True
    if text in ("0", "false", "no", "off"):
        return False
    raise ValueError("expected true or false")


def _to_int(p: Param, v: Any) -> int:
    if isinstance(v, bool):
        raise ValueError("expected an integer")
    f = float(v)
    if f != int(f):
        raise ValueError("expected an integer")
    return int(f)


def _to_choice(p: Param, v: Any) -> str:
    s = str(v)
    if s not in p.choices:
        raise ValueError(f"expected one of {', '.join(p.choices)}")
    return s


def _to_vector(p: Param, v: Any) -> list[float]:
    items = [x for x in str(v).replace(",", " ").split()] if isinstance(v, str) else list(v)
    out = [float(x) for x in items]
    if p.length is not None and len(out) != p.length:
        raise ValueError(f"expected {p.length} numbers, got {len(out)}")
    return out


_COERCE = {
    "float": lambda p, v: float(v),
    "int": _to_int,
    "bool": _to_bool,
    "str": lambda p, v: str(v),
    "choice": _to_choice,
    "vector": _to_vector,
}


def validate(params: list[Param], values: dict[str, Any], owner: str = "") -> dict[str, Any]:
    """Validate a dict of values (JSON, CLI or GUI) against the declarations.

    Unknown names are an error (a typo must not silently fall back to a default);
    missing names take their default. Returns the complete, coerced dict.
    """
    known = {p.name: p for p in params}
    unknown = sorted(set(values) - set(known))
    if unknown:
        where = f" for {owner}" if owner else ""
        raise ParameterError(f"unknown parameter {unknown[0]!r}{where}; known: {', '.join(known) or 'none'}")
    return {name: p.coerce(values.get(name, p.default)) for name, p in known.items()}


def cli_flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def add_cli_options(parser: argparse.ArgumentParser, params: list[Param]) -> None:
    """Add one ``--name VALUE`` option per parameter; values stay text here and are
    coerced by :func:`validate`, so CLI and JSON share one set of rules."""
    for p in params:
        unit = f" [{p.unit}]" if p.unit else ""
        extra = f" (one of: {', '.join(p.choices)})" if p.choices else ""
        default = f" (default: {p.default})" if p.default is not None else ""
        parser.add_argument(cli_flag(p.name), dest=f"param__{p.name}", metavar=p.type.upper(),
                            default=None, help=f"{p.help}{unit}{extra}{default}")


def cli_values(args: argparse.Namespace) -> dict[str, Any]:
    """The parameter values given on the command line (not the defaults)."""
    return {k[len("param__"):]: v for k, v in vars(args).items() if k.startswith("param__") and v is not None}


def form_schema(params: list[Param]) -> list[dict[str, Any]]:
    """A JSON-able description of the GUI form for these parameters."""
    widget = {"float": "number", "int": "number", "bool": "switch", "str": "text", "choice": "select", "vector": "text"}
    out = []
    for p in params:
        label = p.name.replace("_", " ") + (f" [{p.unit}]" if p.unit else "")
        out.append({"name": p.name, "widget": widget[p.type], "label": label, **p.to_dict()})
    return out
