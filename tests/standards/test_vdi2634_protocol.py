"""The standard protocol the GUI wizard builds on (docs/standards.md): evaluate each
measurement as it comes, summarise at the end, write the report — with the same
numbers as the batch run."""

from __future__ import annotations

import html
import re
from pathlib import Path

import pytest
import yaml

import camcmm
from camcmm.api import PointCloud, RunContext
from camcmm.host import default_host


@pytest.fixture(scope="module")
def plan_path(tmp_path_factory):
    d = tmp_path_factory.mktemp("protocol")
    default_host().run(
        "virtuallab.acceptance-set",
        {},
        {
            "directory": str(d),
            "n_sphere": 1500,
            "n_ball_bar": 1500,
            "n_flat": 2000,
            "noise": 0.01,
            "seed": 31,
            "amplitude": 0.01,
        },
    )
    return d / "plan.yaml"


@pytest.mark.slow
def test_wizard_flow_equals_the_batch_run(plan_path, tmp_path):
    host = default_host()
    std = host.load("vdi2634-2")
    ctx = RunContext(host, "vdi2634-2")
    plan = yaml.safe_load(plan_path.read_text())
    reqs = {r["test"]: r for r in std.requirements(plan_path)}
    per = {}
    for test, files in plan["measurements"].items():
        for i, name in enumerate(files):
            pos = reqs[test]["positions"][i]["id"]
            ev = std.evaluate_measurement(ctx, test, plan_path.parent / name, plan_path, file=name, position=pos)
            dev = ev["deviations"]
            assert isinstance(dev, PointCloud) and "deviation" in dev.fields
            assert ev["position"] == pos and len(ev["sha256"]) == 64
            per.setdefault(test, []).append(ev)
    summary = std.summarize(ctx, plan_path, per)
    batch = host.run("vdi2634-2", {"plan": plan_path}).outputs
    for key, p in batch["parameters"].items():
        assert summary["parameters"][key]["value"] == p["value"]
        assert summary["parameters"][key]["verdict"] == p["verdict"]
    assert summary["verdict"] == batch["verdict"]
    paths = std.write_report(summary, tmp_path / "report", plan_path)
    assert set(paths) == {"html", "pdf", "json"}
    # the report writes quality parameters in µm by the number rule (issue 30): P_F of the
    # first sphere as the table cell to 0.01 µm, read back from the evaluation's mm
    text = html.unescape(re.sub(r"<[^>]+>", " ", Path(paths["html"]).read_text()))
    assert "P_F [µm]" in text and "P_F [mm]" not in text and "U (k = 2) [µm]" in text
    pf_um = round(per["sphere"][0]["values"]["PF"] * 1e3, 2)
    assert f"{pf_um:.2f}".rstrip("0").rstrip(".") in text
    assert "passed" in text or "failed" in text or "inconclusive" in text  # the verdicts in words


def test_host_run_takes_a_plan_dict(plan_path):
    plan = yaml.safe_load(plan_path.read_text())
    plan["base_dir"] = str(plan_path.parent)
    res = default_host().run("vdi2634-2", {"plan": plan}, {"workers": 1})
    assert res.outputs["verdict"] == "pass"
    assert res.plugin_id == "vdi2634-2" and res.input_hashes["plan"]
    assert res.outputs["provenance"]["plugins"][0] == {"id": "vdi2634-2", "version": camcmm.__version__}


def test_summarize_accepts_stored_json_evaluations(plan_path):
    """Evaluations read back from a project are plain JSON: no clouds, lists not arrays."""
    from camcmm.host import to_jsonable

    host = default_host()
    res = host.run("vdi2634-2", {"plan": plan_path}).outputs
    stored = to_jsonable(res["measurements"])
    again = host.load("vdi2634-2").summarize(None, plan_path, stored)
    assert {k: p["value"] for k, p in again["parameters"].items()} == {
        k: p["value"] for k, p in res["parameters"].items()
    }


def test_a_cancelled_run_stops(plan_path):
    import threading

    from camcmm.host import Cancelled

    stop = threading.Event()
    seen = []

    def progress(fraction, message):
        seen.append(message)
        if len(seen) == 2:
            stop.set()

    with pytest.raises(Cancelled):
        default_host().run("vdi2634-2", {"plan": plan_path}, {"workers": 1}, progress=progress, cancel=stop)
    assert len(seen) == 2
