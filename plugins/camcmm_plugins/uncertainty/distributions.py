"""From what a budget entry states to its standard uncertainty u (type B evaluation).

A budget entry gives exactly one of

* ``u``: the standard uncertainty itself ("normal (standard)"); ``distribution`` then
  only records how u was evaluated and changes nothing;
* ``half_width`` (alias ``a``) with ``distribution``: the input lies within ±a and
  u = a / divisor —

  ==========================  ========  ==============================================
  distribution                divisor   reference
  ==========================  ========  ==============================================
  ``rectangular``             √3        JCGM 100:2008 (GUM) 4.3.7, u² = a²/3
  ``triangular``              √6        GUM 4.3.9 (trapezoid with β = 0), u² = a²/6
  ``u-shaped`` (arcsine)      √2        JCGM 101:2008 6.4.6; GUM H.1.3.4 (a cyclic
                                        temperature of amplitude a)
  ``normal``                  k         ±a taken as an expanded uncertainty (as files
                                        written before; prefer ``expanded`` + ``k``)
  ==========================  ========  ==============================================

* ``expanded`` (alias ``U``) with its coverage factor ``k`` (distribution normal or
  student-t): u = U / k, GUM 4.3.3 ("the quoted uncertainty divided by the multiplier").

Bad combinations get one line naming the entry: two of u, half_width and expanded; a
negative value; an unknown distribution; a half-width with a student-t distribution; a
k without an expanded (or normal half-width) value; an expanded value without k.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from camcmm.api import InputError

DISTRIBUTIONS = ("normal", "rectangular", "triangular", "u-shaped", "student-t")
ALIASES = {"arcsine": "u-shaped", "arc-sine": "u-shaped", "uniform": "rectangular", "gaussian": "normal"}
#: a / u for a half-width a (GUM 4.3.7, 4.3.9; JCGM 101 6.4.6): exact, as the GUM states them.
DIVISORS = {"rectangular": math.sqrt(3.0), "triangular": math.sqrt(6.0), "u-shaped": math.sqrt(2.0)}
DIVISOR_TEXT = {"rectangular": "√3", "triangular": "√6", "u-shaped": "√2"}
#: The default k of a half-width with a normal distribution (kept for files written before).
LEGACY_K = 2.0
SHOWN_UNIT = {"um": "µm", "deg": "°", "degC": "°C", "1/degC": "/°C"}


@dataclass(frozen=True)
class Entered:
    """How an entry was stated and the standard uncertainty it gives."""

    u: float
    distribution: str
    entered_as: str  # "u" | "half_width" | "expanded"
    value: float  # the number as stated: u, a or U
    divisor: float  # u = value / divisor (1 for u)
    k: float | None = None  # the coverage factor of an expanded value

    def text(self, unit: str = "") -> str:
        """The conversion in words, e.g. ``a = 2 µm, rectangular → u = a/√3 = 1.155 µm``."""
        un = SHOWN_UNIT.get(unit, unit)
        sp = f" {un}" if un else ""
        if self.entered_as == "u":
            return f"u = {self.u:.4g}{sp} ({self.distribution}: entered as u)"
        if self.entered_as == "expanded":
            return f"U = {self.value:.4g}{sp}, {self.distribution} with k = {self.k:g} → u = U/k = {self.u:.4g}{sp}"
        how = f"a/{DIVISOR_TEXT[self.distribution]}" if self.distribution in DIVISORS else f"a/k (k = {self.k:g})"
        return f"a = {self.value:.4g}{sp}, {self.distribution} → u = {how} = {self.u:.4g}{sp}"


def distribution_name(value: Any, tag: str) -> str:
    """The canonical distribution name (aliases: arcsine, uniform, gaussian) or one line."""
    d = str(value if value is not None else "normal").strip().lower()
    d = ALIASES.get(d, d)
    if d not in DISTRIBUTIONS:
        raise InputError(f"{tag}: unknown distribution {d!r}; use one of {', '.join(DISTRIBUTIONS)} (or arcsine)")
    return d


def standard_uncertainty(d: Mapping[str, Any], tag: str, number: Callable[[Any, str], float]) -> Entered:
    """The standard uncertainty of the budget entry ``d`` (see the module docstring);
    ``number`` parses a value with a message naming it; errors name ``tag``."""
    dist = distribution_name(d.get("distribution"), tag)
    given = {
        "u": d.get("u"),
        "half_width": d.get("half_width", d.get("a")),
        "expanded": d.get("expanded", d.get("U")),
    }
    stated = [k for k, v in given.items() if v is not None]
    if len(stated) > 1:
        raise InputError(f"{tag}: give one of u, half_width or expanded, not {' and '.join(stated)}")
    if not stated:
        raise InputError(f"{tag}: missing standard uncertainty u (or half_width and distribution, or expanded and k)")
    kind = stated[0]
    raw_k = d.get("k", d.get("k_a"))
    if kind == "u":
        if raw_k is not None:
            raise InputError(f"{tag}: k = {raw_k!r} applies to an expanded uncertainty; u is already standard")
        u = number(given["u"], f"{tag} u")
        return Entered(u, dist, "u", u, 1.0)
    what = "half-width a" if kind == "half_width" else "expanded U"
    value = number(given[kind], f"{tag} {what}")
    if not value >= 0 or math.isinf(value):
        raise InputError(f"{tag}: {what} = {value:g} must be a finite number >= 0")
    if kind == "half_width" and dist in DIVISORS:
        if raw_k is not None:
            raise InputError(f"{tag}: k = {raw_k!r} does not apply to a {dist} half-width (u = a/{DIVISOR_TEXT[dist]})")
        return Entered(value / DIVISORS[dist], dist, kind, value, DIVISORS[dist])
    if kind == "half_width" and dist == "student-t":
        raise InputError(f"{tag}: a half-width a has no student-t divisor; give expanded U with k, or u")
    if kind == "expanded" and dist not in ("normal", "student-t"):
        raise InputError(f"{tag}: an expanded U is divided by k for a normal distribution, not {dist}; give half_width")
    if raw_k is None and kind == "expanded":
        raise InputError(f"{tag}: expanded U = {value:g} needs its coverage factor k (GUM 4.3.3)")
    k = number(raw_k if raw_k is not None else LEGACY_K, f"{tag} k")
    if not k > 0 or math.isinf(k):
        raise InputError(f"{tag}: coverage factor k = {k:g} must be a finite number > 0")
    return Entered(value / k, dist, kind, value, k, k)
