"""The 3-D view's tools, the same on every page with a view (Inspect, Compare with CAD):
standard views (±X, ±Y, ±Z, iso), reset, point size, a screenshot of the current render
as a PNG download, picked labels that stay, and the stepped colour legend.

:class:`ViewTools` works on any of the GUI's scenes (:class:`camcmm.gui.view.SceneView`,
the Compare page's ``CompareView``): it needs ``plotter``, ``point_actors()``,
``point_size`` and ``_changed(reset_camera)``. Its state keys start with ``prefix``
(``<prefix>_point_size``, ``<prefix>_shot``, ``<prefix>_labels`` …) so that two pages never
share one. :func:`view_toolbar` draws the toolbar (one function: every page gets the same
one). The camera and legend arithmetic are plain functions, testable without trame.
"""

from __future__ import annotations

import itertools
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .downloads import Downloads

#: name -> (direction from the part to the camera, view up, tooltip, shortcut key)
VIEWS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float], str, str]] = {
    "+x": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), "View from +X (camera on the +X side, z up)", "1"),
    "-x": ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), "View from −X (camera on the −X side, z up)", "2"),
    "+y": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), "View from +Y (camera on the +Y side, z up)", "3"),
    "-y": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0), "View from −Y (camera on the −Y side, z up)", "4"),
    "+z": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), "View from +Z (top view, y up)", "5"),
    "-z": ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0), "View from −Z (bottom view, y up)", "6"),
    "iso": ((1.0, 1.0, 1.0), (0.0, 0.0, 1.0), "Isometric view from (+X, +Y, +Z), z up", "i"),
}
POINT_SIZES = (0, 1, 2, 3, 4, 5, 6, 8, 10)  # 0: automatic (by the number of points shown)
LEGENDS = ("continuous", "stepped", "tolerance")
#: out-of-tolerance colours of the stepped legend (outside the diverging map's reds/blues)
ABOVE_COLOUR, BELOW_COLOUR = "#d01c8b", "#4d004b"
MAX_LABELS = 20
_shots = itertools.count(1)


# ------------------------------------------------------------------------------ camera
def camera_for(name: str, bounds: Any) -> dict[str, list[float]]:
    """The camera of standard view ``name`` framing ``bounds`` ((2, 3) min/max, mm):
    focal point at the centre, position along the view's direction at a distance that
    shows the bounding sphere in a 30° view angle, and the view up."""
    if name not in VIEWS:
        raise ValueError(f"view {name!r}: choose one of {', '.join(VIEWS)}")
    b = np.asarray(bounds, dtype=float).reshape(2, 3)
    centre = 0.5 * (b[0] + b[1])
    radius = max(0.5 * float(np.linalg.norm(b[1] - b[0])), 1e-9)
    d = np.asarray(VIEWS[name][0])
    d = d / np.linalg.norm(d)
    dist = radius / math.sin(math.radians(15.0))
    return {"position": (centre + dist * d).tolist(), "focal_point": centre.tolist(), "view_up": list(VIEWS[name][1])}


# ------------------------------------------------------------------------------ legend
def stepped_edges(limit: float, n: int) -> list[float]:
    """The ``n + 1`` band edges of a stepped legend over ±``limit``: equal steps, exact
    by construction (limit·(2i − n)/n: symmetric, 0 exactly in the middle for even n)."""
    n = int(n)
    if n < 2:
        raise ValueError(f"a stepped legend needs at least 2 bands, got {n}")
    lim = abs(float(limit))
    return [lim * (2 * i - n) / n for i in range(n + 1)]


def legend_spec(kind: str, n: int, limit: float, tolerance: float | None) -> dict[str, Any]:
    """How the colour map is drawn: ``{"clim", "n_colors", "edges", "above", "below"}``.

    continuous: the diverging map over ±limit; stepped: ``n`` equal bands over ±limit;
    tolerance: ``n`` bands over ±tolerance, values above / below it in the
    out-of-tolerance colours (falls back to stepped without a tolerance)."""
    if kind not in LEGENDS:
        raise ValueError(f"legend {kind!r}: choose one of {', '.join(LEGENDS)}")
    if kind == "tolerance" and tolerance:
        lim = float(tolerance)
        return {
            "clim": [-lim, lim],
            "n_colors": int(n),
            "edges": stepped_edges(lim, n),
            "above": ABOVE_COLOUR,
            "below": BELOW_COLOUR,
        }
    if kind == "continuous":
        return {"clim": [-abs(limit), abs(limit)], "n_colors": 256, "edges": [], "above": None, "below": None}
    return {
        "clim": [-abs(limit), abs(limit)],
        "n_colors": int(n),
        "edges": stepped_edges(limit, n),
        "above": None,
        "below": None,
    }


# ------------------------------------------------------------------------------ labels
def label_text(number: int, point: Any, deviation_mm: float | None, unit: str) -> str:
    """A picked label: ``"#1 (12.345, 6.789, 0.123) mm\\n+7.6 µm"`` (coordinates in mm to
    the µm, the deviation in the page's unit with a real minus sign)."""
    p = np.asarray(point, dtype=float).ravel()[:3]
    coords = "(" + ", ".join(f"{c:.3f}" for c in p).replace("-", "\u2212") + ") mm"
    text = f"#{number} {coords}"
    if deviation_mm is not None and math.isfinite(deviation_mm):
        f = 1e3 if unit == "µm" else 1.0
        digits = 1 if unit == "µm" else 4
        text += "\n" + f"{deviation_mm * f:+.{digits}f} {unit}".replace("-", "\u2212")
    return text


class ViewTools:
    """The tools of one page's view; state keys ``<prefix>_*``. Loop thread only."""

    def __init__(self, view: Any, state: Any, prefix: str, downloads: Downloads):
        self.view, self.state, self.prefix, self.downloads = view, state, prefix, downloads
        self.labels: list[dict[str, Any]] = []
        self._set("point_size", 0)
        self._set("shot", None)
        self._set("labels", [])

    def _set(self, key: str, value: Any) -> None:
        setattr(self.state, f"{self.prefix}_{key}", value)

    # -- camera ------------------------------------------------------------------------
    def standard_view(self, name: str) -> dict[str, list[float]] | None:
        """Turn the camera to a standard view (or ``"reset"``: frame everything from the
        current direction); returns the camera set, None when nothing is shown."""
        plotter = self.view.plotter
        if name == "reset":
            plotter.reset_camera()
        else:
            bounds = np.asarray(plotter.renderer.ComputeVisiblePropBounds(), dtype=float).reshape(3, 2).T
            if not np.all(np.isfinite(bounds)) or np.any(bounds[1] < bounds[0]):
                return None
            cam = camera_for(str(name), bounds)
            plotter.camera_position = [cam["position"], cam["focal_point"], cam["view_up"]]
            plotter.reset_camera()
        self.view._changed(False)
        c = plotter.camera
        return {"position": list(c.position), "focal_point": list(c.focal_point), "view_up": list(c.up)}

    # -- points ------------------------------------------------------------------------
    def set_point_size(self, size: Any) -> int:
        """Points drawn ``size`` pixels wide (0: automatic, by how many are shown)."""
        try:
            n = int(size)
        except (TypeError, ValueError):
            n = 0
        n = n if n in POINT_SIZES else 0
        self.view.point_size = n or None
        for actor in self.view.point_actors():
            actor.GetProperty().SetPointSize(n or self.view.auto_point_size())
        self._set("point_size", n)
        self.view._changed(False)
        return n

    # -- screenshot --------------------------------------------------------------------
    def screenshot(self) -> dict[str, str] | None:
        """The current render as a PNG offered for download (the link in ``<prefix>_shot``)."""
        with tempfile.TemporaryDirectory(prefix="camcmm-shot-") as tmp:
            path = Path(tmp) / "view.png"
            self.view.plotter.screenshot(str(path))
            data = path.read_bytes()
        link = self.downloads.offer(
            f"{self.prefix}-view-{next(_shots)}.png", data=data, kind="png", title="Download the view (PNG)"
        )
        self._set("shot", link)
        return link

    # -- labels ------------------------------------------------------------------------
    def add_label(self, point: Any, deviation_mm: float | None, unit: str) -> dict[str, Any]:
        """A label that stays (at most MAX_LABELS: the oldest goes first)."""
        number = (self.labels[-1]["number"] + 1) if self.labels else 1
        p = [float(c) for c in np.asarray(point, dtype=float).ravel()[:3]]
        lab = {
            "number": number,
            "point": p,
            "deviation_mm": deviation_mm,
            "text": label_text(number, p, deviation_mm, unit),
        }
        self.labels = (self.labels + [lab])[-MAX_LABELS:]
        self._publish_labels()
        return lab

    def clear_labels(self) -> None:
        self.labels = []
        self._publish_labels()

    def markers(self) -> list[dict[str, Any]]:
        return [{"point": lab["point"], "label": lab["text"], "colour": "#212121"} for lab in self.labels]

    def _publish_labels(self) -> None:
        self._set("labels", [{"number": lab["number"], "text": lab["text"]} for lab in self.labels])
        if hasattr(self.view, "set_labels"):
            self.view.set_labels(self.markers())


def mount_view_tools(server: Any, view: Any, prefix: str) -> ViewTools:
    """The tools of ``view`` with their own served downloads folder (call before the
    server starts; the route is guarded like every other)."""
    downloads = Downloads(f"camcmm-{prefix}-view", f"camcmm-{prefix}-view-")
    downloads.mount(server)
    return ViewTools(view, server.state, prefix, downloads)


def view_toolbar(tools: ViewTools, labels: bool = True) -> None:
    """The view's toolbar: standard views, reset, point size, screenshot and its link, and
    (``labels``) Clear labels. Buttons carry ``data-shortcut-key`` (1–6 for ±X/±Y/±Z, i iso, r reset)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    from .widgets import tid

    p = tools.prefix

    def on_view(name):
        tools.standard_view(name)

    def on_size(size):
        tools.set_point_size(size)

    def on_shot():
        tools.screenshot()

    def on_clear():
        tools.clear_labels()

    with html.Div(
        classes="d-flex align-center flex-wrap ga-1 px-3",
        style="min-height: 36px; row-gap: 14px;",
        raw_attrs=tid(f"{p}-tools"),
    ):
        buttons = [(name, tip, key) for name, (_, _, tip, key) in VIEWS.items()]
        for name, tip, key in buttons + [("reset", "Reset: frame everything, keep the direction", "r")]:
            label = {"iso": "iso", "reset": "reset"}.get(name, name.upper().replace("-", "\u2212"))
            v.VBtn(
                label,
                size="x-small",
                variant="outlined",
                click=(on_view, f"['{name}']"),
                title=f"{tip} [key {key}]",
                raw_attrs=tid(f"{p}-view-{name}") + [f'data-shortcut-key="{key}"'],
            )
        v.VSelect(
            model_value=(f"{p}_point_size",),
            items=([{"title": "auto" if s == 0 else f"{s} px", "value": s} for s in POINT_SIZES],),
            label="Point size",
            density="compact",
            variant="outlined",
            hide_details=True,
            style="max-width: 120px;",
            update_modelValue=(on_size, "[$event]"),
            title="Point size in pixels (auto: smaller the more points are shown)",
            raw_attrs=tid(f"{p}-point-size"),
        )
        v.VBtn(
            "PNG",
            prepend_icon="mdi-camera",
            size="x-small",
            variant="outlined",
            click=on_shot,
            title="Screenshot of the view as it is now: a PNG to download",
            raw_attrs=tid(f"{p}-screenshot"),
        )
        # a fixed slot: the link appearing must not move the buttons before it
        with html.Span(style="display: inline-block; min-width: 120px;"):
            html.A(
                "{{ " + f"{p}_shot.name" + " }}",
                v_if=f"{p}_shot",
                href=(f"{p}_shot.url",),
                download=(f"{p}_shot.name",),
                classes="text-caption",
                title="The screenshot (PNG)",
                raw_attrs=tid(f"{p}-screenshot-link"),
            )
        if labels:
            v.VBtn(
                "Clear labels",
                size="x-small",
                variant="text",
                click=on_clear,
                disabled=(f"!{p}_labels.length",),
                title="Remove every picked label from the view",
                raw_attrs=tid(f"{p}-clear-labels"),
            )
