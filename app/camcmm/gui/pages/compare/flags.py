"""Flag labels of geometric characteristics in the "Compare with CAD" view, as ZEISS
INSPECT draws them: one flag per characteristic at its anchor (the decisive point the
plugin names), its name, value and verdict on a box in the verdict's colour, the
decisive points marked in that colour, over the cloud in the plan's coordinates (points
of a feature darker than the rest) and the nominal.

:func:`flag_texts` (pure) words the flags; :func:`show_flags` draws them in a
:class:`~.scene.CompareView` (loop thread only: VTK is not thread-safe).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ....tasks.gdt import VERDICT_COLOURS, char_title, verdict_of
from .scene import NOMINAL_COLOUR

FEATURE_COLOUR = "#546e7a"  # points that belong to a feature
OTHER_COLOUR = "#cfd8dc"  # points of no feature


def flag_texts(characteristics: list[dict[str, Any]], labels: list[dict[str, Any]], fmt: Any) -> list[dict[str, Any]]:
    """One flag per label the plugin gave: ``{"id", "anchor" [x, y, z], "decisive" (n, 3),
    "verdict", "colour", "text"}``; the text is the characteristic's id and type as a
    person reads them, then its value (``fmt(row)["value"]``) and verdict. A label
    without an anchor is left out (nothing to point at)."""
    by_id = {str(c.get("id")): c for c in characteristics}
    out = []
    for lab in labels:
        anchor = lab.get("anchor")
        if anchor is None or len(anchor) != 3 or not np.all(np.isfinite(np.asarray(anchor, dtype=float))):
            continue
        cid = str(lab.get("id"))
        c = by_id.get(cid, {})
        verdict = str(lab.get("verdict") or verdict_of(c))
        if verdict not in VERDICT_COLOURS:
            verdict = verdict_of(c)
        value = fmt(c)["value"] if c else "—"
        title = char_title(c.get("type")) if c else ""
        out.append(
            {
                "id": cid,
                "anchor": [float(x) for x in anchor],
                "decisive": np.asarray(lab.get("decisive") or [], dtype=float).reshape(-1, 3),
                "verdict": verdict,
                "colour": VERDICT_COLOURS[verdict],
                "text": f"{cid} · {title}\n{value} · {verdict}",
            }
        )
    return out


#: display pixels between the part and the column of flags, and between two flags' baselines
FLAG_GAP, FLAG_STEP = 40, 44


def flag_positions(anchors_xy: Any, column_x: float, top: float) -> np.ndarray:
    """Where the flags go, as ZEISS INSPECT sets them out: in one column at display x
    ``column_x`` (beside the part), each as high as its anchor where it can be, pushed
    down so that no two are closer than ``FLAG_STEP`` pixels and none above ``top``.
    ``anchors_xy`` (n, 2) display pixels of the anchors (y up); returns the (n, 2)
    display positions of the flags' lower left corners."""
    A = np.asarray(anchors_xy, dtype=float).reshape(-1, 2)
    y = np.empty(len(A))
    last = float(top) + FLAG_STEP
    for i in np.argsort(-A[:, 1], kind="stable"):  # from the highest anchor down
        y[i] = min(A[i, 1], last - FLAG_STEP)
        last = y[i]
    return np.column_stack([np.full(len(A), float(column_x)), y])


def _text_width(text: str) -> float:
    """About how wide (display pixels) a flag's text is at 14 px: 7 px a character."""
    return 7.0 * max(len(t) for t in text.split("\n")) + 8.0


def _flag(view: Any, flag: dict[str, Any], at: Any) -> tuple[Any, Any]:
    """A flag: its text on a box in the verdict's colour at display position ``at``
    (fixed on screen, a column right of the part) and a leader line from the box's left
    side to the anchor, which follows the part when the view turns."""
    from vtkmodules.vtkRenderingAnnotation import vtkLeaderActor2D
    from vtkmodules.vtkRenderingCore import vtkTextActor

    from ...view import _use_font

    rgb = [int(flag["colour"][k : k + 2], 16) / 255.0 for k in (1, 3, 5)]
    text = vtkTextActor()
    text.SetInput(flag["text"])
    text.SetDisplayPosition(int(at[0]), int(at[1]))
    tp = text.GetTextProperty()
    _use_font(tp)
    tp.SetFontSize(14)
    tp.SetColor(1.0, 1.0, 1.0)
    tp.SetBackgroundColor(*rgb)
    tp.SetBackgroundOpacity(0.92)
    tp.SetFrame(True)
    tp.SetFrameColor(*rgb)
    tp.SetJustificationToLeft()
    tp.SetVerticalJustificationToBottom()
    leader = vtkLeaderActor2D()
    leader.GetPositionCoordinate().SetCoordinateSystemToWorld()
    leader.GetPositionCoordinate().SetValue(*flag["anchor"])
    leader.GetPosition2Coordinate().SetCoordinateSystemToDisplay()
    leader.GetPosition2Coordinate().SetValue(float(at[0]), float(at[1]) + 8.0)
    leader.SetArrowPlacementToPoint1()
    leader.SetArrowStyleToFilled()
    leader.SetArrowLength(0.012)
    leader.SetArrowWidth(0.006)
    leader.GetProperty().SetColor(*rgb)
    leader.GetProperty().SetLineWidth(2)
    view.plotter.add_actor(leader, reset_camera=False, pickable=False)
    view.plotter.add_actor(text, reset_camera=False, pickable=False)
    return text, leader


def _make_room(view: Any, part_x: np.ndarray, width: float) -> None:
    """Zoom out (only as far as needed) and pan so that the part leaves ``width`` pixels
    free on the right of the view: the flags' column (the camera moves, not the part)."""
    import math

    W, H = view.plotter.window_size
    span = float(np.ptp(part_x))
    cam = view.plotter.camera
    if span > 0 and span + width > W - 24:  # 12 px free on either side
        f = max((W - 24 - width) / span, 0.3)
        cam.zoom(f)
        centre = 0.5 * W
        part_x = centre + (part_x - centre) * f  # about the view's centre
    shift = float(part_x.max()) + width - W  # pixels the part must move left
    if shift <= 0:
        return
    pos, focal = np.asarray(cam.position, dtype=float), np.asarray(cam.focal_point, dtype=float)
    d = focal - pos
    dist = float(np.linalg.norm(d))
    if cam.parallel_projection:
        per_px = 2.0 * float(cam.parallel_scale) / H
    else:
        per_px = 2.0 * dist * math.tan(math.radians(float(cam.view_angle)) / 2.0) / H
    right = np.cross(d / dist, np.asarray(cam.up, dtype=float))
    n = float(np.linalg.norm(right))
    if n == 0:
        return
    move = right / n * shift * per_px  # the camera right: the part left on screen
    cam.position = (pos + move).tolist()
    cam.focal_point = (focal + move).tolist()


def _place(view: Any, flags: list[dict[str, Any]], shown: Any, arrange: bool) -> np.ndarray:
    """The flags' display positions: a column right of the part on screen (``shown``:
    points of the part, mm). With ``arrange`` (a fresh camera) the view is first zoomed
    out and panned so that the column has room beside the part."""
    from .picking import world_to_display

    W, H = view.plotter.window_size
    width = max(_text_width(f["text"]) for f in flags) + FLAG_GAP + 8.0
    P = np.asarray(shown, dtype=float).reshape(-1, 3)
    part, _, ok = world_to_display(view.renderer, P)
    if arrange and ok.any():
        _make_room(view, part[ok][:, 0], width)
        part, _, ok = world_to_display(view.renderer, P)
    xy, _, _ = world_to_display(view.renderer, np.asarray([f["anchor"] for f in flags], dtype=float))
    hi = float(part[ok][:, 0].max()) if ok.any() else float(xy[:, 0].max())
    return flag_positions(xy, min(hi + FLAG_GAP, W - width + FLAG_GAP), H - 40)


def show_flags(view: Any, aligned: Any, nominal: Any, flags: list[dict[str, Any]], reset_camera: bool = True) -> None:
    """The evaluation in ``view`` (a CompareView): the cloud in plan coordinates
    (``aligned``, field ``feature``: its feature's index, −1 none; None: no cloud), the
    nominal faint, and the flags. The view's scene becomes ``"gdt"``."""
    import pyvista as pv

    view._clear()
    view.scene = "gdt"
    if nominal is not None:
        view._add_nominal(getattr(nominal, "mesh", nominal), opacity=0.35)
    note = "characteristics: the cloud in the plan's coordinates"
    if aligned is not None and int(getattr(aligned, "n_points", 0) or 0) > 0:
        from .scene import prepare_cloud

        prep = prepare_cloud(aligned.points, None, view.display_limit)
        feature = np.asarray((aligned.fields or {}).get("feature", np.full(aligned.n_points, -1)), dtype=float)
        feature = feature if prep.idx is None else feature[prep.idx]
        member = feature >= 0
        style = view._point_style(prep.n_shown)
        for key, mask, colour in (("cloud", member, FEATURE_COLOUR), ("measured", ~member, OTHER_COLOUR)):
            if mask.any():
                view._actors[key] = view.plotter.add_mesh(
                    pv.PolyData(np.ascontiguousarray(prep.points[mask])), color=colour, reset_camera=False, **style
                )
        note = f"{note}: {int(member.sum())} of {prep.n_shown} points shown belong to a feature"
    if reset_camera:  # the flags are set out for the camera that shows the part
        view._frame()
    shown = [np.asarray([f["anchor"] for f in flags], dtype=float).reshape(-1, 3)]
    if aligned is not None and int(getattr(aligned, "n_points", 0) or 0) > 0:
        shown.append(np.asarray(aligned.points)[:: max(1, aligned.n_points // 2000)])
    mesh = getattr(nominal, "mesh", nominal)
    for attr in ("vertices", "points"):  # the part drawn is the nominal too
        if mesh is not None and hasattr(mesh, attr):
            V = np.asarray(getattr(mesh, attr), dtype=float).reshape(-1, 3)
            shown.append(V[:: max(1, len(V) // 2000)])
            break
    places = _place(view, flags, np.vstack(shown), reset_camera) if flags else np.zeros((0, 2))
    for i, f in enumerate(flags):
        if len(f["decisive"]):
            view._actors[f"flagpts{i}"] = view.plotter.add_points(
                f["decisive"], color=f["colour"], point_size=9, render_points_as_spheres=True, reset_camera=False
            )
        view._actors[f"flag{i}"], view._actors[f"flagline{i}"] = _flag(view, f, places[i])
    legend = [[v, c, "rectangle"] for v, c in VERDICT_COLOURS.items()]
    legend.append(["nominal", NOMINAL_COLOUR, "rectangle"])
    view._legend(legend, (0.2, 0.16))
    view.legend_labels = [row[0] for row in legend]
    view.note = note
    # the camera was framed (and made room for the column) above: a reset now, or one on
    # the view's next resize, would put the part back under the flags
    view._camera_fresh = False
    view._changed(False)
