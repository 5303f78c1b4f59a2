"""Values on their way in and out of the acceptance test: numbers typed into the setup
form, text with units on the cards, and verdicts against an MPE."""

from __future__ import annotations

import logging
import math
from typing import Any

from camcmm import numbers
from camcmm.conformity import combine, simple_verdict
from camcmm.errors import InputError

#: One logger for the whole task (the page logs under it too).
log = logging.getLogger("camcmm.tasks.acceptance")


def _blank(value: Any) -> bool:
    """Left empty in the form: None or only blanks."""
    return value is None or (isinstance(value, str) and not value.strip())


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool):
        raise InputError(f"{what}: {value!r} is not a number")
    if isinstance(value, (int, float)):
        v = float(value)
    else:
        text = str(value if value is not None else "").strip().replace(",", ".")
        if not text:
            raise InputError(f"{what} is empty; enter a number")
        try:
            v = float(text)
        except ValueError:
            raise InputError(f"{what}: {value!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{what}: {value!r} is not a finite number")
    return v


def _vector(value: Any, what: str, n: int = 3) -> list[float]:
    if isinstance(value, str):
        parts = [p for p in value.replace(";", " ").replace(",", " ").split() if p]
    elif isinstance(value, (list, tuple)):
        parts = list(value)
    else:
        parts = [value]
    if len(parts) != n:
        raise InputError(f"{what}: give {n} numbers, got {value!r}")
    return [_number(p, f"{what}[{i}]") for i, p in enumerate(parts)]


def fmt_mm(v: Any, signed: bool = False, unit: str = "mm") -> str:
    """A quality parameter's figure as the number rule writes it (:mod:`camcmm.numbers`):
    a value in mm (a deviation, a form, an MPE, an uncertainty) in µm, a sign kept when
    ``signed``; another unit plainly with it; "–" when there is none."""
    if v is None or not numbers.finite(v):
        return "–"
    if unit in ("mm", "", None):
        return numbers.deviation(float(v), signed=signed)
    return numbers.plain(float(v), 4) + (f" {numbers.unit_text(unit)}" if unit else "")


def fmt_value(v: Any, signed: bool = False, unit: str = "mm") -> str:
    """A parameter's value (a number, or a list of them, e.g. per length) as text."""
    return ", ".join(fmt_mm(x, signed, unit) for x in v) if isinstance(v, list) else fmt_mm(v, signed, unit)


def _verdict(value: Any, mpe: float | None) -> str:
    if mpe is None:
        return "incomplete"
    if isinstance(value, list):
        return combine(simple_verdict(v, mpe) for v in value)
    return simple_verdict(value, mpe)
