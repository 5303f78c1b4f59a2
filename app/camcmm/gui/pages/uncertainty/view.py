"""The Uncertainty page's 3D scene: the measuring volume's grid of points with the
distortion a systematic offset causes (thesis figs. 3.5-3.8) as arrows, or each
point's standard uncertainty (per factor, from the Monte Carlo run) as colour.

One off-screen pyvista plotter rendered server-side; the page pushes one image per
scene change. Loop thread only. The magnitudes are the plugin's; only the arrows'
drawing scale (so the longest is a tenth of the volume) is chosen here.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .... import numbers as num
from ....errors import InputError
from ... import legendbar, setup_offscreen
from .figures import factor_title, shown_unit, u_text


def map_options(result: dict[str, Any] | None) -> list[dict[str, str]]:
    """What the view can show for a Monte Carlo result: ``distortion:<factor>`` for
    each volume map and ``uncertainty:<factor>`` for each per-point standard deviation."""
    if not result:
        return []
    out = []
    vm = ((result.get("studies") or {}).get("volume_maps") or {}).get("factors") or {}
    for f in vm:
        out.append({"title": f"Distortion of the volume: +1 u of {factor_title(f)}", "value": f"distortion:{f}"})
    for f in result.get("per_point") or {}:
        if f != "points":
            out.append({"title": f"Uncertainty per point: {factor_title(f)}", "value": f"uncertainty:{f}"})
    return out


def scene_arrays(result: dict[str, Any], choice: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, str]:
    """(points (P, 3) mm, magnitude (P,), vectors (P, 3) or None, what) for ``choice``,
    all as the plugin returned them.

    Distortion: the error field (centroid removed) in the result's unit and its
    lengths (``volume_maps.factors.<f>.norm``). Uncertainty: each point's length of its
    (x, y, z) standard deviations (``per_point_norm``)."""
    kind, _, factor = str(choice).partition(":")
    try:
        if kind == "distortion":
            vm = result["studies"]["volume_maps"]
            m = vm["factors"][factor]
            return (
                _points(vm["points"]),
                np.asarray(m["norm"], float).ravel(),
                _points(m["errors"]),
                f"|error| ({factor_title(factor)})",
            )
        if kind == "uncertainty":
            return (
                _points(result["per_point"]["points"]),
                np.asarray(result["per_point_norm"][factor], float).ravel(),
                None,
                f"u ({factor_title(factor)})",
            )
    except KeyError:
        # a result stored by an earlier camcmm lacks the lengths the map shows
        raise InputError(f"{choice}: this result has no such map; run the study again") from None
    raise InputError(f"unknown map {choice!r}")


def _points(a: Any) -> np.ndarray:
    return np.asarray(a, float).reshape(-1, 3)


class UncertaintyView:
    """The off-screen plotter of the measuring volume; ``on_update(reset_camera)`` tells
    the page's remote view to fetch a new image."""

    def __init__(self, window_size: tuple[int, int] = (800, 600)):
        setup_offscreen()
        import pyvista as pv

        self.plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        self.plotter.set_background("#f4f5f7", top="#ffffff")
        self.plotter.show_axes()
        self.on_update: Callable[[bool], None] | None = None
        self.shown = ""
        self.note = ""
        self.scale = 0.0

    def clear(self) -> None:
        self.plotter.clear_actors()
        for title in list(self.plotter.scalar_bars.keys()):
            self.plotter.remove_scalar_bar(title)
        self.shown, self.note, self.scale = "", "", 0.0
        if self.on_update is not None:
            self.on_update(False)

    def show(self, result: dict[str, Any], choice: str, unit: str) -> str:
        """Draw ``choice`` (see :func:`map_options`); returns a one-line note for the page."""
        import pyvista as pv

        pts, mag, vec, what = scene_arrays(result, choice)
        unit = shown_unit(unit)
        self.plotter.clear_actors()
        for title in list(self.plotter.scalar_bars.keys()):
            self.plotter.remove_scalar_bar(title)
        title = num.title(what, unit)
        cloud = pv.PolyData(pts)
        cloud[title] = mag
        bar = {
            "title": title,
            "vertical": True,
            "position_x": 0.86,
            "position_y": 0.1,
            "height": 0.8,
            "title_font_size": 12,
            "label_font_size": 11,
        }
        extent = float(np.ptp(pts, axis=0).max()) or 1.0
        if vec is not None:
            # The errors are micrometres in a volume of tens of millimetres: draw them
            # magnified so that the longest arrow is a tenth of the volume, and say so.
            longest = float(mag.max()) or 1.0
            factor = 0.1 * extent / longest
            cloud["vectors"] = vec
            glyphs = cloud.glyph(
                orient="vectors",
                scale=title,
                factor=factor,
                geom=pv.Arrow(tip_length=0.3, tip_radius=0.12, shaft_radius=0.04),
            )
            self.plotter.add_mesh(glyphs, scalars=title, cmap="viridis", scalar_bar_args=bar)
            self._dress(title, what, unit, mag)
            self.plotter.add_mesh(
                cloud, color="#444444", point_size=3, render_points_as_spheres=True, show_scalar_bar=False
            )
            self.scale = factor
            magnified = factor / {"mm": 1.0, "µm": 1e-3, "nm": 1e-6}.get(unit, 1.0)
            self.note = (
                f"arrows magnified {num.count(round(magnified))}× (longest {num.plain(longest, 3)} {unit}); "
                f"{num.count(len(pts))} grid points"
            )
        else:
            self.plotter.add_mesh(
                cloud, scalars=title, cmap="viridis", point_size=12, render_points_as_spheres=True, scalar_bar_args=bar
            )
            self._dress(title, what, unit, mag)
            self.scale = 0.0
            self.note = (
                f"{num.count(len(pts))} grid points; standard uncertainty u from {u_text(mag.min())} "
                f"to {u_text(mag.max())} {unit}"
            )
        self.shown = choice
        self.plotter.camera_position = "iso"
        self.plotter.reset_camera()
        if self.on_update is not None:
            self.on_update(True)
        return self.note

    def _dress(self, title: str, what: str, unit: str, mag: np.ndarray) -> None:
        """The scalar bar by the number rule: round ticks, a real minus (camcmm.gui.legendbar)."""
        bars = self.plotter.scalar_bars
        if title in bars and mag.size:
            legendbar.dress(bars[title], legendbar.legend(what, unit, float(np.min(mag)), float(np.max(mag))))

    def screenshot(self) -> np.ndarray:
        return self.plotter.screenshot(return_img=True)

    def close(self) -> None:
        try:
            self.plotter.close()
        except Exception:
            pass
