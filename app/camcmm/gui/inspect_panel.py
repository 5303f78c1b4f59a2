"""Compare with CAD: the inspection page's logic, apart from the layout.

The operator picks the measured cloud and the nominal (a CAD mesh or a reference
cloud) from the project's items, an alignment method (the choices of the
``inspect.compare`` manifest; the ``pairs`` methods take three point pairs clicked in
the 3D view: on the measured cloud, then on the nominal, three times) and a tolerance,
and runs the plugin in a worker thread. The result is shown as

* the deviations cloud in the page's own 3D view: a diverging colour map on
  ±``colour_limit`` with a legend titled ``deviation [µm]`` or ``[mm]`` (whichever
  reads better), or tolerance bands (within ±tolerance green, above red, below blue);
* a histogram and the Abbott-Firestone (material-ratio) curve as plotly figures, with
  the 95 % interval, ±tolerance and the ISO 13565-2 construction drawn in;
* a statistics table, the alignment (rms, scale, converged and its reason);
* a picked point's coordinates and deviation (click in the view);
* a section: a plane across an axis at a position, the nominal cut as polylines and
  the measured points within ±half a point spacing of the plane, coloured by deviation.

Export writes the coloured cloud as PLY with the field ``deviation`` (offered for
download and added to the project as an item); Report runs the inspection plugin's own
report writer (HTML, PDF, JSON, added to the project). The comparison is stored in the
project (the result, its deviations cloud as a result file, project state key
``inspection.current``), so reopening the project shows the last comparison.

Two layers, as in the wizard: module functions (units, bands, figures, section,
picking maths) are plain numpy/plotly and testable alone; :class:`InspectView` owns an
off-screen pyvista plotter; :class:`InspectPage` publishes everything through the
trame ``state`` (keys ``ins_*``) for :mod:`camcmm.gui.inspect_layout`. VTK, the state
and the page's scene are touched only from the server loop; the plugin run, the
display preparation, storing, export and report run in a worker thread.
"""

from __future__ import annotations

import asyncio
import importlib
import logging
import math
import re
import shutil
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import CamcmmError, InputError
from ..host import RunResult, to_jsonable
from ..params import form_schema, validate
from .downloads import REPORT_TITLES, Downloads, safe_file_name, sort_links
from .inspect_figures import (BANDS, COLOURMAP, MINUS, _num, alignment_rows, band_codes, band_colours,
                              band_counts, band_legend, display_unit, diverging_colours, empty_figure,
                              fmt_len, histogram_figure, interval_text, legend_title, material_ratio_figure,
                              nice_ticks, section_figure, stats_rows)
from .inspect_geometry import (AXES, pick_point, pick_surface, point_spacing, section, surface_distance,
                               world_to_display)
from .inspect_scene import MEASURED_COLOUR, NOMINAL_COLOUR, InspectView, Prepared, prepare_cloud
from .view import fmt_count

log = logging.getLogger("camcmm.gui.inspect")

PLUGIN = "inspect.compare"
STATE_KEY = "inspection.current"
DOWNLOAD_ROUTE = "camcmm-inspect-downloads"
#: Parameters the page shows up front; the rest of the manifest's go under "More".
MAIN_PARAMS = ("align", "tolerance")
N_PAIRS = 3

ALIGN_TITLES = {
    "icp": "ICP — rigid, from where the cloud is",
    "similarity": "ICP with one uniform scale",
    "global+icp": "Automatic (features + RANSAC), then ICP",
    "global+similarity": "Automatic, then ICP with scale",
    "pairs": "Three point pairs (picked) only",
    "pairs+icp": "Three point pairs, then ICP",
    "pairs+similarity": "Three point pairs, then ICP with scale",
    "none": "None — the cloud is aligned already",
}

PAIR_COLOURS = {"measured": "#c62828", "nominal": "#1565c0"}


# =============================================================================== the page
def _one_line(exc: BaseException | str) -> str:
    msg = str(exc) if isinstance(exc, (CamcmmError, str)) else f"{type(exc).__name__}: {exc}"
    return " ".join(msg.split()) or "unknown error"


def _safe_file_name(name: str) -> str:
    return safe_file_name(name, "inspection")


class InspectPage:
    """Publishes the comparison through the session's trame state (``ins_*`` keys) and
    runs the slow steps in a worker thread. One per server."""

    def __init__(self, session: Any, downloads: str | Path | None = None, display_limit: int | None = None):
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        limit = display_limit or getattr(getattr(session, "view", None), "display_limit", None) or 500_000
        self.view = InspectView(int(limit))
        self.offered = Downloads(DOWNLOAD_ROUTE, "camcmm-inspect-", downloads)
        self.downloads, self.download_route = self.offered.folder, self.offered.route
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="camcmm-inspect")
        self._cancel: threading.Event | None = None
        self._last_progress = 0.0
        # the comparison on show
        self.result: RunResult | None = None
        self.outputs: dict[str, Any] | None = None
        self.deviations: Any = None          # PointCloud with field "deviation"
        self.prepared: Prepared | None = None
        self.nominal: Any = None
        self.measured: Any = None
        self.result_id: int | None = None
        self.saved: dict[str, Any] = {}
        self._spacing: float | None = None
        self._pairs_measured: list[list[float]] = []
        self._pairs_nominal: list[list[float]] = []
        self.timing: dict[str, float] = {}
        self._spec = None
        self._init_state()
        self.refresh_inputs()
        self.restore()

    # -- state ---------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.ins_measured = None
        s.ins_nominal = None
        s.ins_align_options = []
        s.ins_align = "icp"
        s.ins_tolerance = ""
        s.ins_fields = []
        s.ins_params = {}
        s.ins_running = False
        s.ins_progress = 0.0
        s.ins_progress_message = ""
        s.ins_error = ""
        s.ins_has_result = False
        s.ins_failed = False
        s.ins_failed_reason = ""
        s.ins_title = ""
        s.ins_mode = "inputs"
        s.ins_unit = "mm"
        s.ins_legend_title = ""
        s.ins_limit_text = ""
        s.ins_bands = []
        s.ins_note = ""
        s.ins_stats = []
        s.ins_alignment = []
        s.ins_warnings = []
        s.ins_picked = None
        s.ins_pairs = []
        s.ins_pick_hint = ""
        s.ins_fig_hist = empty_figure("the histogram of the deviations appears here after Run")
        s.ins_fig_af = empty_figure("the Abbott-Firestone curve appears here after Run")
        s.ins_fig_section = empty_figure("a section through the part appears here after Run")
        s.ins_section_axis = "z"
        s.ins_section_pos = 0.0
        s.ins_section_range = [0.0, 1.0, 0.01]
        s.ins_export_links = []
        s.ins_report_links = []
        s.ins_busy = ""
        s.ins_result_id = None
        s.ins_timing = {}

    def _flush(self) -> None:
        self.session._flush()

    def _error(self, msg: Any) -> None:
        line = _one_line(msg) if not isinstance(msg, str) else " ".join(msg.split())
        self.state.ins_error = line
        self.session.error(line)

    def _spec_of(self) -> Any:
        if self._spec is None:
            self._spec = self.host.get(PLUGIN)
        return self._spec

    # -- inputs --------------------------------------------------------------------------
    def refresh_inputs(self) -> None:
        """The form: alignment choices and parameters from the manifest; default items."""
        s = self.state
        try:
            spec = self._spec_of()
        except Exception as exc:  # a host without it (or a test's fake host): the page says so
            s.ins_error = f"the inspection plugin ({PLUGIN}) is not available: {_one_line(exc)}"
            return
        if not s.ins_fields:
            fields, values = [], {}
            for f in form_schema(spec.parameters):
                if f["name"] == "align":
                    s.ins_align_options = [{"title": ALIGN_TITLES.get(c, c), "value": c} for c in f.get("choices") or []]
                    if s.ins_align not in (f.get("choices") or []):
                        s.ins_align = f.get("default") or (f.get("choices") or ["icp"])[0]
                    continue
                if f["name"] in MAIN_PARAMS:
                    continue
                d = {k: to_jsonable(v) for k, v in f.items()}
                d["choices"] = list(f.get("choices") or [])
                d["unit"] = f.get("unit", "")
                d["help"] = f.get("help", "")
                default = f.get("default")
                values[f["name"]] = bool(default) if f["widget"] == "switch" else (
                    "" if default is None else (", ".join(str(x) for x in default) if isinstance(default, list)
                                                else to_jsonable(default)))
                fields.append(d)
            s.ins_fields = fields
            s.ins_params = values
        items = list(s.items or [])
        clouds = [it["id"] for it in items if it.get("kind") == "pointcloud"]
        geoms = [it["id"] for it in items if it.get("kind") in ("pointcloud", "mesh")]
        if s.ins_measured not in clouds:
            s.ins_measured = clouds[0] if clouds else None
        if s.ins_nominal not in geoms:
            meshes = [it["id"] for it in items if it.get("kind") == "mesh"]
            others = [g for g in geoms if g != s.ins_measured]
            s.ins_nominal = meshes[0] if meshes else (others[0] if others else None)

    def _name(self, key: Any) -> str:
        m = self.session._measurements.get(str(key)) if key is not None else None
        return str(m.get("name") or key) if m else str(key)

    def _load(self, key: Any, what: str) -> Any:
        if key in (None, ""):
            raise InputError(f"choose the {what} first (import it with the Import field)")
        return self.session._load(str(key))

    def pairs_method(self) -> bool:
        return str(self.state.ins_align or "").startswith("pairs")

    def set_inputs(self, measured: Any = None, nominal: Any = None) -> None:
        """New measured/nominal choice: show them both (and forget picked pairs)."""
        s = self.state
        changed = False
        if measured is not None and measured != s.ins_measured:
            s.ins_measured, changed = measured, True
        if nominal is not None and nominal != s.ins_nominal:
            s.ins_nominal, changed = nominal, True
        if changed:
            self.view.forget_inputs()
            self.clear_pairs(render=False)
        self.show_inputs()

    def show_inputs(self, reset_camera: bool = True, push: bool = True) -> bool:
        """The inputs scene (both objects as they are) for picking point pairs."""
        s = self.state
        try:
            measured = self._load(s.ins_measured, "measured cloud") if s.ins_measured else None
            nominal = self._load(s.ins_nominal, "nominal") if s.ins_nominal else None
        except Exception as exc:
            self._error(exc)
            return False
        if measured is not None and not hasattr(measured, "points"):
            self._error(f"{self._name(s.ins_measured)} is not a point cloud")
            return False
        self.measured, self.nominal = measured, nominal
        self.view.show_inputs(measured, nominal, self._pair_markers(), reset_camera=reset_camera, push=push)
        s.ins_mode = "inputs"
        s.ins_note = self.view.note
        s.ins_legend_title = ""
        self._pick_hint()
        return True

    def set_align(self, method: str) -> None:
        self.state.ins_align = method
        if self.pairs_method() and self.state.ins_mode != "inputs":
            self.show_inputs()
        self._pick_hint()

    def opened(self) -> None:
        """The page is shown: an empty view shows the chosen inputs."""
        if self.view.scene == "empty" and not self.state.ins_running:
            self.refresh_inputs()
            if self.state.ins_measured or self.state.ins_nominal:
                # no image now: the view being mounted asks for one at its own size
                self.show_inputs(push=False)

    # -- point pairs ---------------------------------------------------------------------
    def _pair_markers(self) -> list[dict[str, Any]]:
        out = []
        for i, p in enumerate(self._pairs_measured):
            out.append({"point": p, "label": f"M{i + 1}", "colour": PAIR_COLOURS["measured"]})
        for i, p in enumerate(self._pairs_nominal):
            out.append({"point": p, "label": f"N{i + 1}", "colour": PAIR_COLOURS["nominal"]})
        return out

    def _publish_pairs(self) -> None:
        rows = []
        for i in range(max(len(self._pairs_measured), len(self._pairs_nominal))):
            m = self._pairs_measured[i] if i < len(self._pairs_measured) else None
            n = self._pairs_nominal[i] if i < len(self._pairs_nominal) else None
            fmt = (lambda p: "(" + ", ".join(f"{c:.2f}" for c in p) + ")")
            rows.append({"i": i + 1, "measured": fmt(m) if m else "…", "nominal": fmt(n) if n else "…",
                         "complete": m is not None and n is not None})
        self.state.ins_pairs = rows
        self._pick_hint()

    def _pick_hint(self) -> None:
        s = self.state
        if not self.pairs_method():
            s.ins_pick_hint = ""
            return
        nm, nn = len(self._pairs_measured), len(self._pairs_nominal)
        if nm >= N_PAIRS and nn >= N_PAIRS:
            s.ins_pick_hint = "three pairs picked: Run aligns with them"
        elif nm <= nn:
            s.ins_pick_hint = f"pair {nm + 1}: click a point on the measured cloud (orange)"
        else:
            s.ins_pick_hint = f"pair {nn + 1}: click the same point on the nominal (grey)"

    def pairs(self) -> dict[str, list[list[float]]] | None:
        """The picked pairs as the plugin takes them (complete pairs only)."""
        k = min(len(self._pairs_measured), len(self._pairs_nominal))
        if k == 0:
            return None
        return {"measured": self._pairs_measured[:k], "nominal": self._pairs_nominal[:k]}

    def add_pair_point(self, which: str, point: Any) -> None:
        """Record a picked point of a pair (also used by tests and scripts)."""
        p = [float(c) for c in np.asarray(point, dtype=float).ravel()[:3]]
        (self._pairs_measured if which == "measured" else self._pairs_nominal).append(p)
        self._publish_pairs()
        if self.view.scene == "inputs":
            self.view.set_markers(self._pair_markers())

    def clear_pairs(self, render: bool = True) -> None:
        self._pairs_measured, self._pairs_nominal = [], []
        self._publish_pairs()
        if render and self.view.scene == "inputs":
            self.view.set_markers([])

    def undo_pair_point(self) -> None:
        if len(self._pairs_measured) > len(self._pairs_nominal):
            self._pairs_measured.pop()
        elif self._pairs_nominal:
            self._pairs_nominal.pop()
        self._publish_pairs()
        if self.view.scene == "inputs":
            self.view.set_markers(self._pair_markers())

    # -- picking -------------------------------------------------------------------------
    def pick_at(self, fx: float, fy: float) -> dict[str, Any] | None:
        """A click in the view at fractions (fx from the left, fy from the top): a pair
        point in the inputs scene of a pairs method, else the deviation of the point
        under the click."""
        try:
            x, y = self.view.display_xy(fx, fy)
        except Exception as exc:
            self._error(f"pick: {_one_line(exc)}")
            return None
        return self.pick_display(x, y)

    def pick_display(self, x: float, y: float) -> dict[str, Any] | None:
        """As :meth:`pick_at` with display pixels (x right, y up)."""
        s = self.state
        scene = self.view.scene
        if scene == "inputs":
            if not self.pairs_method():
                s.ins_pick_hint = "choose a 'pairs' alignment to pick point pairs; after Run, a click shows a deviation"
                return None
            nm, nn = len(self._pairs_measured), len(self._pairs_nominal)
            if nm >= N_PAIRS and nn >= N_PAIRS:
                s.ins_pick_hint = "three pairs are picked; Clear them to pick again"
                return None
            which = "measured" if nm <= nn else "nominal"
            p = self.view.pick_input(which, x, y)
            if p is None:
                s.ins_pick_hint = (f"no point of the {which} {'cloud' if which == 'measured' else ''} there; "
                                   "click on it").replace("  ", " ")
                return None
            self.add_pair_point(which, p)
            return {"which": which, "point": p.tolist()}
        if scene in ("colour", "bands", "failed") and self.deviations is not None:
            i = self.view.pick_deviation(x, y)
            if i is None:
                s.ins_picked = {"text": "no point there", "found": False}
                return None
            return self.pick_index(i)
        return None

    def pick_index(self, i: int) -> dict[str, Any]:
        """Show the deviation of point ``i`` of the deviations cloud."""
        cloud = self.deviations
        p = np.asarray(cloud.points[i], dtype=float)
        d = float(np.asarray(cloud.fields["deviation"])[i])
        unit = self.state.ins_unit
        valid = not self.state.ins_failed
        info = {"found": True, "index": int(i), "x": float(p[0]), "y": float(p[1]), "z": float(p[2]),
                "deviation_mm": d, "deviation": fmt_len(d, unit, True, 4),
                "coords": "(" + ", ".join(_num(float(c), 6) for c in p) + ") mm", "valid": valid}
        tol = self._tolerance(quiet=True)
        if tol:
            info["band"] = BANDS[int(band_codes(np.array([d]), tol)[0])][0]
        info["text"] = f"point #{i}: {info['coords']}, deviation {info['deviation']}" + (
            "" if valid else " (alignment failed: not a valid deviation)")
        self.state.ins_picked = info
        label = info["deviation"] if valid else "?"
        self.view.set_markers([{"point": p.tolist(), "label": label, "colour": "#212121"}])
        return info

    # -- running -------------------------------------------------------------------------
    def _tolerance(self, quiet: bool = False) -> float | None:
        t = self.state.ins_tolerance
        if t is None or (isinstance(t, str) and not t.strip()):
            return None
        try:
            v = float(str(t).replace(",", ".")) if not isinstance(t, (int, float)) else float(t)
        except ValueError:
            if not quiet:
                raise InputError(f"tolerance: {t!r} is not a number") from None
            return None
        if not math.isfinite(v) or v < 0:
            if not quiet:
                raise InputError(f"tolerance: {t!r} must be a number ≥ 0 (mm)")
            return None
        return v or None

    def _prepare_run(self, params: dict[str, Any] | None) -> tuple[dict[str, Any], dict[str, Any], list]:
        s = self.state
        spec = self._spec_of()
        self.refresh_inputs()  # the items may have changed without a flush
        if s.ins_measured in (None, ""):
            raise InputError("choose the measured cloud first (import one with the Import field)")
        if s.ins_nominal in (None, ""):
            raise InputError("choose the nominal (a CAD mesh or a reference cloud) first")
        if str(s.ins_measured) == str(s.ins_nominal):
            raise InputError(f"{self._name(s.ins_measured)} is chosen as both measured and nominal; "
                             "choose two different items")
        declared = {p.name: p for p in spec.parameters}
        raw: dict[str, Any] = {}
        for k, v in (params if params is not None else (s.ins_params or {})).items():
            p = declared.get(k)
            if p is None or k in MAIN_PARAMS:
                continue
            if p.type != "str" and (v is None or (isinstance(v, str) and v.strip() == "")):
                continue
            raw[k] = v
        raw["align"] = s.ins_align
        tol = self._tolerance()
        if tol is not None:
            raw["tolerance"] = tol
        values = validate(spec.parameters, raw, owner=f"plugin {PLUGIN!r}")
        inputs: dict[str, Any] = {}
        if str(values["align"]).startswith("pairs"):
            pairs = self.pairs()
            k = 0 if pairs is None else len(pairs["measured"])
            if k < N_PAIRS:
                raise InputError(f"alignment {values['align']!r} needs {N_PAIRS} point pairs, {k} picked: click a "
                                 "point on the measured cloud, then the same point on the nominal, three times")
            inputs["pairs"] = pairs
        mids = [self.session._measurements[str(k)]["id"] for k in (s.ins_measured, s.ins_nominal)
                if str(k) in self.session._measurements]
        return inputs, values, mids

    def _begin(self) -> threading.Event:
        s = self.state
        self._cancel = threading.Event()
        self._last_progress = 0.0
        s.ins_running = True
        s.ins_progress = 0.0
        s.ins_progress_message = f"running {PLUGIN} …"
        s.ins_error = ""
        self.session.clear_error()
        return self._cancel

    def _set_progress(self, fraction: float, message: str) -> None:
        self.state.ins_progress = round(100.0 * float(fraction), 1)
        if message:
            self.state.ins_progress_message = message

    def _progress_cb(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if fraction < 1.0 and now - self._last_progress < 0.1:
            return
        self._last_progress = now
        self.session._post(self._set_progress, fraction, message)

    def cancel(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
            self.state.ins_progress_message = "cancelling …"

    def _compute(self, inputs: dict[str, Any], values: dict[str, Any], cancel: threading.Event,
                 measured_key: str, nominal_key: str) -> tuple[RunResult, Prepared, dict[str, float]]:
        """Worker thread: load the inputs, run the plugin, prepare the display."""
        t0 = time.time()
        cloud = self.session._load(measured_key)
        nominal = self.session._load(nominal_key)
        if not hasattr(cloud, "points") or hasattr(cloud, "faces"):
            raise InputError(f"{self._name(measured_key)}: the measured item must be a point cloud")
        if not hasattr(nominal, "points") and not hasattr(nominal, "faces"):
            raise InputError(f"{self._name(nominal_key)}: the nominal must be a mesh or a point cloud")
        self.measured, self.nominal = cloud, nominal
        result = self.host.run(PLUGIN, inputs={"cloud": cloud, "nominal": nominal, **inputs}, params=values,
                               progress=self._progress_cb, cancel=cancel)
        t_result = time.time()
        dev = result.outputs["deviations"]
        prep = prepare_cloud(dev.points, dev.fields["deviation"], self.view.display_limit)
        return result, prep, {"started": t0, "result": t_result, "prepared": time.time()}

    def run(self, params: dict[str, Any] | None = None) -> RunResult | None:
        """Run the comparison in the calling thread (tests, scripts)."""
        try:
            inputs, values, mids = self._prepare_run(params)
        except Exception as exc:
            self._error(exc)
            return None
        cancel = self._begin()
        try:
            result, prep, timing = self._compute(inputs, values, cancel, str(self.state.ins_measured),
                                                 str(self.state.ins_nominal))
        except Exception as exc:
            self._failed(exc)
            return None
        self._show_result(result, prep, timing)
        self._auto_section()
        try:
            stored = self._store(result, mids)
        except Exception as exc:
            self._error(f"the comparison could not be stored in the project: {_one_line(exc)}")
            return result
        self._stored(stored)
        return result

    async def run_async(self, params: dict[str, Any] | None = None) -> RunResult | None:
        """As :meth:`run`, computing (and storing) in a worker while the page stays live."""
        if self.session._loop is None:
            self.session.bind_loop()
        if self.state.ins_running:
            self._error("a comparison is running; wait for it or cancel it")
            return None
        try:
            inputs, values, mids = self._prepare_run(params)
        except Exception as exc:
            self._error(exc)
            return None
        cancel = self._begin()
        self._flush()
        loop = asyncio.get_running_loop()
        mk, nk = str(self.state.ins_measured), str(self.state.ins_nominal)
        try:
            result, prep, timing = await loop.run_in_executor(
                self._executor, self._compute, inputs, values, cancel, mk, nk)
        except Exception as exc:
            self._failed(exc)
            self._flush()
            return None
        self._show_result(result, prep, timing)
        self._flush()
        self.timing["flushed"] = time.time()
        self.state.ins_timing = dict(self.timing)
        self._auto_section()  # after the colour map is on its way: it needs the point spacing
        self._flush()
        try:
            stored = await loop.run_in_executor(self._executor, self._store, result, mids)
        except Exception as exc:
            self._error(f"the comparison could not be stored in the project: {_one_line(exc)}")
            self._flush()
            return result
        self._stored(stored)
        self._flush()
        return result

    def _failed(self, exc: BaseException) -> None:
        s = self.state
        s.ins_running = False
        s.ins_progress_message = "cancelled" if "cancelled" in str(exc) else "failed"
        msg = _one_line(exc)
        if PLUGIN not in msg and not isinstance(exc, InputError):
            msg = f"{PLUGIN}: {msg}"
        self._error(msg)

    # -- showing a result -------------------------------------------------------------------
    def _show_result(self, result: RunResult, prep: Prepared, timing: dict[str, float] | None = None,
                     mode: str | None = None) -> None:
        """Publish a comparison (fresh or restored) and draw it — the view first, so that
        its image is on its way while the numbers and charts are made. Loop thread."""
        s = self.state
        if timing:
            self.timing = dict(timing)
            self.timing["loop"] = time.time()
        o = result.outputs
        self.result, self.outputs = result, o
        self.deviations = o["deviations"]
        self.prepared = prep
        self._spacing = None
        limit = float(o.get("colour_limit") or 0.0) or 1e-3
        unit, _ = display_unit(limit)
        converged = bool(o.get("converged"))
        tol = self._tolerance(quiet=True)
        if tol is None and o.get("stats", {}).get("tolerance") is not None:
            tol = float(o["stats"]["tolerance"])
            s.ins_tolerance = tol
        s.ins_unit = unit
        s.ins_has_result = True
        s.ins_failed = not converged
        s.ins_failed_reason = "" if converged else (o.get("reason") or "the alignment did not converge")
        s.ins_legend_title = legend_title(unit)
        s.ins_limit_text = f"colours saturate at ±{fmt_len(limit, unit)}"
        s.ins_warnings = [str(w) for w in (result.warnings or [])][:12]
        s.ins_alignment = alignment_rows(o, unit)
        s.ins_picked = None
        s.ins_title = (f"{self._name(s.ins_measured)} against {self._name(s.ins_nominal)} — "
                       f"{fmt_count(self.deviations.n_points)} points, alignment {o.get('alignment', {}).get('method', '')}")
        s.ins_running = False
        s.ins_progress = 100.0
        s.ins_progress_message = "done" if converged else "done — the alignment FAILED"
        if converged:
            wanted = mode or (s.ins_mode if s.ins_mode in ("colour", "bands") else "colour")
            if wanted == "bands" and not tol:
                wanted = "colour"
            self._draw(wanted, reset_camera=True)
            if timing:
                self.timing["drawn"] = time.time()
            self._publish_numbers(tol)
        else:
            s.ins_stats, s.ins_bands = [], []
            s.ins_fig_hist = empty_figure("alignment failed: no deviations")
            s.ins_fig_af = empty_figure("alignment failed: no deviations")
            s.ins_fig_section = empty_figure("alignment failed")
            s.ins_mode = "failed"
            self.view.show_failed(prep, self.nominal, reset_camera=True)
            s.ins_note = self.view.note
        self._section_range(centre=True)
        if timing:
            self.timing.setdefault("drawn", time.time())
            self.timing["numbers"] = time.time()
            s.ins_timing = dict(self.timing)

    def _publish_numbers(self, tol: float | None) -> None:
        """Statistics, bands, histogram and curve for the current tolerance."""
        s = self.state
        o = self.outputs or {}
        unit = s.ins_unit
        dev = np.asarray(self.deviations.fields["deviation"], dtype=float)
        s.ins_stats = stats_rows(o, unit, tol, dev)
        s.ins_bands = band_legend(band_counts(dev, tol), tol, unit) if tol else []
        limit = float(o.get("colour_limit") or 1e-3)
        try:
            s.ins_fig_hist = histogram_figure(o["histogram"], o["stats"], unit, limit, tol)
        except Exception as exc:
            log.exception("histogram figure")
            s.ins_fig_hist = empty_figure(f"histogram: {_one_line(exc)}")
        try:
            s.ins_fig_af = material_ratio_figure(o["material_ratio"], o["stats"], unit, tol)
        except Exception as exc:
            log.exception("material-ratio figure")
            s.ins_fig_af = empty_figure(f"material ratio: {_one_line(exc)}")

    def _draw(self, mode: str, reset_camera: bool = False) -> None:
        s = self.state
        if self.prepared is None or self.outputs is None:
            return
        limit = float(self.outputs.get("colour_limit") or 1e-3)
        self.view.show_deviations(self.prepared, limit, s.ins_unit, mode, self._tolerance(quiet=True),
                                  reset_camera=reset_camera)
        s.ins_mode = self.view.scene
        s.ins_note = self.view.note
        if s.ins_section_axis and s.ins_fig_section.get("data"):
            self.view.set_section_plane(s.ins_section_axis, float(s.ins_section_pos), self.deviations.bounds)

    def set_mode(self, mode: str) -> None:
        """The view's mode: colour | bands | inputs."""
        s = self.state
        if mode not in ("colour", "bands", "inputs"):  # the toggle's button pressed again
            s.ins_mode = self.view.scene if self.view.scene != "empty" else "inputs"
            s.dirty("ins_mode")
            return
        if mode == "inputs":
            self.show_inputs(reset_camera=False)
            return
        if self.deviations is None:
            s.ins_mode = "inputs"
            return
        if s.ins_failed:
            self._error("the alignment failed: the deviations are not valid, so they are not coloured")
            s.ins_mode = "failed"
            self.view.show_failed(self.prepared, self.nominal, reset_camera=False)
            return
        if mode == "bands" and not self._tolerance(quiet=True):
            self._error("tolerance bands need a tolerance: enter one (mm)")
            mode = "colour"
        self._draw(mode)

    def set_tolerance(self, value: Any) -> None:
        """A new tolerance after the run: bands, the share within, the charts follow."""
        s = self.state
        s.ins_tolerance = value
        try:
            tol = self._tolerance()
        except InputError as exc:
            self._error(exc)
            return
        s.ins_error = ""
        if self.deviations is None or s.ins_failed:
            return
        self._publish_numbers(tol)
        if s.ins_mode == "bands":
            self._draw("bands" if tol else "colour")
        if s.ins_picked and s.ins_picked.get("found"):
            self.pick_index(int(s.ins_picked["index"]))

    # -- section ---------------------------------------------------------------------------
    def _auto_section(self) -> None:
        """The section through the middle, once a valid result is shown."""
        if self.deviations is not None and not self.state.ins_failed:
            self.set_section()

    def spacing(self) -> float:
        if self._spacing is None:
            self._spacing = point_spacing(self.deviations.points) if self.deviations is not None else 0.0
        return self._spacing

    def _bounds(self) -> np.ndarray | None:
        if self.deviations is None:
            return None
        b = self.deviations.bounds
        if self.nominal is not None and hasattr(self.nominal, "bounds"):
            nb = np.asarray(self.nominal.bounds, dtype=float)
            b = np.vstack([np.minimum(b[0], nb[0]), np.maximum(b[1], nb[1])])
        return b

    def _section_range(self, centre: bool = False) -> None:
        s = self.state
        b = self._bounds()
        if b is None:
            return
        ax = AXES.index(s.ins_section_axis or "z")
        lo, hi = float(b[0, ax]), float(b[1, ax])
        step = (hi - lo) / 200.0 or 0.01
        s.ins_section_range = [lo, hi, float(f"{step:.3g}")]
        if centre or not lo <= float(s.ins_section_pos or 0.0) <= hi:
            s.ins_section_pos = float(f"{0.5 * (lo + hi):.6g}")

    def set_section(self, axis: str | None = None, position: float | None = None) -> dict[str, Any] | None:
        """Cut the part by the plane axis = position; publish the 2-D chart and show the
        plane in the view."""
        s = self.state
        if axis is not None and axis != s.ins_section_axis:
            s.ins_section_axis = axis
            self._section_range(centre=True)
        if position is not None:
            s.ins_section_pos = float(position)
        if self.deviations is None:
            return None
        try:
            nominal_poly = None
            nominal_points = None
            if self.nominal is not None and hasattr(self.nominal, "faces"):
                nominal_poly = self.view.mesh_poly(self.nominal)
            elif self.nominal is not None:
                nominal_points = self.nominal.points
            sec = section(s.ins_section_axis, float(s.ins_section_pos), self.deviations.points,
                          self.deviations.fields["deviation"], 0.5 * self.spacing(), nominal_poly, nominal_points)
            s.ins_fig_section = section_figure(sec, s.ins_unit, float(self.outputs.get("colour_limit") or 1e-3))
        except Exception as exc:
            log.exception("section")
            self._error(f"section: {_one_line(exc)}")
            return None
        if s.ins_mode in ("colour", "bands", "failed"):
            self.view.set_section_plane(s.ins_section_axis, float(s.ins_section_pos), self._bounds())
        return sec

    # -- storing and restoring --------------------------------------------------------------
    def _store(self, result: RunResult, mids: list) -> dict[str, Any]:
        """Worker thread: the deviations cloud as a project file, the result, the state."""
        dev = result.outputs["deviations"]
        h = self.project.add_object(dev, _safe_file_name(dev.name) + ".ply")
        rid = self.project.add_result(result, measurement_ids=mids, files={"deviations": h},
                                      label="inspection: compare with CAD")
        saved = {"result": rid, "measured": self._mid(self.state.ins_measured),
                 "nominal": self._mid(self.state.ins_nominal), "align": result.params.get("align"),
                 "tolerance": result.params.get("tolerance"), "pairs": self.pairs(), "deviations": h,
                 "report": None, "export": None}
        self.project.set_state(STATE_KEY, saved)
        return saved

    def _mid(self, key: Any) -> Any:
        m = self.session._measurements.get(str(key))
        return m["id"] if m else None

    def _stored(self, saved: dict[str, Any]) -> None:
        self.saved = saved
        self.result_id = saved["result"]
        self.state.ins_result_id = saved["result"]
        self.state.ins_report_links = []
        self.state.ins_export_links = []
        self.session.refresh_results()
        c = "" if not self.state.ins_failed else " (the alignment failed)"
        self.session.info(f"comparison stored as result #{saved['result']}{c}")

    def restore(self) -> bool:
        """Show the last comparison stored in the project (``inspection.current``)."""
        try:
            saved = self.project.get_state(STATE_KEY)
        except Exception:
            return False
        if not isinstance(saved, dict) or saved.get("result") is None:
            return False
        s = self.state
        try:
            d = self.project.result(int(saved["result"]))
            h = (d.get("files") or {}).get("deviations") or saved.get("deviations")
            from .. import io as cio

            cloud = cio.read(self.project.file_path(h))
            outputs = dict(d.get("outputs") or {})
            outputs["deviations"] = cloud
            result = RunResult(d.get("plugin", PLUGIN), d.get("version", ""), d.get("params") or {},
                               d.get("input_hashes") or {}, outputs, d.get("started", ""), d.get("finished", ""),
                               list(d.get("warnings") or []))
        except Exception as exc:
            s.ins_error = f"the last comparison (result {saved.get('result')}) cannot be shown: {_one_line(exc)}"
            return False
        for key, attr in (("measured", "ins_measured"), ("nominal", "ins_nominal")):
            if saved.get(key) is not None and str(saved[key]) in self.session._measurements:
                setattr(s, attr, str(saved[key]))
        if saved.get("align"):
            s.ins_align = saved["align"]
        if saved.get("tolerance") is not None:
            s.ins_tolerance = saved["tolerance"]
        pairs = saved.get("pairs") or {}
        self._pairs_measured = [list(map(float, p)) for p in pairs.get("measured") or []]
        self._pairs_nominal = [list(map(float, p)) for p in pairs.get("nominal") or []]
        self._publish_pairs()
        try:
            self.nominal = self._load(s.ins_nominal, "nominal") if s.ins_nominal else None
            self.measured = self._load(s.ins_measured, "measured cloud") if s.ins_measured else None
        except Exception:
            self.nominal = None
        prep = prepare_cloud(cloud.points, cloud.fields.get("deviation"), self.view.display_limit)
        self._show_result(result, prep)
        self.saved = saved
        self.result_id = int(saved["result"])
        s.ins_result_id = self.result_id
        s.ins_progress = 0.0
        s.ins_progress_message = ""
        self._auto_section()
        s.ins_report_links = self._links(saved.get("report") or {}, "report")
        s.ins_export_links = self._links({"ply": saved["export"]} if saved.get("export") else {}, "export")
        return True

    def _save_state(self) -> None:
        try:
            self.project.set_state(STATE_KEY, self.saved)
        except Exception as exc:
            log.warning("cannot save %s: %s", STATE_KEY, exc)

    # -- export ----------------------------------------------------------------------------
    def _export_cloud(self) -> Any:
        """The deviations cloud coloured as the view shows it (colour map or bands),
        with the field ``deviation`` (mm)."""
        from ..model import PointCloud

        c = self.deviations
        dev = np.asarray(c.fields["deviation"], dtype=float)
        tol = self._tolerance(quiet=True)
        if self.state.ins_mode == "bands" and tol:
            colours, what = band_colours(band_codes(dev, tol)), "tolerance bands"
        else:
            colours, what = diverging_colours(dev, float(self.outputs.get("colour_limit") or 1e-3)), "deviations"
        fields = dict(c.fields)
        units = dict(c.field_units)
        units["deviation"] = "mm"
        base = self._name(self.state.ins_measured) if self.state.ins_measured else c.name
        base = re.sub(r"\.(ply|pcd|xyz|txt|csv|e57)$", "", base, flags=re.I)
        return PointCloud(c.points, colours, c.normals, fields, units, f"{base} {what}", c.source_unit)

    def _write_export(self, cloud: Any) -> tuple[Path, str]:
        """Worker thread: write the PLY into the downloads folder and add it to the project."""
        from .. import io as cio

        name = _safe_file_name(cloud.name) + ".ply"
        path = self.downloads / name
        cio.write(cloud, path)
        h = self.project.add_file(path)
        return path, h

    def export(self) -> dict[str, Any] | None:
        """Export in the calling thread; returns ``{"path", "hash", "item"}``."""
        if not self._can("export"):
            return None
        try:
            cloud = self._export_cloud()
            path, h = self._write_export(cloud)
        except Exception as exc:
            self._error(f"export: {_one_line(exc)}")
            return None
        return self._exported(cloud, path, h)

    async def export_async(self) -> dict[str, Any] | None:
        if not self._can("export"):
            return None
        self.state.ins_busy = "export"
        self._flush()
        try:
            cloud = self._export_cloud()
            path, h = await asyncio.get_running_loop().run_in_executor(self._executor, self._write_export, cloud)
        except Exception as exc:
            self._error(f"export: {_one_line(exc)}")
            return None
        finally:
            self.state.ins_busy = ""
        out = self._exported(cloud, path, h)
        self._flush()
        return out

    def _exported(self, cloud: Any, path: Path, h: str) -> dict[str, Any]:
        mid = self.session._add_measurement(path.name, h, cloud, source=f"{PLUGIN} result #{self.result_id}")
        key = str(mid)
        self.session._objects[key] = cloud
        self.session.refresh_items()
        if self.saved:
            self.saved["export"] = h
            self._save_state()
        self.state.ins_export_links = [self.offered.offer(path.name, path, kind="ply")]
        self.session.info(f"exported {path.name} ({fmt_count(cloud.n_points)} points, field deviation in mm); "
                          "added to the project")
        return {"path": str(path), "hash": h, "item": key}

    def _can(self, what: str) -> bool:
        if self.deviations is None or self.outputs is None:
            self._error(f"{what}: run a comparison first")
            return False
        if what == "export" and self.state.ins_failed:
            self._error("export: the alignment failed, so the deviations are not valid; nothing is exported "
                        "(the report records the failure)")
            return False
        if self.state.ins_busy:
            self._error(f"{what}: wait for the {self.state.ins_busy} to finish")
            return False
        return True

    # -- report ----------------------------------------------------------------------------
    def _report_writer(self) -> Callable[..., Any]:
        """The inspection plugin's own report builder, found through its manifest entry."""
        spec = self._spec_of()
        package = spec.entry.split(":", 1)[0].rsplit(".", 1)[0]
        try:
            return importlib.import_module(f"{package}.report").build_report
        except (ImportError, AttributeError) as exc:
            raise CamcmmError(f"plugin {PLUGIN!r} ({package}) has no report writer: {exc}") from None

    def _make_report(self, folder: Path) -> dict[str, str]:
        """Worker thread: the report files (html, pdf, json) in ``folder``."""
        build = self._report_writer()
        o = dict(self.outputs or {})
        tol = self._tolerance(quiet=True)
        if tol is None:
            tol = (o.get("stats") or {}).get("tolerance")
        mname, nname = self._name(self.state.ins_measured), self._name(self.state.ins_nominal)
        rep = build(o, cloud_file=mname, nominal_file=nname, run=self.result, tolerance=tol)
        inputs = []
        for key, role in ((self.state.ins_measured, "measured cloud"), (self.state.ins_nominal, "nominal")):
            m = self.session._measurements.get(str(key))
            if m and m.get("hash"):
                inputs.append({"file": str(m.get("name")), "sha256": m["hash"], "role": role})
        if inputs:
            rep.provenance(inputs=inputs, extra={"project": str(getattr(self.project, "path", "")),
                                                 "result": self.result_id})
        return rep.write(folder, basename=f"inspection-{self.result_id or 'new'}")

    def _record_report(self, paths: dict[str, str]) -> dict[str, str]:
        files = {f"report_{k}": self.project.add_file(p) for k, p in paths.items()}
        res = self.result
        if res is not None:
            mids = [m for m in (self._mid(self.state.ins_measured), self._mid(self.state.ins_nominal)) if m is not None]
            run = {"plugin": res.plugin_id, "version": res.plugin_version, "params": res.params,
                   "input_hashes": res.input_hashes, "outputs": {"report_of": self.result_id, "formats": sorted(paths)},
                   "started": res.started, "finished": res.finished, "warnings": []}
            try:
                self.project.add_result(run, measurement_ids=mids, files=files,
                                        label=f"inspection report of result #{self.result_id}")
            except Exception as exc:
                log.warning("report result: %s", exc)
        if self.saved is not None:
            self.saved["report"] = files
            self._save_state()
        return files

    def _links(self, files: dict[str, str], what: str) -> list[dict[str, str]]:
        out = []
        for name, h in files.items():
            kind = name.removeprefix("report_")
            try:
                src = self.project.file_path(h)
            except CamcmmError as exc:
                log.warning("%s file %s: %s", what, name, exc)
                continue
            if what == "report":
                link = self.offered.offer(f"inspection-{self.result_id}.{kind}", src, kind=kind,
                                          title=REPORT_TITLES.get(kind))
            else:
                link = self.offered.offer(self._export_name(h), src, kind=kind)
            if link:
                out.append(link)
        return sort_links(out)

    def _export_name(self, h: str) -> str:
        try:
            for f in self.project.files():
                if f["hash"] == h:
                    return str(f["original_name"])
        except Exception:
            pass
        return f"deviations-{self.result_id}.ply"

    def report(self) -> dict[str, Any] | None:
        """The report in the calling thread; returns ``{"paths", "files", "links"}``."""
        if not self._can("report"):
            return None
        folder = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
        try:
            paths = self._make_report(folder)
            files = self._record_report(paths)
        except Exception as exc:
            self._error(f"report: {_one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        return self._reported(files)

    async def report_async(self) -> dict[str, Any] | None:
        if not self._can("report"):
            return None
        self.state.ins_busy = "report"
        self._flush()
        folder = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
        loop = asyncio.get_running_loop()
        try:
            paths = await loop.run_in_executor(self._executor, self._make_report, folder)
            files = await loop.run_in_executor(self._executor, self._record_report, paths)
        except Exception as exc:
            self._error(f"report: {_one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
            self.state.ins_busy = ""
        out = self._reported(files)
        self._flush()
        return out

    def _reported(self, files: dict[str, str]) -> dict[str, Any]:
        links = self._links(files, "report")
        self.state.ins_report_links = links
        self.session.refresh_results()
        self.session.info(f"report written: {', '.join(l['name'] for l in links)} (in the project)")
        paths = {k.removeprefix("report_"): str(self.project.file_path(h)) for k, h in files.items()}
        return {"files": files, "paths": paths, "links": links}

    # -- shutdown --------------------------------------------------------------------------
    def close(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
        self._executor.shutdown(wait=False, cancel_futures=True)
        self.offered.close()
        try:
            self.view.plotter.close()
        except Exception:
            pass


def mount(server: Any, session: Any, display_limit: int | None = None) -> InspectPage:
    """Create the page for a session, serve its downloads folder and follow the
    project's items (call before the server starts)."""
    page = InspectPage(session, display_limit=display_limit)
    page.offered.mount(server)

    @server.state.change("items")
    def _items_changed(**_):
        page.refresh_inputs()

    @server.state.change("page")
    def _page_changed(**changes):
        if changes.get("page") == "compare":
            page.opened()

    return page
