"""A device action's I/O: what the buttons of the selected device do.

:func:`perform` may wait (for a move, a frame, the projector page's acknowledgement),
so the page runs it in its device job's worker threads, never on the server loop: the
loop also serves the projector page whose acknowledgement a ``show`` awaits.
"""

from __future__ import annotations

from typing import Any

from ....assets import resources_dir
from ....errors import CamcmmError
from ....yamlfile import read_yaml

ACTIONS = ("connect", "disconnect", "configure", "grab", "home", "abs", "rel", "stop", "load", "show")


#: The actions that move a stage: a refusal to move goes when any of them succeeds.
MOTION = ("home", "abs", "rel", "stop")


def cause(key: str, action: str) -> str:
    """What a failed ``action`` of device ``key`` is about (:meth:`Session.error`'s cause):
    the same action succeeding later resolves it, and any motion resolves a motion's."""
    return f"device {key}: {'motion' if action in MOTION else action}"


def perform(dev: Any, action: str, arg: Any = None, unhomed: bool = False) -> Any:
    """Do ``action`` on ``dev`` in the calling thread; returns what the device returns.

    ``configure``: ``arg`` is the dict of settings to change (returns all settings);
    ``abs``/``rel``: ``arg`` is the target/step in the stage's unit (mm or deg); ``unhomed``:
    the operator confirmed the move without a reference position;
    ``load``: ``arg`` is a pattern sequence file (empty: the shipped fringe sequence);
    ``show``: ``arg`` is the pattern index (None, "" or "blank": a blank screen).
    """
    if action == "connect":
        return dev.connect()
    if action == "disconnect":
        if getattr(dev, "live", False):
            dev.stop_live()
        return dev.disconnect()
    if action == "configure":
        return dev.configure(**dict(arg or {}))
    if action == "grab":
        return dev.grab()
    if action in ("home", "stop"):
        return getattr(dev, action)()
    if action in ("abs", "rel"):
        try:
            x = float(arg)
        except (TypeError, ValueError):
            raise CamcmmError(f"{dev.label}: move {action}: {arg!r} is not a number") from None
        move = dev.move_abs if action == "abs" else dev.move_rel
        return move(x, allow_unhomed=True) if unhomed else move(x)
    if action == "load":
        if arg and str(arg).strip():
            return dev.load_sequence(str(arg).strip())
        # camcmm's own sequence, as its content: the file lies outside the folders a
        # confined (server) run may read, and it is camcmm's, not the browser's choice
        shipped = resources_dir() / "fringe" / "sequence.yaml"
        return dev.load_sequence(read_yaml(shipped, name=shipped.name))
    if action == "show":
        return dev.show(None if arg in (None, "", "blank") else int(arg))
    raise CamcmmError(f"{dev.label}: unknown action {action!r}")
