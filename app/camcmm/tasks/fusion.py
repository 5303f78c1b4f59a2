"""The CSI fusion task (thesis ch. 6.1): a coloured photogrammetry cloud and CSI height
maps in, the fused cloud and the difference analysis out — headless, as the Fuse page and
the tests run it.

- :class:`FusionRequest` names the inputs (project item ids) and the fused item's name;
- :func:`inputs_of` checks and loads them (one-line :class:`InputError` naming the item);
- :func:`run` runs the plugin found by :data:`TASK` through :func:`camcmm.worker.run`
  (``progress(fraction, message)``, ``cancel``: a :class:`threading.Event`) and holds its
  outputs to :data:`CONTRACT`;
- :func:`store` puts the run into the project: the fused cloud as a file and an item made
  by the plugin, the result row (``RunResult.to_json()``: the numbers, not the figures'
  arrays) naming the input items, and the page's record under :data:`CURRENT_KEY`;
- :func:`stored` / :func:`restore` give the last run back as the project keeps it;
- :func:`numbers` writes one map's figures as rows (lengths in mm written in µm);
- :func:`load_sample` puts the sample pair (the provider of :data:`SAMPLE_TASK`: the
  synthetic coin, which fuses at the default parameters) into the project as two items.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .. import numbers as num
from .. import worker
from ..contracts import Need, OutputContract, check_outputs, register
from ..errors import InputError
from ..jsonable import to_jsonable
from .items import checked, stored_record

TASK = "csi-fusion"
SAMPLE_TASK = "csi-fusion-sample"
CURRENT_KEY = "fuse.current"
CLOUD_KIND = "pointcloud"
MAP_KIND = "heightmap"

#: what the Fuse page, its figures and its numbers read of the provider's outputs
CONTRACT = register(
    OutputContract(
        TASK,
        needs=(
            Need("fused", "pointcloud", why="the fused cloud stored as an item and shown"),
            Need("result", "json", why="the numbers stored in the result row"),
            Need("result.maps", "list", optional=True, why="each map's numbers and the map chooser"),
            Need("result.photogrammetry_scale", "dict", optional=True, why="the scale row"),
            Need("result.n_points_fused", "int", optional=True, why="the fused points row"),
            Need("result.warnings", "list", optional=True, why="the page's warnings"),
            Need("views", "json", optional=True, why="the figures: images, matches, difference, Abbott curve"),
        ),
    )
)


@dataclass
class FusionRequest:
    """The inputs of a fusion: ``cloud`` and ``maps`` are project item ids (text), ``name``
    the fused item's name ("" = made up from the inputs)."""

    cloud: str | None = None
    maps: list[str] = field(default_factory=list)
    name: str = ""

    @classmethod
    def of(cls, raw: dict[str, Any] | FusionRequest | None) -> FusionRequest:
        """A request from the page's or the project's dict (missing keys: empty)."""
        if isinstance(raw, FusionRequest):
            return raw
        raw = dict(raw or {})
        cloud = raw.get("cloud")
        return cls(
            None if cloud in (None, "") else str(cloud),
            [str(m) for m in raw.get("maps") or []],
            str(raw.get("name") or ""),
        )

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass
class FusionInputs:
    """A checked request's objects: the cloud, the height maps, and the items' ``{id, name, kind}``."""

    cloud: Any
    maps: list[Any]
    used: list[dict[str, str]]


def inputs_of(items: Any, req: FusionRequest | dict[str, Any]) -> FusionInputs:
    """The cloud and height maps of ``req`` loaded from ``items`` (a GUI session or a
    :class:`~camcmm.tasks.items.ProjectItems`). InputError naming the item for a missing or
    wrong one."""
    req = FusionRequest.of(req)
    cloud_id = str(req.cloud or "").strip()
    map_ids = [m for m in req.maps if m.strip()]
    if not cloud_id:
        raise InputError("no photogrammetry cloud chosen: pick a coloured point-cloud item")
    if not map_ids:
        raise InputError("no height map chosen: pick one or more CSI height-map items (import .dat/.opd/.plu/.x3p)")
    if len(set(map_ids)) != len(map_ids):
        raise InputError("a height map is chosen twice")
    used = [checked(items, cloud_id, CLOUD_KIND)] + [checked(items, m, MAP_KIND) for m in map_ids]
    # without colour the plugin matches shaded heights
    return FusionInputs(items.load(cloud_id), [items.load(m) for m in map_ids], used)


def run(
    host: Any,
    inputs: FusionInputs,
    params: dict[str, Any] | None = None,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Any:
    """The provider's :class:`~camcmm.host.RunResult` (in a worker process when the host
    allows); ``cancel`` set stops it with :class:`~camcmm.host.Cancelled`."""
    spec = host.provider(TASK)
    ins = {"cloud": inputs.cloud, "csi": list(inputs.maps)}
    result = worker.run(host, spec.id, ins, params, progress=progress, cancel=cancel)
    check_outputs(TASK, spec.id, result.outputs)
    return result


def store(
    project: Any, items: Any, result: Any, req: FusionRequest | dict[str, Any], inputs: FusionInputs
) -> dict[str, Any]:
    """The run into ``project`` (``items``: where the fused item is added, the session or
    :class:`ProjectItems`); returns the page's record, also kept as :data:`CURRENT_KEY`.
    InputError when the run made no fused cloud (nothing is stored then)."""
    req = FusionRequest.of(req)
    used = inputs.used
    out = result.outputs
    fused = out.get("fused")
    if not getattr(fused, "n_points", 0):
        raise InputError("the fusion returned no fused cloud: nothing was stored")
    summary = to_jsonable(out.get("result") or {})
    views = out.get("views") or {}
    views = to_jsonable(views.get("maps") if isinstance(views, dict) else views) or []
    stamp = time.strftime("%Y-%m-%d %H:%M")
    maps = [u["name"] for u in used[1:]]
    base = req.name.strip() or f"fused {used[0]['name']} + {len(maps)} CSI ({stamp})"
    h = project.add_object(fused, base)
    # the row keeps the numbers; the geometry is the file, the figures' arrays the page's record
    row = dataclasses.replace(result, outputs={"result": summary, "fused": fused}).to_json()
    rid = project.add_result(
        row, measurement_ids=[int(u["id"]) for u in used if str(u["id"]).isdigit()], files={"fused": h},
        label=f"fusion: {base}",
    )  # fmt: skip
    plugin = f"{result.plugin_id} {result.plugin_version}"
    item = str(items.add_measurement(base, h, fused, source=f"{plugin} (result #{rid})"))
    rec = {
        "result": rid,
        "items": {"fused": item},
        "name": base,
        "request": {"cloud": used[0]["id"], "maps": [u["id"] for u in used[1:]], "name": req.name},
        "inputs": used,
        "summary": summary,
        "views": views,
        "warnings": [str(w) for w in result.warnings],
        "plugin": plugin,
    }
    project.set_state(CURRENT_KEY, rec)
    return rec


def load_sample(host: Any, project: Any, items: Any) -> FusionRequest:
    """The sample pair as two items of ``project`` (added through ``items``, the session or
    :class:`ProjectItems`, made by the sample's plugin), or the ones a former load made (same
    names and kinds, made by it); returns the request that fuses them."""
    spec = host.provider(SAMPLE_TASK)
    made_by = f"{spec.id} {spec.version}"
    out = None
    ids: dict[str, str] = {}
    for key, kind in (("cloud", CLOUD_KIND), ("csi", MAP_KIND)):
        old = _made_item(project, kind, made_by)
        if old is not None:
            ids[key] = old
            continue
        if out is None:
            out = host.run(spec.id, {}, {}).outputs
        obj = out[key]
        h = project.add_object(obj, obj.name)
        ids[key] = str(items.add_measurement(obj.name, h, obj, source=made_by))
    return FusionRequest(ids["cloud"], [ids["csi"]], "")


def _made_item(project: Any, kind: str, made_by: str) -> str | None:
    """The id of an item of ``kind`` made by ``made_by`` (a former sample load), or None."""
    for m in project.measurements():
        meta = m.get("meta") if isinstance(m.get("meta"), dict) else {}
        if m.get("kind") == kind and meta.get("made_by") == made_by:
            return str(m["id"])
    return None


def stored(project: Any) -> dict[str, Any] | None:
    """The record of the last run, as the project keeps it (None: none yet, or unreadable)."""
    return stored_record(project, CURRENT_KEY)


def restore(project: Any) -> tuple[FusionRequest, dict[str, Any]] | None:
    """The last run's request and record (None: none stored)."""
    rec = stored(project)
    return None if rec is None else (FusionRequest.of(rec.get("request")), rec)


def _given(write: Callable[..., str], x: Any, *args: Any, **kw: Any) -> str:
    """``write(x, ...)`` by the number rule (:mod:`camcmm.numbers`), "—" for a value the
    result does not have."""
    return "—" if x is None else write(x, *args, **kw)


def numbers(summary: dict[str, Any], k: int) -> list[dict[str, str]]:
    """Map ``k``'s figures and the run's (scale, fused points) as rows ``{name, label, value}``,
    written by the number rule: differences and roughness in µm, angles in ° (µrad below
    0.01 rad), the scale to 10⁻⁶ (the similarity's own resolution), no exponents."""
    maps = summary.get("maps") or []
    m = maps[k] if 0 <= k < len(maps) else {}
    t, icp = m.get("transform2d") or {}, m.get("icp") or {}
    d, mr = m.get("difference") or {}, m.get("material_ratio") or {}
    sc = summary.get("photogrammetry_scale") or {}
    dev, px = num.deviation, num.plain

    def pct(x: Any) -> str:
        return _given(lambda v: num.percent(float(v) / 100.0), x)  # Smr1/Smr2 are in %

    spread = "" if sc.get("std") is None else f" ± {_given(px, sc.get('std'), 2)}"
    rows = [
        ("file", "Height map", str(m.get("file") or "—")),
        (
            "matches",
            "Matches / inliers",
            f"{_given(num.count, m.get('n_matches'))} / {_given(num.count, m.get('n_inliers'))}",
        ),
        (
            "inliers_models",
            "Inliers: similarity / fundamental",
            f"{_given(num.count, m.get('n_inliers_similarity'))} / {_given(num.count, m.get('n_inliers_fundamental'))}",
        ),
        (
            "transform2d",
            "2-D similarity (eq. 6.1)",
            f"{_given(num.angle, t.get('angle_deg'), 'deg')}, t = ({_given(px, t.get('tx'), 4)}, "
            f"{_given(px, t.get('ty'), 4)}) px, × {_given(px, t.get('scale'), 7)}",
        ),
        (
            "icp",
            "ICP (tz, rx, ry)",
            f"tz {_given(num.length, icp.get('tz'), signed=True)}, rx {_given(num.angle, icp.get('rx_deg'), 'deg')}, "
            f"ry {_given(num.angle, icp.get('ry_deg'), 'deg')}; rms {_given(dev, icp.get('rms'), signed=False)}"
            + ("" if icp.get("converged", True) else " (not converged)"),
        ),
        (
            "difference",
            "CSI − photogrammetry",
            f"mean {_given(dev, d.get('mean'))}, std {_given(dev, d.get('std'), signed=False)}",
        ),
        ("band", "95 % band", f"{_given(dev, d.get('p2_5'))} … {_given(dev, d.get('p97_5'))}"),
        (
            "material_ratio",
            "Sk / Spk / Svk",
            f"{_given(dev, mr.get('Sk'), signed=False)} / {_given(dev, mr.get('Spk'), signed=False)} / "
            f"{_given(dev, mr.get('Svk'), signed=False)}; Smr1 {pct(mr.get('Smr1'))}, Smr2 {pct(mr.get('Smr2'))}",
        ),
        ("scale", "Photogrammetry scale", f"{_given(px, sc.get('value'), 7)}{spread}"),
        ("fused", "Fused points", _given(num.count, summary.get("n_points_fused"))),
    ]
    return [{"name": n, "label": label, "value": v} for n, label, v in rows]
