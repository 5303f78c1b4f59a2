"""Parameter declarations: declared once in a plugin manifest, used three ways.

A :class:`Param` carries type, unit, default, limits and help. From that one
declaration the host builds the GUI form (:func:`form_schema`), the CLI options
(:func:`add_cli_options`) and validates JSON or CLI values (:func:`validate`).
"""

from __future__ import annotations

import argparse
import math
import re
from dataclasses import dataclass
from typing import Any

from .errors import ParameterError
from .numbers import unit_text

TYPES = ("float", "int", "bool", "str", "choice", "vector", "path", "address")
#: What a ``path`` parameter does with its file or folder (manifest key ``access``).
ACCESS = ("read", "write")
#: The keys a declaration may have; another key is a typo (``maximum:`` for ``max:``) that
#: would silently drop a limit.
KEYS = (
    "name",
    "type",
    "default",
    "unit",
    "min",
    "max",
    "exclusive_min",
    "finite",
    "choices",
    "length",
    "required",
    "help",
    "access",
    "choice_titles",
    "label",
)
#: Largest integer any int parameter takes, declared max or not: beyond it JSON (a double)
#: no longer holds integers exactly.
INT_LIMIT = 2**53
#: Most numbers a vector without a declared ``length`` takes, and longest str value.
MAX_VECTOR = 10_000
MAX_STR = 65_536


@dataclass(frozen=True)
class Param:
    """One declared parameter.

    type: ``float``, ``int``, ``bool``, ``str``, ``choice`` (one of ``choices``),
    ``vector`` (a list of ``length`` floats), ``path`` (a file or folder; ``access``
    ``read`` or ``write`` says what the plugin does with it: the web server confines it
    to the project folder and the data roots, docs/security.md) or ``address`` (a
    network address the plugin connects to, e.g. a Dask scheduler ``tcp://host:8786``:
    the web server takes only the ones its operator configured with ``--scheduler``).
    ``path`` and ``address`` values are text, like ``str``; an empty one means "not given".
    ``unit`` is informative text shown beside the value (``mm``, ``um``, ``deg``, ``px``...).
    ``minimum``/``maximum`` (manifest ``min``/``max``) are inclusive; ``exclusive_minimum``
    (``exclusive_min``) is a bound the value must exceed (a radius > 0). Floats must be
    finite unless ``finite`` is false.
    Limits apply to each number of a vector. Every int parameter and every size, count or
    iteration number should declare ``max`` (the built-in plugins all do; a test checks).
    A ``default`` of ``None`` with ``required`` false means "not given".
    """

    name: str
    type: str = "float"
    default: Any = None
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: float | None = None
    finite: bool = True
    choices: tuple[str, ...] = ()
    length: int | None = None
    required: bool = False
    help: str = ""
    access: str = ""
    #: a choice's words where its key is not (``SIMPLE_RADIAL`` -> "simple radial (f, cx, cy, k)"),
    #: as ``(key, title)`` pairs; the key stays what files, JSON and the CLI take
    choice_titles: tuple[tuple[str, str], ...] = ()
    #: the form's words for the parameter where its key says too little (``scheduler`` ->
    #: "compute cluster (Dask scheduler)"); manifest key ``label``, without the unit
    declared_label: str = ""

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Param:
        if not isinstance(d, dict) or "name" not in d:
            raise ParameterError(f"parameter declaration without a name: {d!r}")
        unknown = [k for k in d if k not in KEYS]
        if unknown:
            raise ParameterError(f"parameter {d['name']!r}: unknown key {unknown[0]!r}; use {', '.join(KEYS)}")
        kind = d.get("type", "float")
        if kind not in TYPES:
            raise ParameterError(f"parameter {d['name']!r}: unknown type {kind!r}; use one of {', '.join(TYPES)}")
        choices = tuple(str(c) for c in d.get("choices", ()))
        if kind == "choice" and not choices:
            raise ParameterError(f"parameter {d['name']!r}: type choice needs 'choices'")
        titles = d.get("choice_titles") or {}
        if not isinstance(titles, dict) or any(str(k) not in choices for k in titles):
            raise ParameterError(f"parameter {d['name']!r}: choice_titles must map some of its choices to words")
        access = str(d.get("access", "read" if kind == "path" else ""))
        if kind != "path" and "access" in d:
            raise ParameterError(f"parameter {d['name']!r}: 'access' is for type path, not {kind}")
        if kind == "path" and access not in ACCESS:
            raise ParameterError(f"parameter {d['name']!r}: access {access!r}; use one of {', '.join(ACCESS)}")
        p = cls(
            name=str(d["name"]),
            type=kind,
            default=d.get("default"),
            unit=str(d.get("unit", "")),
            minimum=_limit(d, "min"),
            maximum=_limit(d, "max"),
            exclusive_minimum=_limit(d, "exclusive_min"),
            finite=bool(d.get("finite", True)),
            choices=choices,
            length=d.get("length"),
            required=bool(d.get("required", False)),
            help=str(d.get("help", "")),
            access=access,
            choice_titles=tuple((str(k), str(v)) for k, v in titles.items()),
            declared_label=str(d.get("label", "")),
        )
        lo = max((x for x in (p.minimum, p.exclusive_minimum) if x is not None), default=None)
        if lo is not None and p.maximum is not None and lo > p.maximum:
            raise ParameterError(f"parameter {p.name!r}: min {lo} is above max {p.maximum}")
        if p.default is not None:
            p.coerce(p.default)  # a bad default is a bad manifest
        return p

    @property
    def label(self) -> str:
        """The form's label (:func:`label`), for a plugin's message that names the parameter
        as a person sees it on the form (plugins have ``Param`` from camcmm.api, not this module)."""
        return label(self)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "type": self.type, "default": self.default}
        for key, value in (
            ("unit", self.unit),
            ("min", self.minimum),
            ("max", self.maximum),
            ("exclusive_min", self.exclusive_minimum),
            ("length", self.length),
            ("help", self.help),
            ("access", self.access),
        ):
            if value not in (None, ""):
                d[key] = value
        if not self.finite:
            d["finite"] = False
        if self.choices:
            d["choices"] = list(self.choices)
        if self.choice_titles:
            d["choice_titles"] = dict(self.choice_titles)
        if self.declared_label:
            d["label"] = self.declared_label
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
        except (TypeError, ValueError, OverflowError) as exc:
            raise ParameterError(
                f"parameter {self.name!r}: {_short(value)} is not a valid {self.type} ({_short(str(exc), quote=False)})"
            ) from None
        unit = f" {self.unit}" if self.unit else ""
        for x in out if isinstance(out, list) else [out]:
            if isinstance(x, float) and not math.isfinite(x):
                if self.finite:
                    raise ParameterError(f"parameter {self.name!r}: {_short(value)} is not finite")
                continue
            if isinstance(x, (int, float)) and not isinstance(x, bool):
                if self.minimum is not None and x < self.minimum:
                    raise ParameterError(f"parameter {self.name!r} = {x} is below its minimum {self.minimum}{unit}")
                if self.exclusive_minimum is not None and not x > self.exclusive_minimum:
                    raise ParameterError(f"parameter {self.name!r} = {x} must be above {self.exclusive_minimum}{unit}")
                if self.maximum is not None and x > self.maximum:
                    raise ParameterError(f"parameter {self.name!r} = {x} is above its maximum {self.maximum}{unit}")
        return out

    def limits_text(self) -> str:
        """The declared limits as one short phrase (``1 <= x <= 64``), '' when none."""
        lo = (
            f"{_num(self.minimum)} <= "
            if self.minimum is not None
            else f"{_num(self.exclusive_minimum)} < "
            if self.exclusive_minimum is not None
            else ""
        )
        hi = f" <= {_num(self.maximum)}" if self.maximum is not None else ""
        return f"{lo}x{hi}" if lo or hi else ""


def _limit(d: dict[str, Any], key: str) -> float | None:
    """A declared limit: a finite number or absent."""
    v = d.get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ParameterError(f"parameter {d.get('name')!r}: {key} must be a finite number, got {v!r}")
    return v


def _num(x: float) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def _short(value: Any, n: int = 60, quote: bool = True) -> str:
    s = repr(value) if quote else value
    return s if len(s) <= n else s[: n - 3] + "..."


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
    if isinstance(v, int):
        n = v
    elif isinstance(v, str) and len(v) > 100:
        raise ValueError("too long for a number")
    else:
        try:
            n = int(str(v).strip()) if isinstance(v, str) else int(v)  # exact for '123456789012345678'
            if not isinstance(v, str) and n != v:
                raise ValueError("expected an integer")
        except ValueError:
            f = float(v)  # '1e3', 2.0; inf/nan raise below
            if not math.isfinite(f) or f != int(f):
                raise ValueError("expected an integer") from None
            n = int(f)
    if abs(n) > INT_LIMIT:
        raise ValueError("beyond +-2**53")
    return n


def _to_float(p: Param, v: Any) -> float:
    if isinstance(v, str) and len(v) > 100:
        raise ValueError("too long for a number")
    return float(v)


def _to_str(p: Param, v: Any) -> str:
    s = str(v)
    if len(s) > MAX_STR:
        raise ValueError(f"longer than {MAX_STR} characters")
    return s


def _to_path(p: Param, v: Any) -> str:
    s = _to_str(p, v).strip()
    if "\x00" in s:
        raise ValueError("a path has no NUL character")
    return s


def _to_address(p: Param, v: Any) -> str:
    s = _to_str(p, v).strip()
    if len(s) > 2048 or any(c.isspace() or not c.isprintable() for c in s):
        raise ValueError("an address is one word of printable characters")
    return s


def _to_choice(p: Param, v: Any) -> str:
    s = str(v)
    if s not in p.choices:
        raise ValueError(f"expected one of {', '.join(p.choices)}")
    return s


def _to_vector(p: Param, v: Any) -> list[float]:
    most = p.length if p.length is not None else MAX_VECTOR
    if isinstance(v, str) and len(v) > 100 * (most + 1):
        raise ValueError(f"more than {most} numbers")
    items = [x for x in v.replace(",", " ").split()] if isinstance(v, str) else list(v)
    if len(items) > most and p.length is None:
        raise ValueError(f"more than {most} numbers")
    out = [_to_float(p, x) for x in items]
    if p.length is not None and len(out) != p.length:
        raise ValueError(f"expected {p.length} numbers, got {len(out)}")
    return out


_COERCE = {
    "float": _to_float,
    "int": _to_int,
    "bool": _to_bool,
    "str": _to_str,
    "choice": _to_choice,
    "vector": _to_vector,
    "path": _to_path,
    "address": _to_address,
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
        limits = f" ({p.limits_text()})" if p.limits_text() else ""
        default = f" (default: {p.default})" if p.default is not None else ""
        # '%' in help text is argparse's format character
        text = f"{p.help}{unit}{extra}{limits}{default}".replace("%", "%%")
        parser.add_argument(cli_flag(p.name), dest=f"param__{p.name}", metavar=p.type.upper(), default=None, help=text)


def cli_values(args: argparse.Namespace) -> dict[str, Any]:
    """The parameter values given on the command line (not the defaults)."""
    return {k[len("param__") :]: v for k, v in vars(args).items() if k.startswith("param__") and v is not None}


def _unit_words(unit: str) -> list[list[str]]:
    """How a name may spell ``unit`` at its end: ``mm/s`` as ``mm_s`` or ``mm_per_s``, ``µm`` as ``um``."""
    text = unit.lower().replace("µ", "u").replace("°", "deg").replace("%", "percent")
    words = [w for w in re.split(r"[^a-z0-9]+", text) if w]
    spelled = [words]
    if "/" in unit and len(words) == 2:
        spelled.append([words[0], "per", words[1]])
    return [w for w in spelled if w]


def label(p: Param) -> str:
    """A form's label: the name in words, the unit once in brackets. A name that already
    ends in its unit (``exposure_ms`` in ms) is not labelled "exposure ms [ms]" but
    "exposure [ms]". A declared ``label`` replaces the name's words."""
    if p.declared_label:
        return f"{p.declared_label} [{unit_text(p.unit)}]" if p.unit else p.declared_label
    words = p.name.split("_")
    for unit_words in _unit_words(p.unit) if p.unit else []:
        n = len(unit_words)
        if len(words) > n and [w.lower() for w in words[-n:]] == unit_words:
            words = words[:-n]
            break
    text = " ".join(w for w in words if w)
    return f"{text} [{unit_text(p.unit)}]" if p.unit else text


def named(p: Param, value: Any = None) -> str:
    """The parameter as a message names it for a person — its label's words, not its key:
    ``named(sigma_px)`` -> ``"sigma"``, ``named(sigma_px, 6)`` -> ``"sigma = 6 px"``
    (issue 30: "sigma_px = 6" read as code)."""
    text = re.sub(r"\s*\[[^\]]*\]$", "", label(p))
    if value is None:
        return text
    shown = _num(value) if isinstance(value, float) else str(value)
    return f"{text} = {shown} {unit_text(p.unit)}".rstrip()


def choice_title(p: Param, choice: Any) -> str:
    """A choice as the form shows it: its declared title, else the key in words
    (``stereo_fringe`` -> "stereo fringe", ``um`` -> "µm")."""
    key = str(choice)
    declared = dict(p.choice_titles)
    if key in declared:
        return declared[key]
    shown = unit_text(key)
    return shown if shown != key else key.replace("_", " ")


def form_schema(params: list[Param]) -> list[dict[str, Any]]:
    """A JSON-able description of the GUI form for these parameters (``label``: :func:`label`)."""
    widget = {
        "float": "number",
        "int": "number",
        "bool": "switch",
        "str": "text",
        "choice": "select",
        "vector": "text",
        "path": "text",
        "address": "text",
    }
    out = []
    for p in params:
        d = {"name": p.name, "widget": widget[p.type], **p.to_dict(), "label": label(p)}
        if p.choices:  # what a select shows; the values stay the keys
            d["items"] = [{"title": choice_title(p, c), "value": c} for c in p.choices]
        out.append(d)
    return out
