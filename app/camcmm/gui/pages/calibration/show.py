"""What the Calibration page shows of one calibration, published through the trame
state (``cal_*`` keys).

From the page document (the run's outputs, the image sources, heat maps and
thumbnails; see :mod:`.run`) :class:`Results` publishes the summary, the image list,
the selected image with its detected board, the per-view error chart, the numbers with
standard deviations, the projection-uncertainty heat map, for a pair the pose, the
epipolar statistics and the rectified pair, and the downloads. Pictures and maps made
on demand (another image, another pair, another working distance) go to the page's
pictures :class:`~camcmm.gui.jobs.Job`, so the page stays live.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .... import numbers
from ....errors import one_line
from ....tasks.calibration import projection_map
from . import figures as figs
from . import links, pictures
from . import results as res
from .board import describe

EMPTY_VIEWS = "run a calibration to see each view's reprojection error"
EMPTY_MAP = "run a calibration to see the projection uncertainty across the image"


class Results:
    """The shown calibration (``doc``) and the state it is published to.

    Parameters
    ----------
    session
        The GUI session (its ``state``, ``project``, ``host`` and ``flush``).
    offered
        The page's :class:`~camcmm.gui.downloads.Downloads`.
    job
        The job that makes pictures and maps on demand.
    error
        ``error(line)``: shows a one-line reason on the page.
    """

    def __init__(self, session: Any, offered: Any, job: Any, error: Callable[[str], None]):
        self.session, self.state, self.project, self.host = session, session.state, session.project, session.host
        self.offered, self.job, self.error = offered, job, error
        self.doc: dict[str, Any] | None = None
        self.shown_side = ""
        self.reset()

    def reset(self) -> None:
        s = self.state
        s.cal_summary = None
        s.cal_warnings = []
        s.cal_sides, s.cal_side = [], "left"
        s.cal_rows, s.cal_selected = [], None
        s.cal_overlay, s.cal_overlay_note = "", ""
        s.cal_fig_views = figs.empty(EMPTY_VIEWS)
        s.cal_numbers = []
        s.cal_fig_map = figs.empty(EMPTY_MAP)
        s.cal_distance, s.cal_map_note = 1000.0, ""
        s.cal_stereo_rows, s.cal_pairs, s.cal_pair = [], [], None
        s.cal_rectified, s.cal_rectified_note = "", ""
        s.cal_links = []
        self.shown_side = ""

    # -- the whole calibration --------------------------------------------------------------
    def show_doc(self, doc: dict[str, Any], pics: dict[str, Any] | None = None) -> None:
        """Publish a calibration (fresh from a run, with its :meth:`pictures`, or read back)."""
        s = self.state
        self.doc = doc
        mode = doc["request"]["mode"]
        out = doc["outputs"]
        cur = doc.get("current") or {}
        s.cal_summary = {
            **res.summary(out, mode),
            "name": cur.get("name", ""),
            "result": cur.get("result"),
            "board": describe(doc["request"]["board"]),
            "model": doc["request"]["model"],
        }
        s.cal_warnings = list(doc.get("warnings") or [])  # the plugin warns on RMS, poses, parameters
        s.cal_sides = [{"title": res.side_title(mode, k), "value": k} for k in res.sides(mode)]
        s.cal_stereo_rows = res.stereo_rows(out) if mode == "stereo" else []
        s.cal_pairs = res.used_pairs(out) if mode == "stereo" else []
        pics = pics if pics is not None else self.pictures(doc)
        self.show_side("left", pics.get("overlay"))
        if mode == "stereo":
            s.cal_pair = 0 if s.cal_pairs else None
            s.cal_rectified, s.cal_rectified_note = pics.get("rectified") or ("", "")
        else:
            s.cal_pair, s.cal_rectified, s.cal_rectified_note = None, "", ""
        s.cal_links = pics["links"]

    def pictures(self, doc: dict[str, Any], images: dict[str, list] | None = None) -> dict[str, Any]:
        """The first image with its board, the first rectified pair and the downloads
        (any thread: the run's worker makes them right after calibrating)."""
        out: dict[str, Any] = {}
        first = pictures.first_used(doc, "left")
        if first is not None:
            out["overlay"] = (first, *pictures.overlay(self.project, doc, "left", first, images))
        if doc["request"]["mode"] == "stereo":
            out["rectified"] = pictures.rectified(self.host, self.project, doc, 0, images)
        out["links"] = links.offer_all(self.offered, self.project, doc)
        return out

    # -- one camera -------------------------------------------------------------------------
    def show_side(self, side: str, overlay: tuple[str, str, str] | None = None) -> None:
        """The image list, chart, numbers and heat map of one camera (left/right of a
        pair); ``overlay`` (name, data URL, note) is the image shown, else its first."""
        s, doc = self.state, self.doc
        if doc is None:
            return
        mode = doc["request"]["mode"]
        side = side if side in res.sides(mode) else "left"
        self.shown_side = side
        s.cal_side = side
        cam = res.camera_part(doc["outputs"], mode, side)
        rows = res.view_rows(cam)
        thumbs = (doc.get("thumbs") or {}).get(side) or {}
        s.cal_rows = [{**r, "rms_text": res.fmt(r["rms"], 3), "thumb": thumbs.get(r["name"], "")} for r in rows]
        s.cal_fig_views = figs.views_figure(
            rows, cam.get("rms"), f"Reprojection error per view, {res.side_title(mode, side)}"
        )
        s.cal_numbers = res.number_rows(cam)
        self._show_map(side)
        if overlay is None and rows:
            first = pictures.first_used(doc, side)
            if first is not None:
                overlay = (first, *pictures.overlay(self.project, doc, side, first))
        if overlay is not None:
            s.cal_selected, s.cal_overlay, s.cal_overlay_note = overlay
        else:
            s.cal_selected, s.cal_overlay, s.cal_overlay_note = None, "", ""

    def _show_map(self, side: str) -> None:
        s, doc = self.state, self.doc
        if doc is None:
            return
        mode = doc["request"]["mode"]
        pu = (doc.get("maps") or {}).get(side)
        cam = res.camera_part(doc["outputs"], mode, side)
        if not pu:
            s.cal_fig_map = figs.empty("no projection-uncertainty map for this calibration")
            s.cal_map_note = ""
            return
        s.cal_distance = pu["distance"]
        z = numbers.significant(pu["distance"], 6)
        title = f"Projection uncertainty (1σ, worst direction) at z = {z} mm, {res.side_title(mode, side)}"
        s.cal_fig_map = figs.heatmap_figure(pu, res.used_corners(cam), cam.get("image_size") or [0, 0], title)
        own = "; from the camera's own calibration" if mode == "stereo" else ""
        s.cal_map_note = (
            f"σ {res.fmt(pu['min'], 2)} … {res.fmt(pu['max'], 3)} px, centre {res.fmt(pu['centre'], 2)} px{own}"
        )

    async def set_distance_async(self, distance: Any) -> None:
        """The heat map of the shown camera at another working distance (mm)."""
        doc = self.doc
        if doc is None:
            return
        try:
            d = float(distance)
            if not d > 0:
                raise ValueError
        except (TypeError, ValueError):
            self.error(f"working distance {distance!r}: give a positive number of mm")
            return
        side, mode = self.shown_side or "left", doc["request"]["mode"]
        try:
            pu = await self.job.call(projection_map, self.host, res.camera_part(doc["outputs"], mode, side), d)
        except Exception as exc:
            self.error(f"projection uncertainty: {one_line(exc)}")
            return
        doc.setdefault("maps", {})[side] = pu
        if self.doc is doc and self.shown_side == side:
            self._show_map(side)
        self.session.flush()
        try:
            await self.job.call(links.offer_heatmap, self.offered, doc, side)
        except Exception as exc:
            self.error(f"heat map download: {one_line(exc)}")

    # -- pictures ---------------------------------------------------------------------------
    async def select_image_async(self, name: str) -> None:
        """Show image ``name`` of the shown camera with its detected board."""
        doc = self.doc
        if doc is None or not name:
            return
        side = self.state.cal_side
        self.state.cal_selected = name
        url, note = await self.job.call(pictures.overlay, self.project, doc, side, name)
        if self.doc is doc and self.state.cal_selected == name:
            self.state.cal_overlay, self.state.cal_overlay_note = url, note
        self.session.flush()

    async def show_pair_async(self, index: Any) -> None:
        """Show used pair ``index`` rectified."""
        doc = self.doc
        if doc is None or index is None:
            return
        self.state.cal_pair = int(index)
        pic = await self.job.call(pictures.rectified, self.host, self.project, doc, int(index))
        if self.doc is doc and self.state.cal_pair == int(index):
            self.state.cal_rectified, self.state.cal_rectified_note = pic
        self.session.flush()
