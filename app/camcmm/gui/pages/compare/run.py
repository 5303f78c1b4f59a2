"""Showing a comparison on the "Compare with CAD" page: the view first (so its image is
on its way while the numbers and charts are made), then the statistics, the alignment,
the tolerance bands, the histogram and the Abbott-Firestone curve; the tolerance and the
display mode follow the operator after the run.

The tolerance bands beside the plugin's outputs come from a plugin too (task
``tolerance-bands``). :class:`Display` is a part of :class:`.page.ComparePage`, made with
the page it serves (its ``state``, ``view``, ``tools``, the comparison shown, its
inputs, section and legend); loop thread.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from ....errors import InputError, one_line
from ....host import RunResult
from ...view import fmt_count
from .figures import empty_figure, histogram_figure, material_ratio_figure
from .scene import Prepared
from .tables import alignment_rows, band_legend, display_unit, fmt_len, legend_title, stats_rows

log = logging.getLogger("camcmm.gui.compare")

BANDS_TASK = "tolerance-bands"


class Display:
    """The comparison shown by ``page``: drawn, its numbers, its bands, mode and tolerance."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.view = page.view

    def show(
        self, result: RunResult, prep: Prepared, timing: dict[str, float] | None = None, mode: str | None = None
    ) -> None:
        """Publish a comparison (fresh or restored) and draw it — the view first, so that
        its image is on its way while the numbers and charts are made. Loop thread."""
        s = self.state
        if timing:
            self.page.timing = dict(timing)
            self.page.timing["loop"] = time.time()
        o = result.outputs
        self.page.result, self.page.outputs = result, o
        self.page.deviations = o["deviations"]
        self.page.prepared = prep
        self.page.spacing_mm = None
        self.page.bands = None
        limit = float(o.get("colour_limit") or 0.0) or 1e-3
        unit, _ = display_unit(limit)
        converged = bool(o.get("converged"))
        tol = self.page.inputs.tolerance(quiet=True)
        if tol is None and o.get("stats", {}).get("tolerance") is not None:
            tol = float(o["stats"]["tolerance"])
            s.ins_tolerance = tol
        s.ins_unit = unit
        s.ins_has_result = True
        s.ins_failed = not converged
        s.ins_failed_reason = "" if converged else (o.get("reason") or "the alignment did not converge")
        s.ins_legend_title = legend_title(unit)
        s.ins_limit_text = f"colours saturate at ±{fmt_len(limit, unit)}"
        self.page.tools.clear_labels()  # labels picked on the comparison shown before
        s.ins_warnings = [str(w) for w in (result.warnings or [])][:12]
        s.ins_alignment = alignment_rows(o, unit)
        s.ins_picked = None
        s.ins_title = (
            f"{self.page.inputs.name(s.ins_measured)} against {self.page.inputs.name(s.ins_nominal)} — "
            f"{fmt_count(self.page.deviations.n_points)} points, "
            f"alignment {o.get('alignment', {}).get('method', '')}"
        )
        s.ins_running = False
        s.ins_progress = 100.0
        s.ins_progress_message = "done" if converged else "done — the alignment FAILED"
        if converged:
            wanted = mode or (s.ins_mode if s.ins_mode in ("colour", "bands") else "colour")
            if wanted == "bands" and not tol:
                wanted = "colour"
            self.draw(wanted, reset_camera=True)
            if timing:
                self.page.timing["drawn"] = time.time()
            self.publish_numbers(tol)
        else:
            s.ins_stats, s.ins_bands = [], []
            why = f"alignment failed: {s.ins_failed_reason}"
            s.ins_fig_hist = empty_figure(why)
            s.ins_fig_af = empty_figure(why)
            s.ins_fig_section = empty_figure(why)
            s.ins_mode = "failed"
            self.view.show_failed(prep, self.page.nominal, reset_camera=True)
            s.ins_note = self.view.note
        self.page.sections.set_range(centre=True)
        if timing:
            self.page.timing.setdefault("drawn", time.time())
            self.page.timing["numbers"] = time.time()
            s.ins_timing = dict(self.page.timing)

    def update_bands(self, tol: float | None) -> None:
        """The plugin's tolerance bands of the whole deviations cloud for ``tol`` (mm):
        ``self.page.bands = {"tolerance", "codes" (N,), "counts", "within"}``, None without a
        tolerance. Made once per tolerance."""
        if not tol or self.page.deviations is None:
            self.page.bands = None
            return
        if self.page.bands is not None and self.page.bands["tolerance"] == tol:
            return
        spec = self.page.host.provider(BANDS_TASK)
        out = self.page.host.run(spec.id, {"deviations": self.page.deviations}, {"tolerance": tol}).outputs
        self.page.bands = {
            "tolerance": tol,
            "codes": np.asarray(out["codes"]),
            "counts": dict(out["counts"]),
            "within": float(out["within"]),
        }

    def publish_numbers(self, tol: float | None) -> None:
        """Statistics, bands, histogram and curve for the current tolerance."""
        s = self.state
        o = self.page.outputs or {}
        unit = s.ins_unit
        try:
            self.update_bands(tol)
        except Exception as exc:
            log.exception("tolerance bands")
            self.page.bands = None
            self.page.error(f"tolerance bands: {one_line(exc)}")
        within = self.page.bands["within"] if self.page.bands else None
        s.ins_stats = stats_rows(o, unit, tol, within)
        s.ins_bands = band_legend(self.page.bands["counts"], tol, unit) if self.page.bands and tol else []
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

    def draw(self, mode: str, reset_camera: bool = False) -> None:
        s = self.state
        if self.page.prepared is None or self.page.outputs is None:
            return
        limit = float(self.page.outputs.get("colour_limit") or 1e-3)
        bands = None
        if mode == "bands":
            try:
                self.update_bands(self.page.inputs.tolerance(quiet=True))
            except Exception as exc:
                self.page.error(f"tolerance bands: {one_line(exc)}")
        if mode == "bands" and self.page.bands is not None:
            bands = {
                "codes": self.page.bands["codes"],
                "rows": band_legend(self.page.bands["counts"], self.page.bands["tolerance"], s.ins_unit),
            }
        self.view.legend = self.page.legend.spec() if mode == "colour" else None
        self.view.show_deviations(self.page.prepared, limit, s.ins_unit, mode, bands, reset_camera=reset_camera)
        s.ins_mode = self.view.scene
        s.ins_note = self.view.note
        if s.ins_section_axis and s.ins_fig_section.get("data"):
            self.view.set_section_plane(s.ins_section_axis, float(s.ins_section_pos), self.page.deviations.bounds)

    def set_mode(self, mode: str) -> None:
        """The view's mode: colour | bands | inputs."""
        s = self.state
        if mode == "gdt":  # the characteristics' flags (the panel's evaluation)
            self.page.gdt.show()
            return
        if mode not in ("colour", "bands", "inputs"):  # the toggle's button pressed again
            s.ins_mode = self.view.scene if self.view.scene != "empty" else "inputs"
            s.dirty("ins_mode")
            return
        if mode == "inputs":
            self.page.inputs.show_inputs(reset_camera=False)
            return
        if self.page.deviations is None:
            s.ins_mode = "inputs"
            return
        if s.ins_failed:
            self.page.error("the alignment failed: the deviations are not valid, so they are not coloured")
            s.ins_mode = "failed"
            self.view.show_failed(self.page.prepared, self.page.nominal, reset_camera=False)
            return
        if mode == "bands" and not self.page.inputs.tolerance(quiet=True):
            self.page.error("tolerance bands need a tolerance: enter one (mm)")
            mode = "colour"
        self.draw(mode)

    def set_tolerance(self, value: Any) -> None:
        """A new tolerance after the run: bands, the share within, the charts follow."""
        s = self.state
        s.ins_tolerance = value
        try:
            tol = self.page.inputs.tolerance()
        except InputError as exc:
            self.page.error(exc)
            return
        s.ins_error = ""
        if self.page.deviations is None or s.ins_failed:
            return
        self.publish_numbers(tol)
        if s.ins_mode == "bands" or (s.ins_mode == "colour" and s.ins_legend_kind == "tolerance"):
            self.draw(s.ins_mode if tol else "colour")
        if s.ins_picked and s.ins_picked.get("found"):
            self.page.inputs.pick_index(int(s.ins_picked["index"]), label=False)
