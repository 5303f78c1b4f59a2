"""Values that used to be accepted silently are refused in one line naming the value:
``simulate`` (sphere diameter 0, -20, NaN; mesh scale 0; negative read noise; seed -1;
image size [0, 0]), ``fit --nominal-radius`` (-10, 0, NaN), ``verify --workers 0``, a
plan that says ``unit: m`` on files in mm (flats as well as spheres), board specs of
impossible sizes; and ``truth.json`` is valid JSON (no NaN).

Each case goes through its CLI command in this process: exit code non-zero, exactly one
line on stderr, no traceback, no internal error.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from camcmm.api import InputError, PointCloud, write
from camcmm.cli.main import main
from helpers.cli import refused


def _no_nan(text: str):
    def refuse(name):
        raise ValueError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


# ---------------------------------------------------------------- camcmm simulate
SEQ = {"projector": {"width": 1280, "height": 800}, "frames": ["white", "black"]}
MESH = {"type": "mesh", "vertices": [[0, 0, 0], [10, 0, 0], [0, 10, 0]], "faces": [[0, 1, 2]]}


def _scene(tmp_path, **changes):
    doc = {
        "name": "validation",
        "seed": 3,
        "artefacts": [{"type": "sphere", "center": [0, 0, 0], "diameter": 20.0}],
        "rig": {"preset": "stereo_fringe", "image_size": [64, 48]},
        "render": {"supersample": 1},
        "sequence": SEQ,
        **changes,
    }
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


@pytest.mark.parametrize(
    "changes,needle",
    [
        ({"artefacts": [{"type": "sphere", "diameter": 0}]}, "artefacts[0].diameter 0 must be a finite number > 0"),
        ({"artefacts": [{"type": "sphere", "diameter": -20}]}, "artefacts[0].diameter -20 must be"),
        ({"artefacts": [{"type": "sphere", "diameter": math.nan}]}, "artefacts[0].diameter nan is not a finite number"),
        ({"artefacts": [{"type": "ball_bar", "length": 50, "sphere_diameter": 0}]}, "artefacts[0].sphere_diameter 0"),
        ({"artefacts": [{"type": "flat", "length": 150, "width": -60}]}, "artefacts[0].width -60"),
        ({"artefacts": [{**MESH, "scale": 0}]}, "artefacts[0].scale 0 must be a finite number > 0"),
        (
            {"artefacts": [{"type": "sphere", "diameter": 20, "center": [0, math.inf, 0]}]},
            "artefacts[0].center[1] inf is not a finite number",
        ),
        ({"sensor": {"read_noise": -10}}, "sensor.read_noise -10 must be >= 0"),
        ({"sensor": {"full_well": 0}}, "sensor.full_well 0 must be > 0"),
        ({"sensor": {"bits": 2.5}}, "sensor.bits 2.5"),
        ({"lighting": {"ambient": -0.1}}, "lighting.ambient -0.1 must be >= 0"),
        ({"errors": {"projector_gamma": 0}}, "errors.projector_gamma 0 must be a finite number > 0"),
        ({"errors": {"baseline": {"relative": math.nan}}}, "errors.baseline.relative nan is not a finite number"),
        ({"seed": -1}, "seed -1 must be a whole number >= 0"),
        ({"render": {"supersample": 0}}, "render.supersample 0"),
        ({"rig": {"preset": "stereo_fringe", "image_size": [0, 0]}}, "rig.image_size [0, 0] must be"),
        ({"rig": {"preset": "stereo_fringe", "image_size": [64, 48], "distance": 0}}, "rig.distance 0"),
        ({"rig": {"preset": "stereo_fringe", "image_size": [64, 48], "projector_size": [0, 0]}}, "rig.projector_size"),
        (
            {"rig": {"preset": "stereo_fringe", "image_size": [16000, 16000]}},
            "rendering camera1 16000 x 16000 px, camera2 16000 x 16000 px at supersample 1 needs ~",
        ),
        ({"patterns": ["white"] * 5000}, "patterns: the number of entries = 5000 is more than the limit of 4096"),
        # wrong types and magnitudes that overflowed inside the renderer
        ({"artefacts": [{"type": "sphere", "diameter": 1e308}]}, "artefacts[0].diameter 1e+308 is not a finite number"),
        ({"sensor": {"exposure": 1e6}}, "sensor.exposure 1000000.0 must be >= 0 and <= 1000"),
        ({"render": "abc"}, "render: expected a mapping"),
        ({"sensor": [8]}, "sensor: expected a mapping"),
        ({"errors": {"focal_length": 2.5}}, "errors.focal_length: expected a mapping with relative"),
        ({"errors": {"focal_length": {"relative": "abc"}}}, "errors.focal_length.relative 'abc'"),
        ({"errors": {"baseline": {"relative": -1}}}, "errors.baseline.relative -1 must lie between -1 and 1"),
    ],
)
def test_simulate_refuses_bad_scene_values(tmp_path, capsys, changes, needle):
    out = tmp_path / "out"
    line = refused(capsys, ["simulate", _scene(tmp_path, **changes), "--out", out], needle)
    assert "scene.yaml" in line
    assert not (out / "truth.json").exists()


def test_simulate_memory_estimate_follows_the_limit(tmp_path, capsys, monkeypatch):
    # 2 x 64 x 48 px at supersample 4: 6144 px x 16 rays x 130 B = 12.8 MB
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "5")
    refused(
        capsys,
        ["simulate", _scene(tmp_path, render={"supersample": 4}), "--out", tmp_path / "out"],
        "at supersample 4 needs ~",
    )


def test_simulate_writes_valid_json_truth(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["simulate", str(_scene(tmp_path)), "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    truth = _no_nan((out / "truth.json").read_text())
    assert doc["n_frames"] == 2 and truth["artefacts"][0]["diameter"] == 20.0


def test_truth_with_a_nan_is_refused_naming_where():
    from camcmm_plugins.virtuallab.capture import _json_text

    assert _no_nan(_json_text({"a": [1.0, 2]})) == {"a": [1.0, 2]}
    with pytest.raises(InputError, match=r"^truth.json: coverage.camera1.lit = nan is not a finite number$"):
        _json_text({"coverage": {"camera1": {"surface": 0.5, "lit": np.float64("nan")}}})


# ---------------------------------------------------------------- camcmm fit --nominal-radius
@pytest.fixture
def sphere_file(tmp_path):
    rng = np.random.default_rng(1)
    d = rng.normal(size=(500, 3))
    pts = 25.0 * d / np.linalg.norm(d, axis=1, keepdims=True) + [1.0, 2.0, 3.0]
    path = tmp_path / "sphere.ply"
    write(PointCloud(pts, name="sphere"), path)
    return path


@pytest.mark.parametrize(
    "value,needle",
    [
        ("-10", "--nominal-radius: parameter 'nominal_radius' = -10.0"),
        ("0", "--nominal-radius: parameter 'nominal_radius' = 0.0"),
        ("nan", "--nominal-radius: parameter 'nominal_radius': nan is not finite"),
        ("inf", "--nominal-radius: parameter 'nominal_radius': inf is not finite"),
    ],
)
def test_fit_nominal_radius_through_the_declaration(sphere_file, capsys, value, needle):
    refused(capsys, ["fit", "sphere", sphere_file, f"--nominal-radius={value}"], needle)
    refused(capsys, ["fit", "sphere", sphere_file, "--extract", f"--nominal-radius={value}"], needle)


def test_fit_nominal_radius_still_works(sphere_file, capsys):
    assert main(["fit", "sphere", str(sphere_file), "--nominal-radius", "24.9", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["radius"] == pytest.approx(25.0, abs=1e-9)  # exact points on the sphere
    assert out["radius_deviation"] == pytest.approx(0.1, abs=1e-9)
    refused(capsys, ["fit", "plane", sphere_file, "--nominal-radius", "3"], "fit.plane has no nominal radius")


def test_segment_refuses_a_nan_radius(sphere_file):
    from camcmm.api import read
    from camcmm_plugins.fitting.segment import extract_sphere, segment_spheres

    pts = read(sphere_file).points
    for fn in (segment_spheres, extract_sphere):
        with pytest.raises(InputError, match="nominal radius .* got nan"):
            fn(pts, float("nan"))


# ---------------------------------------------------------------- camcmm verify
def test_verify_workers_zero_is_refused(tmp_path, capsys):
    plan = tmp_path / "plan.yaml"
    plan.write_text("standard: vdi2634-2\n")
    refused(capsys, ["verify", plan, "--workers", "0"], "'workers' = 0")
    refused(capsys, ["verify", plan, "--workers", "1000"], "'workers' = 1000")


@pytest.fixture(scope="module")
def acceptance_set(tmp_path_factory):
    from camcmm.host import default_host

    d = tmp_path_factory.mktemp("accept")
    default_host().run(
        "virtuallab.acceptance-set",
        {},
        {"directory": str(d), "n_sphere": 2000, "n_ball_bar": 2000, "n_flat": 2000, "noise": 0.01, "seed": 13},
    )
    return d


def test_plan_in_metres_on_mm_files_is_caught_for_the_flat(acceptance_set, capsys):
    plan = yaml.safe_load((acceptance_set / "plan.yaml").read_text())
    plan["unit"] = "m"  # the files are in mm
    plan["measurements"] = {k: v[:2] for k, v in plan["measurements"].items()}
    path = acceptance_set / "plan_in_metres.yaml"
    path.write_text(yaml.safe_dump(plan))
    assert main(["verify", str(path), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["verdict"] != "pass"
    for param in ("F", "PF"):
        rows = res["parameters"][param]["per_measurement"]
        assert rows and all(r["value"] is None for r in rows)
        for r in rows:
            assert "read as metres" in r["error"] and "\n" not in r["error"], r


# ---------------------------------------------------------------- board specs
@pytest.mark.parametrize(
    "spec,needle",
    [
        ("chessboard:100000x100000:25", "100000x100000 is more than a board holds"),
        ("chessboard:0x6:25", "needs at least 2x2 points"),
        ("circles:7x6:1e9", "1e+09 mm is more than 10000 mm"),
        ("chessboard:9x6:nan", "must be positive numbers"),
        ("charuco:30x30:15:11", "30x30 squares hold 450 markers; DICT_5X5_100 has only 100"),
    ],
)
def test_board_specs_of_impossible_sizes(tmp_path, capsys, spec, needle):
    refused(capsys, ["calibrate", "camera", tmp_path / "none.png", "--board", spec], needle)


# ---------------------------------------------------------------- GUM budgets and ISO 15530-3
def test_budget_dof_does_not_depend_on_the_scale(tmp_path, capsys):
    """Welch-Satterthwaite is scale-free: the same budget in units 1e200 times larger has
    the same nu_eff (u^4 of 1e200 used to overflow to inf/inf = nan)."""
    base = {"contributions": [{"name": "a", "u": 3.1, "dof": 14}, {"name": "b", "u": 1.7, "dof": 2244}]}
    docs = []
    for scale in (1.0, 1e200):
        doc = {"contributions": [{**c, "u": c["u"] * scale} for c in base["contributions"]]}
        (tmp_path / "b.yaml").write_text(yaml.safe_dump(doc))
        assert main(["uncertainty", "budget", str(tmp_path / "b.yaml"), "--json"]) == 0
        docs.append(json.loads(capsys.readouterr().out))
    a, b = docs
    assert b["dof_eff"] == pytest.approx(a["dof_eff"], rel=1e-12) and math.isfinite(a["dof_eff"])
    assert b["combined"] == pytest.approx(a["combined"] * 1e200, rel=1e-12)


@pytest.mark.parametrize(
    "command,doc,needle",
    [
        ("budget", {"contributions": [{"name": "a", "u": 1e308, "dof": 14}]}, "U = k u_c overflows"),
        ("iso15530-3", {"calibrated_value": 5, "u_cal": 1e308, "measurements": [5.0, 5.1]}, "U = k u_c overflows"),
        (
            "iso15530-3",
            {"calibrated_value": 5, "u_cal": 0.001, "measurements": [5.0, 5.1], "k": None},
            "k = None must be a finite number > 0",
        ),
        (
            "iso15530-3",
            {"calibrated_value": 5, "u_cal": 0.001, "measurements": [1e308, -1e308]},
            "measurements: their mean or spread overflows",
        ),
    ],
)
def test_uncertainty_overflow_is_one_line(tmp_path, capsys, command, doc, needle):
    (tmp_path / "u.yaml").write_text(yaml.safe_dump(doc))
    refused(capsys, ["uncertainty", command, tmp_path / "u.yaml"], needle)


def test_truth_with_a_nan_is_refused_naming_where_it_is():
    from camcmm.errors import InputError
    from camcmm_plugins.virtuallab.capture import _json_text

    with pytest.raises(InputError, match=r"truth.json: a.b\[1\] = nan is not a finite number"):
        _json_text({"a": {"b": [1.0, float("nan")]}, "seed": 3})
    assert json.loads(_json_text({"a": [1.0, 2e300]}))["a"][1] == 2e300  # big but finite is fine here
