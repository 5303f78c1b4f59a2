"""Command-line values checked by the plugin's own parameter declaration (plugin.yaml).

The ``calibrate``, ``scale`` and ``gauge-block`` commands call the numerics directly,
not through the host, so without this their options would skip the limits that JSON
runs and the GUI get from the declaration (a subpix window of 0 reached OpenCV's
assertion; ``--accuracy -1`` gave a negative uncertainty). One rule, declared once.
"""

from __future__ import annotations

from typing import Any


def declared(plugin_id: str, name: str, value: Any, flag: str | None = None) -> Any:
    """``value`` coerced and checked by parameter ``name`` of ``plugin_id``; None stays
    None (not given). ParameterError names the option: ``--subpix-window: parameter
    'subpix_window' = 0 is below its minimum 1 px``."""
    from camcmm.api import ParameterError, default_host

    if value is None:
        return None
    param = next(p for p in default_host().get(plugin_id).parameters if p.name == name)
    try:
        return param.coerce(value)
    except ParameterError as exc:
        raise ParameterError(f"{flag or '--' + name.replace('_', '-')}: {exc}") from None
