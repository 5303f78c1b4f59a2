"""What a comparison on the "Compare with CAD" page takes: the plugin's form, the
measured cloud and the nominal chosen among the project's items, the alignment method,
the tolerance, and the point pairs clicked in the 3D view (also a click on a result:
the deviation of the point under it).

:class:`Inputs` is a part of :class:`.page.ComparePage`, made with the page it serves
(its ``state``, ``session``, ``view``, ``tools``, the comparison shown and ``error``);
its :meth:`Inputs.request` is the :class:`~camcmm.tasks.compare.CompareRequest` the
page's task runs. Loop thread only.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ....errors import InputError, one_line
from ....host import to_jsonable
from ....params import form_schema
from ....tasks.compare import MAIN_PARAMS, N_PAIRS, TASK, CompareRequest, parse_tolerance
from ....units import decide_unit, object_span
from .tables import BANDS, _num, fmt_len

__all__ = ["ALIGN_TITLES", "MAIN_PARAMS", "N_PAIRS", "TASK", "Inputs"]

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


class Inputs:
    """The form, the inputs scene, point pairs and picking of ``page``."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.session = page.session
        self.view = page.view
        self.measured_pairs: list[list[float]] = []
        self.nominal_pairs: list[list[float]] = []

    def _error(self, msg: Any) -> None:
        self.page.error(msg)

    # -- inputs --------------------------------------------------------------------------
    def refresh_inputs(self) -> None:
        """The form: alignment choices and parameters from the manifest; default items."""
        s = self.state
        try:
            spec = self.page.task.spec
        except Exception as exc:  # a host without it (or a test's fake host): the page says so
            s.ins_error = f"no plugin to compare with CAD ({TASK}) is available: {one_line(exc)}"
            return
        if not s.ins_fields:
            fields, values = [], {}
            for f in form_schema(spec.parameters):
                if f["name"] == "align":
                    s.ins_align_options = [
                        {"title": ALIGN_TITLES.get(c, c), "value": c} for c in f.get("choices") or []
                    ]
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
                values[f["name"]] = (
                    bool(default)
                    if f["widget"] == "switch"
                    else (
                        ""
                        if default is None
                        else (", ".join(str(x) for x in default) if isinstance(default, list) else to_jsonable(default))
                    )
                )
                fields.append(d)
            s.ins_fields = fields
            s.ins_params = values
        items = list(s.items or [])
        clouds = [it["id"] for it in items if it.get("kind") == "pointcloud"]
        geoms = [it["id"] for it in items if it.get("kind") in ("pointcloud", "mesh", "cad")]
        if s.ins_measured not in clouds:
            s.ins_measured = clouds[0] if clouds else None
        if s.ins_nominal not in geoms:
            # an exact CAD model first: a mesh's facets bias every deviation by up to its
            # chordal error (the demo's icosphere: 11 um), the B-rep's surface does not
            exact = [it["id"] for it in items if it.get("kind") == "cad"]
            meshes = [it["id"] for it in items if it.get("kind") == "mesh"]
            others = [g for g in geoms if g != s.ins_measured]
            s.ins_nominal = (exact + meshes + others + [None])[0]

    def name(self, key: Any) -> str:
        m = self.session.measurement(key)
        return str(m.get("name") or key) if m else str(key)

    def load(self, key: Any, what: str) -> Any:
        if key in (None, ""):
            raise InputError(f"choose the {what} first (import it with the Import field)")
        return self.session.load(str(key))

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
        if getattr(self.page, "gdt", None) is not None:
            self.page.gdt.stop_picking()  # the clicks are the pairs' again
        try:
            measured = self.load(s.ins_measured, "measured cloud") if s.ins_measured else None
            nominal = self.load(s.ins_nominal, "nominal") if s.ins_nominal else None
        except Exception as exc:
            self._error(exc)
            return False
        if measured is not None and not hasattr(measured, "points"):
            self._error(f"{self.name(s.ins_measured)} is not a point cloud")
            return False
        self.page.measured, self.page.nominal = measured, nominal
        note = self.unit_note(measured, nominal)
        if note:  # shown, not refused: the user may know better (a scan of a small detail)
            self._error(note)
        self.view.show_inputs(measured, nominal, self._pair_markers(), reset_camera=reset_camera, push=push)
        s.ins_mode = "inputs"
        s.ins_note = self.view.note
        s.ins_legend_title = ""
        self._pick_hint()
        return True

    def unit_note(self, measured: Any, nominal: Any) -> str:
        """The unit question of camcmm.units with the nominal's size as the expected one:
        a measured cloud 1000 times smaller or larger than its CAD model was imported in
        the wrong unit (or the model was). "" when the sizes agree (docs/units.md)."""
        if measured is None or nominal is None or not hasattr(measured, "points"):
            return ""
        expected = float(np.linalg.norm(object_span(nominal)))
        if not expected > 0:
            return ""
        unit = getattr(measured, "source_unit", "mm") or "mm"
        name = self.name(self.state.ins_measured)
        check = decide_unit(object_span(measured), unit, unit=unit, expected=expected, name=name, what="nominal")
        if not check.asks:
            return ""
        return (
            f"{check.reason.replace(': give its unit', '')}; import it again with its unit "
            f"(or the nominal {self.name(self.state.ins_nominal)}, if that is the one in another unit)"
        )

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
        for i, p in enumerate(self.measured_pairs):
            out.append({"point": p, "label": f"M{i + 1}", "colour": PAIR_COLOURS["measured"]})
        for i, p in enumerate(self.nominal_pairs):
            out.append({"point": p, "label": f"N{i + 1}", "colour": PAIR_COLOURS["nominal"]})
        return out

    def _publish_pairs(self) -> None:
        rows = []
        for i in range(max(len(self.measured_pairs), len(self.nominal_pairs))):
            m = self.measured_pairs[i] if i < len(self.measured_pairs) else None
            n = self.nominal_pairs[i] if i < len(self.nominal_pairs) else None
            fmt = lambda p: "(" + ", ".join(f"{c:.2f}" for c in p) + ")"
            rows.append(
                {
                    "i": i + 1,
                    "measured": fmt(m) if m else "…",
                    "nominal": fmt(n) if n else "…",
                    "complete": m is not None and n is not None,
                }
            )
        self.state.ins_pairs = rows
        self._pick_hint()

    def _pick_hint(self) -> None:
        s = self.state
        if not self.pairs_method():
            s.ins_pick_hint = ""
            return
        nm, nn = len(self.measured_pairs), len(self.nominal_pairs)
        if nm >= N_PAIRS and nn >= N_PAIRS:
            s.ins_pick_hint = "three pairs picked: Run aligns with them"
        elif nm <= nn:
            s.ins_pick_hint = f"pair {nm + 1}: click a point on the measured cloud (orange)"
        else:
            s.ins_pick_hint = f"pair {nn + 1}: click the same point on the nominal (grey)"

    def pairs(self) -> dict[str, list[list[float]]] | None:
        """The picked pairs as the plugin takes them (complete pairs only)."""
        k = min(len(self.measured_pairs), len(self.nominal_pairs))
        if k == 0:
            return None
        return {"measured": self.measured_pairs[:k], "nominal": self.nominal_pairs[:k]}

    def set_pairs(self, pairs: dict[str, Any] | None) -> None:
        """The pairs as the task's record keeps them (``{"measured", "nominal"}``), shown."""
        pairs = pairs or {}
        self.measured_pairs = [list(map(float, p)) for p in pairs.get("measured") or []]
        self.nominal_pairs = [list(map(float, p)) for p in pairs.get("nominal") or []]
        self._publish_pairs()

    def add_pair_point(self, which: str, point: Any) -> None:
        """Record a picked point of a pair (also used by tests and scripts)."""
        p = [float(c) for c in np.asarray(point, dtype=float).ravel()[:3]]
        (self.measured_pairs if which == "measured" else self.nominal_pairs).append(p)
        self._publish_pairs()
        if self.view.scene == "inputs":
            self.view.set_markers(self._pair_markers())

    def clear_pairs(self, render: bool = True) -> None:
        self.measured_pairs, self.nominal_pairs = [], []
        self._publish_pairs()
        if render and self.view.scene == "inputs":
            self.view.set_markers([])

    def undo_pair_point(self) -> None:
        if len(self.measured_pairs) > len(self.nominal_pairs):
            self.measured_pairs.pop()
        elif self.nominal_pairs:
            self.nominal_pairs.pop()
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
            self._error(f"pick: {one_line(exc)}")
            return None
        return self.pick_display(x, y)

    def pick_display(self, x: float, y: float) -> dict[str, Any] | None:
        """As :meth:`pick_at` with display pixels (x right, y up)."""
        s = self.state
        scene = self.view.scene
        gdt = getattr(self.page, "gdt", None)
        if gdt is not None and gdt.picking and scene == "inputs":  # a feature picked on the nominal
            return gdt.pick(x, y)
        if scene == "inputs":
            if not self.pairs_method():
                s.ins_pick_hint = "choose a 'pairs' alignment to pick point pairs; after Run, a click shows a deviation"
                return None
            nm, nn = len(self.measured_pairs), len(self.nominal_pairs)
            if nm >= N_PAIRS and nn >= N_PAIRS:
                s.ins_pick_hint = "three pairs are picked; Clear them to pick again"
                return None
            which = "measured" if nm <= nn else "nominal"
            p = self.view.pick_input(which, x, y)
            if p is None:
                s.ins_pick_hint = (
                    f"no point of the {which} {'cloud' if which == 'measured' else ''} there; click on it"
                ).replace("  ", " ")
                return None
            self.add_pair_point(which, p)
            return {"which": which, "point": p.tolist()}
        if scene in ("colour", "bands", "failed") and self.page.deviations is not None:
            i = self.view.pick_deviation(x, y)
            if i is None:
                s.ins_picked = {"text": "no point there", "found": False}
                return None
            return self.pick_index(i)
        return None

    def pick_index(self, i: int, label: bool = True) -> dict[str, Any]:
        """Show the deviation of point ``i`` of the deviations cloud (and, with ``label``,
        add a label that stays in the view)."""
        cloud = self.page.deviations
        p = np.asarray(cloud.points[i], dtype=float)
        d = float(np.asarray(cloud.fields["deviation"])[i])
        unit = self.state.ins_unit
        valid = not self.state.ins_failed
        info = {
            "found": True,
            "index": int(i),
            "x": float(p[0]),
            "y": float(p[1]),
            "z": float(p[2]),
            "deviation_mm": d,
            "deviation": fmt_len(d, unit, True, 4),
            "coords": "(" + ", ".join(_num(float(c), 6) for c in p) + ") mm",
            "valid": valid,
        }
        bands = self.page.bands
        if bands is not None:
            info["band"] = BANDS[int(bands["codes"][i])][0]
        info["text"] = f"point #{i}: {info['coords']}, deviation {info['deviation']}" + (
            "" if valid else " (alignment failed: not a valid deviation)"
        )
        self.state.ins_picked = info
        # a label that stays (with the others picked); no deviation when the alignment failed
        if label:
            self.page.tools.add_label(p, d if valid else None, unit)
        return info

    # -- the request ----------------------------------------------------------------------
    def tolerance(self, quiet: bool = False) -> float | None:
        """The tolerance in the field (mm; None: none); InputError unless ``quiet``."""
        return parse_tolerance(self.state.ins_tolerance, quiet)

    def request(self, params: dict[str, Any] | None = None) -> CompareRequest:
        """The form as the task's request (``params``: the "More" parameters, else the form's)."""
        s = self.state
        return CompareRequest(
            measured=s.ins_measured,
            nominal=s.ins_nominal,
            align=str(s.ins_align),
            tolerance=self.tolerance(),
            params=dict(params if params is not None else (s.ins_params or {})),
            pairs=self.pairs(),
        )
