"""``camcmm fit`` and the fitting plugins through the host: the JSON contract."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from camcmm.api import PointCloud
from camcmm.host import PluginHost
from camcmm_plugins.fitting import cli
from helpers.cli import cli_json, run_camcmm

KEYS = {"element", "method", "outliers", "n_points", "n_used", "n_removed", "form", "std_uncertainty"}
PARAMS = {
    "sphere": ("center", "radius"),
    "plane": ("point", "normal"),
    "circle": ("center", "normal", "radius"),
    "cylinder": ("point", "axis", "radius"),
    "line": ("point", "direction"),
}
FORM = {"range", "max", "min", "std", "rms"}
NIST = Path(__file__).parents[1] / "data" / "nist_spheres"


def _clouds(tmp_path):
    rng = np.random.default_rng(1)
    far = np.array([1000.0, 2000.0, -500.0])
    u = rng.normal(size=(3000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    t = rng.uniform(0, 2 * np.pi, 3000)
    z = rng.uniform(-20, 20, 3000)
    noise = rng.normal(scale=0.01, size=3000)
    shapes = {
        "sphere": far + (10 + noise)[:, None] * u,
        "plane": far + np.column_stack([rng.uniform(-50, 50, 3000), rng.uniform(-50, 50, 3000), noise]),
        "circle": far + np.column_stack([(8 + noise) * np.cos(t), (8 + noise) * np.sin(t), 0.5 * noise]),
        "cylinder": far + np.column_stack([(5 + noise) * np.cos(t), (5 + noise) * np.sin(t), z]),
        "line": far + np.column_stack([z, noise, 0.5 * noise]),
    }
    files = {}
    for k, pts in shapes.items():
        files[k] = tmp_path / f"{k}.xyz"
        np.savetxt(files[k], pts, fmt="%.9f")
    return files


def _run(argv):
    p = argparse.ArgumentParser()
    cli.configure(p)
    return cli.run(p.parse_args(argv))


@pytest.mark.parametrize("rule", ["none", "vdi2634", "percent:5", "sigma:3"])
@pytest.mark.parametrize("element", list(PARAMS))
def test_cli_module_all_elements_all_rules(tmp_path, element, rule):
    files = _clouds(tmp_path)
    out = _run([element, str(files[element]), "--outliers", rule])
    assert KEYS <= set(out) and set(PARAMS[element]) <= set(out)
    assert set(out["form"]) == FORM
    assert set(out["std_uncertainty"]) == set(PARAMS[element])
    assert out["element"] == element and out["method"] == "ls" and out["n_points"] == 3000
    assert out["n_used"] + out["n_removed"] == 3000
    if rule == "vdi2634":
        assert out["n_removed"] == 9
    if rule == "percent:5":
        assert out["n_removed"] == 150
    json.dumps(out, allow_nan=False)
    assert cli.text(out).startswith(element)


def test_cli_module_minzone_nominal_and_errors(tmp_path):
    files = _clouds(tmp_path)
    out = _run(["sphere", str(files["sphere"]), "--method", "minzone", "--nominal-radius", "10"])
    assert out["method"] == "minzone" and abs(out["radius_deviation"]) < 0.01
    assert out["std_uncertainty"]["radius"] is None
    out = _run(["plane", str(files["plane"]), "--method", "minzone", "--residuals"])
    assert len(out["residuals"]) == 3000 and out["removed_indices"] == []
    from camcmm.api import ParameterError

    with pytest.raises(ParameterError):
        _run(["cylinder", str(files["cylinder"]), "--method", "minzone"])


@pytest.mark.slow
def test_camcmm_fit_subprocess_json(tmp_path):
    files = _clouds(tmp_path)
    out = cli_json("fit", "sphere", files["sphere"], "--outliers", "vdi2634", "--json")
    assert KEYS <= set(out) and out["n_removed"] == 9
    assert abs(out["radius"] - 10) < 0.01 and len(out["center"]) == 3
    assert set(out["form"]) == FORM


@pytest.mark.slow
def test_camcmm_fit_subprocess_text_and_errors(tmp_path):
    files = _clouds(tmp_path)
    assert run_camcmm("fit", "plane", files["plane"]).stdout.startswith("plane (ls, outliers none)")
    run = run_camcmm("fit", "sphere", files["plane"], ok=False)
    assert run.returncode != 0
    assert run.stderr.count("\n") == 1 and "nearly on a plane" in run.stderr
    run = run_camcmm("fit", "sphere", files["sphere"], "--outliers", "bogus", ok=False)
    assert run.returncode != 0 and "unknown outlier rule" in run.stderr


@pytest.mark.slow
def test_camcmm_fit_extract_nist_scan():
    out = cli_json(
        "fit",
        "sphere",
        NIST / "SPH102.xyz",
        "--unit",
        "m",
        "--extract",
        "--nominal-radius",
        "50",
        "--outliers",
        "vdi2634",
        "--json",
    )
    assert abs(out["radius"] - 50) < 0.3 and out["n_points_raw"] == 1893 and out["n_points"] < 1893


def test_plugins_through_the_host():
    host = PluginHost()
    ids = {"fit.line", "fit.plane", "fit.circle", "fit.sphere", "fit.cylinder", "segment.spheres", "segment.sphere"}
    assert ids <= set(host.plugins)
    assert all(host.plugins[i].status == "ok" for i in ids)
    assert "fit" in host.commands
    rng = np.random.default_rng(2)
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    cloud = PointCloud(500 + (20 + rng.normal(scale=0.01, size=2000))[:, None] * u, name="ball")
    run = host.run("fit.sphere", {"cloud": cloud}, {"outliers": "vdi2634", "nominal_radius": 20})
    out = run.outputs
    assert out["n_removed"] == 6 and abs(out["radius_deviation"]) < 0.01
    dev = out["deviations"]
    assert dev.fields["deviation"].shape == (2000,) and dev.field_units["deviation"] == "mm"
    assert int(dev.fields["outlier"].sum()) == 6
    doc = run.to_json()
    json.dumps(doc, allow_nan=False)
    run = host.run("fit.plane", {"cloud": cloud}, {"method": "minzone"})
    assert run.outputs["method"] == "minzone"
    bar = PointCloud(np.vstack([cloud.points, cloud.points + [100, 0, 0]]), name="bar")
    seg = host.run("segment.spheres", {"cloud": bar}, {"nominal_radius": 20}).outputs
    assert seg["n_spheres"] == 2 and len(seg["clouds"]) == 2
    assert abs(np.linalg.norm(np.subtract(seg["spheres"][1]["center"], seg["spheres"][0]["center"])) - 100) < 0.01
    one = host.run("segment.sphere", {"cloud": bar}, {"nominal_radius": 20}).outputs
    assert one["cloud"].n_points == 2000


# -- the options are the fit plugins' declared parameters; the fit runs through the host (issue 25)
def test_help_lists_every_declared_parameter_of_the_fits(capsys):
    from camcmm.cli.main import main
    from camcmm.host import default_host

    with pytest.raises(SystemExit) as stop:
        main(["fit", "--help"])
    assert stop.value.code == 0
    flags = set(capsys.readouterr().out.split())
    for element in PARAMS:
        for p in default_host().get(f"fit.{element}").parameters:
            assert "--" + p.name.replace("_", "-") in flags, (element, p.name)
    assert {"--unit", "--residuals", "--json"} <= flags


def test_fit_json_carries_the_plugin_block(tmp_path, capsys):
    """`camcmm fit --json` in this process: the run's provenance (plugin id and version, the
    validated parameters, the input hash, the times) beside every key it had."""
    from camcmm.cli.main import main
    from camcmm.host import default_host

    files = _clouds(tmp_path)
    assert main(["fit", "sphere", str(files["sphere"]), "--nominal-radius", "10", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert KEYS | {"center", "radius", "radius_deviation", "form", "warnings", "file"} <= set(out)
    plugin = out["plugin"]
    assert plugin["id"] == "fit.sphere" and plugin["version"] == default_host().get("fit.sphere").version
    assert plugin["params"] == {"outliers": "none", "method": "ls", "nominal_radius": 10.0, "extract": False}
    assert set(plugin["input_hashes"]) == {"cloud"} and len(plugin["input_hashes"]["cloud"]) == 64
    assert plugin["started"] <= plugin["finished"]
    assert "deviations" not in out and "removed_indices" not in out  # a cloud, and indices without --residuals


def test_old_flags_keep_their_meaning_for_each_element(tmp_path, capsys):
    from helpers.cli import refused

    files = _clouds(tmp_path)
    out = _run(["line", str(files["line"]), "--method", "ls"])  # what every line fit does: accepted
    assert out["method"] == "ls" and out["plugin"]["params"] == {"outliers": "none"}
    needle = "--method: fit.line has no method (it takes --outliers)"
    refused(capsys, ["fit", "line", files["line"], "--method", "minzone"], needle)
    refused(capsys, ["fit", "plane", files["plane"], "--extract"], "--extract: fit.plane has no extract")
    refused(capsys, ["fit", "sphere", files["sphere"], "--method", "fast"], "--method: parameter 'method': 'fast'")
    out = _run(["sphere", str(files["sphere"]), "--extract", "--nominal-radius", "10", "--outliers", "percent:1"])
    assert out["n_points_raw"] == 3000 and out["plugin"]["params"]["extract"] is True
    assert out["outliers"] == "percent:1" and abs(out["radius"] - 10) < 0.01


def test_extraction_says_how_many_points_it_removed_beside_the_outlier_rule(tmp_path):
    """A sphere of 3000 points on a plate of 500 points 30 mm below its centre (exact by
    construction: the plate is 20 mm from the sphere's surface, far outside its band):
    the extraction removes exactly the plate, the outlier rule its own few, each said apart."""
    rng = np.random.default_rng(4)
    u = rng.normal(size=(3000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    ball = (10 + rng.normal(scale=0.005, size=3000))[:, None] * u
    plate = np.column_stack([rng.uniform(-40, 40, 500), rng.uniform(-40, 40, 500), np.full(500, -30.0)])
    f = tmp_path / "scan.xyz"
    np.savetxt(f, np.vstack([ball, plate]), fmt="%.9f")
    out = _run(["sphere", str(f), "--extract", "--nominal-radius", "10", "--outliers", "percent:1"])
    assert out["n_points_raw"] == 3500 and out["n_extracted_away"] == 500 and out["n_points"] == 3000
    assert out["n_removed"] == 30  # percent:1 of the 3000 sphere points, counted apart
    said = cli.text(out)
    assert "3000 of 3500 points of the scan, 500 removed as not on the sphere" in said
    assert "30 removed by the outlier rule" in said
