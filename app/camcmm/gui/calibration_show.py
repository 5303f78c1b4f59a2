"""What the Calibration page shows of a calibration, and "use this calibration".

A mix-in of :class:`calibration_page.CalibrationPage`: from the page document (the run's
outputs, the image sources, heat maps and thumbnails) it publishes the image list, the
selected image with its detected board, the per-view error chart, the numbers with
standard deviations, the projection-uncertainty heat map, for a pair the pose, the
epipolar statistics and the rectified pair, and the downloads. A measuring system of the
project refers to its calibration by the file's hash in its meta (``calibration``).
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from .. import worker
from ..errors import InputError
from . import calibration_draw as draw
from . import calibration_figures as figs
from . import calibration_inputs as inputs
from . import calibration_results as res
from .downloads import table_csv

log = logging.getLogger("camcmm.gui.calibration")


def _err(exc: BaseException) -> str:
    from .calibration_page import one_line

    return one_line(exc)


class CalibrationShow:
    # -- state ------------------------------------------------------------------------------
    def _init_results(self) -> None:
        s = self.state
        s.cal_summary = None
        s.cal_warnings = []
        s.cal_sides, s.cal_side = [], "left"
        s.cal_rows, s.cal_selected = [], None
        s.cal_overlay, s.cal_overlay_note = "", ""
        s.cal_fig_views = figs.empty("run a calibration to see each view's reprojection error")
        s.cal_numbers = []
        s.cal_fig_map = figs.empty("run a calibration to see the projection uncertainty across the image")
        s.cal_distance, s.cal_map_note = 1000.0, ""
        s.cal_stereo_rows, s.cal_pairs, s.cal_pair = [], [], None
        s.cal_rectified, s.cal_rectified_note = "", ""
        s.cal_links = []
        self.shown_side = ""

    # -- the whole calibration --------------------------------------------------------------
    def show_doc(self, doc: dict[str, Any], pics: dict[str, Any] | None = None) -> None:
        """Publish a calibration (fresh from a run, with its pictures, or read back)."""
        s = self.state
        self.doc = doc
        mode = doc["request"]["mode"]
        out = doc["outputs"]
        cur = doc.get("current") or {}
        s.cal_summary = {**res.summary(out, mode), "name": cur.get("name", ""), "result": cur.get("result"),
                         "board": doc["request"]["board"], "model": doc["request"]["model"]}
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
        s.cal_links = pics.get("links") if pics.get("links") is not None else self._links()
        self.refresh_systems()

    def pictures(self, doc: dict[str, Any], images: dict[str, list] | None = None) -> dict[str, Any]:
        """The first image with its board, the first rectified pair and the downloads
        (thread-safe: the worker draws them after a run)."""
        out: dict[str, Any] = {}
        rows = res.view_rows(res.camera_part(doc["outputs"], doc["request"]["mode"], "left"))
        first = next((r["name"] for r in rows if r["status"] == "used"), rows[0]["name"] if rows else None)
        if first is not None:
            out["overlay"] = (first, *self._overlay(doc, "left", first, images))
        if doc["request"]["mode"] == "stereo":
            out["rectified"] = self._rectified(doc, 0, images)
        out["links"] = self._links(doc)
        return out

    # -- one camera -------------------------------------------------------------------------
    def show_side(self, side: str, overlay: tuple[str, str, str] | None = None) -> None:
        """The image list, chart, numbers and heat map of one camera (left/right of a pair)."""
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
        title = f"Reprojection error per view, {res.side_title(mode, side)}"
        s.cal_fig_views = figs.views_figure(rows, cam.get("rms"), title)
        s.cal_numbers = res.number_rows(cam)
        self._show_map(side)
        if overlay is None and rows:
            first = next((r["name"] for r in rows if r["status"] == "used"), rows[0]["name"])
            overlay = (first, *self._overlay(doc, side, first))
        if overlay is not None:
            s.cal_selected, s.cal_overlay, s.cal_overlay_note = overlay
        else:
            s.cal_selected, s.cal_overlay, s.cal_overlay_note = None, "", ""

    def _show_map(self, side: str) -> None:
        s, doc = self.state, self.doc
        mode = doc["request"]["mode"]
        pu = (doc.get("maps") or {}).get(side)
        cam = res.camera_part(doc["outputs"], mode, side)
        size = cam.get("image_size") or [0, 0]
        if not pu:
            s.cal_fig_map = figs.empty("no projection-uncertainty map for this calibration")
            s.cal_map_note = ""
            return
        s.cal_distance = pu["distance"]
        title = (f"Projection uncertainty (1σ, worst direction) at z = {pu['distance']:g} mm, "
                 f"{res.side_title(mode, side)}")
        s.cal_fig_map = figs.heatmap_figure(pu, res.used_corners(cam), size, title)
        s.cal_map_note = (f"σ {res.fmt(pu['min'], 2)} … {res.fmt(pu['max'], 3)} px, centre {res.fmt(pu['centre'], 2)} px"
                          + ("; from the camera's own calibration" if mode == "stereo" else ""))

    def set_distance(self, distance: Any) -> None:
        """The heat map of the shown camera at another working distance (mm)."""
        if self.doc is None:
            return
        try:
            d = float(distance)
            if not d > 0:
                raise ValueError
        except (TypeError, ValueError):
            self._error(f"working distance {distance!r}: give a positive number of mm")
            return
        side, mode = self.state.cal_side, self.doc["request"]["mode"]
        try:
            pu = self.projection_map(res.camera_part(self.doc["outputs"], mode, side), d)
        except Exception as exc:
            self._error(f"projection uncertainty: {_err(exc)}")
            return
        self.doc.setdefault("maps", {})[side] = pu
        self._show_map(side)
        self._offer_heatmap(self.doc, side)

    # -- pictures ---------------------------------------------------------------------------
    def _image(self, doc: dict[str, Any], side: str, name: str, images: dict[str, list] | None) -> Any:
        for img in (images or {}).get(side) or []:
            if img.name == name:
                return img
        src = next((x for x in doc["sources"].get(side) or [] if x["name"] == name), None)
        if src is None:
            raise InputError(f"{name}: not among the calibration's images")
        return inputs.read_source(src, self.project)

    def _overlay(self, doc: dict[str, Any], side: str, name: str, images: dict[str, list] | None = None) -> tuple[str, str]:
        """(data URL, note) of image ``name`` with its detected board drawn."""
        mode = doc["request"]["mode"]
        cam = res.camera_part(doc["outputs"], mode, side)
        det = next((d for d in cam["detections"] if d["image"] == name), None)
        row = next((r for r in res.view_rows(cam) if r["name"] == name), None)
        if det is None or row is None:
            return "", f"{name}: not among the calibration's images"
        if row["status"] == "used":
            note = f"{name}: {row['n']} points, view RMS {res.fmt(row['rms'], 3)} px"
        else:
            note = f"{name}: {row['status']}: {row['reason']}"
        try:
            img = self._image(doc, side, name, images)
        except Exception as exc:
            return "", f"{note} (image not shown: {_err(exc)})"
        _, layout = inputs.board_layout(doc["request"]["board"])
        text = "" if row["status"] == "used" else f"{row['status']}: {row['reason']}"
        return draw.data_url(draw.draw_detection(img.data, det.get("corners"), layout, row["status"], text)), note

    def select_image(self, name: str) -> None:
        if self.doc is None or not name:
            return
        url, note = self._overlay(self.doc, self.state.cal_side, name)
        self.state.cal_selected, self.state.cal_overlay, self.state.cal_overlay_note = name, url, note

    async def select_image_async(self, name: str) -> None:
        """As :meth:`select_image`, reading and drawing in the worker."""
        if self.doc is None or not name:
            return
        doc, side = self.doc, self.state.cal_side
        self.state.cal_selected = name
        url, note = await asyncio.get_running_loop().run_in_executor(self._executor, self._overlay, doc, side, name)
        if self.doc is doc and self.state.cal_selected == name:
            self.state.cal_overlay, self.state.cal_overlay_note = url, note
        self.flush()

    def _rectified(self, doc: dict[str, Any], index: int, images: dict[str, list] | None = None) -> tuple[str, str]:
        """(data URL, note) of used pair ``index`` rectified, with horizontal lines."""
        pairs = doc["outputs"].get("pairs") or []
        if not 0 <= int(index) < len(pairs):
            return "", "no pair to show"
        ln, rn = pairs[int(index)]
        try:
            left, right = self._image(doc, "left", ln, images), self._image(doc, "right", rn, images)
            out = worker.run(self.host, "calibration.rectify", {"calibration": doc["outputs"]["calibration"],
                                                              "left": left, "right": right}).outputs
            pic = draw.rectified_pair(out["left"].data, out["right"].data)
        except Exception as exc:
            return "", f"{ln} / {rn}: the rectified pair cannot be shown: {_err(exc)}"
        dy = doc["outputs"].get("rectified_dy") or {}
        return draw.data_url(pic), (f"{ln} / {rn} rectified: a board corner lies on the same row in both images "
                                    f"(row difference over all pairs: RMS {res.fmt(dy.get('rms'), 2)} px, "
                                    f"max {res.fmt(dy.get('max'), 2)} px)")

    def show_pair(self, index: Any) -> None:
        if self.doc is None or index is None:
            return
        self.state.cal_pair = int(index)
        self.state.cal_rectified, self.state.cal_rectified_note = self._rectified(self.doc, int(index))

    async def show_pair_async(self, index: Any) -> None:
        if self.doc is None or index is None:
            return
        doc = self.doc
        self.state.cal_pair = int(index)
        pic = await asyncio.get_running_loop().run_in_executor(self._executor, self._rectified, doc, int(index))
        if self.doc is doc and self.state.cal_pair == int(index):
            self.state.cal_rectified, self.state.cal_rectified_note = pic
        self.flush()

    # -- downloads --------------------------------------------------------------------------
    def _base(self, doc: dict[str, Any]) -> str:
        return f"calibration-{(doc.get('current') or {}).get('result', 'unsaved')}"

    def _offer_heatmap(self, doc: dict[str, Any], side: str) -> dict[str, str] | None:
        mode = doc["request"]["mode"]
        pu = (doc.get("maps") or {}).get(side)
        if not pu:
            return None
        cam = res.camera_part(doc["outputs"], mode, side)
        suffix = f"-{side}" if mode == "stereo" else ""
        title = f"Projection uncertainty at z = {pu['distance']:g} mm, {res.side_title(mode, side)}"
        return self.offered.offer(f"{self._base(doc)}-heatmap{suffix}.png", replace=True, data=figs.heatmap_png(
            pu, res.used_corners(cam), cam.get("image_size") or [0, 0], title))

    def _links(self, doc: dict[str, Any] | None = None) -> list[dict[str, str]]:
        """OpenCV YAML, JSON, the per-view CSV and the charts as PNG."""
        doc = doc if doc is not None else self.doc
        if doc is None:
            return []
        base, cur, mode = self._base(doc), doc.get("current") or {}, doc["request"]["mode"]
        links = []
        for key, ext in (("yaml", "yaml"), ("calibration", "json")):
            try:
                links.append(self.offered.offer(f"{base}.{ext}", src=self.project.file_path(cur[key]), replace=True))
            except Exception as exc:
                log.warning("cannot offer the calibration %s: %s", ext, exc)
        links.append(self.offered.offer(f"{base}-views.csv", replace=True, data=table_csv(
            ["camera", "image", "status", "rms_px", "points", "reason"], res.views_csv_rows(doc["outputs"], mode))))
        for side in res.sides(mode):
            cam = res.camera_part(doc["outputs"], mode, side)
            suffix = f"-{side}" if mode == "stereo" else ""
            links.append(self.offered.offer(f"{base}-errors{suffix}.png", replace=True, data=figs.views_png(
                res.view_rows(cam), cam.get("rms"), f"Reprojection error per view, {res.side_title(mode, side)}")))
            links.append(self._offer_heatmap(doc, side))
        return [x for x in links if x]

    # -- measuring systems ------------------------------------------------------------------
    def refresh_systems(self) -> None:
        """The project's measuring systems and the calibration each refers to."""
        s = self.state
        try:
            systems = self.project.systems()
        except Exception as exc:
            s.cal_systems, s.cal_system_options = [], [{"title": "a new measuring system", "value": "new"}]
            self._error(f"measuring systems: {_err(exc)}")
            return
        cur = (self.doc or {}).get("current") or {}
        rows = []
        for sy in systems:
            c = (sy.get("meta") or {}).get("calibration") or {}
            rows.append({"id": sy["id"], "name": sy["name"], "calibration": c.get("name", "") if c else "",
                         "file": str(c.get("file", ""))[:12], "current": bool(c) and c.get("file") == cur.get("calibration")})
        s.cal_systems = rows
        s.cal_system_options = [{"title": f"#{r['id']} {r['name']}", "value": r["id"]} for r in rows] + \
            [{"title": "a new measuring system", "value": "new"}]
        if s.cal_system_target not in [o["value"] for o in s.cal_system_options]:
            s.cal_system_target = "new"

    def use_calibration(self, target: Any = "new", name: str = "") -> int | None:
        """Let measuring system ``target`` (an id, or "new" with ``name``) refer to the
        shown calibration: its meta gets ``calibration`` {file, yaml, name, result, kind,
        board, rms}; the rest of its meta is kept. Returns the system's id."""
        cur = (self.doc or {}).get("current")
        if not cur:
            self._error("no calibration to use yet: run one first")
            return None
        ref = {k: cur.get(k) for k in ("name", "result", "kind", "board", "rms", "yaml")}
        ref["file"] = cur["calibration"]
        try:
            if target in (None, "", "new"):
                label = str(name or "").strip() or f"{'stereo system' if cur['kind'] == 'stereo' else 'camera'} " \
                                                     f"({cur['name']})"
                sid = self.project.add_system(label, {"calibration": ref})
            else:
                sid = int(target)
                meta = dict(self.project.system(sid).get("meta") or {})
                meta["calibration"] = ref
                self.project.update_system(sid, meta=meta)
        except Exception as exc:
            self._error(f"measuring system: {_err(exc)}")
            return None
        self.state.cal_system_target = sid
        self.refresh_systems()
        self.state.cal_system_target = sid
        self.session.info(f"measuring system #{sid} uses calibration {cur['name']!r}")
        return sid
