"""The fusion task without trame (camcmm.tasks.fusion): the real fusion.csi plugin on a
small exact-by-construction coin (helpers.fusion_synthetic), run through the worker with
progress and cancel, stored in a bare project (ProjectItems) and restored; the inputs'
refusals in one line; the output contract the Fuse page reads."""

from __future__ import annotations

import threading
from types import SimpleNamespace

import numpy as np
import pytest

from camcmm.contracts import check_outputs, contract, manifest_problem
from camcmm.errors import InputError, PluginError
from camcmm.host import Cancelled, RunResult, default_host
from camcmm.model import HeightMap, PointCloud
from camcmm.project import Project
from camcmm.tasks import fusion
from camcmm.tasks.items import ProjectItems
from helpers.fusion_synthetic import csi_map, photo_cloud


def add_item(items: ProjectItems, obj, name: str) -> str:
    h = items.project.add_object(obj, name, ext=".x3p" if isinstance(obj, HeightMap) else ".ply")
    return str(items.add_measurement(name, h, obj))


@pytest.fixture
def items(tmp_path):
    project = Project.create(tmp_path / "proj")
    yield ProjectItems(project)
    project.close()


def test_the_contract_lists_what_the_page_reads_and_the_provider_declares_it():
    c = contract(fusion.TASK)
    assert c is fusion.CONTRACT and c.required_outputs() == ["fused", "result"]
    assert {n.key for n in c.needs if n.optional} >= {"views", "result.maps", "result.photogrammetry_scale"}
    spec = default_host().provider(fusion.TASK)
    assert manifest_problem(spec, fusion.TASK) == ""
    lacking = SimpleNamespace(id="lab.fuse", outputs=[SimpleNamespace(name="result")])
    assert "declares no output 'fused'" in manifest_problem(lacking, fusion.TASK)
    with pytest.raises(PluginError, match="gave no 'fused'"):
        check_outputs(fusion.TASK, "lab.fuse", {"result": {}})
    with pytest.raises(PluginError, match="'result.maps' is a str"):
        check_outputs(fusion.TASK, "lab.fuse", {"fused": PointCloud(np.zeros((3, 3))), "result": {"maps": "x"}})


def test_missing_or_wrong_inputs_are_refused_in_one_line(items):
    cloud = add_item(items, PointCloud(np.random.default_rng(0).random((50, 3))), "photo cloud")
    hm = add_item(items, HeightMap(np.zeros((10, 12)), 0.1, 0.1, name="map A"), "map A")
    cases = [
        ({"cloud": None, "maps": [hm]}, "no photogrammetry cloud"),
        ({"cloud": cloud, "maps": []}, "no height map"),
        ({"cloud": cloud, "maps": [hm, hm]}, "chosen twice"),
        ({"cloud": cloud, "maps": [cloud]}, "'photo cloud' is a pointcloud, not a heightmap"),
        ({"cloud": hm, "maps": [hm]}, "'map A' is a heightmap, not a pointcloud"),
        ({"cloud": cloud, "maps": ["999"]}, "999"),
    ]
    for req, words in cases:
        with pytest.raises(InputError) as err:
            fusion.inputs_of(items, fusion.FusionRequest.of(req))
        assert words in str(err.value) and "\n" not in str(err.value), (words, err.value)


def test_a_run_without_a_fused_cloud_stores_nothing(items):
    cloud = add_item(items, PointCloud(np.random.default_rng(0).random((50, 3))), "photo cloud")
    hm = add_item(items, HeightMap(np.zeros((10, 12)), 0.1, 0.1, name="map A"), "map A")
    ins = fusion.inputs_of(items, {"cloud": cloud, "maps": [hm]})
    empty = RunResult("fusion.csi", "0.1", {}, {}, {"fused": PointCloud(np.zeros((0, 3))), "result": {}}, "", "")
    with pytest.raises(InputError, match="no fused cloud: nothing was stored"):
        fusion.store(items.project, items, empty, {"cloud": cloud, "maps": [hm]}, ins)
    assert items.project.results() == [] and fusion.stored(items.project) is None


def test_numbers_of_a_map_in_micrometres():
    summary = {
        "maps": [{"file": "map A", "n_matches": 30, "n_inliers": 12, "n_inliers_similarity": 12,
                  "n_inliers_fundamental": 9, "transform2d": {"angle_deg": 12.0, "tx": 7.0, "ty": -3.0, "scale": 1.25},
                  "icp": {"tz": 0.002, "rms": 0.004, "converged": False},
                  "difference": {"mean": 0.001, "std": 0.01, "p2_5": -0.033, "p97_5": 0.024}}],
        "photogrammetry_scale": {"value": 1.25, "std": 0.0},
        "n_points_fused": 1234,
    }  # fmt: skip
    num = {r["name"]: r["value"] for r in fusion.numbers(summary, 0)}
    assert num["matches"] == "30 / 12" and num["inliers_models"] == "12 / 9" and num["file"] == "map A"
    assert "12.00°" in num["transform2d"] and "× 1.25" in num["transform2d"] and "1.25" in num["scale"]
    # the number rule (camcmm.numbers): µm with a real minus, a thin space in counts
    assert num["band"] == "−33.0 µm … +24.0 µm" and "(not converged)" in num["icp"] and num["fused"] == "1 234"
    assert (
        "tz +0.0020 mm" in num["icp"]
        and "rms 4.00 µm" in num["icp"]
        and num["difference"] == "mean +1.00 µm, std 10.0 µm"
    )
    assert {r["value"] for r in fusion.numbers({}, 3) if r["name"] == "matches"} == {"— / —"}


@pytest.mark.slow
def test_a_real_fusion_is_stored_and_restored(items):
    cloud, _s, _m = photo_cloud()
    hm, _a = csi_map()
    cid, mid = add_item(items, cloud, "photo cloud"), add_item(items, hm, "map A")
    req = fusion.FusionRequest(cid, [mid], name="coin")
    ins = fusion.inputs_of(items, req)
    seen: list[float] = []
    result = fusion.run(default_host(), ins, {}, progress=lambda f, msg: seen.append(f), cancel=threading.Event())
    assert seen and result.outputs["fused"].n_points > cloud.n_points // 2
    rec = fusion.store(items.project, items, result, req, ins)
    # the result row: RunResult's record, numbers not the figures' arrays, naming both inputs
    row = items.project.result(rec["result"])
    assert RunResult.from_json(row).plugin_id == "fusion.csi" and "fused" in row["files"]
    assert sorted(int(x) for x in row["measurement_ids"]) == sorted([int(cid), int(mid)])
    assert row["outputs"]["result"]["maps"][0]["n_inliers"] >= 8 and "photo_image" not in str(row["outputs"])
    item = items.measurement(rec["items"]["fused"])
    assert item["kind"] == "pointcloud" and f"result #{rec['result']}" in item["meta"]["made_by"]
    assert items.load(rec["items"]["fused"]).n_points == result.outputs["fused"].n_points
    # the round trip: a reopened project gives the request and the record back
    again = Project.open(items.project.path)
    try:
        got = fusion.restore(again)
    finally:
        again.close()
    assert got is not None
    back, stored = got
    assert back == fusion.FusionRequest(cid, [mid], "coin") and stored == rec
    assert stored["views"][0]["matches"]["photo"] and fusion.numbers(stored["summary"], 0)[0]["value"] == "csi_1"


@pytest.mark.slow  # a worker process may start first
def test_a_cancelled_run_raises_cancelled(items):
    cloud, _s, _m = photo_cloud(spacing=0.03, half=3.0)
    hm, _a = csi_map(shape=(240, 320), step=0.012, centre=(0.3, -0.2))
    ins = fusion.inputs_of(items, {"cloud": add_item(items, cloud, "c"), "maps": [add_item(items, hm, "m")]})
    stop = threading.Event()  # the operator cancels once the run reports progress
    with pytest.raises(Cancelled):
        fusion.run(default_host(), ins, {}, progress=lambda f, msg: stop.set(), cancel=stop)
    assert items.project.results() == []
