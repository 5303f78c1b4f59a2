"""The pictograms on the position cards: the standard draws them
(``std.pictograms(requirements, plan) -> {"test/position": svg}``) or declares one per
position (``pictogram``); any other position gets a plain card-sized SVG with its label."""

from __future__ import annotations

import html
from typing import Any

from camcmm.errors import one_line

from .values import log


def plain(label: str) -> str:
    """A neutral pictogram: a frame with the position's label (SVG text)."""
    text = html.escape(label)
    return (
        '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 120 80" width="100%" height="100%" role="img" '
        f'aria-label="{text}"><title>{text}</title><rect x="4" y="4" width="112" height="72" rx="6" '
        'fill="#eceff1" stroke="#78909c"/><circle cx="60" cy="34" r="10" fill="#1565c0"/>'
        f'<text x="60" y="66" font-size="9" text-anchor="middle" fill="#455a64" '
        f'font-family="sans-serif">{text}</text></svg>'
    )


def pictograms(std: Any, requirements: list[dict[str, Any]], plan: dict[str, Any]) -> dict[str, str]:
    """``{"test/position": svg}`` for every position of the requirements."""
    drawn: dict[str, str] = {}
    draw = getattr(std, "pictograms", None)
    if callable(draw):
        try:
            drawn = dict(draw(requirements, plan) or {})
        except Exception as exc:  # a drawing bug must not stop the page: plain pictograms then
            log.warning("the standard's pictograms failed: %s", one_line(exc))
    out = {}
    for r in requirements:
        for p in r["positions"]:
            key = f"{r['test']}/{p['id']}"
            out[key] = drawn.get(key) or p.get("pictogram") or plain(str(p.get("label") or p["id"]))
    return out
