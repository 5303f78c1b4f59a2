"""The photogrammetry task without trame (camcmm.tasks.photogrammetry): the image series
checked (folder inside the roots, or image items), the provider run with progress and
cancel — here a stand-in host whose plugin answers with a reconstruction exact by
construction (a ring of cameras around a sphere of points) —, stored in a bare project
(ProjectItems) and restored; one-line refusals; the output contract the page reads."""

from __future__ import annotations

import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from camcmm.contracts import contract, manifest_problem
from camcmm.errors import InputError, PluginError
from camcmm.host import Cancelled, RunResult, default_host
from camcmm.model import PointCloud
from camcmm.project import Project
from camcmm.tasks import photogrammetry as task
from camcmm.tasks.items import ProjectItems

N_VIEWS = 6


def reconstruction(names: list[str]) -> dict:
    """Cameras on a ring of 300 mm looking at the origin; the last image unregistered."""
    views, images = [], []
    for k, name in enumerate(names):
        ok = k != len(names) - 1
        images.append({"image": name, "n_features": 900 + k, "n_matched": 400 if ok else 3, "registered": ok,
                       "reason": "" if ok else "too few matches (3) with the other views"})  # fmt: skip
        if ok:
            a = 2 * np.pi * k / len(names)
            views.append({"image": name, "centre": [300 * np.cos(a), 300 * np.sin(a), 90.0]})
    return {
        "n_images": len(names), "n_registered": len(views), "views": views, "images": images,
        "reprojection_rms_px": 0.42, "n_points_sparse": 150, "n_points_dense": 600,
        "camera": {"model": "SIMPLE_RADIAL", "fx": 800.0, "fy": 800.0, "cx": 320.0, "cy": 240.0},
        "scale": {"method": "none", "factor": 1.0, "u": 0.0}, "timings": {"features": 0.1}, "warnings": [],
    }  # fmt: skip


class StandInHost:
    """A host whose provider of the task answers with :func:`reconstruction` (runs in the
    calling thread: :func:`camcmm.worker.run` sends only a real PluginHost to a worker)."""

    def __init__(self, drop: str = ""):
        self.drop = drop
        self.spec = SimpleNamespace(id="lab.photogrammetry", outputs=[])

    def provider(self, name):
        assert name == task.TASK
        return self.spec

    def run(self, plugin_id, inputs=None, params=None, progress=None, cancel=None):
        for k, stage in enumerate(("features", "matching", "mapping", "dense")):
            if cancel is not None and cancel.is_set():
                raise Cancelled("reconstruction: cancelled")
            if progress is not None:
                progress(k / 4, f"{stage}: working")
        d = np.random.default_rng(1).normal(size=(600, 3))
        pts = 20.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
        names = [Path(p).name for p in inputs["images"]]
        params = {"dense": True, **(params or {})}
        out = {"cloud": PointCloud(pts if params["dense"] else pts[:150]), "sparse": PointCloud(pts[:150]),
               "reconstruction": reconstruction(names)}  # fmt: skip
        out.pop(self.drop, None)
        return RunResult(plugin_id, "0.9", params, {"images": "x"}, out, "t0", "t1", ["one warning"])


class Roots:
    """The GUI's roots in small: a path inside ``root`` is allowed."""

    def __init__(self, root: Path):
        self.root = root.resolve()

    def allows(self, p) -> bool:
        return Path(p).resolve().is_relative_to(self.root)

    def check(self, text, what):
        p = Path(text).expanduser().resolve()
        if not self.allows(p):
            raise InputError(f"{what} {text}: outside the folders this server may reach")
        return p


def series(folder: Path, n: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(n):
        (folder / f"view{k:02d}.png").write_bytes(b"\x89PNG not read here")
    (folder / "notes.txt").write_text("not an image")
    return folder


@pytest.fixture
def items(tmp_path):
    project = Project.create(tmp_path / "proj")
    yield ProjectItems(project)
    project.close()


def test_the_contract_lists_what_the_page_reads_and_the_provider_declares_it():
    c = contract(task.TASK)
    assert c is task.CONTRACT and c.required_outputs() == ["cloud", "reconstruction"]
    assert {"sparse", "reconstruction.images", "reconstruction.views"} <= {n.key for n in c.needs if n.optional}
    assert manifest_problem(default_host().provider(task.TASK), task.TASK) == ""
    lacking = SimpleNamespace(id="lab.sfm", outputs=[SimpleNamespace(name="cloud")])
    assert "declares no output 'reconstruction'" in manifest_problem(lacking, task.TASK)
    # at run time: a provider that leaves out the reconstruction is one line naming it
    with pytest.raises(PluginError, match="lab.photogrammetry.*gave no 'reconstruction'"):
        task.run(StandInHost(drop="reconstruction"), [{"path": "a.png"}, {"path": "b.png"}], {})


def test_series_refused_in_one_line(items, tmp_path):
    roots = Roots(tmp_path / "data")
    series(tmp_path / "data" / "s", 3)
    (tmp_path / "data" / "empty").mkdir()
    cases = [
        ({"source": "folder", "folder": ""}, "give a folder on the server"),
        ({"source": "folder", "folder": "/etc"}, "outside the folders"),
        ({"source": "folder", "folder": str(tmp_path / "data" / "none")}, "no such folder"),
        ({"source": "folder", "folder": str(tmp_path / "data" / "empty")}, "no image files"),
        ({"source": "folder", "folder": str(tmp_path / "data" / "s"), "pattern": "*.jpg"}, "matching '*.jpg'"),
        ({"source": "items", "items": []}, "choose image items"),
        ({"source": "items", "items": ["999"]}, "item '999' is not in the project"),
    ]
    for req, words in cases:
        with pytest.raises(InputError) as err:
            task.sources_of(task.PhotogrammetryRequest.of(req), items.project, roots)
        assert words in str(err.value) and "\n" not in str(err.value), (words, err.value)
    with pytest.raises(InputError, match="1 image; a reconstruction needs several"):
        task.run(StandInHost(), [{"name": "a.png", "path": "a.png"}], {})
    with pytest.raises(InputError, match="scale lengths file /etc/passwd: outside"):
        task.scale_checked({"scale": "lengths:/etc/passwd"}, roots)
    assert task.calibration_file(items.project) is None


def test_stages_read_from_the_plugins_words():
    assert task.stage_of("matching: 12/28 pairs") == "matching" and task.stage_of("Dense 3/8") == "dense"
    assert task.stage_of("SIFT features") == "features" and task.stage_of("registered 3 of 8 images") == "mapping"
    assert task.stage_of("starting") == ""


def test_a_run_is_stored_and_restored(items, tmp_path):
    folder = series(tmp_path / "data" / "s", N_VIEWS)
    req = task.PhotogrammetryRequest(source="folder", folder=str(folder), name="part")
    sources = task.sources_of(req, items.project, Roots(tmp_path / "data"))
    assert [s["name"] for s in sources] == [f"view{k:02d}.png" for k in range(N_VIEWS)]
    seen: list[str] = []
    result = task.run(StandInHost(), sources, {}, None, lambda f, m: seen.append(task.stage_of(m)), threading.Event())
    assert seen == ["features", "matching", "mapping", "dense"]
    rec = task.store(items.project, items, result, req, sources)
    # the result row is RunResult's record with both clouds as its files; two items made by the plugin
    row = items.project.result(rec["result"])
    assert RunResult.from_json(row).plugin_id == "lab.photogrammetry" and set(row["files"]) == {"cloud", "sparse"}
    assert rec["name"] == "part" and set(rec["items"]) == {"cloud", "sparse"} and rec["warnings"] == ["one warning"]
    made = {k: items.measurement(v) for k, v in rec["items"].items()}
    assert all(f"lab.photogrammetry 0.9 (result #{rec['result']})" == m["meta"]["made_by"] for m in made.values())
    assert items.load(rec["items"]["cloud"]).n_points == 600 and made["sparse"]["name"] == "part (sparse)"
    rows = {r["name"]: r["value"] for r in task.summary(rec["reconstruction"])}
    assert rows["registered"] == f"{N_VIEWS - 1} of {N_VIEWS}" and rows["rms"] == "0.42 px"
    # the camera model in words (the key stays in the JSON), numbers by the one rule
    assert (
        rows["camera"].startswith("simple radial (f, cx, cy, k): f = 800 / 800 px") and "SIMPLE" not in rows["camera"]
    )
    assert rows["timings"] == "features 0.1 s"
    # a reopened project gives the request and the record back
    again = Project.open(items.project.path)
    try:
        back, stored = task.restore(again)
    finally:
        again.close()
    assert back == req and stored == rec
    assert stored["reconstruction"]["images"][-1]["reason"].startswith("too few matches")


def test_sparse_only_is_one_item_and_cancel_stores_nothing(items, tmp_path):
    folder = series(tmp_path / "s", 3)
    sources = task.sources_of({"folder": str(folder)}, items.project)
    result = task.run(StandInHost(), sources, {"dense": False})
    rec = task.store(items.project, items, result, {"folder": str(folder)}, sources)
    assert set(rec["items"]) == {"sparse"} and set(items.project.result(rec["result"])["files"]) == {"sparse"}
    n = len(items.project.results())
    stop = threading.Event()
    stop.set()
    with pytest.raises(Cancelled):
        task.run(StandInHost(), sources, {}, cancel=stop)
    empty = RunResult("p", "1", {}, {}, {"cloud": PointCloud(np.zeros((0, 3))), "reconstruction": {}}, "", "")
    with pytest.raises(InputError, match="no points: nothing was stored"):
        task.store(items.project, items, empty, {}, sources)
    assert len(items.project.results()) == n and task.stored(items.project) == rec
