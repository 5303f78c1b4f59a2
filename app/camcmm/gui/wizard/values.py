"""Values on their way in and out of the wizard: numbers typed into the setup form, mm
text on the cards, verdicts against an MPE, and errors as one line for the operator."""

from __future__ import annotations

import logging
import math
from typing import Any

from ...conformity import combine, simple_verdict
from ...errors import CamcmmError, InputError

#: One logger for the whole package, under the name it always had, so logging set up
#: for "camcmm.gui.wizard" keeps seeing every message.
log = logging.getLogger("camcmm.gui.wizard")

#: Quality parameters by their symbol as cards and reports print it; the SIGNED ones
#: (probing size, sphere distance) are shown with their sign.
SYMBOLS = {"PF": "P_F", "PS": "P_S", "SD": "SD", "F": "F"}
SIGNED = ("PS", "SD")


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


def fmt_mm(v: Any, signed: bool = False) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{float(v):+.4f} mm" if signed else f"{float(v):.4f} mm"


def fmt_value(param: str, v: Any) -> str:
    """A parameter's value (a number, or a list of them per length) as mm text, signed
    where the parameter has a sign."""
    signed = param in SIGNED
    return ", ".join(fmt_mm(x, signed) for x in v) if isinstance(v, list) else fmt_mm(v, signed)


def _verdict(value: Any, mpe: float | None) -> str:
    if mpe is None:
        return "incomplete"
    if isinstance(value, list):
        return combine(simple_verdict(v, mpe) for v in value)
    return simple_verdict(value, mpe)


def _one_line(exc: BaseException, name: str = "") -> str:
    msg = str(exc) if isinstance(exc, CamcmmError) else f"{type(exc).__name__}: {exc}"
    msg = " ".join(msg.split()) or type(exc).__name__
    if name and name not in msg:
        msg = f"{name}: {msg}"
    return msg
