"""What the shared 3-D view shows: the current page's scene, never another page's.

The session's one :class:`~camcmm.gui.view.SceneView` sits beside every page that does not
fill the main area (Inspect, Acceptance). Each such page declares itself with a hint
(:meth:`SharedView.share`) and says what it shows (:meth:`SharedView.show_item` for a
project item, :meth:`SharedView.show_object` for geometry of its own such as an acceptance
position's deviations, :meth:`SharedView.clear` for nothing). The view draws the scene of
the page shown; entering another page that shares it (:meth:`SharedView.enter`, called on
every change of the state ``page``) draws that page's scene, or an empty view with the
page's one-line hint (state ``view_hint``) when it has none yet. A page that fills the area
hides the view and changes nothing in it.

Issue 30: the Acceptance page showed the Inspect page's SPH101 deviations, later a CSI
map; Inspect then showed the acceptance deviations under the name of its own item.

State keys: ``view_owner`` (the page whose scene is drawn), ``view_hint``, and the view's
``color_fields``, ``color_field``, ``legend_title``, ``display_note`` of that scene.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import one_line
from ..tasks.items import describe, kind_of
from .view import color_fields

#: The page whose scene is the project's selected item (state ``selected_item``).
ITEM_PAGE = "inspect"


def _in_display_units(obj: Any, units: Any) -> Any:
    """A copy of cloud ``obj`` whose fields named in ``units`` ({field: "µm"}) are
    scaled from mm for the view (a fit's residuals read in µm); ``obj`` itself when
    there is nothing to convert. The data, and every computation, stay in mm."""
    if not isinstance(units, dict) or not hasattr(obj, "fields") or not hasattr(obj, "points"):
        return obj
    factors = {"µm": 1e3, "mm": 1.0}
    fields, field_units = dict(obj.fields), dict(obj.field_units)
    changed = False
    for name, unit in units.items():
        if name in fields and field_units.get(name) == "mm" and unit in factors and unit != "mm":
            fields[name] = np.asarray(fields[name], dtype=float) * factors[unit]
            field_units[name] = unit
            changed = True
    if not changed:
        return obj
    return type(obj)(obj.points, obj.colors, obj.normals, fields, field_units, obj.name, obj.source_unit)


@dataclass
class Scene:
    """What one page shows: project item ``key`` (``item``) or its own ``obj``, coloured by
    ``field``, seen from ``look`` = (direction object -> camera, view-up) when given;
    ``label`` names it in the view's note."""

    key: str
    obj: Any = None
    field: str | None = None
    look: tuple[Any, Any] | None = None
    label: str = ""
    item: bool = True


class SharedView:
    """The pages' scenes and which one the view draws (held by the session)."""

    def __init__(self, session: Any):
        self.session = session
        self.state = session.state
        self.view = session.view
        self.scenes: dict[str, Scene] = {}
        self.hints: dict[str, str] = {}
        self._once: dict[str, str] = {}  # a page's hint for its next empty view only (why it emptied)
        self.owner = ITEM_PAGE  # the first page shown is Inspect's (the toolbar's first)
        self.state.update({"view_owner": self.owner, "view_hint": ""})

    # -- what the pages declare ------------------------------------------------------------
    def share(self, page: str, hint: str) -> None:
        """Page ``page`` shows the shared view; ``hint``: the line its empty view shows."""
        self.hints[page] = str(hint)
        if page == self.owner and page not in self.scenes:
            self.state.view_hint = self.hints[page]

    def scene(self, page: str) -> Scene | None:
        return self.scenes.get(page)

    def show_item(self, page: str, key: str, field: str | None = None) -> None:
        """``page`` shows project item ``key`` (drawn now when ``page`` is the one shown)."""
        self.scenes[page] = Scene(str(key), field=field)
        if page == self.owner:
            self.draw()

    def show_object(
        self, page: str, key: str, obj: Any, field: str | None = None, look: Any = None, label: str = ""
    ) -> None:
        """``page`` shows its own geometry ``obj`` (cached in the view under ``key``)."""
        self.scenes[page] = Scene(str(key), obj, field, look, label, item=False)
        if page == self.owner:
            self.draw()

    def clear(self, page: str, hint: str | None = None) -> None:
        """``page`` shows nothing; its empty view says ``hint`` (default: the one it declared)."""
        self.scenes.pop(page, None)
        if hint is not None:
            self._once[page] = str(hint)
        if page == self.owner:
            self.draw()

    def colour(self, field: str | None) -> None:
        """The shown scene is now coloured by ``field``: a return to its page keeps it."""
        scene = self.scenes.get(self.owner)
        if scene is not None:
            scene.field = field

    # -- which page is shown -----------------------------------------------------------------
    def enter(self, page: Any) -> bool:
        """Page ``page`` is shown: a page sharing the view gets its own scene drawn. True
        when the view changed hands."""
        page = str(page or "")
        if page not in self.hints or page == self.owner:
            return False
        self.owner = page
        self.state.view_owner = page
        self.draw()
        return True

    def draw(self) -> None:
        """Draw the owner's scene, or the empty view with its hint."""
        scene = self.scenes.get(self.owner)
        if scene is None:
            self._empty(self._once.pop(self.owner, "") or self.hints.get(self.owner, ""))
        elif scene.item:
            self._draw_item(scene)
        else:
            self._draw_object(scene)

    def _empty(self, hint: str) -> None:
        self.view.clear()
        self.state.update(
            {"color_fields": [], "color_field": None, "legend_title": "", "display_note": "", "view_hint": hint}
        )

    def _draw_object(self, scene: Scene) -> None:
        """A page's own geometry, coloured by its field, seen as it asks."""
        try:
            self.view.show(scene.key, scene.obj, scene.field)
            if scene.look is not None:
                self.view.look(*scene.look)
        except Exception as exc:
            self._failed(f"cannot show {scene.label or scene.key}: {one_line(exc)}")
            return
        self._published(scene.obj, f"{scene.label}: {self.view.note}" if scene.label else self.view.note)

    def _draw_item(self, scene: Scene) -> None:
        """A project item; one the view cannot draw (an image) says so in the note.
        Fields the item's ``meta["display_units"]`` names are shown in that unit."""
        session, key = self.session, scene.key
        try:
            obj = session.load(key)
        except Exception as exc:
            self._failed(one_line(exc, str((session.measurement(key) or {}).get("name", key))))
            return
        k = kind_of(obj)
        if k == "cad":  # a STEP/IGES nominal is shown by its tessellation (camcmm.cad)
            obj, k = obj.mesh, "mesh"
        if k not in ("pointcloud", "mesh", "heightmap"):
            self._empty("")
            self.state.display_note = f"{describe(obj)} (not shown in the 3D view)"
            return
        meta = (session.measurement(key) or {}).get("meta") or {}
        obj = _in_display_units(obj, meta.get("display_units") if isinstance(meta, dict) else None)
        fields = {f["value"] for f in color_fields(obj)}
        try:
            self.view.show(key, obj, scene.field if scene.field in fields else None)
        except Exception as exc:
            self._failed(one_line(exc, getattr(obj, "name", key)))
            return
        scene.field = self.view.field
        self._published(obj, self.view.note)

    def _published(self, obj: Any, note: str) -> None:
        self.state.update(
            {
                "color_fields": color_fields(obj),
                "color_field": self.view.field,
                "legend_title": self.view.scalar_bar_title,
                "display_note": note,
                "view_hint": "",
            }
        )

    def _failed(self, line: str) -> None:
        """A scene that cannot be drawn: the page's message, and an empty view (never the
        previous page's scene left in its place)."""
        self._empty("")
        self.session.error(line, page=self.owner)
