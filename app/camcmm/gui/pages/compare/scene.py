"""The "Compare with CAD" page's own 3D scene: one off-screen pyvista plotter, rendered
server-side, showing the inputs (for picking point pairs), the deviations on a colour
map or in tolerance bands, or where a failed alignment left the cloud.

:func:`prepare_cloud` builds what is drawn (in a worker thread); :class:`CompareView`
draws it (server loop only: VTK is not thread-safe). The main page's scene is
:class:`camcmm.gui.view.SceneView`; this one is separate so that each page keeps its
own scene and camera.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import setup_offscreen
from ...legendbar import label
from ...view import _use_font, display_index, fmt_count
from .picking import pick_point, pick_surface
from .tables import COLOURMAP, band_colours, legend_title, nice_ticks

AXES = ("x", "y", "z")
MEASURED_COLOUR = "#ef8a17"
NOMINAL_COLOUR = "#b0b7c3"


@dataclass
class Prepared:
    """What the view draws of a deviations cloud (made in a worker thread)."""

    idx: np.ndarray | None  # displayed subset of the full cloud (None: all points)
    points: np.ndarray  # displayed points (n_shown, 3), nominal coordinates
    dev: np.ndarray  # their deviations (mm)
    poly: Any  # pyvista PolyData of the displayed points
    n_total: int

    @property
    def n_shown(self) -> int:
        return len(self.points)


def prepare_cloud(points: np.ndarray, dev: np.ndarray | None, display_limit: int, seed: int = 0) -> Prepared:
    """The displayed subset (a fixed random one above ``display_limit``) as pyvista
    points. Thread-safe: builds data only, draws nothing."""
    import pyvista as pv

    P = np.asarray(points, dtype=float)
    n = len(P)
    idx = display_index(n, int(display_limit), seed)
    sub = P if idx is None else P[idx]
    d = np.zeros(len(sub)) if dev is None else (np.asarray(dev, dtype=float) if idx is None else np.asarray(dev)[idx])
    poly = pv.PolyData(np.ascontiguousarray(sub))
    return Prepared(idx, sub, d, poly, n)


class CompareView:
    """The page's own 3D scene (one off-screen pyvista plotter, rendered server-side).

    Scenes: ``inputs`` (the measured cloud and the nominal as they are, for picking
    point pairs), ``colour`` (the deviations on the diverging map), ``bands``
    (tolerance bands), ``failed`` (the cloud where the failed alignment left it, over
    the nominal, uncoloured). Loop thread only.
    """

    def __init__(self, display_limit: int, window_size: tuple[int, int] = (900, 650)):
        setup_offscreen()
        import pyvista as pv

        self.display_limit = int(display_limit)
        self.plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        self.plotter.set_background("#f4f5f7", top="#ffffff")
        self.plotter.show_axes()
        self.scene = "empty"
        self.scalar_bar_title = ""
        self.legend_labels: list[str] = []
        self.note = ""
        self.on_update: Callable[[bool], None] | None = None
        # inputs scene: "measured" (Prepared) of the cloud "measured_key", "nominal_cloud"
        # (Prepared) of a reference cloud as the nominal
        self._inputs: dict[str, Any] = {}
        self._actors: dict[str, Any] = {}
        self.dev: Prepared | None = None
        self.nominal_poly: Any = None  # pyvista mesh of the nominal mesh _nominal_src
        self._nominal_src: Any = None
        self.point_size: int | None = None  # None: automatic (the view's tools set it)
        self.labels: list[dict[str, Any]] = []  # picked labels that stay (markers)
        self.legend: dict[str, Any] | None = None  # viewtools.legend_spec of the colour map
        # Until the operator turns or zooms, a new size of the view (the browser's, on
        # mount or resize) frames the part anew: a camera reset for the wrong aspect
        # leaves it small or cut.
        self._camera_fresh = False
        rw = self.plotter.render_window
        rw.AddObserver("WindowResizeEvent", self._resized)
        iren = rw.GetInteractor()
        if iren is not None:
            for event in (
                "LeftButtonPressEvent",
                "RightButtonPressEvent",
                "MiddleButtonPressEvent",
                "MouseWheelForwardEvent",
                "MouseWheelBackwardEvent",
            ):
                iren.AddObserver(event, self._touched)

    @property
    def renderer(self) -> Any:
        return self.plotter.renderer

    # -- helpers -----------------------------------------------------------------------
    def _frame(self) -> None:
        self.plotter.camera_position = "iso"
        self.plotter.reset_camera()
        self.plotter.camera.zoom(0.85 if self.scalar_bar_title else 0.95)

    def _resized(self, *_: Any) -> None:
        if self._camera_fresh and self.scene != "empty":
            self._frame()

    def _touched(self, *_: Any) -> None:
        self._camera_fresh = False

    def _changed(self, reset_camera: bool, push: bool = True) -> None:
        if reset_camera:
            self._frame()
            self._camera_fresh = True
        if push and self.on_update is not None:
            self.on_update(reset_camera)

    def _clear(self) -> None:
        self.plotter.clear_actors()
        for title in list(self.plotter.scalar_bars.keys()):
            self.plotter.remove_scalar_bar(title)
        if self.plotter.legend is not None:
            self.plotter.remove_legend()
        self._actors = {}
        self.scalar_bar_title = ""
        self.legend_labels = []

    def _point_style(self, n: int) -> dict[str, Any]:
        """Points small enough that they hardly overlap in a view of the whole part:
        where they do, the ones standing out of the surface hide those below it and a
        dense map looks redder than it is."""
        size = self.point_size or self.auto_point_size(n)
        return {"style": "points", "point_size": size, "render_points_as_spheres": False}

    def auto_point_size(self, n: int | None = None) -> int:
        if n is None:
            prep = self.dev if self.dev is not None else self._inputs.get("measured")
            n = prep.n_shown if prep is not None else 0
        return 1 if n > 250_000 else (2 if n > 100_000 else (3 if n > 40_000 else (4 if n > 10_000 else 5)))

    def point_actors(self) -> list[Any]:
        """The actors drawn as points (clouds, not a nominal mesh nor the markers)."""
        out = [self._actors[k] for k in ("measured", "cloud") if k in self._actors]
        if "nominal" in self._actors and "nominal_cloud" in self._inputs:
            out.append(self._actors["nominal"])
        return out

    def mesh_poly(self, nominal: Any) -> Any:
        """The pyvista mesh of a nominal TriangleMesh, made once per mesh."""
        if self._nominal_src is not nominal or self.nominal_poly is None:
            self.nominal_poly = nominal.to_pyvista()
            self._nominal_src = nominal
        return self.nominal_poly

    def _add_nominal(self, nominal: Any, opacity: float = 1.0) -> None:
        import pyvista as pv

        if nominal is None:
            return
        if type(nominal).__name__ == "CadModel":  # a STEP/IGES nominal: drawn as its tessellation
            nominal = nominal.mesh
        if hasattr(nominal, "faces"):
            self._inputs.pop("nominal_cloud", None)
            poly = self.mesh_poly(nominal)
            self._actors["nominal"] = self.plotter.add_mesh(
                poly, color=NOMINAL_COLOUR, opacity=opacity, smooth_shading=False, reset_camera=False, pickable=True
            )
        else:
            prep = self._inputs.get("nominal_cloud")
            if prep is None or prep.n_total != nominal.n_points:
                prep = prepare_cloud(nominal.points, None, self.display_limit, seed=1)
                self._inputs["nominal_cloud"] = prep
            self._actors["nominal"] = self.plotter.add_mesh(
                pv.PolyData(prep.points), color="#7b8494", reset_camera=False, **self._point_style(prep.n_shown)
            )

    # -- scenes ------------------------------------------------------------------------
    def show_inputs(
        self,
        measured: Any,
        nominal: Any,
        markers: list[dict[str, Any]] | None = None,
        reset_camera: bool = True,
        push: bool = True,
    ) -> None:
        """The measured cloud (orange) and the nominal (grey) as they are."""
        self._clear()
        self.scene = "inputs"
        self._add_nominal(nominal, opacity=0.55)
        if measured is not None:
            prep = self._inputs.get("measured")
            if prep is None or self._inputs.get("measured_key") is not measured:
                prep = prepare_cloud(measured.points, None, self.display_limit)
                self._inputs["measured"] = prep
                self._inputs["measured_key"] = measured
            self._actors["measured"] = self.plotter.add_mesh(
                prep.poly, color=MEASURED_COLOUR, reset_camera=False, **self._point_style(prep.n_shown)
            )
            n = prep.n_total
            self.note = (
                f"measured: {fmt_count(prep.n_shown)} of {fmt_count(n)} points shown"
                if prep.n_shown < n
                else f"measured: {fmt_count(n)} points"
            )
        self._legend(
            [["measured", MEASURED_COLOUR, "rectangle"], ["nominal", NOMINAL_COLOUR, "rectangle"]], (0.16, 0.08)
        )
        self.legend_labels = ["measured", "nominal"]
        self.set_markers(markers or [], render=False)
        self._changed(reset_camera, push)

    def show_deviations(
        self,
        prep: Prepared,
        limit: float,
        unit: str,
        mode: str = "colour",
        bands: dict[str, Any] | None = None,
        reset_camera: bool = True,
    ) -> None:
        """The deviations: ``mode`` "colour" (diverging map on ±limit mm, legend
        "deviation [unit]") or "bands" (within ±tolerance green, above red, below blue):
        ``bands`` is ``{"codes": (n_total,) band codes of the whole cloud, "rows": the
        legend rows}``."""
        self._clear()
        self.dev = prep
        style = self._point_style(prep.n_shown)
        if mode == "bands" and bands:
            codes = np.asarray(bands["codes"])
            codes = codes if prep.idx is None else codes[prep.idx]
            self.scene = "bands"
            self._actors["cloud"] = self.plotter.add_mesh(
                prep.poly, scalars=band_colours(codes), rgb=True, reset_camera=False, **style
            )
            rows = bands["rows"]
            labels = [[r["label"], r["colour"], "rectangle"] for r in rows]
            self._legend(labels, (0.3, 0.04 * len(labels)))
            self.legend_labels = [r["label"] for r in rows]
        else:
            self.scene = "colour"
            self._colour_map(prep, limit, unit, style)
        n = prep.n_total
        self.note = (
            f"showing {fmt_count(prep.n_shown)} of {fmt_count(n)} points (random subset for display; "
            "statistics use all)"
            if prep.n_shown < n
            else f"showing all {fmt_count(n)} points"
        )
        self.set_markers(self.labels, render=False)
        self._changed(reset_camera)

    def _colour_map(self, prep: Prepared, limit: float, unit: str, style: dict[str, Any]) -> None:
        """The deviations on the diverging map: continuous over ±limit, or stepped as
        ``self.legend`` says (n bands, ticks at the band edges; out-of-tolerance colours)."""
        f = 1e3 if unit == "µm" else 1.0
        spec = self.legend or {}
        lim = float(limit) * f if limit and limit > 0 else 1.0
        clim = [c * f for c in spec["clim"]] if spec.get("edges") else [-lim, lim]
        self.scalar_bar_title = legend_title(unit)
        extra: dict[str, Any] = {}
        bar_args: dict[str, Any] = {}
        if spec.get("edges"):
            extra["n_colors"] = int(spec["n_colors"])
        if spec.get("above"):
            extra.update(above_color=spec["above"], below_color=spec["below"])
            bar_args.update(above_label="above", below_label="below")
        self._actors["cloud"] = self.plotter.add_mesh(
            prep.poly,
            scalars=(prep.dev * f),
            cmap=COLOURMAP,
            clim=clim,
            reset_camera=False,
            nan_color="#888888",
            scalar_bar_args={
                "title": self.scalar_bar_title,
                "color": "black",
                "vertical": True,
                "position_x": 0.86,
                "position_y": 0.12,
                "height": 0.75,
                "width": 0.05,
                "fmt": "%.3g",
                "n_labels": 5,
                "title_font_size": 16,
                "label_font_size": 13,
                **bar_args,
            },
            **extra,
            **style,
        )
        bars = self.plotter.scalar_bars
        if self.scalar_bar_title in bars:
            bar = bars[self.scalar_bar_title]
            from vtkmodules.vtkCommonCore import vtkDoubleArray

            _use_font(bar.GetTitleTextProperty(), bar.GetLabelTextProperty())
            ticks = vtkDoubleArray()
            for t in [round(e * f, 9) for e in spec["edges"]] if spec.get("edges") else nice_ticks(lim):
                ticks.InsertNextValue(t)
            bar.SetCustomLabels(ticks)
            bar.SetUseCustomLabels(True)
            bar.SetLabelFormat("%g")
            # the labels written by the number rule (real minus, one number of decimals)
            label(bar, [ticks.GetValue(i) for i in range(ticks.GetNumberOfTuples())])

    def show_failed(self, prep: Prepared, nominal: Any, reset_camera: bool = True) -> None:
        """Where the failed alignment left the cloud, over the nominal; no colour map."""
        self._clear()
        self.dev = prep
        self.scene = "failed"
        self._add_nominal(nominal, opacity=0.5)
        self._actors["cloud"] = self.plotter.add_mesh(
            prep.poly, color=MEASURED_COLOUR, reset_camera=False, **self._point_style(prep.n_shown)
        )
        self._legend(
            [["measured (alignment failed)", MEASURED_COLOUR, "rectangle"], ["nominal", NOMINAL_COLOUR, "rectangle"]],
            (0.3, 0.08),
        )
        self.note = "alignment failed: no deviations shown"
        self.set_markers(self.labels, render=False)
        self._changed(reset_camera)

    def clear(self) -> None:
        self._clear()
        self.scene = "empty"
        self.dev = None
        self.note = ""
        self._changed(False)

    def _legend(self, labels: list[list[str]], size: tuple[float, float]) -> None:
        """A legend box in the upper left corner (pyvista's "upper right" lets a wide box
        run out of the window), in a font with µ, ± and −."""
        lg = self.plotter.add_legend(labels, bcolor="white", size=size, loc="upper left", border=True)
        _use_font(lg.GetEntryTextProperty())

    # -- overlays ----------------------------------------------------------------------
    def set_markers(self, markers: list[dict[str, Any]], render: bool = True) -> None:
        """Labelled markers ``{"point": [x, y, z], "label": str, "colour": hex}`` (picked
        pairs, a picked point)."""
        for name in [k for k in self._actors if k.startswith("marker")]:
            self.plotter.remove_actor(self._actors.pop(name), render=False)
        if markers:
            pts = np.asarray([m["point"] for m in markers], dtype=float)
            for i, m in enumerate(markers):
                self._actors[f"marker{i}"] = self.plotter.add_points(
                    pts[i : i + 1],
                    color=m.get("colour", "#000000"),
                    point_size=16,
                    render_points_as_spheres=True,
                    reset_camera=False,
                    pickable=False,
                )
            lab = self.plotter.add_point_labels(
                pts,
                [m["label"] for m in markers],
                font_size=15,
                point_size=1,
                shape_opacity=0.8,
                always_visible=True,
                show_points=False,
                reset_camera=False,
                pickable=False,
            )
            self._actors["marker_labels"] = lab
        if render:
            self._changed(False)

    def set_labels(self, markers: list[dict[str, Any]]) -> None:
        """The picked labels that stay (drawn over a result, kept across redraws)."""
        self.labels = list(markers)
        if self.scene in ("colour", "bands", "failed"):
            self.set_markers(self.labels)

    def set_section_plane(
        self, axis: str | None, position: float = 0.0, bounds: np.ndarray | None = None, render: bool = True
    ) -> None:
        """The section plane's outline in the view (None removes it)."""
        import pyvista as pv

        old = self._actors.pop("section", None)
        if old is not None:
            self.plotter.remove_actor(old, render=False)
        if axis is not None and bounds is not None:
            ax = AXES.index(axis)
            lo, hi = np.asarray(bounds[0], float), np.asarray(bounds[1], float)
            pad = 0.06 * (hi - lo).max()
            u, v = [a for a in range(3) if a != ax]
            corners = []
            for cu, cv in (
                (lo[u] - pad, lo[v] - pad),
                (hi[u] + pad, lo[v] - pad),
                (hi[u] + pad, hi[v] + pad),
                (lo[u] - pad, hi[v] + pad),
                (lo[u] - pad, lo[v] - pad),
            ):
                p = np.zeros(3)
                p[ax], p[u], p[v] = position, cu, cv
                corners.append(p)
            self._actors["section"] = self.plotter.add_mesh(
                pv.lines_from_points(np.asarray(corners)),
                color="#37474f",
                line_width=3,
                reset_camera=False,
                pickable=False,
            )
        if render:
            self._changed(False)

    # -- picking -----------------------------------------------------------------------
    def display_xy(self, fx: float, fy: float) -> tuple[float, float]:
        """Fractions of the view (0..1 from the left, 0..1 from the top) as display
        pixels (y up) of the render window."""
        W, H = self.plotter.window_size
        return float(fx) * W, (1.0 - float(fy)) * H

    def pick_deviation(self, x: float, y: float) -> int | None:
        """The index (into the full cloud) of the deviation point drawn at (x, y)."""
        if self.dev is None:
            return None
        i = pick_point(self.renderer, self.dev.points, x, y)
        if i is None:
            return None
        return int(i if self.dev.idx is None else self.dev.idx[i])

    def pick_input(self, which: str, x: float, y: float) -> np.ndarray | None:
        """The point of the measured cloud or of the nominal under (x, y)."""
        if which == "measured":
            prep = self._inputs.get("measured")
            if prep is None:
                return None
            i = pick_point(self.renderer, prep.points, x, y)
            return None if i is None else prep.points[i].copy()
        actor = self._actors.get("nominal")
        if actor is None:
            return None
        prep = self._inputs.get("nominal_cloud")
        if prep is None:  # a mesh: the surface under the click
            return pick_surface(self.renderer, actor, x, y)
        i = pick_point(self.renderer, prep.points, x, y)
        return None if i is None else prep.points[i].copy()

    def forget_inputs(self) -> None:
        self._inputs = {}
        self.nominal_poly = self._nominal_src = None

    def screenshot(self, path: str | None = None) -> np.ndarray:
        return self.plotter.screenshot(path, return_img=True)
