"""Part 3's calibrated ball-plate lengths are checked against the measured plate before
they scale it (issue 26): scaling by lengths agrees with itself whatever the lengths are,
so a plan 10 x too long scaled the cloud 10 x and passed. The plate here is exact by
construction: three spheres of radius 0.37 x 2.5 whose centres are 0.37 x the calibrated
lengths apart (a reconstruction at scale 0.37), points exactly on them."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from camcmm.api import InputError, PointCloud, RunContext, write
from camcmm.host import default_host
from camcmm_plugins.vdi2634 import plan as plans
from camcmm_plugins.vdi2634 import rules, scaling
from helpers.cli import main_json

L_CAL = [5.942, 7.956, 9.957]  # thesis ch. 4.3
D_BALL = 5.0
SCALE = 0.37  # the reconstruction's arbitrary scale
PLAN = {
    "standard": "vdi2634-3",
    "system": {"name": "turntable", "measuring_volume": [30, 30, 30]},
    "mpe": {"PF": 0.06, "PS": 0.03, "SD": 0.04},
    "artefacts": {
        "sphere": {"diameter": 10.0, "uncertainty": 0.0008, "k": 2},
        "ball_plate": {"sphere_diameter": D_BALL, "lengths": L_CAL, "uncertainty": 0.0003, "k": 2},
    },
    "scaling": {"ball_plate": "lengths"},
    "repeats": 1,
}


def _sphere(centre, radius: float, n: int, seed: int) -> np.ndarray:
    """``n`` points exactly on a sphere (uniform directions)."""
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return np.asarray(centre) + radius * v / np.linalg.norm(v, axis=1, keepdims=True)


def plate(scale: float = SCALE, lengths=L_CAL, seed: int = 0, n: int = 1500) -> PointCloud:
    """The ball plate at ``scale``: |c1c2| = L1, |c2c3| = L2, |c3c1| = L3 (x scale)."""
    l1, l2, l3 = (scale * x for x in lengths)
    x = (l3**2 - l2**2 + l1**2) / (2 * l1)  # c3 from |c3 - c1| = L3 and |c3 - c2| = L2
    centres = [(0.0, 0.0, 0.0), (l1, 0.0, 0.0), (x, math.sqrt(l3**2 - x**2), 0.0)]
    pts = np.vstack([_sphere(c, scale * D_BALL / 2, n, seed + k) for k, c in enumerate(centres)])
    return PointCloud(pts, name="plate.ply")


def _plan(factor: float) -> dict:
    p = copy.deepcopy(PLAN)
    p["artefacts"]["ball_plate"]["lengths"] = [factor * x for x in L_CAL]
    return p


def test_check_lengths_by_numbers():
    l_rec = [SCALE * x for x in L_CAL]
    radii = [SCALE * D_BALL / 2] * 3
    assert scaling.check_lengths("plan.yaml", L_CAL, l_rec, radii, D_BALL, "bp.ply") is None
    # 10 x too long: scaled by them the spheres would be 50 mm; the plate measures 9.957 mm
    with pytest.raises(InputError) as e:
        scaling.check_lengths("plan.yaml", [10 * x for x in L_CAL], l_rec, radii, D_BALL, "bp.ply")
    assert str(e.value).startswith(
        "plan.yaml: artefacts.ball_plate.lengths[2] = 99.57 mm but bp.ply measures 9.957 mm "
        "(its spheres, scaled by these lengths, would be 50 mm across"
    )
    with pytest.raises(InputError, match=r"lengths\[2\] = 0.9957 mm but bp.ply measures 9.957 mm"):
        scaling.check_lengths("plan.yaml", [0.1 * x for x in L_CAL], l_rec, radii, D_BALL, "bp.ply")
    # the bounds: within 25 % nothing, up to a factor 2 a warning, beyond it a refusal
    assert scaling.check_lengths("p", [1.24 * x for x in L_CAL], l_rec, radii, D_BALL, "b") is None
    w = scaling.check_lengths("p", [1.5 * x for x in L_CAL], l_rec, radii, D_BALL, "b")
    assert w is not None and "50 % apart" in w and "measures 9.957 mm" in w
    assert scaling.check_lengths("p", [1.99 * x for x in L_CAL], l_rec, radii, D_BALL, "b") is not None
    with pytest.raises(InputError):
        scaling.check_lengths("p", [2.01 * x for x in L_CAL], l_rec, radii, D_BALL, "b")
    with pytest.raises(InputError):
        scaling.check_lengths("p", [x / 2.01 for x in L_CAL], l_rec, radii, D_BALL, "b")


@pytest.fixture(scope="module")
def ctx():
    return RunContext(default_host(), "vdi2634-3")


@pytest.mark.slow
def test_a_plan_10_times_too_long_is_refused_and_the_right_one_passes(ctx):
    std = default_host().load("vdi2634-3")
    cloud = plate()
    ev = std.evaluate_measurement(ctx, "ball_plate", cloud, _plan(1.0), file="plate.ply")
    assert ev["lengths_reconstructed"] == pytest.approx([SCALE * x for x in L_CAL], abs=1e-9)
    assert ev["lengths"] == pytest.approx(L_CAL, abs=1e-9)
    assert ev["scale"] == pytest.approx(1 / SCALE, rel=1e-9) and ev["warnings"] == []
    # (a plan 10 x too short is refused on loading: its spheres would overlap, below)
    with pytest.raises(InputError, match=r"^plan: artefacts.ball_plate.lengths\[2\] = 99.57 mm but plate.ply"):
        std.evaluate_measurement(ctx, "ball_plate", cloud, _plan(10.0), file="plate.ply")
    # borderline: 1.5 x evaluates (the lengths scale it) with the warning naming both
    ev = std.evaluate_measurement(ctx, "ball_plate", cloud, _plan(1.5), file="plate.ply")
    assert len(ev["warnings"]) == 1 and "lengths[2] = 14.94 mm but plate.ply measures 9.957 mm" in ev["warnings"][0]


def test_plan_level_checks_of_the_lengths():
    # lengths no longer than a sphere diameter: the spheres would overlap
    p = _plan(0.1)
    with pytest.raises(InputError, match=r"artefacts.ball_plate.lengths .* no longer than sphere_diameter 5 mm"):
        plans.load(p)
    # a plate longer than the volume's diagonal (52 mm for 30 mm) cannot be measured in it
    checks = rules.check(plans.load(_plan(10.0)), ["ball_plate"])
    bad = [c for c in checks if not c["ok"]]
    assert len(bad) == 1 and "99.57 mm is longer than the measuring volume's diagonal L0 = 51.96 mm" in bad[0]["text"]
    assert all(c["ok"] for c in rules.check(plans.load(_plan(1.0)), ["ball_plate"]) if "diagonal L0" in c["rule"])


def _write_set(d, factor: float) -> None:
    """A whole part-3 set of this plate: 5 metric probing spheres, 7 plate orientations."""
    rot = lambda a: np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])  # noqa: E731
    meas: dict[str, list[str]] = {"sphere": [], "ball_plate": []}
    for k in range(5):
        write(PointCloud(_sphere((3.0 * k, 0, 0), 5.0, 1500, 10 + k)), d / f"sphere_{k}.ply")
        meas["sphere"].append(f"sphere_{k}.ply")
    for k in range(7):
        pts = plate(seed=20 + 3 * k).points @ rot(k * 0.5).T
        write(PointCloud(pts), d / f"plate_{k}.ply")
        meas["ball_plate"].append(f"plate_{k}.ply")
    p = _plan(factor)
    p["measurements"] = meas
    (d / "plan.yaml").write_text(yaml.safe_dump(p), encoding="utf-8")


@pytest.mark.slow
def test_verify_passes_the_right_plan_and_refuses_every_plate_of_the_10x_one(tmp_path, capfd):
    _write_set(tmp_path, 1.0)
    ok = main_json(capfd, "verify", tmp_path / "plan.yaml", "--json")
    assert ok["verdict"] == "pass", ok["warnings"]
    assert ok["parameters"]["SD"]["value"] == pytest.approx(0.0, abs=1e-9)
    _write_set(tmp_path, 10.0)
    bad = main_json(capfd, "verify", tmp_path / "plan.yaml", "--json")
    assert bad["verdict"] != "pass"
    refused = [w for w in bad["warnings"] if "but plate_" in w]
    assert len(refused) == 7 and all("lengths[2] = 99.57 mm" in w and "measures 9.957 mm" in w for w in refused)


def test_a_confined_run_refuses_a_measurement_outside_its_folders(tmp_path):
    """The plan names its measurement files: in a confined run (the server) one outside
    is refused on loading, saying only that it was refused (issue 26)."""
    from camcmm import confine
    from camcmm.api import PathRefused

    inside = tmp_path / "in"
    inside.mkdir()
    for item, ok in (("plate.ply", True), ("sub/../plate.ply", True), ("../out/x.ply", False), ("/etc/passwd", False)):
        p = copy.deepcopy(PLAN)
        p["measurements"] = {"ball_plate": [item]}
        (inside / "plan.yaml").write_text(yaml.safe_dump(p), encoding="utf-8")
        with confine.confined([inside]):
            if ok:
                got = plans.load(inside / "plan.yaml").measurements["ball_plate"][0].file
                assert got == (inside / "plate.ply").resolve()
            else:
                with pytest.raises(
                    PathRefused, match=r"^plan.yaml: measurements.ball_plate\[0\]: .*outside the folders"
                ):
                    plans.load(inside / "plan.yaml")
    # not confined (the CLI): resolved against the plan's folder, whatever it is
    assert plans.load(inside / "plan.yaml").measurements["ball_plate"][0].file == Path("/etc/passwd")
