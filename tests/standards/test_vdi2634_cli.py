"""``camcmm verify PLAN.yaml [--json] [--report DIR]`` as a user runs it (subprocess)."""

from __future__ import annotations

import json

import pytest

from camcmm.host import default_host
from helpers.cli import cli_json, cli_refused, run_camcmm


@pytest.fixture(scope="module")
def plan(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    default_host().run(
        "virtuallab.acceptance-set",
        {},
        {"directory": str(d), "n_sphere": 2000, "n_ball_bar": 1500, "n_flat": 2000, "noise": 0.01, "seed": 21},
    )
    return d / "plan.yaml"


@pytest.mark.slow
def test_verify_json(plan):
    res = cli_json("verify", plan, "--json")
    assert res["standard"] == "vdi2634-2" and res["verdict"] == "pass"
    assert set(res["parameters"]) == {"PF", "PS", "SD", "F"}
    for p in res["parameters"].values():
        assert {"value", "mpe", "verdict", "per_measurement"} <= set(p)
        assert all({"file", "value"} <= set(r) for r in p["per_measurement"])
    assert isinstance(res["warnings"], list)
    assert res["run"]["plugin"] == "vdi2634-2" and res["run"]["input_hashes"]["plan"]
    # the run's record (RunResult.to_json without the outputs) and the plugin block of every command
    assert {"plugin", "version", "params", "input_hashes", "started", "finished", "warnings"} == set(res["run"])
    assert "workers" in res["run"]["params"]
    plugin = res["plugin"]
    assert plugin["id"] == "vdi2634-2" and plugin["version"] == res["run"]["version"]
    assert plugin["input_hashes"] == res["run"]["input_hashes"] and plugin["params"] == res["run"]["params"]
    # the deviation clouds stay out of the JSON (a summary at most)
    ev = res["measurements"]["sphere"][0]
    assert ev["deviations"]["kind"] == "pointcloud"


@pytest.mark.slow
def test_verify_text_and_report(plan, tmp_path):
    out = run_camcmm("verify", plan, "--report", tmp_path / "rep", "--workers", 1)
    assert out.stdout.startswith("VDI/VDE 2634 part 2: PASS")
    assert "Probing error form P_F" in out.stdout and "report:" in out.stdout
    for ext in ("html", "pdf", "json"):
        assert (tmp_path / "rep" / f"report.{ext}").stat().st_size > 1000
    doc = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert doc["data"]["verdict"] == "pass"
    prov = doc["provenance"]
    assert {p["id"] for p in prov["plugins"]} >= {"vdi2634-2", "fit.sphere", "fit.plane", "segment.spheres"}
    assert len(prov["inputs"]) == 23 and all(len(i["sha256"]) == 64 for i in prov["inputs"])
    titles = [s["title"] for s in doc["sections"]]
    assert "Result" in titles and "Uncertainty of the test (for guarded acceptance)" in titles
    figures = [b for s in doc["sections"] for b in s["blocks"] if b["type"] == "figure"]
    assert len(figures) >= 10 + 6 + 4  # a map per sphere and flat, a chart per parameter
    verdicts = [b for s in doc["sections"] for b in s["blocks"] if b["type"] == "verdict"]
    assert {v["label"] for v in verdicts} == {"P_F", "P_S", "SD", "F"}
    assert all(v["simple"] == "pass" and v["guarded"] == "pass" for v in verdicts)


@pytest.mark.slow
def test_verify_errors_are_one_line(tmp_path):
    assert cli_refused("verify", tmp_path / "nothere.yaml", code=2).strip().endswith("plan file not found")
    (tmp_path / "p.yaml").write_text("standard: vdi2634-2\nsystem: {measuring_volume: [1, 1]}\n")
    out = run_camcmm("verify", tmp_path / "p.yaml", "--json", ok=False)
    assert out.returncode == 2 and "system.measuring_volume must be [x, y, z]" in out.stderr
    (tmp_path / "q.yaml").write_text("standard: iso9999\n")
    out = run_camcmm("verify", tmp_path / "q.yaml", ok=False)
    assert out.returncode == 2 and "no plugin with id 'iso9999'" in out.stderr


def test_help_lists_every_declared_parameter_of_the_standards(capsys):
    """The options are what the standard plugins declare (the plan names which one runs)."""
    from camcmm.cli.main import main

    with pytest.raises(SystemExit) as stop:
        main(["verify", "--help"])
    assert stop.value.code == 0
    flags = set(capsys.readouterr().out.split())
    standards = [s for s in default_host().plugins.values() if s.kind == "standard"]
    assert {"vdi2634-2", "vdi2634-3"} <= {s.id for s in standards}
    for spec in standards:
        for p in spec.parameters:
            assert "--" + p.name.replace("_", "-") in flags, (spec.id, p.name)
    assert {"--report", "--json"} <= flags


def test_workers_is_checked_by_the_declaration_naming_the_option(tmp_path, capsys):
    from helpers.cli import refused

    plan = tmp_path / "plan.yaml"
    plan.write_text("standard: vdi2634-3\n")
    refused(capsys, ["verify", plan, "--workers", "65"], "--workers: parameter 'workers' = 65 is above its maximum 64")
