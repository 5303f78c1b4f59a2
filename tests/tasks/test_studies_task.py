"""The study tasks without trame (camcmm.tasks.studies): the virtual lab's light-field
study (true gradient law g = -1 + 0.15 f mm/λ by construction) written, run through the
worker with progress, stored in a bare project, restored and reported; a speckle study's
record from a stand-in provider (deviation clouds decimated for the maps, no geometry in
the row); the study file refused in one line outside the roots; the output contracts."""

from __future__ import annotations

import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from camcmm.contracts import check_outputs, contract, manifest_problem
from camcmm.errors import InputError, PluginError
from camcmm.host import Cancelled, RunResult, default_host
from camcmm.model import PointCloud
from camcmm.project import Project
from camcmm.tasks import studies

LAW = (-1.0, 0.15)  # virtuallab.lightfield-set's default gradient law g = a + b f


class Roots:
    """The GUI's roots in small: a path inside ``root`` is allowed."""

    def __init__(self, root: Path):
        self.root = root.resolve()

    def check(self, text, what):
        p = (self.root / Path(text).expanduser()).resolve()
        if not p.is_relative_to(self.root):
            raise InputError(f"{what} {text}: outside the folders this server may reach")
        return p


class SpeckleHost:
    """A host whose speckle-study provider answers with two cases and their deviation clouds."""

    def __init__(self, cases: bool = True):
        self.cases = cases
        self.asked: list = []

    def provider(self, name):
        return SimpleNamespace(id=f"lab.{name}", outputs=[])

    def run(self, plugin_id, inputs=None, params=None, progress=None, cancel=None):
        self.asked.append((inputs, params))
        if progress is not None:
            progress(0.5, "case 1/2")
        if cancel is not None and cancel.is_set():
            raise Cancelled("the study: cancelled")
        pts = np.random.default_rng(0).uniform(-10, 10, (5000, 3))
        clouds = {c: PointCloud(pts, fields={"deviation": pts[:, 0] / k}) for c, k in (("a-off", 100), ("a-on", 200))}
        out = {"summary": {"m": {"std_um_change": -1.0}}, "deviation_clouds": clouds}
        if self.cases:
            out["cases"] = [{"id": "a-off", "condition": "off"}, {"id": "a-on", "condition": "on"}]
        return RunResult(plugin_id, "2.0", dict(params or {}), {}, out, "t0", "t1", ["w1"])


@pytest.fixture
def project(tmp_path):
    p = Project.create(tmp_path / "proj")
    yield p
    p.close()


def test_the_contracts_list_what_the_page_reads_and_the_providers_declare_it():
    host = default_host()
    for kind, c in studies.CONTRACTS.items():
        task = studies.KINDS[kind]["task"]
        assert contract(task) is c and manifest_problem(studies.spec_of(host, kind), task) == ""
    assert studies.CONTRACTS["lightfield"].required_outputs() == ["table"]
    assert studies.CONTRACTS["speckle"].required_outputs() == ["cases"]
    lacking = SimpleNamespace(id="lab.lf", outputs=[SimpleNamespace(name="focal")])
    assert "declares no output 'table'" in manifest_problem(lacking, "lightfield-study")
    with pytest.raises(PluginError, match="'focal' is a list, not a dict"):
        check_outputs("lightfield-study", "lab.lf", {"table": {}, "focal": []})
    with pytest.raises(PluginError, match="lab.speckle-study.*gave no 'cases'"):
        studies.run(SpeckleHost(cases=False), studies.StudyRequest("speckle", "s.yaml"))


def test_the_study_file_and_kind_are_refused_in_one_line(tmp_path):
    roots = Roots(tmp_path / "proj")
    (tmp_path / "proj").mkdir()
    outside = tmp_path / "elsewhere" / "study.yaml"
    outside.parent.mkdir()
    outside.write_text("runs: []\n")
    for text, words in [
        (str(outside), "outside the folders"),
        ("../elsewhere/study.yaml", "outside the folders"),
        ("missing.yaml", "no such file"),
        ("", "give the path"),
    ]:
        with pytest.raises(InputError) as err:
            studies.study_file(roots, text)
        assert words in str(err.value) and "study file" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(InputError, match="study kind 'nonsense': not one of lightfield, speckle"):
        studies.run(SpeckleHost(), {"kind": "nonsense", "file": "x"})


def test_a_speckle_record_keeps_decimated_maps_and_no_geometry(project):
    host = SpeckleHost()
    req = studies.StudyRequest("speckle", "/data/s/study.yaml")
    seen: list[str] = []
    result = studies.run(host, req, {"fresh": True}, lambda f, m: seen.append(m))
    assert host.asked == [({}, {"fresh": True, "study": "/data/s/study.yaml"})] and seen == ["case 1/2"]
    rec = studies.store(project, result, req)
    assert rec["name"] == "s/study.yaml" and rec["plugin"] == "lab.speckle-study 2.0" and rec["warnings"] == ["w1"]
    assert set(rec["maps"]) == {"a-off", "a-on"} and len(rec["maps"]["a-off"]["d"]) == studies.MAP_POINTS
    m = rec["maps"]["a-on"]
    assert np.allclose(np.asarray(m["d"]), np.asarray(m["x"]) / 200)
    row = project.result(rec["result"])
    assert "deviation_clouds" not in row["outputs"] and RunResult.from_json(row).outputs["cases"][1]["id"] == "a-on"
    back, stored = studies.restore(project)
    assert back == req and stored == rec
    # cancelled: nothing stored, the last record kept
    stop = threading.Event()
    with pytest.raises(Cancelled):
        studies.run(host, req, {}, lambda f, m: stop.set(), stop)
    assert len(project.results()) == 1 and studies.stored(project) == rec


@pytest.mark.slow
def test_the_virtual_light_field_study_stored_restored_and_reported(project, tmp_path):
    host = default_host()
    path = studies.make_virtual(host, "lightfield", project.path)
    assert Path(path).is_file() and Path(path).resolve().is_relative_to(Path(project.path).resolve())
    req = studies.StudyRequest("lightfield", path)
    fractions: list[float] = []
    result = studies.run(host, req, {"predict_focal_mm": 45}, lambda f, m: fractions.append(f), threading.Event())
    assert fractions
    rec = studies.store(project, result, req)
    t = rec["outputs"]["table"]
    g = np.array(t["gradients"], float)  # [artefact][set]
    assert np.allclose(g, (LAW[0] + LAW[1] * np.array(t["focal_length_mm"]))[None, :], atol=0.02)
    assert np.allclose(t["std"], np.std(g, axis=0, ddof=1))  # table 6.3's sample std per set
    pred = rec["outputs"]["focal"]["predicted"]
    assert abs(pred["gradient_mm_per_lambda"] - (LAW[0] + LAW[1] * 45)) < 0.02
    assert rec["outputs"]["scatter"][0]["views"] and rec["maps"] == {}
    assert RunResult.from_json(project.result(rec["result"])).params["predict_focal_mm"] == 45
    # a reopened project: the same request and record
    again = Project.open(project.path)
    try:
        assert studies.restore(again) == (req, rec)
    finally:
        again.close()
    # the plugin's declared report
    spec = studies.spec_of(host, "lightfield")
    paths = studies.write_report(spec, result.outputs, tmp_path / "report", "study")
    assert set(paths) == {"html", "pdf", "json"}
    html = Path(paths["html"]).read_text()
    assert "table 6.3" in html and f"{g[0][0]:.4f}" in html
    with pytest.raises(PluginError, match="declares no report builder"):
        studies.write_report(SimpleNamespace(id="lab.x", report=None), {}, tmp_path, "x")
