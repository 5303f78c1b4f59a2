"""What the Photogrammetry page shows of a run: its figures, the image rows with the
plugin's counts, and the cloud (dense or sparse, in a chosen colouring) with the
registered cameras in the page's scene. The page holds one :class:`Display`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ....errors import one_line
from ....tasks import photogrammetry
from ...view import RGB, color_fields
from . import inputs


class Display:
    """The shown run (``record``) of a page with ``state`` (``pg_*``), its ``view`` (a
    :class:`.scene.PhotoScene`), the ``session`` (to load an item) and ``error`` (the page's
    one-line error)."""

    def __init__(self, state: Any, view: Any, session: Any, error: Callable[[Any], None]):
        self.state, self.view, self.session, self.error = state, view, session, error
        self.record: dict[str, Any] | None = None
        self.shown_result: Any = None  # the result whose cloud the scene shows

    def show_record(self, rec: dict[str, Any], outputs: dict[str, Any] | None = None, draw: bool = True) -> None:
        """A run's record on the page: figures, image counts and (``draw``) the cloud with
        its cameras; a restored record is drawn when the page opens."""
        s, rc = self.state, rec.get("reconstruction") or {}
        self.record = rec
        s.pg_title = f"{rec.get('name', '')} — result #{rec.get('result')} ({rec.get('plugin', '')})"
        s.pg_summary = photogrammetry.summary(rc)
        s.pg_warnings = [str(w) for w in rec.get("warnings") or rc.get("warnings") or []]
        s.pg_items_made = dict(rec.get("items") or {})
        listed = s.pg_images if len(s.pg_images or []) == len(rec.get("sources") or []) else None
        s.pg_images = inputs.with_counts(listed or inputs.rows(rec.get("sources") or []), rc.get("images"))
        if draw:
            objs = {k: (outputs or {}).get(k) for k in ("cloud", "sparse")}
            self.show_cloud(self.which(), objs)

    def clear(self) -> None:
        """Nothing of a run on the page: a new run starts from an empty result, so no figure,
        warning or cloud of the previous one is taken for the new one's (the image rows keep
        their thumbnails, without counts)."""
        s = self.state
        self.record, self.shown_result = None, None
        s.pg_title, s.pg_summary, s.pg_warnings, s.pg_items_made = "", [], [], {}
        s.pg_colours, s.pg_colour, s.pg_cameras, s.pg_note = [], None, 0, ""
        s.pg_images = [inputs.without_counts(r) for r in s.pg_images or []]
        self.view.clear()

    def which(self) -> str:
        """The cloud to show: the one shown before if this run has it, else dense, else sparse."""
        made = self.state.pg_items_made or {}
        return self.state.pg_display if self.state.pg_display in made else ("cloud" if "cloud" in made else "sparse")

    def show_cloud(self, which: str = "cloud", objs: dict[str, Any] | None = None) -> None:
        """Show the dense ("cloud") or the sparse cloud with the registered cameras."""
        s, rec = self.state, self.record or {}
        key = (rec.get("items") or {}).get(which)
        if key is None:
            return
        try:
            obj = (objs or {}).get(which) or self.session.load(key)
            rc = rec.get("reconstruction") or {}
            self.view.views, self.view.camera = list(rc.get("views") or []), rc.get("camera")
            # a photograph's cloud reads best in its measured colour (n_views, quality: "Colour by")
            self.view.show(key, obj, RGB if getattr(obj, "colors", None) is not None else None)
        except Exception as exc:
            self.error(f"the {which} cannot be shown: {one_line(exc)}")
            return
        s.pg_display = which
        s.pg_colours, s.pg_colour = color_fields(obj), self.view.field
        s.pg_cameras = self.view.cameras_drawn()
        s.pg_note = f"{self.view.note}; {s.pg_cameras} registered cameras drawn"
        self.shown_result = rec.get("result")

    def set_colour(self, name: Any) -> None:
        """Colour the shown cloud by field ``name`` (its measured colour, n_views, quality, x/y/z)."""
        if self.view.shown is None or name not in {f["value"] for f in self.state.pg_colours or []}:
            return
        self.view.set_field(str(name))
        self.state.pg_colour = self.view.field
