"""What a device plugin declares about itself, and which devices fill its object slots.

A device entry of a manifest says its ``role`` (camera, stage, projector, …,
``sequence``), whether it is ``simulated``, and what it ``needs``: ``{slot: role}``,
where ``camera*`` takes every device of that role (a list), and a trailing ``?`` makes
the slot optional (``camera*?``: the list may be empty; ``speckle?``: left out when there
is none). The page reads these declarations, never a plugin id.
"""

from __future__ import annotations

from typing import Any, Iterable

from ....errors import CamcmmError

ROLES = ("camera", "projector", "stage", "interferometer", "speckle", "sequence")
"""The roles in the order the catalogue lists them (any other role comes after)."""


def declared(spec: Any, key: str, default: Any = None) -> Any:
    """A manifest field of ``spec``: its validated attribute when the core has one for
    ``key``, else the raw manifest value (``spec.extra``), else ``default``."""
    value = getattr(spec, key, None)
    if value is None or value == {} or value == "":
        value = (getattr(spec, "extra", None) or {}).get(key, default)
    return default if value is None else value


def role(spec: Any) -> str:
    return str(declared(spec, "role", "device") or "device")


def simulated(spec: Any) -> bool:
    return bool(declared(spec, "simulated", False))


def needs(spec: Any) -> dict[str, str]:
    """``{slot: role pattern}`` the plugin declares (empty: it takes no devices)."""
    value = declared(spec, "needs", {}) or {}
    if not isinstance(value, dict):
        raise CamcmmError(f"{spec.id}: 'needs' must map each slot to a role, got {value!r}")
    return {str(k): str(v) for k, v in value.items()}


def catalogue_entry(spec: Any) -> dict[str, Any]:
    """One row of the page's list of addable plugins (``dev_catalogue``)."""
    sim = simulated(spec)
    return {"id": spec.id, "title": f"{spec.name}{' (simulated)' if sim else ''}", "role": role(spec),
            "simulated": sim, "summary": spec.summary}


def catalogue_order(row: dict[str, Any]) -> tuple[int, bool, str]:
    """Sort key of a catalogue row: by role (:data:`ROLES`), real before simulated, then title."""
    order = {r: i for i, r in enumerate(ROLES)}
    return order.get(row["role"], len(ROLES)), bool(row["simulated"]), str(row["title"])


def objects_for(spec: Any, devices: Iterable[Any]) -> dict[str, Any]:
    """The keyword objects for ``host.device(spec.id, …)``: each declared slot filled from
    ``devices`` by their ``kind``; a missing required one is a one-line error."""
    pool = list(devices)
    out: dict[str, Any] = {}
    for slot, pattern in needs(spec).items():
        base, many, optional = pattern.rstrip("*?"), "*" in pattern, pattern.endswith("?")
        found = [d for d in pool if getattr(d, "kind", "") == base]
        if not found and not optional:
            article = "an" if base[:1] in "aeiou" else "a"
            raise CamcmmError(f"{spec.id}: connect {article} {base} first")
        if many:
            out[slot] = found
        elif found:
            out[slot] = found[0]
    return out
