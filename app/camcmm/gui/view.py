"""The 3D scene: one off-screen pyvista plotter rendered server-side.

Clouds larger than ``display_limit`` points are shown as a fixed random subset (the
full data stay in the model for every computation); the scene says so in
:attr:`SceneView.note`. The colour legend is a scalar bar titled ``"name in words [unit]"`` with round ticks
(:mod:`camcmm.gui.legendbar`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import numbers
from ..tasks.items import fmt_count
from . import legendbar, setup_offscreen

DISPLAY_LIMIT = 500_000

#: Pseudo-fields offered for every cloud and mesh besides its own scalar fields.
SOLID = "solid colour"
RGB = "RGB (measured colour)"
COORDS = {"x": 0, "y": 1, "z": 2}

# Names that usually hold signed deviations: shown with a diverging map centred on 0.
_SIGNED = ("deviation", "residual", "distance", "error", "diff")


def color_fields(obj: Any) -> list[dict[str, str]]:
    """The colourings offered for a cloud or mesh: its scalar fields, x/y/z, RGB, solid.

    Each entry is ``{"value": name, "title": "name [unit]", "unit": unit}``.
    """
    out: list[dict[str, str]] = []
    units = getattr(obj, "field_units", {}) or {}
    for name, values in (getattr(obj, "fields", {}) or {}).items():
        if np.asarray(values).ndim == 1:
            unit = units.get(name, "")
            # titled as its legend will be ("radial deviation [µm]" for a deviation in mm)
            v = np.asarray(values, dtype=float)
            ok = v[np.isfinite(v)]
            lo, hi = (float(ok.min()), float(ok.max())) if ok.size else (0.0, 0.0)
            out.append({"value": name, "title": legendbar.legend(name, unit, lo, hi).title, "unit": unit})
    for name in COORDS:
        out.append({"value": name, "title": legend_title(name, "mm"), "unit": "mm"})
    if getattr(obj, "colors", None) is not None:
        out.append({"value": RGB, "title": RGB, "unit": ""})
    out.append({"value": SOLID, "title": SOLID, "unit": ""})
    return out


def default_field(obj: Any) -> str:
    """The first own scalar field, else measured colour, else z."""
    fields = [f for f in (getattr(obj, "fields", {}) or {}) if np.asarray(obj.fields[f]).ndim == 1]
    if fields:
        return fields[0]
    if getattr(obj, "colors", None) is not None:
        return RGB
    return "z"


def _font_file() -> str | None:
    """A TrueType font with real square brackets and µ (VTK's built-in "arial" draws
    "[" like "(" , which would misprint "deviation [mm]")."""
    import os

    candidates = ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"]
    try:
        import matplotlib

        candidates.append(os.path.join(matplotlib.get_data_path(), "fonts", "ttf", "DejaVuSans.ttf"))
    except Exception:
        pass
    return next((c for c in candidates if os.path.isfile(c)), None)


def _use_font(*props: Any) -> None:
    path = _font_file()
    for tp in props:
        if tp is None:
            continue
        if path:
            tp.SetFontFamily(4)  # VTK_FONT_FILE
            tp.SetFontFile(path)
        else:
            tp.SetFontFamilyAsString("Times")


def legend_title(name: str, unit: str) -> str:
    """``"radial deviation [mm]"``: the field in words (:func:`camcmm.numbers.title`)."""
    return numbers.title(name, unit)


def display_index(n: int, limit: int, seed: int = 0) -> np.ndarray | None:
    """Sorted indices of a reproducible random subset of ``limit`` of ``n`` points, or
    None when all ``n`` are shown."""
    if n <= limit:
        return None
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(n, size=limit, replace=False))


def field_ranges(obj: Any) -> dict[str, tuple[float, float]]:
    """(lo, hi) of the finite values of each scalar field and of x, y, z of a cloud."""
    out: dict[str, tuple[float, float]] = {}
    columns = {name: np.asarray(v) for name, v in (getattr(obj, "fields", {}) or {}).items()}
    P = np.asarray(obj.points)
    columns.update({name: P[:, axis] for name, axis in COORDS.items()})
    for name, v in columns.items():
        if v.ndim == 1 and v.size and np.issubdtype(v.dtype, np.number):
            lo, hi = np.nanmin(v), np.nanmax(v)  # NaN only when no value is finite
            if np.isfinite(lo) and np.isfinite(hi):
                out[name] = (float(lo), float(hi))
    return out


@dataclass
class Shown:
    """What the view shows for one item."""

    key: str
    poly: Any  # pyvista.PolyData of the displayed (possibly decimated) geometry
    kind: str  # "pointcloud" | "mesh" | "heightmap"
    n_total: int
    n_shown: int
    units: dict[str, str] = field(default_factory=dict)
    #: (lo, hi) of each field over the whole cloud when a subset is shown: the colour map's
    #: limits, so that every subset (the random one, a level of detail) is coloured alike
    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)


class SceneView:
    """Owns the plotter. All methods must be called from one thread (the server loop)."""

    def __init__(self, display_limit: int = DISPLAY_LIMIT, window_size: tuple[int, int] = (900, 650)):
        setup_offscreen()
        import pyvista as pv

        self.display_limit = int(display_limit)
        self.plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        self.plotter.set_background("#f4f5f7", top="#ffffff")
        self.plotter.show_axes()
        # Parts are seen from the theme's iso direction, as trame-pyvista's widget used to
        # set it: VTK's own default camera looks straight down -z, a flat top view.
        r = self.plotter.renderer
        r.camera_position = r.get_default_cam_pos()
        r.ResetCamera()
        self.shown: Shown | None = None
        self.source: Any = None  # the object shown, whole
        self.field: str = SOLID
        self.actor = None
        self.scalar_bar_title: str = ""
        self.legend: legendbar.Legend | None = None  # what the scalar bar says (a pick reads values by it)
        self.note: str = ""
        self._cache: dict[str, Shown] = {}
        self.point_size: int | None = None  # None: automatic (viewtools.ViewTools sets it)
        self.on_update = None  # callable(reset_camera: bool) set by the app

    # -- geometry --------------------------------------------------------------------
    def _prepare(self, key: str, obj: Any) -> Shown:
        if key in self._cache:
            return self._cache[key]
        units = dict(getattr(obj, "field_units", {}) or {})
        if hasattr(obj, "faces"):  # TriangleMesh: shown whole (remote rendering copes)
            poly = obj.to_pyvista()
            shown = Shown(key, poly, "mesh", obj.n_vertices, obj.n_vertices, units)
        elif hasattr(obj, "heights"):  # HeightMap: a surface coloured by z = height, invalid cells left out
            ny, nx = obj.shape
            s = max(1, int(np.ceil(np.sqrt(nx * ny / self.display_limit))))  # every s-th row and column
            sub = obj
            if s > 1:
                sub = type(obj)(obj.heights[::s, ::s], obj.dx * s, obj.dy * s, origin=obj.origin, name=obj.name)
            poly = sub.to_pyvista()
            shown = Shown(key, poly, "heightmap", obj.n_valid, sub.n_valid, units)
        elif hasattr(obj, "points"):
            n = obj.n_points
            idx = display_index(n, self.display_limit)
            sub = obj if idx is None else obj.subset(idx)
            poly = sub.to_pyvista()
            shown = Shown(key, poly, "pointcloud", n, sub.n_points, units, {} if idx is None else field_ranges(obj))
        else:
            raise TypeError(f"cannot show a {type(obj).__name__} in the 3D view")
        pts = np.asarray(poly.points)
        for name, axis in COORDS.items():
            if name not in poly.point_data:
                poly.point_data[name] = pts[:, axis] if len(pts) else np.zeros(0)
        self._cache[key] = shown
        return shown

    def forget(self, key: str) -> None:
        self._cache.pop(key, None)

    def show(self, key: str, obj: Any, field_name: str | None = None) -> None:
        """Show ``obj`` (replacing what was shown) coloured by ``field_name``."""
        shown = self._prepare(key, obj)
        self.shown = shown
        self.source = obj  # the whole object (a level of detail of a big cloud reads it)
        self.field = field_name or default_field(obj)
        if shown.n_shown < shown.n_total:
            how = "every few rows and columns" if shown.kind == "heightmap" else "random subset"
            self.note = (
                f"showing {fmt_count(shown.n_shown)} of {fmt_count(shown.n_total)} points "
                f"({how} for display; computations use all points)"
            )
        else:
            what = "vertices" if shown.kind == "mesh" else "valid points" if shown.kind == "heightmap" else "points"
            self.note = f"showing all {fmt_count(shown.n_total)} {what}"
        self._draw()
        self.plotter.reset_camera()
        self._changed(reset_camera=True)

    def set_field(self, field_name: str) -> None:
        self.field = field_name
        if self.shown is not None:
            self._draw()
            self._changed(reset_camera=False)

    def clear(self) -> None:
        self.plotter.clear_actors()
        self._remove_bars()
        self.shown, self.actor, self.scalar_bar_title, self.note = None, None, "", ""
        self.legend = None
        self._changed(reset_camera=False)

    # -- drawing ---------------------------------------------------------------------
    def _remove_bars(self) -> None:
        for title in list(self.plotter.scalar_bars.keys()):
            self.plotter.remove_scalar_bar(title)

    def _draw(self) -> None:
        shown = self.shown
        assert shown is not None
        self.plotter.clear_actors()
        self._remove_bars()
        poly = shown.poly
        style: dict[str, Any] = {}
        if shown.kind == "pointcloud":
            style = {
                "style": "points",
                "point_size": self.point_size or self.auto_point_size(),
                "render_points_as_spheres": False,
            }
        else:
            style = {"smooth_shading": True, "show_edges": False}
        name = self.field
        self.scalar_bar_title, self.legend = "", None
        if name == RGB and "RGB" in poly.point_data:
            self.actor = self.plotter.add_mesh(poly, scalars="RGB", rgb=True, reset_camera=False, **style)
        elif name in poly.point_data and name not in (SOLID, RGB):
            values = np.asarray(poly.point_data[name], dtype=float)
            unit = "mm" if name in COORDS else shown.units.get(name, "")
            finite = values[np.isfinite(values)]
            lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
            lo, hi = shown.ranges.get(name, (lo, hi))
            cmap = "viridis"
            if any(s in name.lower() for s in _SIGNED) and lo < 0 < hi:
                m = max(-lo, hi)
                lo, hi, cmap = -m, m, "coolwarm"
            if hi <= lo:
                hi = lo + 1.0
            # title in words, round ticks, µm for deviations, swatches for a few categories (H3, issue 30)
            legend_spec = legendbar.legend(name, unit, lo, hi, finite)
            self.scalar_bar_title, self.legend = legend_spec.title, legend_spec
            self.actor = self.plotter.add_mesh(
                poly,
                scalars=name,
                cmap=cmap,
                clim=[lo, hi],
                reset_camera=False,
                nan_color="#888888",
                scalar_bar_args={
                    "title": self.scalar_bar_title,
                    "color": "black",
                    "vertical": True,
                    "position_x": 0.80,
                    "position_y": 0.12,
                    "height": 0.75,
                    "width": 0.08,
                    "fmt": "%.4g",
                    "title_font_size": 16,
                    "label_font_size": 13,
                },
                **style,
            )
            bars = self.plotter.scalar_bars
            if self.scalar_bar_title in bars:
                bar = bars[self.scalar_bar_title]
                _use_font(bar.GetTitleTextProperty(), bar.GetLabelTextProperty(), bar.GetAnnotationTextProperty())
                legendbar.dress(bar, legend_spec)
        else:
            self.field = SOLID
            self.actor = self.plotter.add_mesh(poly, color="#3b6ea5", reset_camera=False, **style)

    def value_text(self, value: Any) -> str:
        """A value of the colouring field as the legend writes it: ``"deviation = +12.3 µm"``."""
        if self.legend is None:
            return f"{numbers.words(self.field)} = {numbers.plain(value, 6)}"
        return legendbar.value_text(self.legend, value)

    def auto_point_size(self) -> int:
        return 3 if self.shown is not None and self.shown.n_shown > 100_000 else 5

    def point_actors(self) -> list[Any]:
        """The actors drawn as points (for the point size of the view's tools)."""
        return (
            [self.actor]
            if self.actor is not None and self.shown is not None and self.shown.kind == "pointcloud"
            else []
        )

    def look(self, direction: Any, up: Any) -> None:
        """Look at what is shown from ``direction`` (object to camera) with ``up`` up,
        framing it (e.g. a deviation map from the side its standard suggests)."""
        self.plotter.view_vector(list(direction), viewup=list(up))
        self.plotter.reset_camera()
        self._changed(reset_camera=True)

    def _changed(self, reset_camera: bool) -> None:
        if self.on_update is not None:
            self.on_update(reset_camera)

    def screenshot(self, path: str | None = None) -> np.ndarray:
        """Render now; return the image (H, W, 3) and save it when ``path`` is given."""
        return self.plotter.screenshot(path, return_img=True)
