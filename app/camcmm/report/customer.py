"""What a report handed to a customer states about the order, and its overall verdict.

The fields (:data:`FIELDS`) come from the ``report:`` mapping of a plan (``customer``,
``part_number``, ``order``, ``drawing_revision``, ``operator``, ``instrument``, ``date``,
``temperature``) and from a command's options (``--customer``, ``--part-number`` …),
an option winning over the plan. They head the report (its meta block) under the words a
person reads; ``date`` defaults to the day the report is made, ``temperature`` is in °C
(a number, or a text such as "20.2 ± 0.3 °C").

The overall verdict (:func:`overall`) follows ISO 14253-1: the part conforms when every
characteristic conforms with its expanded uncertainty U as guard band; a characteristic
out of tolerance makes it not conform; one within U of a limit leaves it undecided.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Iterable, Mapping
from typing import Any

from ..errors import InputError

#: The customer fields: key in a plan's ``report:`` mapping -> the words on the report.
FIELDS: dict[str, str] = {
    "customer": "Customer",
    "part_number": "Part number",
    "order": "Order",
    "drawing_revision": "Drawing revision",
    "operator": "Operator",
    "instrument": "Instrument",
    "date": "Date",
    "temperature": "Temperature",
}


def check_fields(doc: Any, where: str = "report") -> dict[str, str]:
    """The fields of a ``report:`` mapping as texts; InputError (one line naming ``where``
    and the key) for a key not in :data:`FIELDS` or a value that is not a plain text or
    number. A temperature given as a number is in °C."""
    if doc is None:
        return {}
    if not isinstance(doc, Mapping):
        raise InputError(f"{where}: expected a mapping of {', '.join(FIELDS)}")
    out: dict[str, str] = {}
    for key, value in doc.items():
        if key not in FIELDS:
            raise InputError(f"{where}.{key}: unknown key; use {', '.join(FIELDS)}")
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (str, int, float)) and not hasattr(value, "isoformat"):
            raise InputError(f"{where}.{key}: expected a text or a number, got a {type(value).__name__}")
        out[str(key)] = _text(str(key), value, f"{where}.{key}")
    return out


def _text(key: str, value: Any, where: str) -> str:
    if key == "temperature":
        try:
            t = float(value)
        except (TypeError, ValueError):
            return str(value).strip()
        if not math.isfinite(t) or not -100.0 <= t <= 200.0:
            raise InputError(f"{where}: {value!r} is not a temperature in °C")
        return f"{t:g} °C"
    if hasattr(value, "isoformat"):  # YAML reads 2026-11-29 as a date
        return str(value.isoformat())
    return str(value).strip()


def add_options(parser: argparse.ArgumentParser) -> None:
    """``--customer``, ``--part-number``, ``--order``, ``--drawing-revision``,
    ``--operator``, ``--instrument``, ``--date``, ``--temperature`` on a command that
    writes a report."""
    g = parser.add_argument_group("report", "what the report states about the order (overrides the plan's report:)")
    for key, words in FIELDS.items():
        extra = " in °C" if key == "temperature" else " (default: today)" if key == "date" else ""
        g.add_argument(
            "--" + key.replace("_", "-"), dest=f"report_{key}", default=None, metavar="TEXT", help=f"{words}{extra}"
        )


def from_args(args: argparse.Namespace, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The fields ``base`` (a plan's, checked) with the command's options over them."""
    out = dict(base or {})
    for k in FIELDS:
        v = getattr(args, f"report_{k}", None)
        if v not in (None, ""):
            out[k] = _text(k, v, "--" + k.replace("_", "-"))
    return out


def header(fields: Mapping[str, str], created: str) -> dict[str, str]:
    """The fields in :data:`FIELDS` order under their words, the date defaulting to the
    report's ``created`` day, the temperature only where given, every other field not
    given shown as a dash."""
    out = {}
    for key, words in FIELDS.items():
        if key == "temperature" and not fields.get(key):
            continue  # stated where it was measured; a dash would read as "not controlled"
        out[words] = fields.get(key) or (created[:10] if key == "date" else "\u2014")
    return out


#: ISO 14253-1 verdict words of a characteristic -> the report's badge words.
BADGES = {"conform": "pass", "not conform": "fail", "undecided": "inconclusive", "not evaluated": "incomplete"}


def overall(verdicts: Iterable[tuple[str, str]]) -> tuple[str, str]:
    """(badge word, sentence) for the part from (name, verdict) pairs with the words of
    :data:`BADGES`: fail when any is not conform, else inconclusive when any is undecided,
    else incomplete when any was not evaluated, else pass. The sentence names those that
    are not in tolerance."""
    pairs = list(verdicts)
    by: dict[str, list[str]] = {}
    for name, v in pairs:
        by.setdefault(v if v in BADGES else "not evaluated", []).append(name)
    n = len(pairs)
    if not n:
        return "incomplete", "No characteristic was evaluated."
    if len(by.get("conform", [])) == n:
        return "pass", f"All {n} characteristics are in tolerance (ISO 14253-1: with the expanded uncertainty U)."
    parts = []
    for v, words in (
        ("not conform", "Out of tolerance"),
        ("undecided", "Undecided (within U of a limit)"),
        ("not evaluated", "Not evaluated"),
    ):
        if by.get(v):
            parts.append(f"{words}: {', '.join(by[v])}.")
    word = next(BADGES[v] for v in ("not conform", "undecided", "not evaluated") if by.get(v))
    ok = len(by.get("conform", []))
    return word, f"{ok} of {n} characteristics in tolerance. " + " ".join(parts)
