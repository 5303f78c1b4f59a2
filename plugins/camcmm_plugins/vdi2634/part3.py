"""VDI/VDE 2634 part 3: multi-view systems, as the thesis adapted it for a single
camera on a turntable with laser-speckle texture (ch. 2.7.2, 4.4, 4.5).

* P_F, P_S: the probing sphere from five camera positions (ch. 4.5.1), its
  reconstruction scaled by the calibrated radii of ball-plate spheres beside it
  (``scaling: {sphere: radii}``) or metric already (``none``).
* SD: the ball plate of three spheres gives three calibrated lengths in 7
  orientations (fig. 4.4), scaled by eqs. 4.10-4.12 (``scaling: {ball_plate: lengths}``),
  by calibrated radii, or not at all. A ball bar may be added (7 orientations).
* F: a flat, when the plan gives mpe.F or flat measurements (6 orientations).
* Every test repeated ``repeats`` times (default 3, ISO 10360-8 as in ch. 4.4).
* The outlier rule is the plan's (``outliers: {sphere: "percent:5"}`` reproduces the
  thesis's 5 % removal, ch. 4.5.1); default ``vdi2634``.

Besides the verdicts the result gives, as the thesis's tables 4.1 and 4.2 do, the
mean, spread and ISO 15530-3 expanded uncertainty of the sphere size, form and of
each length: U = k sqrt(u_cal² + u_p²) (eq. 4.1 with u_b = u_w = 0, as the thesis
argues: reconstructions are scaled by the calibrated workpiece itself).
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

import numpy as np

from camcmm.api import InputError

from . import plan as plans
from .standard import Standard, TestSpec

DEFAULT_REPEATS = 3


def _stats(values: list[float], u_cal: float, reference: float | None) -> dict[str, Any]:
    v = np.asarray([x for x in values if x is not None], dtype=float)
    if len(v) == 0:
        return {"n": 0}
    sd = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
    out = {
        "n": int(len(v)),
        "mean": float(v.mean()),
        "std": sd,
        "U_iso15530_3": 2 * math.sqrt(u_cal**2 + (sd if math.isfinite(sd) else 0.0) ** 2),
    }
    if reference is not None:
        out["calibrated"] = reference
        out["mean_deviation"] = float(v.mean() - reference)
    return out


class Part3(Standard):
    id = "vdi2634-3"
    part = 3
    title = "VDI/VDE 2634 part 3"
    specs = (
        TestSpec("sphere", "Sphere positions", ("PF", "PS"), 5),
        TestSpec("ball_plate", "Ball plate orientations", ("SD",), 7),
        TestSpec("ball_bar", "Ball bar orientations", ("SD",), 7, required=False),
        TestSpec("flat", "Flat orientations", ("F",), 6, required=False),
    )

    def check_plan(self, plan: plans.Plan) -> None:
        super().check_plan(plan)
        if plan.scaling.get("sphere") == "radii" and "ball_plate" not in plan.artefacts:
            raise InputError(
                f"{plan.source}: scaling.sphere is radii but artefacts.ball_plate (the scale spheres) is missing"
            )
        if plan.scaling.get("ball_bar") == "lengths":
            raise InputError(
                f"{plan.source}: scaling.ball_bar cannot be lengths (a ball bar has one length); use radii or none"
            )

    def repeats(self, plan: plans.Plan | None) -> int:
        return DEFAULT_REPEATS if plan is None or plan.repeats is None else plan.repeats

    def extra(self, p: plans.Plan, per: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
        ok = {t: [e for e in evs if not e.get("error")] for t, evs in per.items()}
        out: dict[str, Any] = {"repeats": self.repeats(p), "scaling": {t: p.scaling.get(t, "none") for t in per}}
        by_pos: dict[str, list[dict[str, Any]]] = {}
        for test, evs in ok.items():
            groups: dict[Any, list] = defaultdict(list)  # by position (or file)
            for e in evs:
                groups[e.get("position") or e.get("file")].append(e)
            by_pos[test] = [
                {
                    "position": pos,
                    "repeats": [e.get("repeat") for e in g],
                    "values": {k: [e["values"][k] for e in g] for k in g[0]["values"]},
                }
                for pos, g in groups.items()
            ]
        out["repeat_values"] = by_pos
        if ok.get("ball_plate"):
            certs = [p.required_certificate("ball_plate", f"length_{i}") for i in (1, 2, 3)]
            out["lengths"] = []
            for i, c in enumerate(certs):
                vals = [e["lengths"][i] for e in ok["ball_plate"]]
                st = _stats(vals, c.standard_uncertainty, c.value)
                st.update({"name": f"L{i + 1}", "values": vals})
                out["lengths"].append(st)
        if ok.get("sphere"):
            d = p.required_certificate("sphere", "diameter")
            size = _stats([e["diameter"] for e in ok["sphere"]], d.standard_uncertainty, d.value)
            stds = [e["form"]["std"] for e in ok["sphere"]]
            form = {
                "n": len(stds),
                "mean_std": float(np.mean(stds)),
                "U_iso15530_3": 2 * math.sqrt(d.standard_uncertainty**2 + float(np.mean(stds)) ** 2),
            }
            out["iso15530_3"] = {
                "size": size,
                "form": form,
                "note": "U = k sqrt(u_cal^2 + u_p^2), thesis eq. 4.1 with u_b = u_w = 0",
            }
        return out


#: The manifest entry: ``camcmm_plugins.vdi2634.part3:PART3``.
PART3 = Part3()
