"""Numbers as a metrology report writes them (the Inspect page's one formatter).

Lengths arrive in mm. A length is written with as many decimals as its standard
uncertainty resolves (two significant digits of u, at least 1 µm, at most 0.1 nm);
small lengths — form figures, deviations, uncertainties below 1 mm — in µm; a real
minus sign; thin-space grouping of counts. Pure functions of numbers, no state.
"""

from __future__ import annotations

import math
from typing import Any

MINUS = "\u2212"  # "-" reads as a hyphen next to a unit
MICRO = "µm"


def _sign(text: str) -> str:
    return text.replace("-", MINUS)


def finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))


def count(n: Any) -> str:
    """``59997`` -> ``"59 997"``."""
    return f"{int(n):,}".replace(",", " ")


def significant(v: float, digits: int = 6) -> str:
    """A plain number with ``digits`` significant digits (``"not defined"`` for NaN/None)."""
    if not finite(v):
        return "not defined"
    return _sign(f"{float(v):.{digits}g}")


def decimals_for(u_mm: Any, default: int = 4) -> int:
    """Decimals (in mm) that show a value to two significant digits of its standard
    uncertainty ``u_mm``; ``default`` (1 µm... 0.1 µm) when u is not known."""
    if not finite(u_mm) or float(u_mm) <= 0:
        return default
    return int(min(7, max(3, 1 - math.floor(math.log10(float(u_mm))))))


def mm(v: Any, u_mm: Any = None, default: int = 4) -> str:
    """A length in mm to the decimals its uncertainty resolves: ``"9.999983"``."""
    if not finite(v):
        return "not defined"
    return _sign(f"{float(v):.{decimals_for(u_mm, default)}f}")


def micro(v_mm: Any, signed: bool = False) -> str:
    """A small length (given in mm) in µm: 3 significant digits, at most 0.01 µm
    resolution: ``0.0157`` -> ``"15.8"``; ``signed`` writes ``+`` too."""
    if not finite(v_mm):
        return "not defined"
    x = float(v_mm) * 1e3
    mag = abs(x)
    dec = 2 if mag < 10 else (1 if mag < 100 else 0)
    text = f"{x:+.{dec}f}" if signed else f"{x:.{dec}f}"
    return _sign(text)


def uncertainty(u_mm: Any) -> tuple[str, str]:
    """``(text, unit)`` of a standard uncertainty given in mm: two significant digits,
    in µm below 1 mm (``1.89e-5`` -> ``("0.019", "µm")``)."""
    if not finite(u_mm):
        return "not defined", ""
    u = abs(float(u_mm))
    if u >= 1.0:
        return f"{u:.2g}", "mm"
    x = u * 1e3
    if x == 0:
        return "0", MICRO
    dec = max(0, 1 - math.floor(math.log10(x)))
    return f"{x:.{dec}f}", MICRO


def vector(values: Any, u: Any = None, default: int = 4) -> str:
    """``(x, y, z)`` lengths in mm with the decimals the largest component uncertainty resolves."""
    us = [abs(float(x)) for x in (u or []) if finite(x)]
    dec = decimals_for(max(us), default) if us else default
    return "(" + ", ".join(mm(x, None, dec) if finite(x) else "not defined" for x in values) + ")"


def direction(values: Any) -> str:
    """A unit vector: six decimals per component."""
    return "(" + ", ".join(_sign(f"{float(x):.6f}") if finite(x) else "not defined" for x in values) + ")"


def uncertainty_vector(u: Any) -> tuple[str, str]:
    """``(text, unit)`` of per-component uncertainties (mm), all in the unit of the largest."""
    us = [abs(float(x)) for x in u if finite(x)]
    if not us:
        return "not defined", ""
    if max(us) >= 1.0:
        return "(" + ", ".join(f"{x:.2g}" for x in us) + ")", "mm"
    parts = [uncertainty(x)[0] if x > 0 else "0" for x in us]
    return "(" + ", ".join(parts) + ")", MICRO
