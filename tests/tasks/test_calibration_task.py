"""The calibration task without trame (camcmm.tasks.calibration) on OpenCV's stereo sample
images: the request checked with one-line refusals, the camera calibrated through the
worker with progress (OpenCV's own unit-test reference within its tolerances), the
heat map made, stored in a bare project (JSON, YAML, page document, result row), used by
measuring systems and restored; a cancelled run stores nothing; the output contracts."""

from __future__ import annotations

import shutil
import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from camcmm.contracts import check_outputs, contract, manifest_problem
from camcmm.errors import InputError, PluginError
from camcmm.host import Cancelled, RunResult, default_host
from camcmm.io import read_calibration
from camcmm.project import Project
from camcmm.tasks import calibration as task
from helpers.paths import TEST_DATA

DATA = TEST_DATA / "opencv_stereo_chessboard"
LEFT = sorted(DATA.glob("left*.jpg"))
BOARD = "chessboard:9x6:25"
# OpenCV's own unit-test reference for these left images (SOURCE.txt): K, |rms - ref| < 0.01, L1(K - K_ref) < 10
K_REF = np.array([[532.80992189, 0.0, 342.4952186], [0.0, 532.93346422, 233.8879292], [0.0, 0.0, 1.0]])
RMS_REF = 0.196334638034


def folder_request(mode="camera", **kw) -> dict:
    req = {"mode": mode, "source": "folder", "folder": str(DATA), "left_pattern": "left*",
           "right_pattern": "right*", "board": BOARD}  # fmt: skip
    return {**req, **kw}


@pytest.fixture
def project(tmp_path):
    p = Project.create(tmp_path / "proj")
    yield p
    p.close()


def test_the_contracts_list_what_the_page_reads_and_the_providers_declare_it():
    host = default_host()
    for name in (task.CAMERA, task.STEREO, task.PROJECTION, task.RECTIFY):
        assert contract(name) is task.CONTRACTS[name]
        assert manifest_problem(host.provider(name), name) == ""
    assert task.CONTRACTS[task.CAMERA].required_outputs() == [
        "camera_matrix", "detections", "dist_coeffs", "per_view_rms", "rms",
    ]  # fmt: skip
    lacking = SimpleNamespace(id="lab.cal", outputs=[SimpleNamespace(name="rms")])
    assert "declares no output 'camera_matrix'" in manifest_problem(lacking, task.CAMERA)
    with pytest.raises(PluginError, match="'rms' is a str, not a float"):
        check_outputs(task.CAMERA, "lab.cal", {"camera_matrix": [], "dist_coeffs": [], "rms": "small",
                                               "per_view_rms": {}, "detections": []})  # fmt: skip


def test_bad_requests_are_refused_in_one_line(project, tmp_path):
    odd = tmp_path / "odd"
    odd.mkdir()
    shutil.copy(LEFT[0], odd / "left01.jpg")
    cases = [
        ({"mode": "camera", "source": "items", "left": [], "board": BOARD}, "choose the board images"),
        ({"mode": "camera", "source": "items", "left": ["999"], "board": BOARD}, "item 999 is no longer"),
        (folder_request(folder=str(tmp_path / "nowhere")), "no such folder"),
        (folder_request(folder=""), "give the folder on the server"),
        (folder_request(left_pattern="*.tif"), "no image files"),
        (folder_request(board=""), "board: give the board and its square size"),
        (folder_request(outlier_factor="many"), "outlier factor: 'many' is not a number"),
        (folder_request("stereo", folder=str(odd), left_pattern="*", right_pattern="*"), "the same image"),
    ]
    for req, words in cases:
        with pytest.raises(InputError) as err:
            task.check_request(req, project)
        assert words in str(err.value) and "\n" not in str(err.value), (words, err.value)
    req, src = task.check_request(folder_request(outlier_factor="2.5", model=None), project)
    assert req.outlier_factor == 2.5 and req.model == "standard" and req.left is None
    assert [s["name"] for s in src["left"]] == [p.name for p in LEFT] and "right" not in src
    with pytest.raises(InputError, match="the image is no longer at"):
        task.read_source({"name": "gone.png", "path": str(tmp_path / "gone.png")}, project)
    assert task.restore(project) == (None, None)


@pytest.mark.slow
def test_a_camera_calibration_stored_used_by_systems_and_restored(project):
    req, src = task.check_request(folder_request(name="left camera, May"), project)
    seen: list[float] = []
    cal = task.run(default_host(), req, src, project, lambda f, m: seen.append(f), threading.Event())
    assert seen and max(seen) >= 0.82 and cal.folder.is_dir()
    out = cal.outputs
    # OpenCV's unit-test reference within OpenCV's own tolerances
    assert abs(out["rms"] - RMS_REF) < 0.01 and np.abs(np.asarray(out["camera_matrix"]) - K_REF).sum() < 10.0
    assert len(out["per_view_rms"]) == 13 and len(cal.images["left"]) == 13
    pu = cal.maps["left"]
    assert np.asarray(pu["map"]).shape == (36, 48) and pu["distance"] == task.default_distance(out)
    doc = task.store(project, cal, req, src, {"left": {"left01.jpg": "data:image/jpeg;base64,x"}})
    assert not cal.folder.exists()  # the temporary folder is gone once stored
    cur = doc["current"]
    row = project.result(cur["result"])
    assert row["plugin"] == "calibration.camera" and row["label"] == "calibration: left camera, May"
    assert set(row["files"]) == {"calibration", "calibration_yaml", "page"}
    assert RunResult.from_json(row).outputs["rms"] == pytest.approx(out["rms"])
    K = np.asarray(out["camera_matrix"])
    for key in ("calibration", "calibration_yaml"):
        c = read_calibration(project.file_path(row["files"][key]))
        assert np.allclose(c["cameras"][0].camera_matrix, K, rtol=1e-12) and c["board"] == BOARD
    # "use this calibration": a new system, and an existing one keeping the rest of its meta
    sid_new = task.use_for_system(project, cur, task.NEW, "rig A")
    sid_old = project.add_system("rig B", {"measuring_volume": [500, 400, 300]})
    assert task.use_for_system(project, cur, sid_old) == sid_old
    for sid in (sid_new, sid_old):
        meta = project.system(sid)["meta"]
        assert meta["calibration"]["file"] == row["files"]["calibration"]
        assert meta["calibration"]["name"] == "left camera, May" and meta["calibration"]["result"] == cur["result"]
        assert read_calibration(project.file_path(meta["calibration"]["file"]))["cameras"][0].image_size == (640, 480)
    assert project.system(sid_old)["meta"]["measuring_volume"] == [500, 400, 300]
    assert project.system(sid_new)["name"] == "rig A"
    # the photogrammetry task finds it as the project's camera calibration
    from camcmm.tasks.photogrammetry import calibration_file

    assert calibration_file(project) == Path(project.file_path(cur["calibration"]))
    # reopened: the request and the page document as stored
    again = Project.open(project.path)
    try:
        back, stored = task.restore(again)
    finally:
        again.close()
    assert back == req and stored["current"] == cur and stored["outputs"] == out
    assert stored["thumbs"]["left"]["left01.jpg"].startswith("data:image/jpeg") and stored["maps"]["left"] == pu


def test_a_cancelled_run_stores_nothing(project):
    req, src = task.check_request(folder_request(left_pattern="left0[1-3]*"), project)
    stop = threading.Event()
    with pytest.raises(Cancelled):
        task.run(default_host(), req, src, project, lambda f, m: stop.set(), stop)
    assert project.results() == [] and task.stored(project) is None
