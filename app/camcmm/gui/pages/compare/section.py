"""The section of the "Compare with CAD" page: a plane across an axis at a position
cuts the part; the nominal's cut (polylines of a mesh, points of a reference cloud) and
the measured points within ± half their spacing of the plane, coloured by deviation,
are drawn as a 2-D chart, and the plane's outline in the 3D view.

The cut is made by the plugin providing the task ``deviation-section``; this module
publishes it. :class:`Section` is a part of :class:`.page.ComparePage`, made with the
page it serves (its ``state``, ``host``, ``view`` and the comparison shown); loop thread.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from ....errors import one_line
from .figures import section_figure
from .scene import AXES

log = logging.getLogger("camcmm.gui.compare")

SECTION_TASK = "deviation-section"


class Section:
    """The section plane, its range and its chart on ``page``."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.view = page.view
        # the axis the slider's range was set for: the browser shows a clicked axis at once
        # (the toggle writes the state itself, see layout._section_controls), so the state's
        # axis can be the new one already when the click arrives and cannot tell a change
        self.range_axis: str | None = None

    def auto(self) -> None:
        """The section through the middle, once a valid result is shown."""
        if self.page.deviations is not None and not self.state.ins_failed:
            self.set_section()

    def spacing(self) -> float:
        """The median point spacing of the deviations cloud (mm), as the section plugin
        measured it (0 without a result)."""
        if self.page.spacing_mm is None and self.page.deviations is not None:
            self.set_section()
        return self.page.spacing_mm or 0.0

    def bounds(self) -> np.ndarray | None:
        if self.page.deviations is None:
            return None
        b = self.page.deviations.bounds
        if self.page.nominal is not None and hasattr(self.page.nominal, "bounds"):
            nb = np.asarray(self.page.nominal.bounds, dtype=float)
            b = np.vstack([np.minimum(b[0], nb[0]), np.maximum(b[1], nb[1])])
        return b

    def set_range(self, centre: bool = False) -> None:
        s = self.state
        b = self.bounds()
        if b is None:
            return
        self.range_axis = s.ins_section_axis or "z"
        ax = AXES.index(self.range_axis)
        lo, hi = float(b[0, ax]), float(b[1, ax])
        step = (hi - lo) / 200.0 or 0.01
        s.ins_section_range = [lo, hi, float(f"{step:.3g}")]
        if centre or not lo <= float(s.ins_section_pos or 0.0) <= hi:
            s.ins_section_pos = float(f"{0.5 * (lo + hi):.6g}")

    def set_section(self, axis: str | None = None, position: float | None = None) -> dict[str, Any] | None:
        """Cut the part by the plane axis = position; publish the 2-D chart and show the
        plane in the view."""
        s = self.state
        if axis is not None and axis in AXES and axis != self.range_axis:
            s.ins_section_axis = axis
            self.set_range(centre=True)
        if position is not None:
            s.ins_section_pos = float(position)
        if self.page.deviations is None:
            return None
        if s.ins_failed:  # the unaligned distances are no deviations: no section of them
            self.page.error("the alignment failed: the deviations are not valid, so no section is drawn")
            return None
        try:
            spec = self.page.host.provider(SECTION_TASK)
            inputs = {"deviations": self.page.deviations}
            if self.page.nominal is not None:
                inputs["nominal"] = self.page.nominal
            params = {"axis": s.ins_section_axis, "position": float(s.ins_section_pos)}
            if self.page.spacing_mm is not None:  # measured once per result: the slab is half of it
                params["half_width"] = 0.5 * self.page.spacing_mm
            out = self.page.host.run(spec.id, inputs, params).outputs
            if out.get("spacing") is not None:
                self.page.spacing_mm = float(out["spacing"])
            sec = out["section"]
            s.ins_fig_section = section_figure(sec, s.ins_unit, float(self.page.outputs.get("colour_limit") or 1e-3))
        except Exception as exc:
            log.exception("section")
            self.page.error(f"section: {one_line(exc)}")
            return None
        if s.ins_mode in ("colour", "bands", "failed"):
            self.view.set_section_plane(s.ins_section_axis, float(s.ins_section_pos), self.bounds())
        return sec
