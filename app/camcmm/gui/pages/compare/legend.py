"""The colour legend of the "Compare with CAD" page's deviation map: continuous, stepped
in n bands over ±the colour limit, or n bands over ±tolerance with the out-of-tolerance
colours (the arithmetic is :func:`camcmm.gui.viewtools.legend_spec`).

:class:`Legend` is a part of :class:`.page.ComparePage`, made with the page it serves
(its ``state``, the comparison shown, the tolerance); loop thread.
"""

from __future__ import annotations

from typing import Any

from ...viewtools import LEGENDS, legend_spec
from .tables import fmt_len

MIN_BANDS, MAX_BANDS = 2, 32


class Legend:
    """The legend's kind and bands on ``page``."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state

    def spec(self) -> dict[str, Any] | None:
        s = self.state
        limit = float((self.page.outputs or {}).get("colour_limit") or 1e-3)
        kind = s.ins_legend_kind if s.ins_legend_kind in LEGENDS else "continuous"
        tol = self.page.inputs.tolerance(quiet=True)
        spec = legend_spec(kind, int(s.ins_legend_n), limit, tol)
        unit = s.ins_unit
        if spec["edges"]:
            step = spec["edges"][1] - spec["edges"][0]
            span = f"±{fmt_len(spec['clim'][1], unit)}"
            extra = ", beyond: out of tolerance" if spec["above"] else ""
            s.ins_limit_text = f"{len(spec['edges']) - 1} bands of {fmt_len(step, unit)} over {span}{extra}"
        else:
            s.ins_limit_text = f"colours saturate at ±{fmt_len(limit, unit)}"
        return spec

    def set(self, kind: Any = None, n: Any = None) -> None:
        """A new legend kind ("continuous", "stepped", "tolerance") and/or number of bands;
        the colour map is drawn again with it."""
        s = self.state
        if kind is not None:
            if kind not in LEGENDS:
                self.page.error(f"legend {kind!r}: choose one of {', '.join(LEGENDS)}")
                return
            if kind == "tolerance" and not self.page.inputs.tolerance(quiet=True):
                self.page.error("a tolerance legend needs a tolerance: enter one (mm)")
                kind = "stepped"
            s.ins_legend_kind = kind
        if n is not None:
            try:
                k = int(float(n))
            except (TypeError, ValueError):
                self.page.error(f"legend bands: {n!r} is not a whole number")
                return
            if not MIN_BANDS <= k <= MAX_BANDS:
                self.page.error(f"legend bands: {k} is outside {MIN_BANDS}…{MAX_BANDS}")
                return
            s.ins_legend_n = k
        if self.page.outputs is not None and s.ins_mode == "colour":
            self.page.display.draw("colour")
