"""LAB-1: a gauge block of calibrated length L_c in three positions; E = L_m - L_c.

L_m is the extent of the measured cloud along its principal axis (mm); the test's U is
the gauge block's calibration uncertainty (k = 2)."""

from pathlib import Path

import numpy as np

from camcmm.api import (
    ArtefactField,
    ArtefactKind,
    InputError,
    ParameterResult,
    PointCloud,
    PositionEvaluation,
    PositionSpec,
    QualityParameter,
    Report,
    StandardDeclaration,
    TestDeclaration,
    TestResult,
    read,
)

E = QualityParameter("E", "E", "Length error E", signed=True, help="measured minus calibrated length")
BLOCK = ArtefactKind(
    "gauge_block",
    "Gauge block",
    (
        ArtefactField(
            "length", "Length (calibrated)", min=0.5, max=1000, certificate="length", uncertainty="uncertainty"
        ),
        ArtefactField("uncertainty", "Its uncertainty U", min=0),
        ArtefactField("k", "Coverage factor k", unit="", min=1),
    ),
)
AXES = {"x": [1, 0, 0], "y": [0, 1, 0], "diagonal": [1, 1, 1]}
DECLARATION = StandardDeclaration(
    "lab-1",
    "LAB-1 length check",
    (E,),
    (BLOCK,),
    (TestDeclaration("gauge_block", "Gauge block positions", "gauge_block", ("E",), 3),),
    tuple(
        PositionSpec(
            "gauge_block",
            f"block-{a}",
            f"Block along {a}",
            "gauge_block",
            f"long axis along {a}, in the centre",
            placement={"direction": d},
        )
        for a, d in AXES.items()
    ),
)


class Lab1:
    def declare(self):
        return DECLARATION

    def requirements(self, plan=None):
        if plan is not None and "E" not in (plan.get("mpe") or {}):
            raise InputError("plan: mpe.E is missing; LAB-1 judges the length error E against it")
        if plan is not None and "length" not in (plan.get("artefacts") or {}).get("gauge_block", {}):
            raise InputError("plan: artefacts.gauge_block.length is missing")
        return DECLARATION.requirements_list((plan or {}).get("artefacts"))

    def evaluate_measurement(self, ctx, test, cloud, plan, *, file=None, position=None, repeat=None):
        cloud = cloud if isinstance(cloud, PointCloud) else read(Path(cloud))
        x = cloud.points - cloud.points.mean(axis=0)
        t = x @ np.linalg.svd(x, full_matrices=False)[2][0]
        length = float(np.ptp(t))
        e = length - float(plan["artefacts"]["gauge_block"]["length"])
        dev = PointCloud(
            cloud.points,
            fields={"deviation": np.full(cloud.n_points, e)},
            field_units={"deviation": "mm"},
            name=f"{file} deviations",
        )
        return PositionEvaluation(
            test,
            {"E": e},
            file,
            position,
            repeat or 1,
            fit=[{"name": "length", "value": f"{length:.4f} mm"}],
            fit_text=f"L {length:.4f} mm · {cloud.n_points} pts",
            deviations=dev,
            extra={"length": length},
        )

    def summarize(self, ctx, plan, per_measurement):
        evs = per_measurement.get("gauge_block") or []
        rows = [
            {
                "file": e.get("file"),
                "position": e.get("position"),
                "repeat": e.get("repeat", 1),
                "value": None if e.get("error") else e["values"]["E"],
            }
            for e in evs
        ]
        art = plan["artefacts"]["gauge_block"]
        e = ParameterResult.judge(E, rows, plan["mpe"]["E"], float(art.get("uncertainty") or 0.0), required=3)
        return TestResult(
            "lab-1",
            DECLARATION.title,
            {"E": e},
            measurements=per_measurement,
            warnings=[x["error"] for x in evs if x.get("error")],
        )

    def write_report(self, result, directory, plan=None):
        r = Report(DECLARATION.title, subtitle=(plan or {}).get("system", {}).get("name", ""))
        e = result["parameters"]["E"]
        s = r.section("Length error E")
        s.verdict("E", e["verdict"], e["verdict_guarded"], e["value"], e["mpe"], e["U"])
        s.table(["Position", "E [mm]"], [[x["position"], x["value"]] for x in e["per_measurement"]])
        r.data = {k: v for k, v in result.items() if k != "measurements"}
        return r.write(directory)


LAB1 = Lab1()
