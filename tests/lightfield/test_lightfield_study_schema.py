"""The light-field study's one schema validation (issue 26): each problem one line naming
the file, the key path and the value; repeated runs, non-finite gradients and focal
lengths <= 0 refused; every path a study names resolved through document_path and, in a
confined run, refused before it is read. Also the views' cameras and poses and the depth
maps through camcmm's capped image reader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from camcmm.api import InputError, PathRefused
from camcmm.confine import confined
from camcmm_plugins.lightfield import gradient as grad
from camcmm_plugins.lightfield import lytro, study
from helpers.badinputs import png


def _write(tmp_path, runs, **top):
    f = tmp_path / "study.yaml"
    f.write_text(yaml.safe_dump({"runs": runs, **top}, sort_keys=False))
    return f


def _run(**over):
    r = {"set": "S1", "artefact": "A", "focal_length_mm": 30.0, "gradient_mm_per_lambda": 3.5}
    r.update(over)
    return r


S2 = {"set": "S2", "artefact": "A", "focal_length_mm": 40.0, "gradient_mm_per_lambda": 5.0}


def _never(**kw):
    raise AssertionError(f"a gradient was run: {kw}")


@pytest.mark.parametrize(
    "runs, top, key, value",
    [
        ([_run(focal_length_mm="abc"), S2], {}, "runs[0].focal_length_mm", "'abc'"),
        ([S2, _run(focal_length_mm=-30.0)], {}, "runs[1].focal_length_mm", "-30.0"),
        ([_run(focal_length_mm=0), S2], {}, "runs[0].focal_length_mm", "0"),
        ([_run(gradient_mm_per_lambda=float("nan")), S2], {}, "runs[0].gradient_mm_per_lambda", "nan"),
        ([_run(gradient_mm_per_lambda=float("inf")), S2], {}, "runs[0].gradient_mm_per_lambda", "inf"),
        ([_run(gradient_mm_per_lambda=[1]), S2], {}, "runs[0].gradient_mm_per_lambda", "[1]"),
        ([_run(set={"a": 1}), S2], {}, "runs[0].set", "{'a': 1}"),
        ([_run(), S2], {"predict_focal_mm": "far"}, "predict_focal_mm", "'far'"),
        ([_run(), S2], {"pixel_pitch_um": -1.4}, "pixel_pitch_um", "-1.4"),
        ([_run(), S2], {"truth": "3.5"}, "truth", "'3.5'"),
        ([_run(), S2], {"truth": {"sets": [{"set": "S1", "gradient_mm_per_lambda": "x"}]}}, "truth.sets[0]", "'x'"),
        ([_run(), S2], {"truth": {"sets": [{"set": "S7", "gradient_mm_per_lambda": 3}]}}, "truth.sets[0].set", "S7"),
        ([_run(focal_lenght_mm=30), S2], {}, "runs[0].focal_lenght_mm", "30"),
    ],
)
def test_each_problem_is_one_line_naming_file_key_and_value(tmp_path, runs, top, key, value):
    f = _write(tmp_path, runs, **top)
    with pytest.raises(InputError) as err:
        study.run_study(str(f), _never)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"{f}: {key}") and value in msg, msg


def test_a_repeated_run_is_refused_not_silently_replaced(tmp_path):
    f = _write(tmp_path, [_run(), S2, _run(gradient_mm_per_lambda=9.9)])
    with pytest.raises(InputError, match=r"runs\[2\]: set 'S1', artefact 'A' repeats runs\[0\]"):
        study.run_study(str(f), _never)


def test_a_valid_study_of_measured_gradients_still_fits(tmp_path):
    f = _write(
        tmp_path,
        [_run(), S2, {"set": "S3", "artefact": "A", "focal_length_mm": "50", "gradient_mm_per_lambda": 6.5}],
        predict_focal_mm=45,
        truth={"sets": [{"set": "S2", "gradient_mm_per_lambda": 5.01}], "gradient_law": {"slope": 0.15}},
    )
    out = study.run_study(str(f), _never)
    assert out["focal"]["slope"] == pytest.approx(0.15) and out["focal"]["intercept"] == pytest.approx(-1.0)
    assert out["focal"]["predicted"]["gradient_mm_per_lambda"] == pytest.approx(5.75)
    assert out["truth"]["sets"][0]["difference"] == pytest.approx(-0.01)


def _files(folder):
    (folder / "cloud.ply").write_text("ply\n")
    (folder / "views.json").write_text("{}")
    (folder / "depth").mkdir()


@pytest.mark.parametrize("cloud", ["/etc/passwd", "../x.ply", "../outside/cloud.ply"])
def test_a_path_outside_the_confined_folders_is_refused_before_it_is_read(tmp_path, monkeypatch, cloud):
    project = tmp_path / "project"
    project.mkdir()
    _files(project)
    outside = tmp_path / "outside"
    outside.mkdir()
    _files(outside)
    f = _write(project, [{"set": "S1", "artefact": "A", "cloud": cloud, "views": "views.json", "depth_maps": "depth"}])
    # every path looked at or opened through pathlib while the study is checked (not stat:
    # Path.resolve stats the result to detect a symlink loop, which reads nothing)
    touched = []
    for name in ("is_file", "is_dir", "exists", "open", "read_bytes", "read_text"):
        original = getattr(Path, name)

        def spy(self, *a, _original=original, **k):
            touched.append(str(self))
            return _original(self, *a, **k)

        monkeypatch.setattr(Path, name, spy)
    with confined([project]):
        with pytest.raises(PathRefused) as err:
            study.load_study(str(f))
    monkeypatch.undo()
    assert any(t.endswith("study.yaml") for t in touched)  # the spy works: the study itself was read
    assert not [t for t in touched if t.endswith(("passwd", "x.ply", "cloud.ply"))], touched
    msg = str(err.value)
    assert "study.yaml: runs[0].cloud" in msg and "outside the folders" in msg, msg
    assert "no such" not in msg  # never says whether the refused file exists


def test_paths_are_relative_to_the_study_and_inside_are_accepted(tmp_path):
    project = tmp_path / "project"
    (project / "run").mkdir(parents=True)
    _files(project / "run")
    f = _write(project, [{"set": "S1", "artefact": "A", "cloud": "run/cloud.ply", "views": "run/views.json",
                          "depth_maps": "run/depth", "lambda_range": [-6, 9]}])  # fmt: skip
    seen = {}

    def fake(cloud, views, depth_maps, **params):
        seen.update(cloud=cloud, views=views, depth_maps=depth_maps, **params)
        return {
            "result": {"mean": 3.5, "std": 0.01, "n_views": 1, "views": [], "focal_length_px": 100.0},
            "scatter": [],
        }

    with confined([project]):
        study.run_study(str(f), fake)
    assert seen["cloud"] == str((project / "run" / "cloud.ply").resolve())
    assert seen["lambda_range"] == "-6.0,9.0"


def _views(**cam):
    c = {"fx": 100.0, "fy": 100.0, "cx": 31.5, "cy": 23.5, "width": 64, "height": 48, **cam}
    return {"camera": c, "views": [{"image": "v0.png", "R": np.eye(3).tolist(), "t": [0, 0, 300]}]}


@pytest.mark.parametrize(
    "change, needle",
    [
        (lambda d: d["camera"].update(fx=-500.0), "fx -500"),
        (lambda d: d["camera"].update(fy=float("nan")), "fy nan"),
        (lambda d: d["camera"].update(width="abc"), "cameras[0].width"),
        (lambda d: d["views"][0].update(R=[[2, 0, 0], [0, 1, 0], [0, 0, 1]]), "views[0].R is not a rotation"),
        (lambda d: d["views"][0].update(R=[[-1, 0, 0], [0, 1, 0], [0, 0, 1]]), "views[0].R is not a rotation"),
        (lambda d: d["views"][0].update(t=[0, 0, float("inf")]), "non-finite"),
    ],
)
def test_views_with_impossible_cameras_or_poses_are_refused(tmp_path, change, needle):
    d = _views()
    change(d)
    p = tmp_path / "views.json"
    p.write_text(json.dumps(d))
    with pytest.raises(InputError) as err:
        grad.load_views(str(p))
    assert str(err.value).startswith(str(p)) and needle in str(err.value), str(err.value)


def test_a_depth_map_bomb_is_refused_by_the_capped_reader(tmp_path):
    p = tmp_path / "v0.png"
    p.write_bytes(png(20000, 20000))
    with pytest.raises(InputError, match=r"v0\.png: the image header declares 20000 x 20000 px"):
        lytro.read_raw(p)
    p.write_bytes(png(4000, 2500))  # under the reader's cap, above a depth map's 8 Mpx
    with pytest.raises(InputError, match=r"v0\.png: 4000 x 2500 px, more than the 8 Mpx"):
        lytro.read_raw(p)
    with pytest.raises(InputError, match=r"v0\.txt: not a depth-map image"):
        lytro.read_raw(tmp_path / "v0.txt")
    with pytest.raises(InputError, match="must be finite"):
        lytro.parse_range("-inf,inf")


@pytest.mark.parametrize(
    "text", ['[["a",1],[2,3],[4,5]]', "[[NaN,1],[2,3],[4,5]]", '{"a": 1}', "[[1e400,1],[2,3],[4,5]]"]
)
def test_a_polygon_of_non_numbers_is_one_line(text):
    from camcmm_plugins.lightfield.plugin import _polygon

    with pytest.raises(InputError, match="polygon .*finite numbers"):
        _polygon(text)
