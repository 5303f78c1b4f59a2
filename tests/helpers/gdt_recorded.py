"""A stand-in provider of ``gdt-evaluation`` with the outputs of the contract in
notes/gdt-design.md (features, datums, alignment, characteristics, labels, aligned), for
the task's and the panel's tests of storing, restoring, showing and reporting — what they
do with an evaluation does not depend on how it was computed.

Its numbers are real for the sphere it is given: the plan's sphere feature is fitted by
``fit.sphere`` (least squares) through the host, the diameter characteristic is the fitted
diameter (its limits deviations from the nominal, as the plugin's), the profile twice the
largest radial residual; the verdicts follow from them by ISO 14253-1 with U = 2·u.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.host import PluginHost
from camcmm.manifest import PluginSpec, Port
from camcmm.model import PointCloud
from camcmm.params import Param

PLUGIN_ID = "lab.gdt"


def spec(outputs: tuple[str, ...] = ("features", "datums", "alignment", "characteristics", "labels", "aligned")):
    """The stand-in's manifest (it provides ``gdt-evaluation``)."""
    types = {"aligned": "pointcloud"}
    return PluginSpec(
        PLUGIN_ID,
        "algorithm",
        "recorded GD&T",
        "0.1",
        "",
        "helpers.gdt_recorded:evaluate",
        parameters=[
            Param("align", "choice", default="best-fit", choices=["best-fit", "datums", "rps", "3-2-1", "none"])
        ],
        inputs=[Port("cloud", "pointcloud"), Port("plan", "json"), Port("nominal", "geometry", optional=True)],
        outputs=[Port(o, types.get(o, "json")) for o in outputs],
        distribution="lab",
        provides=["gdt-evaluation"],
        report="camcmm_plugins.gdt.report:build_report",  # camcmm's writer reads the contract's outputs
    )


class RecordedHost(PluginHost):
    """The installed plugins plus the stand-in; not a plain PluginHost, so its runs stay in
    this process (a worker could not rebuild the stand-in)."""

    def __init__(self, plugin: PluginSpec | None = None):
        super().__init__()
        self.plugins[PLUGIN_ID] = plugin or spec()


def _verdicts(value: float, u: float, lo: float, hi: float) -> tuple[str, str]:
    simple = "conform" if lo <= value <= hi else "not conform"
    U = 2.0 * u
    if lo + U <= value <= hi - U:
        return simple, "conform"
    if value < lo - U or value > hi + U:
        return simple, "not conform"
    return simple, "undecided"


def evaluate(ctx: Any, cloud: Any, plan: dict, nominal: Any = None, align: str = "best-fit") -> dict[str, Any]:
    P = np.asarray(cloud.points, dtype=float)
    fid, f = next((k, v) for k, v in plan["features"].items() if v["type"] == "sphere")
    fit = ctx.algorithm("fit.sphere")(cloud=PointCloud(P, name="s"))
    centre, radius = np.asarray(fit["center"], float), float(fit["radius"])
    aligned = P - centre + np.asarray(f["centre"], float)  # a best fit of a sphere: its centre
    res = np.linalg.norm(aligned - np.asarray(f["centre"], float), axis=1) - 0.5 * float(f["diameter"])
    u_r = float(fit["std_uncertainty"]["radius"])
    chars, labels = [], []
    for c in plan["characteristics"]:
        if c["type"] == "diameter":  # the size itself; its limits are deviations from the nominal
            value = 2 * radius
            nominal = float(f["diameter"])
            u, tol, dec = 2 * u_r, None, [int(np.argmax(res))]
            lo, hi = nominal + float(c["lower"]), nominal + float(c["upper"])
        else:
            value = float(np.ptp(res)) if c["type"] != "surface-profile" else 2 * float(np.abs(res).max())
            u, lo, hi, tol = float(res.std() / np.sqrt(len(res))), 0.0, float(c["tolerance"]), float(c["tolerance"])
            dec = [int(np.argmax(res)), int(np.argmin(res))]
        simple, guarded = _verdicts(value, u, lo, hi)
        chars.append(
            {
                "id": c["id"],
                "type": c["type"],
                "feature": c["feature"],
                "datums": list(c.get("datums") or []),
                "value": value,
                "unit": "mm",
                "tolerance": tol,
                "lower": c.get("lower"),
                "upper": c.get("upper"),
                "u": u,
                "U": 2 * u,
                "k": 2.0,
                "u_method": "covariance",
                "verdict": simple,
                "verdict_guarded": guarded,
            }
        )
        labels.append(
            {"id": c["id"], "anchor": aligned[dec[0]].tolist(), "decisive": aligned[dec].tolist(), "verdict": guarded}
        )
    return {
        "features": [
            {
                "id": fid,
                "type": "sphere",
                "association": "ls",
                "n_points": len(P),
                "params": {"centre": list(f["centre"]), "diameter": 2 * radius},
                "form": fit["form"],
                "status": "evaluated",
            }
        ],
        "datums": [],
        "alignment": {"method": align, "transform": np.eye(4).tolist()},
        "characteristics": chars,
        "labels": labels,
        "aligned": PointCloud(aligned, fields={"feature": np.zeros(len(P))}, name="aligned"),
    }
