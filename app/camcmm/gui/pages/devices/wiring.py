"""What a device plugin declares about itself, and which devices fill its object slots.

A device entry of a manifest (docs/manifest.md) says its ``role`` (camera, stage,
projector, …, ``sequence``), whether it is ``simulated``, and what it ``needs``:
``{slot: role pattern}`` (``camera*``: every device of that role, one or more, as a list;
a trailing ``?``: the slot may stay empty). The page reads these declarations
(:class:`camcmm.manifest.PluginSpec` attributes), never a plugin id.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ....errors import CamcmmError
from ....manifest import ROLES, need


def role(spec: Any) -> str:
    """The declared role; ``device`` when the manifest gives none."""
    return spec.role or "device"


def catalogue_entry(spec: Any) -> dict[str, Any]:
    """One row of the page's list of addable plugins (``dev_catalogue``)."""
    sim = bool(spec.simulated)
    return {
        "id": spec.id,
        "title": f"{spec.name}{' (simulated)' if sim else ''}",
        "role": role(spec),
        "simulated": sim,
        "summary": spec.summary,
    }


def catalogue_order(row: dict[str, Any]) -> tuple[int, bool, str]:
    """Sort key of a catalogue row: by role (camcmm's roles first, in their order; a lab's
    own after them), real before simulated, then by title."""
    order = {r: i for i, r in enumerate(ROLES)}
    return order.get(row["role"], len(ROLES)), bool(row["simulated"]), str(row["title"])


def objects_for(spec: Any, devices: Iterable[Any]) -> dict[str, Any]:
    """The keyword objects for ``host.device(spec.id, …)``: each slot ``spec.needs``
    declares, filled from ``devices`` by their ``kind``; a missing required one is a
    one-line error."""
    pool = list(devices)
    out: dict[str, Any] = {}
    for slot, pattern in spec.needs.items():
        want = need(pattern)
        found = [d for d in pool if getattr(d, "kind", "") == want.role]
        if not found and not want.optional:
            article = "an" if want.role[:1] in "aeiou" else "a"
            raise CamcmmError(f"{spec.id}: connect {article} {want.role} first")
        if want.many:
            out[slot] = found
        elif found:
            out[slot] = found[0]
    return out
