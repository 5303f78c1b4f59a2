"""Numbers as a metrologist writes them: the one formatting rule of the app and its reports.

Every number a person reads — on a page, in a chart's legend or axis, in the HTML and PDF
reports, in a plugin's report table — goes through these functions. Plugins import the
module as ``from camcmm.api import numbers``. Pure functions of numbers, no state.

The rule
--------
- **Digits follow the uncertainty** where there is one: a value is written to the decimal of
  the second significant digit of its standard uncertainty (GUM, JCGM 100:2008 §7.2.6), and
  the uncertainty with two significant digits. Where there is none, a fixed precision per
  kind of quantity: a length 0.1 µm (4 decimals in mm), a deviation or form 0.01 µm and at
  most three significant digits, a time 0.1 s below 10 s, a percentage 0.1 % below 10 %.
- **µm** for deviations, form figures and uncertainties below 1 mm — everywhere, legends too.
  Lengths inside the app are mm; these functions take mm and convert.
- **Never scientific notation** (no ``e`` exponent) for a length, time or percentage a person
  reads, whatever its size (1e-9 ... 1e6 is tested).
- A real minus sign ``−`` (U+2212); a value that rounds to zero is written ``0`` — never
  ``−0.000`` or ``+0.00``.
- Units as written for people: ``mm``, ``µm``, ``µrad``, ``°``, ``s``, ``%``
  (:func:`unit_text` turns ``um``/``urad``/``deg`` into those).
- Legend and axis ticks on round values, 1, 2 or 5 × 10^k (:func:`ticks`), all written with
  the decimals of their step (:func:`tick_text`).
- Times as ``0.8 s``, ``42 s``, ``2 min 50 s``, ``1 h 5 min``.
- A value that is not a finite number is written ``not defined``.

Signatures (``v_mm``, ``u_mm``: millimetres; every function returns ``str`` unless said)
----------------------------------------------------------------------------------------
- ``length(v_mm, u_mm=None, unit=None, signed=False)`` -> ``"25.40012 mm"`` (``unit``:
  ``"mm"`` (default) or ``"µm"``; the decimals follow ``u_mm`` when given).
- ``characteristic(v_mm, size=False, u_mm=None)`` -> a GD&T value: a size in mm
  (``"20.0100 mm"``), a zone below 1 mm in µm (``"12.3 µm"``).
- ``deviation(v_mm, signed=True, u_mm=None)`` -> ``"+12.3 µm"`` (always µm; deviations,
  form (``signed=False``), distances to a nominal).
- ``uncertainty(u_mm, k=1)`` -> ``"0.019 µm"``; ``k != 1`` adds the coverage factor:
  ``uncertainty(0.0131, k=2)`` -> ``"13 µm (k = 2)"``. ``u_mm`` is the value at coverage
  factor ``k`` (it is not multiplied).
- ``uncertainty_parts(u_mm) -> tuple[str, str]`` -> ``("0.019", "µm")`` for a table with a
  unit column.
- ``measured(v_mm, u_mm, k=1, unit=None)`` -> ``"25.40012 mm ± 0.80 µm"``
  (``"... (k = 2)"`` when ``k != 1``).
- ``time(s)`` -> ``"0.8 s"``, ``"42 s"``, ``"2 min 50 s"``, ``"1 h 5 min"``, ``"12 ms"``.
- ``percent(fraction, decimals=None)`` -> ``percent(0.632)`` = ``"63 %"``,
  ``percent(0.004)`` = ``"0.4 %"`` (argument is a fraction; ``decimals`` fixes the decimals).
- ``percentile(p)`` -> ``percentile(2.5)`` = ``"2.5 %"`` (``p`` in percent, as many decimals
  as it has; for naming percentiles such as the JSON keys ``p2_5``: :func:`percentile_key`).
- ``percentile_key(key)`` -> ``"p2_5"`` -> ``"2.5 %"``, ``"p97_5"`` -> ``"97.5 %"``.
- ``angle(v, unit="rad", u=None)`` -> ``"12.3 µrad"`` below 0.01 rad, else ``"12.35°"``;
  ``unit`` names what ``v`` (and ``u``) are in: ``"rad"``, ``"µrad"``/``"urad"``,
  ``"deg"``/``"°"``.
- ``count(n)`` -> ``"59 997"``.
- ``plain(x, digits=3)`` / ``ratio(x, digits=3)`` -> a dimensionless number with ``digits``
  significant digits, fixed-point.
- ``significant(v, digits=6)`` -> as ``plain`` (kept for the Inspect page's callers).
- ``mm(v_mm, u_mm=None, default=4)`` -> the number only, in mm: ``"9.999983"``.
- ``micro(v_mm, signed=False)`` -> the number only, in µm: ``"15.7"``.
- ``decimals_for(u_mm, default=4) -> int``: decimals in mm that ``u_mm`` resolves.
- ``value_u(v, u, unit="", signed=False)`` -> any quantity with its u in its own unit:
  ``"0.012346 ± 0.000021 mm λ⁻¹"`` (digits follow u).
- ``vector(values_mm, u=None, default=4)``, ``direction(values)``,
  ``uncertainty_vector(u_mm) -> tuple[str, str]``: ``(x, y, z)`` forms.
- ``ticks(lo, hi, n=5) -> list[float]``: round values (1/2/5 × 10^k) inside [lo, hi],
  about ``n`` of them; ``tick_text(values, unit="") -> list[str]``: all with one number of
  decimals, the step's.
- ``legend_unit(unit, lo, hi) -> tuple[str, float]``: the unit a legend over [lo, hi] in
  ``unit`` is shown in and the factor to it (mm spanning less than 1 mm -> ``("µm", 1000)``).
- ``words(key) -> str``: ``"radial_deviation"`` -> ``"radial deviation"``;
  ``title(key, unit) -> str``: ``"radial deviation [µm]"``.
- ``unit_text(unit) -> str``: ``"um"`` -> ``"µm"``, ``"urad"`` -> ``"µrad"``, ``"deg"`` -> ``"°"``.
- ``finite(v) -> bool``; constants ``MINUS`` (``"−"``), ``MICRO`` (``"µm"``), ``UNDEFINED``.
"""

from __future__ import annotations

import math
import re
from typing import Any

__all__ = [
    "MICRO",
    "MINUS",
    "UNDEFINED",
    "angle",
    "characteristic",
    "count",
    "decimals_for",
    "deviation",
    "direction",
    "finite",
    "legend_unit",
    "length",
    "measured",
    "micro",
    "mm",
    "percent",
    "percentile",
    "percentile_key",
    "plain",
    "ratio",
    "significant",
    "tick_text",
    "ticks",
    "time",
    "title",
    "uncertainty",
    "uncertainty_parts",
    "uncertainty_vector",
    "unit_text",
    "value_u",
    "vector",
    "words",
]

MINUS = "\u2212"  # "-" reads as a hyphen next to a unit
MICRO = "µm"
UNDEFINED = "not defined"

_UNITS = {
    "um": "µm",
    "µm": "µm",
    "micron": "µm",
    "microns": "µm",
    "urad": "µrad",
    "µrad": "µrad",
    "deg": "°",
    "degree": "°",
    "degrees": "°",
    "percent": "%",
    "sec": "s",
    "lambda": "λ",  # the light field's depth unit (thesis ch. 6.3)
    "1/lambda": "λ⁻¹",
    "mm/lambda": "mm/λ",
}


def finite(v: Any) -> bool:
    """True for an int or float (not bool) that is finite; numpy scalars count."""
    if isinstance(v, bool) or v is None:
        return False
    try:
        return math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def unit_text(unit: Any) -> str:
    """A unit as a person reads it: ``"um"`` -> ``"µm"``, ``"urad"`` -> ``"µrad"``,
    ``"deg"`` -> ``"°"``; others unchanged (``None`` -> ``""``)."""
    if unit is None:
        return ""
    text = str(unit).strip()
    return _UNITS.get(text.lower(), text)


def _fixed(x: float, decimals: int, signed: bool = False) -> str:
    """``x`` fixed-point with ``decimals`` (never an exponent), a real minus, and ``0`` for a
    value that rounds to zero."""
    decimals = max(0, int(decimals))
    text = f"{x:+.{decimals}f}" if signed else f"{x:.{decimals}f}"
    if not any(c in "123456789" for c in text):
        return "0"
    return text.replace("-", MINUS)


def _sig_decimals(x: float, digits: int) -> int:
    """Decimals that show ``x`` with ``digits`` significant digits (>= 0)."""
    if x == 0 or not math.isfinite(x):
        return 0
    return max(0, digits - 1 - math.floor(math.log10(abs(x))))


def _with_unit(text: str, unit: str) -> str:
    if not unit:
        return text
    return f"{text}{unit}" if unit == "°" else f"{text} {unit}"


# -- plain numbers ---------------------------------------------------------------------------


def plain(x: Any, digits: int = 3) -> str:
    """A dimensionless number with ``digits`` significant digits, fixed-point: ``0.8213``
    -> ``"0.821"``; ``1234567`` -> ``"1234567"`` (integers keep their digits)."""
    if not finite(x):
        return UNDEFINED
    v = float(x)
    dec = _sig_decimals(v, digits)
    # rounding can carry into a new leading digit (0.0999 -> 0.100): one decimal fewer
    if dec and _sig_decimals(round(v, dec), digits) < dec:
        dec -= 1
    return _fixed(v, dec)


ratio = plain


def significant(v: Any, digits: int = 6) -> str:
    """A plain number with ``digits`` significant digits (as :func:`plain`; trailing zeros of
    the decimals dropped as ``%g`` does, never an exponent)."""
    text = plain(v, digits)
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text


def count(n: Any) -> str:
    """A count with its thousands apart: ``59997`` -> ``"59 997"``."""
    if not finite(n):
        return UNDEFINED
    return f"{int(n):,}".replace(",", " ").replace("-", MINUS)


# -- lengths ---------------------------------------------------------------------------------


def decimals_for(u_mm: Any, default: int = 4) -> int:
    """Decimals (in mm) that show a value to two significant digits of its standard
    uncertainty ``u_mm`` (at least 3, at most 7: 1 µm ... 0.1 nm); ``default`` when u is
    not known."""
    if not finite(u_mm) or float(u_mm) <= 0:
        return default
    return int(min(7, max(3, 1 - math.floor(math.log10(float(u_mm))))))


def mm(v: Any, u_mm: Any = None, default: int = 4) -> str:
    """The number of a length in mm to the decimals its uncertainty resolves: ``"9.999983"``."""
    if not finite(v):
        return UNDEFINED
    return _fixed(float(v), decimals_for(u_mm, default))


def _micro_decimals(x_um: float) -> int:
    """A small length in µm: three significant digits, at most 0.01 µm resolution."""
    mag = abs(x_um)
    return 2 if mag < 10 else (1 if mag < 100 else 0)


def micro(v_mm: Any, signed: bool = False) -> str:
    """The number of a small length (given in mm) in µm: 3 significant digits, at most
    0.01 µm resolution: ``0.0157`` -> ``"15.7"``; ``signed`` writes ``+`` too."""
    if not finite(v_mm):
        return UNDEFINED
    x = float(v_mm) * 1e3
    return _fixed(x, _micro_decimals(x), signed)


def length(v_mm: Any, u_mm: Any = None, unit: str | None = None, signed: bool = False) -> str:
    """A length with its unit: ``length(25.400123, 8e-4)`` -> ``"25.40012 mm"``.

    ``unit`` ``"mm"`` (default) or ``"µm"``. The decimals follow the standard uncertainty
    ``u_mm`` (two significant digits of it) when given, else 0.1 µm in mm and 0.01 µm (three
    significant digits) in µm."""
    if not finite(v_mm):
        return UNDEFINED
    shown = unit_text(unit) or "mm"
    if shown not in ("mm", "µm"):
        raise ValueError(f"length: unit {unit!r} is neither mm nor µm")
    v = float(v_mm)
    if shown == "mm":
        dec = 1 - math.floor(math.log10(float(u_mm))) if finite(u_mm) and float(u_mm) > 0 else 4
        return _with_unit(_fixed(v, dec, signed), "mm")
    x = v * 1e3
    if finite(u_mm) and float(u_mm) > 0:
        dec = 1 - math.floor(math.log10(float(u_mm) * 1e3))
    else:
        dec = _micro_decimals(x)
    return _with_unit(_fixed(x, dec, signed), MICRO)


def deviation(v_mm: Any, signed: bool = True, u_mm: Any = None) -> str:
    """A deviation, form figure or distance to a nominal (given in mm) in µm:
    ``deviation(0.0123)`` -> ``"+12.3 µm"``; ``signed=False`` for form (``"12.3 µm"``)."""
    return length(v_mm, u_mm, "µm", signed)


def uncertainty_parts(u_mm: Any) -> tuple[str, str]:
    """``(text, unit)`` of an uncertainty given in mm: two significant digits, in µm below
    1 mm (``1.89e-5`` -> ``("0.019", "µm")``, ``2.5`` -> ``("2.5", "mm")``)."""
    if not finite(u_mm):
        return UNDEFINED, ""
    u = abs(float(u_mm))
    if u >= 1.0:
        return _fixed(u, _sig_decimals(u, 2)), "mm"
    x = u * 1e3
    if x == 0:
        return "0", MICRO
    dec = max(0, 1 - math.floor(math.log10(x)))
    text = _fixed(x, dec)
    if float(text) >= 1000:  # 999.7 µm rounds to 1000 µm: that is 1.0 mm
        return "1.0", "mm"
    return text, MICRO


def uncertainty(u_mm: Any, k: float = 1) -> str:
    """An uncertainty (mm) with two significant digits and its unit, µm below 1 mm:
    ``"0.019 µm"``; a coverage factor other than 1 is said: ``"13 µm (k = 2)"``.
    ``u_mm`` is the value at that ``k`` (not multiplied here)."""
    text, unit = uncertainty_parts(u_mm)
    if not unit:
        return text
    out = f"{text} {unit}"
    if finite(k) and float(k) != 1:
        out += f" (k = {significant(k, 3)})"
    return out


def measured(v_mm: Any, u_mm: Any, k: float = 1, unit: str | None = None) -> str:
    """A measured length and its uncertainty: ``"25.40012 mm ± 0.80 µm"`` (``k`` as in
    :func:`uncertainty`; the value's digits follow the standard uncertainty ``u_mm / k``)."""
    if not finite(v_mm):
        return UNDEFINED
    if not finite(u_mm):
        return length(v_mm, None, unit)
    u_std = float(u_mm) / float(k) if finite(k) and float(k) > 0 else float(u_mm)
    return f"{length(v_mm, u_std, unit)} ± {uncertainty(u_mm, k)}"


def characteristic(v_mm: Any, size: bool = False, u_mm: Any = None) -> str:
    """A GD&T characteristic's value with its unit: a size (diameter, width, distance) in
    mm to the decimals its uncertainty resolves (``"20.0100 mm"``); a zone (form,
    orientation, location, runout) below 1 mm in µm (``"12.3 µm"``). The Compare and Series
    pages write characteristics with it, so the two agree."""
    if not finite(v_mm):
        return UNDEFINED
    if size or abs(float(v_mm)) >= 1.0:
        return f"{mm(v_mm, u_mm)} mm"
    return f"{micro(v_mm)} {MICRO}"


def value_u(v: Any, u: Any, unit: str = "", signed: bool = False) -> str:
    """Any quantity (a slope, a gradient, a scale) with its standard uncertainty, in its own
    unit: the value to the decimal of u's second significant digit, u with two:
    ``value_u(0.0123456, 2.1e-5, "mm λ⁻¹")`` -> ``"0.012346 ± 0.000021 mm λ⁻¹"``. Without a
    finite positive u, six significant digits."""
    if not finite(v):
        return UNDEFINED
    shown = unit_text(unit)
    if not finite(u) or float(u) <= 0:
        text = significant(v, 6)
        return _with_unit(("+" + text if signed and float(v) > 0 and text != "0" else text), shown)
    dec = 1 - math.floor(math.log10(abs(float(u))))
    body = f"{_fixed(float(v), dec, signed)} ± {_fixed(abs(float(u)), dec)}"
    return _with_unit(body, shown)


def vector(values: Any, u: Any = None, default: int = 4) -> str:
    """``(x, y, z)`` lengths in mm with the decimals the largest component uncertainty resolves."""
    us = [abs(float(x)) for x in (u or []) if finite(x)]
    dec = decimals_for(max(us), default) if us else default
    return "(" + ", ".join(mm(x, None, dec) if finite(x) else UNDEFINED for x in values) + ")"


def direction(values: Any) -> str:
    """A unit vector: six decimals per component."""
    return "(" + ", ".join(_fixed(float(x), 6) if finite(x) else UNDEFINED for x in values) + ")"


def uncertainty_vector(u: Any) -> tuple[str, str]:
    """``(text, unit)`` of per-component uncertainties (mm), all in the unit of the largest."""
    us = [abs(float(x)) for x in u if finite(x)]
    if not us:
        return UNDEFINED, ""
    if max(us) >= 1.0:
        return "(" + ", ".join(_fixed(x, _sig_decimals(x, 2)) for x in us) + ")", "mm"
    parts = [uncertainty_parts(x)[0] if x > 0 else "0" for x in us]
    return "(" + ", ".join(parts) + ")", MICRO


# -- time, percentages, angles ---------------------------------------------------------------


def time(s: Any) -> str:
    """A duration in seconds as a person reads it: ``"12 ms"`` below 0.1 s, ``"0.8 s"``
    (0.1 s below 10 s), ``"42 s"`` below 2 min, ``"2 min 50 s"`` below 1 h, ``"1 h 5 min"``."""
    if not finite(s):
        return UNDEFINED
    t = float(s)
    sign = MINUS if t < 0 else ""
    t = abs(t)
    if t == 0:
        return "0 s"
    if t < 0.1:
        ms = t * 1e3
        dec = _sig_decimals(ms, 2)
        return sign + _fixed(ms, dec) + " ms"
    if t < 9.95:
        return sign + _fixed(t, 1) + " s"
    whole = int(round(t))
    if whole < 120:
        return f"{sign}{whole} s"
    if whole < 3600:
        return f"{sign}{whole // 60} min {whole % 60} s"
    minutes = int(round(t / 60))
    return f"{sign}{minutes // 60} h {minutes % 60} min"


def percent(fraction: Any, decimals: int | None = None) -> str:
    """A fraction as a percentage: ``0.632`` -> ``"63 %"``, ``0.004`` -> ``"0.4 %"``
    (0.1 % below 10 %, whole percent above); ``decimals`` fixes them."""
    if not finite(fraction):
        return UNDEFINED
    p = float(fraction) * 100.0
    if decimals is None:
        decimals = 1 if abs(p) < 9.95 else 0
    return _fixed(p, decimals) + " %"


def percentile(p: Any) -> str:
    """The name of a percentile given in percent: ``2.5`` -> ``"2.5 %"``, ``50`` -> ``"50 %"``."""
    if not finite(p):
        return UNDEFINED
    return significant(float(p), 6) + " %"


_PKEY = re.compile(r"^p(\d+)(?:_(\d+))?$")


def percentile_key(key: str) -> str:
    """A percentile's JSON key in words: ``"p0_5"`` -> ``"0.5 %"``, ``"p97_5"`` ->
    ``"97.5 %"``, ``"p50"`` -> ``"50 %"``; another key comes back unchanged."""
    m = _PKEY.match(str(key))
    if not m:
        return str(key)
    return percentile(float(m.group(1) + ("." + m.group(2) if m.group(2) else "")))


_RAD_PER = {"rad": 1.0, "µrad": 1e-6, "mrad": 1e-3, "°": math.pi / 180.0}


def angle(v: Any, unit: str = "rad", u: Any = None) -> str:
    """An angle given in ``unit`` (``"rad"``, ``"mrad"``, ``"µrad"``/``"urad"``, ``"deg"``/``"°"``):
    below 0.01 rad in µrad (``"12.3 µrad"``), else in degrees (``"12.35°"``). With an
    uncertainty ``u`` (same unit) the decimals follow it; else 3 significant digits (at
    most 0.01 µrad) in µrad and 0.01° in degrees."""
    if not finite(v):
        return UNDEFINED
    name = unit_text(unit)
    if name not in _RAD_PER:
        raise ValueError(f"angle: unit {unit!r} is not rad, mrad, µrad or °")
    rad = float(v) * _RAD_PER[name]
    u_rad = abs(float(u)) * _RAD_PER[name] if finite(u) and float(u) > 0 else None
    if abs(rad) < 0.01:
        x = rad * 1e6
        dec = 1 - math.floor(math.log10(u_rad * 1e6)) if u_rad else _micro_decimals(x)
        return _with_unit(_fixed(x, dec), "µrad")
    deg = math.degrees(rad)
    dec = 1 - math.floor(math.log10(math.degrees(u_rad))) if u_rad else 2
    return _with_unit(_fixed(deg, dec), "°")


# -- legends and axes ------------------------------------------------------------------------


def ticks(lo: Any, hi: Any, n: int = 5) -> list[float]:
    """About ``n`` round values (1, 2 or 5 × 10^k) inside [lo, hi], ascending; ``[lo]`` when
    the range is empty, ``[]`` when it is not finite."""
    if not (finite(lo) and finite(hi)):
        return []
    a, b = sorted((float(lo), float(hi)))
    if a == b:
        return [a]
    mag = 10.0 ** math.floor(math.log10((b - a) / max(1, n - 1)))

    def inside(step: float) -> int:
        return math.floor(b / step + 1e-9) - math.ceil(a / step - 1e-9) + 1

    # the round step whose count of ticks inside is nearest n (the finer one on a tie)
    steps = [m * mag * f for f in (0.1, 1.0, 10.0) for m in (1, 2, 5)]
    step = min(steps, key=lambda s: (abs(inside(s) - n), s))
    dec = max(0, -math.floor(math.log10(step)) + 1)
    first, last = math.ceil(a / step - 1e-9), math.floor(b / step + 1e-9)
    return [round(k * step, dec) + 0.0 for k in range(first, last + 1)]


def tick_text(values: Any, unit: str = "") -> list[str]:
    """Tick values written with one number of decimals — their step's — and ``unit``:
    ``[-0.02, 0, 0.02]`` -> ``["−0.02", "0", "0.02"]``."""
    vals = [float(v) for v in values if finite(v)]
    if not vals:
        return []
    diffs = [abs(b - a) for a, b in zip(vals, vals[1:]) if b != a]
    ref = min(diffs) if diffs else max(abs(v) for v in vals) or 1.0
    dec = max(0, -math.floor(math.log10(ref) + 1e-9))
    # a step of 2.5 or 0.25 needs one decimal more than its magnitude
    while dec < 12 and abs(round(ref, dec) - ref) > 1e-9 * ref:
        dec += 1
    shown = unit_text(unit)
    return [_with_unit(_fixed(v, dec), shown) for v in vals]


def legend_unit(unit: Any, lo: Any, hi: Any) -> tuple[str, float]:
    """``(unit shown, factor)`` for a legend over [lo, hi] in ``unit``: a length in mm
    whose extent is below 1 mm (deviations, form, uncertainties) reads in µm (factor 1000);
    ``"um"``/``"urad"``/``"deg"`` are written as people write them."""
    name = unit_text(unit)
    if name == "mm" and finite(lo) and finite(hi) and max(abs(float(lo)), abs(float(hi))) < 1.0:
        return MICRO, 1000.0
    if name == "rad" and finite(lo) and finite(hi) and max(abs(float(lo)), abs(float(hi))) < 0.01:
        return "µrad", 1e6
    return name, 1.0


def words(key: Any) -> str:
    """An internal key in words: ``"radial_deviation"`` -> ``"radial deviation"``."""
    return re.sub(r"[_\s]+", " ", str(key)).strip()


def title(key: Any, unit: Any = None) -> str:
    """A legend or column title: ``title("radial_deviation", "um")`` -> ``"radial deviation [µm]"``."""
    shown = unit_text(unit)
    return f"{words(key)} [{shown}]" if shown else words(key)
