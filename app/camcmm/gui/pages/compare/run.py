"""Running a comparison on the "Compare with CAD" page and showing its result: the
plugin runs in the page's job (a worker thread; progress, cancel); the result is drawn
(the view first, so its image is on its way while the numbers and charts are made), the
tolerance and the display mode follow the operator after the run, and a section cuts
the part by a plane.

The tolerance bands beside the plugin's outputs come from a plugin too (task
``tolerance-bands``); the section is :mod:`.section`.

:class:`Run` is a mixin of :class:`.page.ComparePage`; it needs the inputs
(:class:`.inputs.Inputs`) and stores through :class:`.export.Export`.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from .... import worker
from ....errors import InputError, one_line
from ....host import RunResult
from ....params import validate
from ...jobs import Job
from ...view import fmt_count
from .figures import empty_figure, histogram_figure, material_ratio_figure
from .inputs import MAIN_PARAMS, N_PAIRS
from .scene import Prepared, prepare_cloud
from .tables import alignment_rows, band_legend, display_unit, fmt_len, legend_title, stats_rows

log = logging.getLogger("camcmm.gui.compare")

BANDS_TASK = "tolerance-bands"


class Run:
    """Run, cancel, show the result, tolerance and mode, section (mixin of ComparePage)."""

    def _prepare_run(self, params: dict[str, Any] | None) -> tuple[dict[str, Any], dict[str, Any], list]:
        s = self.state
        spec = self._spec_of()
        self.refresh_inputs()  # the items may have changed without a flush
        if s.ins_measured in (None, ""):
            raise InputError("choose the measured cloud first (import one with the Import field)")
        if s.ins_nominal in (None, ""):
            raise InputError("choose the nominal (a CAD mesh or a reference cloud) first")
        if str(s.ins_measured) == str(s.ins_nominal):
            raise InputError(
                f"{self._name(s.ins_measured)} is chosen as both measured and nominal; choose two different items"
            )
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
        values = validate(spec.parameters, raw, owner=f"plugin {spec.id!r}")
        inputs: dict[str, Any] = {}
        if str(values["align"]).startswith("pairs"):
            pairs = self.pairs()
            k = 0 if pairs is None else len(pairs["measured"])
            if k < N_PAIRS:
                raise InputError(
                    f"alignment {values['align']!r} needs {N_PAIRS} point pairs, {k} picked: click a "
                    "point on the measured cloud, then the same point on the nominal, three times"
                )
            inputs["pairs"] = pairs
        mids = [self._mid(k) for k in (s.ins_measured, s.ins_nominal) if self._mid(k) is not None]
        return inputs, values, mids

    def _started(self, plugin_id: str) -> None:
        s = self.state
        s.ins_running = True
        s.ins_progress = 0.0
        s.ins_progress_message = f"running {plugin_id} …"
        s.ins_error = ""
        self.session.clear_error()

    def _set_progress(self, fraction: float, message: str) -> None:
        """The job's progress (fraction 0..1), on the loop thread."""
        self.state.ins_progress = round(100.0 * float(fraction), 1)
        if message:
            self.state.ins_progress_message = message

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.ins_progress_message = "cancelling …"

    def _compute(
        self, inputs: dict[str, Any], values: dict[str, Any], measured_key: str, nominal_key: str
    ) -> tuple[RunResult, Prepared, dict[str, float]]:
        """Worker thread: load the inputs, run the plugin, prepare the display."""
        t0 = time.time()
        cloud = self.session.load(measured_key)
        nominal = self.session.load(nominal_key)
        if not hasattr(cloud, "points") or hasattr(cloud, "faces"):
            raise InputError(f"{self._name(measured_key)}: the measured item must be a point cloud")
        if not hasattr(nominal, "points") and not hasattr(nominal, "faces"):
            raise InputError(f"{self._name(nominal_key)}: the nominal must be a mesh or a point cloud")
        self.measured, self.nominal = cloud, nominal
        result = worker.run(
            self.host,
            self._spec_of().id,
            {"cloud": cloud, "nominal": nominal, **inputs},
            values,
            progress=self.job.progress,
            cancel=self.job.cancel_event,
        )
        t_result = time.time()
        dev = result.outputs["deviations"]
        prep = prepare_cloud(dev.points, dev.fields["deviation"], self.view.display_limit)
        return result, prep, {"started": t0, "result": t_result, "prepared": time.time()}

    def _not_stored(self, exc: BaseException) -> None:
        # the result is shown all the same: only reopening the project will miss it
        self._error(f"the comparison could not be stored in the project: {one_line(exc)}")

    async def run_async(self, params: dict[str, Any] | None = None) -> RunResult | None:
        """Check the form, compute (and store) in the page's job while the page stays
        live, show the result. None (with the reason shown) if it did not run."""
        if self.job.running:
            self._error("a comparison is running; wait for it or cancel it")
            return None
        try:
            inputs, values, mids = self._prepare_run(params)
        except Exception as exc:
            self._error(exc)
            return None
        self.job.begin()
        try:
            return await self._run_begun(inputs, values, mids)
        finally:
            self.job.end()

    async def _run_begun(self, inputs: dict[str, Any], values: dict[str, Any], mids: list) -> RunResult | None:
        self._started(self._spec_of().id)
        self.flush()
        mk, nk = str(self.state.ins_measured), str(self.state.ins_nominal)
        try:
            result, prep, timing = await self.job.call(self._compute, inputs, values, mk, nk)
        except Exception as exc:
            self._failed(exc)
            self.flush()
            return None
        self._show_result(result, prep, timing)
        self.flush()
        self.timing["flushed"] = time.time()
        self.state.ins_timing = dict(self.timing)
        self._auto_section()  # after the colour map is on its way: it needs the point spacing
        self.flush()
        try:
            stored = await self.job.call(self._store, result, mids)
        except Exception as exc:
            self._not_stored(exc)
            self.flush()
            return result
        self._stored(stored)
        self.flush()
        return result

    def _failed(self, exc: BaseException) -> None:
        s = self.state
        s.ins_running = False
        # an input the operator gave speaks for itself; anything else names the plugin
        status, msg = Job.outcome(exc, "" if isinstance(exc, InputError) else self._spec_of().id)
        s.ins_progress_message = status
        self._error(msg)

    # -- showing a result -------------------------------------------------------------------
    def _show_result(
        self, result: RunResult, prep: Prepared, timing: dict[str, float] | None = None, mode: str | None = None
    ) -> None:
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
        self.bands = None
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
        self.tools.clear_labels()  # labels picked on the comparison shown before
        s.ins_warnings = [str(w) for w in (result.warnings or [])][:12]
        s.ins_alignment = alignment_rows(o, unit)
        s.ins_picked = None
        s.ins_title = (
            f"{self._name(s.ins_measured)} against {self._name(s.ins_nominal)} — "
            f"{fmt_count(self.deviations.n_points)} points, "
            f"alignment {o.get('alignment', {}).get('method', '')}"
        )
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
            why = f"alignment failed: {s.ins_failed_reason}"
            s.ins_fig_hist = empty_figure(why)
            s.ins_fig_af = empty_figure(why)
            s.ins_fig_section = empty_figure(why)
            s.ins_mode = "failed"
            self.view.show_failed(prep, self.nominal, reset_camera=True)
            s.ins_note = self.view.note
        self._section_range(centre=True)
        if timing:
            self.timing.setdefault("drawn", time.time())
            self.timing["numbers"] = time.time()
            s.ins_timing = dict(self.timing)

    def _update_bands(self, tol: float | None) -> None:
        """The plugin's tolerance bands of the whole deviations cloud for ``tol`` (mm):
        ``self.bands = {"tolerance", "codes" (N,), "counts", "within"}``, None without a
        tolerance. Made once per tolerance."""
        if not tol or self.deviations is None:
            self.bands = None
            return
        if self.bands is not None and self.bands["tolerance"] == tol:
            return
        spec = self.host.provider(BANDS_TASK)
        out = self.host.run(spec.id, {"deviations": self.deviations}, {"tolerance": tol}).outputs
        self.bands = {
            "tolerance": tol,
            "codes": np.asarray(out["codes"]),
            "counts": dict(out["counts"]),
            "within": float(out["within"]),
        }

    def _publish_numbers(self, tol: float | None) -> None:
        """Statistics, bands, histogram and curve for the current tolerance."""
        s = self.state
        o = self.outputs or {}
        unit = s.ins_unit
        try:
            self._update_bands(tol)
        except Exception as exc:
            log.exception("tolerance bands")
            self.bands = None
            self._error(f"tolerance bands: {one_line(exc)}")
        within = self.bands["within"] if self.bands else None
        s.ins_stats = stats_rows(o, unit, tol, within)
        s.ins_bands = band_legend(self.bands["counts"], tol, unit) if self.bands else []
        limit = float(o.get("colour_limit") or 1e-3)
        try:
            s.ins_fig_hist = histogram_figure(o["histogram"], o["stats"], unit, limit, tol)
        except Exception as exc:
            log.exception("histogram figure")
            s.ins_fig_hist = empty_figure(f"histogram: {one_line(exc)}")
        try:
            s.ins_fig_af = material_ratio_figure(o["material_ratio"], o["stats"], unit, tol)
        except Exception as exc:
            log.exception("material-ratio figure")
            s.ins_fig_af = empty_figure(f"material ratio: {one_line(exc)}")

    def _draw(self, mode: str, reset_camera: bool = False) -> None:
        s = self.state
        if self.prepared is None or self.outputs is None:
            return
        limit = float(self.outputs.get("colour_limit") or 1e-3)
        bands = None
        if mode == "bands":
            try:
                self._update_bands(self._tolerance(quiet=True))
            except Exception as exc:
                self._error(f"tolerance bands: {one_line(exc)}")
        if mode == "bands" and self.bands is not None:
            bands = {
                "codes": self.bands["codes"],
                "rows": band_legend(self.bands["counts"], self.bands["tolerance"], s.ins_unit),
            }
        self.view.legend = self._legend_spec() if mode == "colour" else None
        self.view.show_deviations(self.prepared, limit, s.ins_unit, mode, bands, reset_camera=reset_camera)
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
        if s.ins_mode == "bands" or (s.ins_mode == "colour" and s.ins_legend_kind == "tolerance"):
            self._draw(s.ins_mode if tol else "colour")
        if s.ins_picked and s.ins_picked.get("found"):
            self.pick_index(int(s.ins_picked["index"]), label=False)
