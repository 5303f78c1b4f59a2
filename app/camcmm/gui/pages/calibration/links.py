"""The downloads of one calibration: OpenCV YAML, JSON, the per-view CSV, and the
per-view error chart and heat map of each camera as PNG (written by a worker thread)."""

from __future__ import annotations

import logging
from typing import Any

from .... import numbers
from ...downloads import Downloads, table_csv
from . import figures as figs
from . import results as res

log = logging.getLogger("camcmm.gui.calibration")


def base(doc: dict[str, Any]) -> str:
    """The downloads' common file name: ``calibration-<result id>``."""
    return f"calibration-{(doc.get('current') or {}).get('result', 'unsaved')}"


def offer_heatmap(offered: Downloads, doc: dict[str, Any], side: str) -> dict[str, str] | None:
    """Camera ``side``'s heat map as PNG, replacing the one offered before; None without a map."""
    mode = doc["request"]["mode"]
    pu = (doc.get("maps") or {}).get(side)
    if not pu:
        return None
    cam = res.camera_part(doc["outputs"], mode, side)
    suffix = f"-{side}" if mode == "stereo" else ""
    title = f"Projection uncertainty at z = {numbers.significant(pu['distance'], 6)} mm, {res.side_title(mode, side)}"
    return offered.offer(
        f"{base(doc)}-heatmap{suffix}.png",
        replace=True,
        data=figs.heatmap_png(pu, res.used_corners(cam), cam.get("image_size") or [0, 0], title),
    )


def offer_all(offered: Downloads, project: Any, doc: dict[str, Any]) -> list[dict[str, str]]:
    """Every download of the calibration ``doc`` ({name, url} each)."""
    name, cur, mode = base(doc), doc.get("current") or {}, doc["request"]["mode"]
    links = []
    for key, ext in (("yaml", "yaml"), ("calibration", "json")):
        try:
            links.append(offered.offer(f"{name}.{ext}", src=project.file_path(cur[key]), replace=True))
        except Exception as exc:  # the numbers stay shown without the file
            log.warning("cannot offer the calibration %s: %s", ext, exc)
    links.append(
        offered.offer(
            f"{name}-views.csv",
            replace=True,
            data=table_csv(
                ["camera", "image", "status", "rms_px", "points", "reason"], res.views_csv_rows(doc["outputs"], mode)
            ),
        )
    )
    for side in res.sides(mode):
        cam = res.camera_part(doc["outputs"], mode, side)
        suffix = f"-{side}" if mode == "stereo" else ""
        links.append(
            offered.offer(
                f"{name}-errors{suffix}.png",
                replace=True,
                data=figs.views_png(
                    res.view_rows(cam), cam.get("rms"), f"Reprojection error per view, {res.side_title(mode, side)}"
                ),
            )
        )
        links.append(offer_heatmap(offered, doc, side))
    return [x for x in links if x]
