"""VDI/VDE 2634 part 3 as the thesis adapted it (ch. 4.4-4.5): ball-plate scaling by
eqs. 4.10-4.12, scaling by calibrated radii, three repeats, configurable outlier rule."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import yaml

from camcmm.api import RunContext
from camcmm.host import default_host
from camcmm_plugins.vdi2634.scaling import ball_plate_lengths, by_radii

L_CAL = [5.942, 7.956, 9.957]  # thesis ch. 4.3, calibrated on a Zeiss F25
PLAN = {
    "standard": "vdi2634-3",
    "system": {"name": "turntable", "measuring_volume": [30, 30, 30]},
    "mpe": {"PF": 0.06, "PS": 0.03, "SD": 0.04},
    "artefacts": {
        "sphere": {"diameter": 10.0, "uncertainty": 0.0008, "k": 2},
        "ball_plate": {
            "sphere_diameter": 5.0,
            "sphere_diameter_uncertainty": 0.0008,
            "lengths": L_CAL,
            "uncertainty": 0.0003,
            "k": 2,
        },
    },
    "scaling": {"sphere": "radii", "ball_plate": "lengths"},
}


def test_eqs_4_10_to_4_12_by_hand():
    # a reconstruction at scale 0.37: every length recovered exactly
    l_rec = [0.37 * x for x in L_CAL]
    assert ball_plate_lengths(l_rec, L_CAL) == pytest.approx(L_CAL, abs=1e-12)
    # reconstructed lengths with their own errors: eqs. 4.10-4.12 written out by hand
    r1, r2, r3 = 2.2, 2.95, 3.68
    c1, c2, c3 = L_CAL
    want = [r1 * c3 / r3, r2 * c3 / r3, 0.5 * r3 * (c1 / r1 + c2 / r2)]
    assert ball_plate_lengths([r1, r2, r3], L_CAL) == pytest.approx(want, rel=1e-15)
    assert want[0] == pytest.approx(2.2 * 9.957 / 3.68)
    # each length is scaled by the *other* ones: an error in L_r,1 alone moves L_m,1 ...
    base = ball_plate_lengths(l_rec, L_CAL)
    bumped = ball_plate_lengths([l_rec[0] * 1.001, l_rec[1], l_rec[2]], L_CAL)
    assert bumped[0] == pytest.approx(base[0] * 1.001) and bumped[1] == pytest.approx(base[1])
    assert by_radii([1.25, 1.25], 2.5) == 2.0


# One xdist work unit (under --dist loadgroup each ungrouped test is scheduled alone): the five
# tests on `part3` then share one acceptance set and its evaluation (~35 s under load) instead
# of one per worker.
pytestmark = pytest.mark.xdist_group("vdi2634-part3")


@pytest.fixture(scope="module")
def ctx():
    return RunContext(default_host(), "vdi2634-3")


@pytest.mark.slow
def test_noise_free_ball_plate_at_scale_037_recovers_the_metric_lengths(ctx):
    sim = default_host().algorithm("virtuallab.artefact-cloud")
    std = default_host().load("vdi2634-3")
    for rotation, tilt in ((0, 0), (135, 0), (0, 30)):
        cloud = sim(
            artefact="ball_plate",
            sensor="turntable",
            noise=0.0,
            reconstruction_scale=0.37,
            n_points=4000,
            diameter=5.0,
            lengths=L_CAL,
            rotation=rotation,
            tilt=tilt,
        )["cloud"]
        ev = std.evaluate_measurement(ctx, "ball_plate", cloud, PLAN)
        assert ev["lengths_reconstructed"] == pytest.approx([0.37 * x for x in L_CAL], abs=1e-9)
        assert ev["lengths"] == pytest.approx(L_CAL, abs=1e-9)
        assert max(abs(x) for x in ev["values"]["SD"]) < 1e-9
        assert ev["scale"] == pytest.approx(1 / 0.37)


def test_noise_free_sphere_scaled_by_calibrated_radii(ctx):
    sim = default_host().algorithm("virtuallab.artefact-cloud")
    std = default_host().load("vdi2634-3")
    cloud = sim(
        artefact="sphere_with_scale",
        sensor="turntable",
        noise=0.0,
        reconstruction_scale=0.37,
        n_points=5000,
        diameter=10.0,
        scale_diameter=5.0,
    )["cloud"]
    ev = std.evaluate_measurement(ctx, "sphere", cloud, PLAN)
    assert ev["diameter"] == pytest.approx(10.0, abs=1e-9)
    assert ev["values"]["PS"] == pytest.approx(0.0, abs=1e-9)
    assert ev["values"]["PF"] < 1e-9
    assert [s["diameter"] for s in ev["scale_spheres"]] == pytest.approx([5.0, 5.0], abs=1e-9)


@pytest.fixture(scope="module")
def part3(tmp_path_factory):
    d = tmp_path_factory.mktemp("part3")
    default_host().run(
        "virtuallab.acceptance-set",
        {},
        {
            "directory": str(d),
            "standard": "vdi2634-3",
            "n_sphere": 2500,
            "n_ball_plate": 2500,
            "random_scale": True,
            "seed": 3,
        },
    )
    return d, default_host().run("vdi2634-3", {"plan": d / "plan.yaml"}).outputs


@pytest.mark.slow
def test_full_part3_set_with_three_repeats(part3):
    d, res = part3
    assert res["standard"] == "vdi2634-3"
    assert res["verdict"] == "pass", res["warnings"]
    assert set(res["parameters"]) == {"PF", "PS", "SD"}  # no flat planned: no F
    assert res["repeats"] == 3
    rows = res["parameters"]["SD"]["per_measurement"]
    assert len(rows) == 7 * 3 * 3  # 7 orientations x 3 repeats x 3 lengths
    assert {r["repeat"] for r in rows} == {1, 2, 3}
    assert {r["item"] for r in rows} == {"L1", "L2", "L3"}
    assert len(res["parameters"]["PS"]["per_measurement"]) == 5 * 3
    for length, cal in zip(res["lengths"], L_CAL):
        assert length["n"] == 21 and length["calibrated"] == cal
        assert abs(length["mean_deviation"]) < 0.002  # noise 8 um, no distortion
        assert length["U_iso15530_3"] == pytest.approx(2 * math.sqrt((0.0003 / 2) ** 2 + length["std"] ** 2))
    groups = res["repeat_values"]["ball_plate"]
    assert len(groups) == 7 and all(len(g["repeats"]) == 3 for g in groups)
    assert res["iso15530_3"]["size"]["n"] == 15


@pytest.mark.slow
def test_outlier_rule_is_the_plans(part3):
    d, res = part3
    ev = res["measurements"]["sphere"][0]
    n = ev["n_points"]
    assert ev["outliers"] == "percent:5"  # as the thesis, ch. 4.5.1
    assert ev["n_removed"] == math.floor(5 * n / 100)
    plan = yaml.safe_load((d / "plan.yaml").read_text())
    plan["base_dir"] = str(d)
    plan.pop("outliers")
    plan["measurements"] = {"sphere": plan["measurements"]["sphere"][:1]}
    res2 = default_host().load("vdi2634-3")(None, plan)
    ev2 = res2["measurements"]["sphere"][0]
    assert ev2["outliers"] == "vdi2634" and ev2["n_removed"] == (3 * ev2["n_points"]) // 1000


@pytest.mark.slow
def test_a_missing_repeat_makes_the_test_incomplete(part3):
    d, res = part3
    plan = yaml.safe_load((d / "plan.yaml").read_text())
    plan["base_dir"] = str(d)
    per = copy.deepcopy(res["measurements"])
    per["ball_plate"] = per["ball_plate"][:-1]
    out = default_host().load("vdi2634-3").summarize(None, plan, per)
    assert out["parameters"]["SD"]["verdict"] == "incomplete"
    assert "20 of the 21 ball plate measurements required" in out["parameters"]["SD"]["incomplete_reasons"][0]
    assert out["verdict"] == "incomplete"


@pytest.mark.slow
def test_requirements_for_part3(part3):
    d, _ = part3
    reqs = {r["test"]: r for r in default_host().load("vdi2634-3").requirements(d / "plan.yaml")}
    assert set(reqs) == {"sphere", "ball_plate"}
    assert reqs["sphere"]["repeats"] == 3 and reqs["sphere"]["min_count"] == 5
    assert reqs["sphere"]["positions"][0]["camera"] == {"azimuth": 0.0, "elevation": 45.0}
    assert reqs["ball_plate"]["positions"][6]["tilt"] == 30.0


@pytest.mark.slow
def test_scaling_uncertainty_enters_U(part3):
    _, res = part3
    sd = res["parameters"]["SD"]["uncertainty"]
    # L1 and L2 scaled by L3 (eqs. 4.10, 4.11): u(L_c,i) and L_c,i u(L_c,3)/L_c,3 in quadrature
    u = 0.0003 / 2
    want = [2 * math.hypot(u, c * u / L_CAL[2]) for c in L_CAL[:2]]
    assert sd["per_length"][:2] == pytest.approx(want)
    ps = res["parameters"]["PS"]["uncertainty"]
    assert ps["U"] == pytest.approx(2 * math.hypot(0.0004, 10.0 * 0.0004 / 5.0))
    assert np.isfinite(res["parameters"]["PS"]["U"])


def test_ball_bar_scaled_by_its_calibrated_spheres(ctx):
    sim = default_host().algorithm("virtuallab.artefact-cloud")
    plan = copy.deepcopy(PLAN)
    plan["artefacts"]["ball_bar"] = {
        "length": 20.0,
        "uncertainty": 0.0005,
        "sphere_diameter": 5.0,
        "sphere_diameter_uncertainty": 0.0008,
    }
    plan["scaling"]["ball_bar"] = "radii"
    cloud = sim(
        artefact="ball_bar",
        sensor="turntable",
        noise=0.0,
        reconstruction_scale=0.37,
        n_points=4000,
        diameter=5.0,
        length=20.0,
        direction=[1, 1, 0],
    )["cloud"]
    ev = default_host().load("vdi2634-3").evaluate_measurement(ctx, "ball_bar", cloud, plan)
    assert ev["length"] == pytest.approx(20.0, abs=1e-9) and ev["scale"] == pytest.approx(1 / 0.37)


def test_part3_plan_errors():
    from camcmm.api import InputError

    std = default_host().load("vdi2634-3")
    plan = copy.deepcopy(PLAN)
    plan["artefacts"].pop("ball_plate")
    with pytest.raises(InputError, match="artefacts.ball_plate is missing; VDI/VDE 2634 part 3 needs it"):
        std.requirements(plan)
    plan = copy.deepcopy(PLAN)
    plan["scaling"]["ball_bar"] = "lengths"
    with pytest.raises(InputError, match="scaling.ball_bar cannot be lengths"):
        std.requirements(plan)
    plan = copy.deepcopy(PLAN)
    plan["repeats"] = 0
    with pytest.raises(InputError, match="repeats must be a whole number"):
        std.requirements(plan)
    plan2 = {**copy.deepcopy(PLAN), "standard": "vdi2634-2"}
    with pytest.raises(InputError, match="scaling.sphere is 'radii'; part 2 systems measure in mm"):
        default_host().load("vdi2634-2").requirements(
            {
                **plan2,
                "mpe": {"PF": 1, "PS": 1, "SD": 1, "F": 1},
                "artefacts": {
                    **plan2["artefacts"],
                    "ball_bar": {"length": 50, "uncertainty": 0, "sphere_diameter": 20},
                    "flat": {"length": 100, "width": 50},
                },
            }
        )
