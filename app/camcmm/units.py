"""Length units. The model works in millimetres; files are converted at the edge."""

from __future__ import annotations

from .errors import ParameterError

#: Factor that converts one unit of each length into millimetres.
LENGTH_TO_MM: dict[str, float] = {
    "nm": 1e-6,
    "um": 1e-3,
    "µm": 1e-3,
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "in": 25.4,
}


def to_mm_factor(unit: str) -> float:
    """Return the factor that converts lengths in ``unit`` to mm.

    >>> to_mm_factor("m")
    1000.0
    """
    try:
        return LENGTH_TO_MM[unit.strip().lower().replace("µ", "u")]
    except KeyError:
        raise ParameterError(
            f"unknown length unit {unit!r}; use one of {', '.join(sorted(set(LENGTH_TO_MM) - {'µm'}))}"
        ) from None
