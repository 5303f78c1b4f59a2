"""A page's pyvista scene as the layers the browser draws (docs: /work/notes design,
"Client view protocol"): plain data out of a VTK renderer, no trame, no files.

For every visible 3-D actor: its points (world mm), the triangles, line segments or
points it is drawn as, the colour of every vertex exactly as VTK maps it
(``vtkMapper.MapScalars``: the lookup table, its range, n colours, NaN/above/below
colours, direct RGB) or the property's colour, the point size and opacity. A points
layer is put in level-of-detail order: a fixed random permutation (seed 0), so that any
prefix is a uniform random subsample of the cloud and the browser can draw a prefix
while the view turns; :attr:`Layer.order` maps a drawn index back to the actor's point.
Scalar bars give the legend (title, range, colours, tick labels formatted as the bar
formats them), a legend box its entries, point labels and flags their texts, and the
active camera its position.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any

import numpy as np

from ..legendbar import lut_annotations

#: colour stops sampled from the legend's lookup table (lo -> hi)
LEGEND_STOPS = 32
#: seed of the level-of-detail permutation (fixed: the same cloud, the same order)
LOD_SEED = 0


@dataclass(eq=False)
class Layer:
    """One drawn thing: ``kind`` "points" | "mesh" | "lines", ``n`` vertices. Its arrays
    are made when first read (a publish whose buffers are all known reads none):
    ``positions`` (n, 3) world mm (points: in LOD order), ``colors`` (n, 3) uint8 or None
    (then ``color``), ``indices`` (T, 3) or (E, 2) uint32 for meshes and lines. ``order``
    (n,): the actor's point index of each position (None: the actor's own order)."""

    id: str
    kind: str
    n: int
    color: list[int]
    make_positions: Callable[[], np.ndarray] = field(repr=False)
    make_colors: Callable[[], np.ndarray | None] | None = field(default=None, repr=False)
    make_indices: Callable[[], np.ndarray] | None = field(default=None, repr=False)
    make_point: Callable[[int], np.ndarray] | None = field(default=None, repr=False)
    point_size: float = 2.0
    opacity: float = 1.0
    pickable: bool = True
    order: np.ndarray | None = field(default=None, repr=False)
    #: world bounds (xmin, xmax, ymin, ymax, zmin, zmax), mm
    bounds: tuple[float, ...] = ()
    #: what the arrays were made from (for the buffer memo): the points array and its
    #: modification time; the scalars array, the lookup table and the mapper's settings
    geometry_key: tuple[Any, ...] = ()
    colour_key: tuple[Any, ...] = ()

    @cached_property
    def positions(self) -> np.ndarray:
        return self.make_positions()

    @cached_property
    def colors(self) -> np.ndarray | None:
        return None if self.make_colors is None else self.make_colors()

    @cached_property
    def indices(self) -> np.ndarray | None:
        return None if self.make_indices is None else self.make_indices()

    def actor_index(self, i: int) -> int:
        """The actor's point index of drawn vertex ``i``."""
        return int(i if self.order is None else self.order[i])

    def point(self, i: int) -> np.ndarray:
        """Drawn vertex ``i`` (world mm), without making every position."""
        if self.make_point is None or "positions" in self.__dict__:
            return np.asarray(self.positions[i], dtype=float)
        return self.make_point(i)

    def release(self) -> None:
        """Forget the arrays made (the buffers hold them; a pick reads one point)."""
        for name in ("positions", "colors", "indices"):
            self.__dict__.pop(name, None)


@dataclass
class Scene:
    """Everything the browser draws besides its own camera."""

    layers: list[Layer] = field(default_factory=list)
    legend: dict[str, Any] | None = None
    entries: list[dict[str, Any]] = field(default_factory=list)
    labels: list[dict[str, Any]] = field(default_factory=list)
    camera: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------------------ helpers
@lru_cache(maxsize=4)
def lod_order(n: int, seed: int = LOD_SEED) -> np.ndarray:
    """A fixed random permutation of ``range(n)`` (int64, read-only): any prefix of
    it is a uniform random subsample."""
    order = np.random.default_rng(seed).permutation(int(n)).astype(np.int64)
    order.flags.writeable = False
    return order


def rgb255(c: Any) -> list[int]:
    """A VTK colour (3 floats 0..1) as three ints 0..255."""
    return [int(round(255 * min(max(float(v), 0.0), 1.0))) for v in list(c)[:3]]


def c_format(fmt: str, value: float) -> str:
    """``value`` as a C printf format such as VTK's ``%.4g`` formats it (Python's
    ``%`` operator takes the same conversions); ``%g`` when the format is unusable."""
    try:
        return fmt % value
    except (TypeError, ValueError):
        return f"{value:g}"


def _camera(renderer: Any) -> dict[str, Any]:
    cam = renderer.GetActiveCamera()
    return {
        "position": [float(v) for v in cam.GetPosition()],
        "focal_point": [float(v) for v in cam.GetFocalPoint()],
        "view_up": [float(v) for v in cam.GetViewUp()],
        "view_angle": float(cam.GetViewAngle()),
    }


def _props(renderer: Any) -> list[Any]:
    props = renderer.GetViewProps()
    props.InitTraversal()
    return [props.GetNextProp() for _ in range(props.GetNumberOfItems())]


def _world(actor: Any, pts: np.ndarray) -> np.ndarray:
    """``pts`` moved by the actor's matrix (position, orientation, scale, user matrix)."""
    m = actor.GetMatrix()
    M = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
    if np.allclose(M, np.eye(4)):
        return pts
    return pts @ M[:3, :3].T + M[:3, 3]


def _segments(cells: Any) -> np.ndarray:
    """Line segments (E, 2) uint32 of a vtkCellArray of polylines (each cell's
    consecutive points joined)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    conn = vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64)
    offs = vtk_to_numpy(cells.GetOffsetsArray()).astype(np.int64)
    if len(conn) < 2:
        return np.zeros((0, 2), np.uint32)
    keep = np.ones(len(conn) - 1, dtype=bool)
    ends = offs[1:-1] - 1  # the last point of every cell but the last: no segment to the next cell
    keep[ends[(ends >= 0) & (ends < len(keep))]] = False
    k = np.nonzero(keep)[0]
    return np.column_stack([conn[k], conn[k + 1]]).astype(np.uint32)


# ------------------------------------------------------------------------------ 3-D actors
def _point_scalars(mapper: Any, data: Any) -> Any:
    """The point array the mapper colours by (None: it colours by nothing, or by cells)."""
    if not mapper.GetScalarVisibility():
        return None
    mode = mapper.GetScalarMode()  # 0 default, 1 point data, 2 cell data, 3 point field data
    pd = data.GetPointData()
    if mode in (0, 1):
        return pd.GetScalars()
    if mode == 3:
        name = mapper.GetArrayName()
        return pd.GetAbstractArray(name) if name else pd.GetAbstractArray(mapper.GetArrayId())
    return None


def _mapped_colours(mapper: Any, n: int) -> np.ndarray | None:
    """(n, 3) uint8 of the colours VTK draws the input's points in, or None."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    # pyvista interpolates scalars before mapping (a texture of the table): MapScalars then
    # maps nothing; per vertex the colour is the table's colour of its value all the same
    before = mapper.GetInterpolateScalarsBeforeMapping()
    mapper.SetInterpolateScalarsBeforeMapping(False)
    try:
        rgba = mapper.MapScalars(1.0)
        a = None if rgba is None or rgba.GetNumberOfTuples() != n else vtk_to_numpy(rgba).reshape(n, -1)
        out = None if a is None else np.array(a[:, :3], dtype=np.uint8)  # a copy: the mapper owns rgba
    finally:
        mapper.SetInterpolateScalarsBeforeMapping(before)
    return out


def _colour_key(mapper: Any, scalars: Any) -> tuple[Any, ...]:
    """What the mapped colours depend on: the scalars array, the lookup table and the
    mapper's colouring settings (not the mapper's own modification time: mapping the
    colours touches it)."""
    if scalars is None:
        return ("solid",)
    lut = mapper.GetLookupTable()
    return (
        scalars.GetAddressAsString(""),
        scalars.GetMTime(),
        None if lut is None else (lut.GetAddressAsString(""), lut.GetMTime()),
        mapper.GetColorMode(),
        mapper.GetUseLookupTableScalarRange(),
        tuple(mapper.GetScalarRange()),
        mapper.GetArrayComponent(),
    )


def actor_layer(actor: Any, layer_id: str) -> Layer | None:
    """The layer of a visible 3-D actor (None when it draws nothing)."""
    import pyvista as pv
    from vtkmodules.util.numpy_support import vtk_to_numpy

    mapper = actor.GetMapper()
    if mapper is None:
        return None
    if mapper.GetInputAlgorithm() is not None:  # pyvista feeds some inputs through a pass-through algorithm
        mapper.GetInputAlgorithm().Update()
    data = mapper.GetInput()
    if data is None or data.GetNumberOfPoints() == 0:
        return None
    prop = actor.GetProperty()
    rep = int(prop.GetRepresentation())  # 0 points, 1 wireframe, 2 surface
    scalars = _point_scalars(mapper, data)
    surf = pv.wrap(data)
    keep: np.ndarray | None = None  # the surface's points in the input's numbering
    if not isinstance(surf, pv.PolyData):  # a height map's grid: its outer surface
        surf = surf.extract_surface(pass_pointid=True)
        keep = np.asarray(surf.point_data["vtkOriginalPointIds"], dtype=np.int64)
    n = int(surf.GetNumberOfPoints())
    n_polys, n_lines = surf.GetNumberOfPolys() + surf.GetNumberOfStrips(), surf.GetNumberOfLines()
    if rep == 0 or (n_polys == 0 and n_lines == 0):
        kind = "points"
        sel: np.ndarray | None = lod_order(n)
        order = sel if keep is None else keep[sel]
    else:
        sel, order = None, keep
        kind = "lines" if rep == 1 or n_polys == 0 else "mesh"

    def positions() -> np.ndarray:
        pts = _world(actor, np.asarray(surf.points, dtype=float))
        return pts if sel is None else pts[sel]

    def point(k: int) -> np.ndarray:
        j = int(k if sel is None else sel[k])
        return _world(actor, np.asarray(surf.points[j : j + 1], dtype=float))[0]

    def colours() -> np.ndarray | None:
        c = _mapped_colours(mapper, data.GetNumberOfPoints())
        if c is None:
            return None
        c = c if keep is None else c[keep]
        return c if sel is None else c[sel]

    def indices() -> np.ndarray:
        if kind == "mesh":
            tri = surf if surf.is_all_triangles else surf.triangulate()
            return np.ascontiguousarray(
                vtk_to_numpy(tri.GetPolys().GetConnectivityArray()).reshape(-1, 3), dtype=np.uint32
            )
        if n_polys:  # a surface drawn as wireframe: its edges
            return _segments(surf.extract_all_edges(use_all_points=True).GetLines())
        return _segments(surf.GetLines())

    pdata = surf.GetPoints().GetData()
    geometry = (layer_id, kind, pdata.GetAddressAsString(""), pdata.GetMTime(), data.GetMTime(), rep)
    return Layer(
        id=layer_id,
        kind=kind,
        n=n,
        color=rgb255(prop.GetColor()),
        make_positions=positions,
        make_colors=None if scalars is None else colours,
        make_indices=None if kind == "points" else indices,
        make_point=point,
        point_size=float(prop.GetPointSize()),
        opacity=float(prop.GetOpacity()),
        pickable=bool(actor.GetPickable()),
        order=order,
        bounds=tuple(float(b) for b in actor.GetBounds()),
        geometry_key=(*geometry, *_matrix_key(actor)),
        colour_key=(layer_id, kind, rep, data.GetMTime(), *_colour_key(mapper, scalars)),
    )


def _matrix_key(actor: Any) -> tuple[float, ...]:
    m = actor.GetMatrix()
    return tuple(m.GetElement(i, j) for i in range(3) for j in range(4))


# ------------------------------------------------------------------------------ 2-D actors
def bar_legend(bar: Any) -> dict[str, Any]:
    """A scalar bar as the protocol's legend: its title, the lookup table's range and
    LEGEND_STOPS colours sampled at the centres of equal steps lo -> hi (a stepped
    table's bands stay bands), the tick labels as the bar writes them (its custom
    labels, else its n labels evenly over the range) in its label format."""
    lut = bar.GetLookupTable()
    lo, hi = (float(v) for v in lut.GetRange())
    stops = []
    for k in range(LEGEND_STOPS):
        rgb = [0.0, 0.0, 0.0]
        lut.GetColor(lo + (k + 0.5) / LEGEND_STOPS * (hi - lo), rgb)
        stops.append(rgb255(rgb))
    fmt = bar.GetLabelFormat() or "%g"
    notes = lut_annotations(lut)  # the number rule's ticks (camcmm.gui.legendbar) or categories
    if notes and lut.GetIndexedLookup():
        rgba = [0.0, 0.0, 0.0, 0.0]
        swatches = []
        for i, (_value, text) in enumerate(notes):
            lut.GetIndexedColor(i, rgba)
            swatches.append({"text": text, "color": rgb255(rgba)})
        return {"title": str(bar.GetTitle() or ""), "categories": swatches}
    if notes:
        values, texts = [v for v, _ in notes], [t for _, t in notes]
    elif bar.GetUseCustomLabels() and bar.GetCustomLabels() is not None:
        arr = bar.GetCustomLabels()
        values = [float(arr.GetValue(i)) for i in range(arr.GetNumberOfTuples())]
    else:
        n = int(bar.GetNumberOfLabels())
        values = [lo] if n == 1 else [lo + i * (hi - lo) / (n - 1) for i in range(n)] if n > 1 else []
    if not notes:
        texts = [c_format(fmt, v) for v in values]
    legend: dict[str, Any] = {
        "title": str(bar.GetTitle() or ""),
        "lo": lo,
        "hi": hi,
        "colors": stops,
        "labels": [{"value": v, "text": t} for v, t in zip(values, texts) if lo - 1e-12 <= v <= hi + 1e-12],
    }
    for side in ("Above", "Below"):  # the out-of-range colours the table draws, where it does
        if hasattr(lut, f"GetUse{side}RangeColor") and getattr(lut, f"GetUse{side}RangeColor")():
            legend[side.lower()] = rgb255(getattr(lut, f"Get{side}RangeColor")())
    return legend


def legend_entries(box: Any) -> list[dict[str, Any]]:
    """A legend box's rows: their text and colour."""
    out = []
    for i in range(box.GetNumberOfEntries()):
        text = box.GetEntryString(i)
        if text:
            out.append({"text": str(text), "color": rgb255(box.GetEntryColor(i))})
    return out


def point_labels(actor: Any) -> list[dict[str, Any]]:
    """The labels of a pyvista ``add_point_labels`` actor: world position and text."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    mapper = actor.GetMapper()
    if mapper is None or not mapper.IsA("vtkLabelPlacementMapper"):
        return []
    hier = mapper.GetInputAlgorithm()
    if hier is None or not hier.IsA("vtkPointSetToLabelHierarchy"):
        return []
    src = hier.GetInputAlgorithm()
    data = src.GetInputDataObject(0, 0) if src.IsA("vtkSelectVisiblePoints") else hier.GetInputDataObject(0, 0)
    if data is None or data.GetPoints() is None:
        return []
    names = data.GetPointData().GetAbstractArray(hier.GetLabelArrayName() or "labels")
    pts = vtk_to_numpy(data.GetPoints().GetData()).reshape(-1, 3)
    tp = hier.GetTextProperty()
    colour = rgb255(tp.GetColor()) if tp is not None else [0, 0, 0]
    out = []
    for i in range(len(pts)):
        text = "" if names is None or i >= names.GetNumberOfValues() else str(names.GetValue(i))
        out.append({"pos": [float(v) for v in pts[i]], "text": text, "color": colour})
    return out


def flag_labels(props: list[Any]) -> list[dict[str, Any]]:
    """Flags drawn as a text box on a leader line (the Compare page's characteristics):
    the text at the leader's world anchor (each vtkTextActor follows its leader)."""
    out = []
    leaders = [p for p in props if p.IsA("vtkLeaderActor2D") and p.GetVisibility()]
    texts = [p for p in props if p.IsA("vtkTextActor") and p.GetVisibility()]
    for leader, text in zip(leaders, texts, strict=False):
        coord = leader.GetPositionCoordinate()
        if coord.GetCoordinateSystemAsString() != "World":
            continue
        out.append(
            {
                "pos": [float(v) for v in coord.GetValue()],
                "text": str(text.GetInput() or ""),
                "color": rgb255(text.GetTextProperty().GetBackgroundColor()),
            }
        )
    return out


# ------------------------------------------------------------------------------ the scene
def export_scene(renderer: Any, names: dict[int, str] | None = None) -> Scene:
    """The scene of ``renderer`` (visible props only). ``names``: layer id by
    ``id(actor)`` (the page's own names, e.g. "cloud", "nominal"); other actors are
    named ``a<k>`` in drawing order."""
    names = names or {}
    scene = Scene(camera=_camera(renderer))
    props = _props(renderer)
    used: set[str] = set()
    for k, p in enumerate(props):
        if not p.GetVisibility():
            continue
        if p.IsA("vtkActor") and not p.IsA("vtkFollower"):
            lid = names.get(id(p)) or f"a{k}"
            while lid in used:
                lid += "'"
            layer = actor_layer(p, lid)
            if layer is not None:
                used.add(lid)
                scene.layers.append(layer)
        elif p.IsA("vtkScalarBarActor"):
            if scene.legend is None and not scene.entries:
                legend = bar_legend(p)
                if "categories" in legend:  # a categorical field: labelled swatches, no ramp
                    scene.entries.extend(legend["categories"])
                else:
                    scene.legend = legend
        elif p.IsA("vtkLegendBoxActor"):
            scene.entries.extend(legend_entries(p))
        elif p.IsA("vtkActor2D"):
            scene.labels.extend(point_labels(p))
    scene.labels.extend(flag_labels(props))
    return scene


def finite_camera(cam: Any) -> dict[str, Any] | None:
    """A camera dict from the browser, checked: position, focal_point, view_up three
    finite numbers each, the position off the focal point, the up not along the view,
    view_angle in (0, 180) degrees (30 when absent). None when any of it is wrong."""
    if not isinstance(cam, dict):
        return None
    out: dict[str, Any] = {}
    for key in ("position", "focal_point", "view_up"):
        v = finite_vector(cam.get(key), 3)
        if v is None:
            return None
        out[key] = v
    angle = cam.get("view_angle", 30.0)
    if not isinstance(angle, (int, float)) or isinstance(angle, bool) or not (0.0 < float(angle) < 180.0):
        return None
    out["view_angle"] = float(angle)
    d = np.subtract(out["focal_point"], out["position"])
    nd, nu = float(np.linalg.norm(d)), float(np.linalg.norm(out["view_up"]))
    if nd <= 0 or nu <= 0 or float(np.linalg.norm(np.cross(d / nd, np.asarray(out["view_up"]) / nu))) < 1e-6:
        return None
    return out


def finite_vector(v: Any, n: int) -> list[float] | None:
    """``v`` as ``n`` finite floats (a list or tuple of real numbers), else None."""
    if not isinstance(v, (list, tuple)) or len(v) != n:
        return None
    out = []
    for x in v:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(float(x)):
            return None
        out.append(float(x))
    return out
