"""The speckle study's file is validated whole before anything is created (issue 26): a
string where a mapping belongs, a work folder that is a file / under a file / not
writable, every key's type and range — one line naming the file, the key path and the
value; every path through camcmm.api.document_path (a confined run refuses one outside
before creating or listing it); a study whose every case failed exits 3."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from camcmm import confine
from camcmm.api import InputError, PathRefused
from camcmm_plugins.studies import cases, speckle, studyfile
from helpers.cli import main_run

PNG = b"\x89PNG\r\n\x1a\n"  # the signature is all the study file's checks read


def _study(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "STUDY.yaml"
    f.write_text(text, encoding="utf-8")
    return f


def _images(folder: Path, n: int = 3, data: bytes = PNG) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(n):
        (folder / f"{k}.png").write_bytes(data)


ONE = "artefacts: [am_pyramid]\nmaterials: [abs]\nconditions: [off]\n"
IMG = ONE + "capture:\n  images:\n    - {artefact: am_pyramid, material: abs, condition: off, folder: img}\n"


@pytest.mark.parametrize(
    "text, match",
    [
        # a string (or a list) where a mapping belongs: formerly AttributeError / TypeError
        ("capture: simulated\n", r"^STUDY.yaml: capture: must be a mapping \(simulated, images\), got 'simulated'$"),
        ("capture: {simulated: fast}\n", r"^STUDY.yaml: capture.simulated: must be a mapping .*got 'fast'$"),
        ("reconstruct: big\n", r"^STUDY.yaml: reconstruct: must be a mapping .*got 'big'$"),
        ("align: [auto]\n", r"^STUDY.yaml: align: must be a mapping .*got \['auto'\]$"),
        ("coverage: 3\n", r"^STUDY.yaml: coverage: must be a mapping .*got 3$"),
        ("artefacts: [{name: am_sphere, sizes: big}]\n", r"^STUDY.yaml: artefacts\[0\].sizes: must be a mapping"),
        (ONE + "capture: {images: [img]}\n", r"^STUDY.yaml: capture.images\[0\]: must be a mapping .*got 'img'$"),
        (ONE + "capture: {images: img}\n", r"^STUDY.yaml: capture.images: must list image folders"),
        ("- a\n- b\n", r"^STUDY.yaml: expected a mapping"),
        # unknown keys, names and duplicates
        ("speed: 3\n", r"^STUDY.yaml: speed: is not a key here; use name, work"),
        ("artefacts: [am_cube]\n", r"^STUDY.yaml: artefacts\[0\]: unknown artefact 'am_cube'"),
        ("artefacts: am_cube\n", r"^STUDY.yaml: artefacts: unknown artefact 'am_cube'"),
        ("artefacts: [{name: am_sphere, size: {}}]\n", r"^STUDY.yaml: artefacts\[0\].size: is not a key here"),
        ("materials: [abs, abs]\n", r"^STUDY.yaml: materials\[1\]: material 'abs' is listed twice$"),
        ("conditions: [on, sideways]\n", r"^STUDY.yaml: conditions\[1\]: unknown condition 'sideways'"),
        ("conditions: []\n", r"^STUDY.yaml: conditions: lists no condition"),
        ("name: [a]\n", r"^STUDY.yaml: name: must be a text, got \['a'\]$"),
        # types and ranges by the declarations of the plugins the settings go to
        (
            "capture: {simulated: {n_images: 0}}\n",
            r"^STUDY.yaml: capture.simulated.n_images: .*= 0 is below its minimum",
        ),
        ("capture: {simulated: {n_images: many}}\n", r"^STUDY.yaml: capture.simulated.n_images: .*'many' is not"),
        ("capture: {simulated: {downscale: .nan}}\n", r"^STUDY.yaml: capture.simulated.downscale: .*not finite"),
        ("capture: {simulated: {seed: null}}\n", r"^STUDY.yaml: capture.simulated.seed: is empty"),
        ("reconstruct: {max_image_size: 10}\n", r"^STUDY.yaml: reconstruct.max_image_size: .*= 10 is below"),
        ("reconstruct: {scheduler: 'tcp://1.2.3.4:1'}\n", r"^STUDY.yaml: reconstruct.scheduler: is not a key"),
        ("reconstruct: {scale: 'lengths:/etc/passwd'}\n", r"^STUDY.yaml: reconstruct.scale: is not a key"),
        ("align: {method: magic}\n", r"^STUDY.yaml: align.method: .*'magic' is not a valid choice"),
        ("align: {inlier_distance: -1}\n", r"^STUDY.yaml: align.inlier_distance: .*= -1.0 is below"),
        ("coverage: {samples: 5}\n", r"^STUDY.yaml: coverage.samples: .*= 5 is below its minimum 1000"),
        ("coverage: {distance: -0.1}\n", r"^STUDY.yaml: coverage.distance: .*is below"),
        ("artefacts: [{name: am_sphere, sizes: {diameter: 1e300}}]\n", r"sizes.diameter: must be a size in mm"),
        ("artefacts: [{name: am_sphere, sizes: {diameter: abc}}]\n", r"sizes.diameter: must be a size in mm"),
        # image entries
        (ONE + "capture: {images: [{artefact: am_pyramid, material: abs, condition: off}]}\n", r"images\[0\].folder:"),
        (IMG.replace("folder: img", "folder: img, pairs: {measured: [[0, 0, 0]], nominal: []}"), r"pairs.measured"),
        (IMG.replace("condition: off,", "condition: maybe,"), r"capture.images\[0\].condition: unknown condition"),
    ],
)
def test_every_key_is_checked_in_one_line_before_anything_is_created(tmp_path, text, match):
    _images(tmp_path / "img")
    with pytest.raises(InputError, match=match) as e:
        studyfile.load(_study(tmp_path, text))
    assert "\n" not in str(e.value)
    assert not (tmp_path / "STUDY.work").exists()


def test_image_folders_missing_empty_or_without_images(tmp_path):
    f = _study(tmp_path, IMG)
    with pytest.raises(
        InputError, match=r"^STUDY.yaml: capture.images\[0\].folder: image folder 'img' does not exist$"
    ):
        studyfile.load(f)
    (tmp_path / "img").write_text("a file")
    with pytest.raises(InputError, match=r"folder: 'img' is not a folder$"):
        studyfile.load(f)
    (tmp_path / "img").unlink()
    _images(tmp_path / "img", n=2)
    with pytest.raises(InputError, match=r"folder: 'img' holds 2 image\(s\); a case needs at least 3$"):
        studyfile.load(f)
    (tmp_path / "img" / "2.png").write_bytes(b"not a picture at all")
    with pytest.raises(InputError, match=r"folder: 2.png in 'img' is not an image"):
        studyfile.load(f)
    (tmp_path / "img" / "2.png").write_bytes(PNG)
    assert studyfile.load(f)["images"]["am_pyramid-abs-off"]["folder"] == str((tmp_path / "img").resolve())


def test_a_work_folder_that_cannot_be_one_is_refused_before_it_is_created(tmp_path, monkeypatch):
    (tmp_path / "afile").write_text("x")
    f = _study(tmp_path, "work: afile\n")
    with pytest.raises(InputError, match=r"^STUDY.yaml: work: afile is a file, not a folder$"):
        studyfile.load(f)
    f = _study(tmp_path, "work: afile/sub/w\n")
    with pytest.raises(InputError, match=r"^STUDY.yaml: work: afile/sub/w cannot be created: .*afile is a file$"):
        studyfile.load(f)
    f = _study(tmp_path, "work: ro/w\n")
    (tmp_path / "ro").mkdir()
    real = os.access
    # root may write anywhere, so the permission is denied through os.access itself
    monkeypatch.setattr(os, "access", lambda p, m: False if Path(p) == tmp_path / "ro" else real(p, m))
    with pytest.raises(InputError, match=r"^STUDY.yaml: work: ro/w cannot be written: no permission in .*ro$"):
        studyfile.load(f)
    assert not (tmp_path / "ro" / "w").exists()
    for bad in ("work: ''\n", "work: [a]\n", "work: {a: 1}\n"):
        with pytest.raises(InputError, match=r"^STUDY.yaml: work: must be a folder name"):
            studyfile.load(_study(tmp_path, bad))


def test_a_confined_run_refuses_every_path_outside_before_creating_or_listing_it(tmp_path):
    inside, outside = tmp_path / "in", tmp_path / "out"
    inside.mkdir()
    _images(outside / "img")
    _images(inside / "img")
    f = inside / "STUDY.yaml"
    f.write_text(f"work: {outside / 'w'}\n", encoding="utf-8")
    with confine.confined([inside]), pytest.raises(PathRefused, match=r"^STUDY.yaml: work: .*outside the folders"):
        studyfile.load(f)
    assert not (outside / "w").exists()
    f.write_text(IMG.replace("folder: img", f"folder: {outside / 'img'}"), encoding="utf-8")
    with confine.confined([inside]), pytest.raises(PathRefused, match=r"capture.images\[0\].folder: .*outside the"):
        studyfile.load(f)
    f.write_text(IMG.replace("folder: img", "folder: ../out/img"), encoding="utf-8")
    with confine.confined([inside]), pytest.raises(PathRefused, match="outside the folders"):
        studyfile.load(f)
    # the study file itself, and inside the folders everything resolves against the study
    with confine.confined([inside / "img"]), pytest.raises(PathRefused, match="study: .*outside the folders"):
        studyfile.load(f)
    f.write_text(IMG + "work: results\n", encoding="utf-8")
    with confine.confined([inside]):
        st = studyfile.load(f)
    assert st["work"] == str((inside / "results").resolve()) and not (inside / "results").exists()


def test_sizes_that_make_no_part_are_refused_before_the_work_folder(tmp_path):
    f = _study(tmp_path, "artefacts: [am_pyramid, {name: am_sphere, sizes: {centre_height: 99}}]\n")
    with pytest.raises(InputError, match=r"^STUDY.yaml: artefacts\[1\].sizes: am_sphere: centre_height 99"):
        speckle.speckle_study(_Ctx(), str(f))
    assert not (tmp_path / "STUDY.work").exists()


class _Ctx:
    """The host's algorithms, a run context's warnings."""

    def __init__(self):
        from camcmm.api import default_host

        self.host = default_host()
        self.warnings: list[str] = []

    def algorithm(self, pid):
        return self.host.algorithm(pid)

    def progress(self, *_):
        pass

    def warn(self, w):
        self.warnings.append(w)


def test_a_study_whose_every_case_failed_exits_3_and_a_partial_one_warns(tmp_path, capfd, monkeypatch):
    """In-process (the host runs the plugin here), the cases failing by a stand-in."""
    f = _study(tmp_path, "artefacts: [am_pyramid]\nmaterials: [abs]\n")
    fail = {"am_pyramid-abs-off", "am_pyramid-abs-on"}

    def fake(ctx, st, case, folder):
        if case["id"] in fail:
            raise InputError(f"{case['id']}: no images")
        import numpy as np

        from camcmm.api import PointCloud

        pts = np.zeros((12, 3))
        res = {**case, "std_um": 100.0, "n_points": 12, "coverage_area_fraction": 0.5}
        res["coverage_by_face"] = {"top": 0.5, "side": 0.5, "curved": None, "bottom": 0.0}
        return {"result": res, "deviations": PointCloud(pts, fields={"deviation": pts[:, 0]})}

    monkeypatch.setattr(cases, "run_case", fake)
    code, out, err = main_run(capfd, "study", "speckle", f)
    assert code == 3, err
    assert err.count("\n") == 1
    assert err.startswith(
        "camcmm: STUDY.yaml: every case failed (am_pyramid-abs-off, am_pyramid-abs-on); the first: am_pyramid-abs-off"
    )
    assert "am_pyramid-abs-off: FAILED" in out and "am_pyramid-abs-on: FAILED" in out
    fail.discard("am_pyramid-abs-on")
    code, out, err = main_run(capfd, "study", "speckle", f)
    assert code == 0 and err == ""
    assert "warning: case am_pyramid-abs-off: am_pyramid-abs-off: no images" in out
