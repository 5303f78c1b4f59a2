"""The speckle on/off study of ch. 6.2 (studies.speckle, issue 18): area coverage per face
class against a case whose covered area is known by construction, the study file's
refusals, resuming after an interruption, and one tiny study end to end."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from camcmm.api import Cancelled, InputError, PointCloud, default_host
from camcmm_plugins.studies import cases, speckle, studyfile
from camcmm_plugins.virtuallab import am_artefacts
from helpers.cli import main_json


def _sample(V, F, tri, n, rng):
    """``n`` points uniformly by area on the triangles ``tri``."""
    t = V[F[tri]]
    a = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    k = rng.choice(len(t), n, p=a / a.sum())
    r1, r2 = np.sqrt(rng.random(n)), rng.random(n)
    return (1 - r1)[:, None] * t[k, 0] + (r1 * (1 - r2))[:, None] * t[k, 1] + (r1 * r2)[:, None] * t[k, 2]


@pytest.mark.slow
def test_area_coverage_of_points_on_the_top_faces_only_is_known_by_construction():
    # a 10 x 10 x 4 mm block with a 4 x 4 x 2 mm recess; points only on the faces looking up
    # (the top annulus and the recess floor), 1000 per mm²: every top sample has a point within
    # d = 0.2 mm (chance of none: exp(-π d² ρ) = e^-126). The walls are covered only in the band
    # of height d along their edges on a top face: the outer walls' upper edges (4 x 10 mm) and
    # both edges of the recess walls (2 x 4 x 4 mm): 0.2 * (40 + 32) = 14.4 mm² of 192 mm².
    V, F, cls, _ = am_artefacts.build("am_recess", {"plate": [10, 4], "recess": [4, 2]})
    top = np.flatnonzero(cls == am_artefacts.FACE_CLASSES.index("top"))
    pts = _sample(V, F, top, 100_000, np.random.default_rng(3))
    from camcmm.api import TriangleMesh

    out = (
        default_host()
        .run(
            "inspect.deviations",
            {"cloud": PointCloud(pts), "nominal": TriangleMesh(V, F)},
            {"coverage_distance": 0.2, "coverage_samples": 200_000},
        )
        .outputs
    )
    cc = out["coverage_cloud"]
    by = cases.coverage_by_class(cc.fields["covered"], cc.fields["triangle"], cls, list(am_artefacts.FACE_CLASSES))
    n_side = int(np.sum(cls[np.asarray(cc.fields["triangle"])] == 1))
    se = np.sqrt(0.075 / n_side)  # binomial standard error of the side's share
    assert by["top"] == 1.0
    assert by["bottom"] == 0.0 and by["curved"] is None
    # the band is a little narrower than d: the top points nearest an edge lie ~0.03 mm
    # (1/sqrt(ρ)) from it, so a wall point at depth s needs one within sqrt(d² - s²) along it
    assert 0.85 * 14.4 / 192 - 3 * se < by["side"] < 14.4 / 192 + 3 * se
    vis = cases.visible_fraction(cc.fields["covered"], cc.fields["triangle"], cls, list(am_artefacts.FACE_CLASSES))
    assert vis == pytest.approx((100 + by["side"] * 192) / 292, abs=2e-3)


def _study(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "STUDY.yaml"
    f.write_text(text, encoding="utf-8")
    return f


@pytest.mark.parametrize(
    "text, match",
    [
        ("artefacts: [am_cube]\n", r"STUDY.yaml: artefacts\[0\]: unknown artefact 'am_cube'"),
        ("materials: [steel]\n", r"STUDY.yaml: materials\[0\]: unknown material 'steel'"),
        (
            "artefacts: [am_pyramid]\nmaterials: [abs]\nconditions: [on]\ncapture:\n  images:\n"
            "    - {artefact: am_pyramid, material: abs, condition: on, folder: nowhere}\n",
            r"STUDY.yaml: capture.images\[0\].folder: image folder 'nowhere' does not exist",
        ),
        ("capture:\n  simulated: {n_pictures: 3}\n", r"STUDY.yaml: capture.simulated.n_pictures: is not a key here"),
    ],
)
def test_bad_study_files_are_refused_in_one_line(tmp_path, text, match):
    with pytest.raises(InputError, match=match) as e:
        studyfile.load(_study(tmp_path, text))
    assert "\n" not in str(e.value)


class _Ctx:
    def __init__(self):
        self.warnings = []

    def progress(self, *_):
        pass

    def warn(self, w):
        self.warnings.append(w)


def test_an_interrupted_study_resumes_without_redoing_finished_cases(tmp_path, monkeypatch):
    study = studyfile.load(_study(tmp_path, "artefacts: [am_pyramid, am_recess]\nmaterials: [abs]\n"))
    calls: list[str] = []
    stop = {"at": "am_recess-abs-off"}

    def fake(ctx, st, case, folder):  # the numerics are tested elsewhere; this counts the cases run
        if case["id"] == stop["at"]:
            raise Cancelled("interrupted")
        calls.append(case["id"])
        pts = np.random.default_rng(len(calls)).normal(size=(20, 3))
        res = {**case, "std_um": 100.0 + len(calls), "n_points": 20, "coverage_area_fraction": 0.5}
        return {"result": res, "deviations": PointCloud(pts, fields={"deviation": pts[:, 0]})}

    monkeypatch.setattr(cases, "run_case", fake)
    with pytest.raises(Cancelled):
        speckle.run_study(_Ctx(), study)
    assert calls == ["am_pyramid-abs-off", "am_pyramid-abs-on"]
    stop["at"] = None
    out = speckle.run_study(_Ctx(), study)
    assert calls[2:] == ["am_recess-abs-off", "am_recess-abs-on"]  # only what was not finished
    assert out["reused"] == ["am_pyramid-abs-off", "am_pyramid-abs-on"]
    # a deleted case is computed again, alone; a changed setting recomputes what it touches
    import shutil

    shutil.rmtree(Path(study["work"]) / "am_recess-abs-on")
    out = speckle.run_study(_Ctx(), study)
    assert out["computed"] == ["am_recess-abs-on"] and len(out["reused"]) == 3
    study["reconstruct"]["max_image_size"] = 300
    assert len(speckle.run_study(_Ctx(), study)["computed"]) == 4


def test_summary_is_the_mean_change_per_material():
    rows = []
    for a, off, on in (("p", 200.0, 150.0), ("r", 300.0, 150.0)):
        for cond, s in (("off", off), ("on", on)):
            rows.append(
                {"artefact": a, "material": "m", "condition": cond, "std_um": s, "n_points": 10 if cond == "off" else 7}
                | {"coverage_area_fraction": 0.5 if cond == "off" else 0.6}
            )
    s = speckle.summary(rows)["m"]
    assert s["n_artefacts"] == 2 and s["std_um_change"] == pytest.approx(-100.0)
    assert s["std_um_relative_change"] == pytest.approx((-0.25 - 0.5) / 2)
    assert s["n_points_change"] == -3 and s["coverage_area_fraction_change"] == pytest.approx(0.1)


@pytest.mark.slow
def test_tiny_study_end_to_end_through_the_cli_and_resumed(tmp_path, capfd):
    """One artefact, one material, speckle off and on, 12 small images through 108° (the
    thesis's 9° steps): the CLI's JSON keys, the report, and a rerun that reuses both."""
    f = _study(
        tmp_path,
        "name: tiny\nartefacts: [am_pyramid]\nmaterials: [ti6al4v]\n"
        "capture:\n  simulated: {n_images: 12, arc_deg: 108, downscale: 12, diffuser: 0.06}\n"
        "reconstruct: {max_image_size: 500}\ncoverage: {samples: 20000}\n",
    )
    # in-process (main_json: the CLI's main with capfd), not `python -m camcmm`: the test is
    # about the study's JSON, report and resume, not the process; a subprocess only added
    # interpreter start and imports (~2 s) to each of the two runs
    argv = ["study", "speckle", f, "--json", "--report", tmp_path / "rep"]
    out = main_json(capfd, *argv)
    assert out["failed"] == [] and sorted(out["computed"]) == ["am_pyramid-ti6al4v-off", "am_pyramid-ti6al4v-on"]
    for c in out["cases"]:
        assert set(c) >= {"std_um", "n_points", "coverage_area_fraction", "coverage_by_face"}
        # the reconstruction lands on the CAD: deviations of the order of the thesis's (table 6.1)
        assert 10 < c["std_um"] < 1000 and c["n_points"] > 1000
        assert 0.2 < c["coverage_area_fraction"] <= 1 and c["coverage_by_face"]["bottom"] < 0.05
        assert c["alignment"]["converged"]
    assert set(out["summary"]["ti6al4v"]) >= {"std_um_change", "n_points_change"}
    html = (tmp_path / "rep" / "report.html").read_text("utf-8")
    assert "table 6.1" in html and "Coverage by area" in html
    again = main_json(capfd, *argv[:-2])
    assert again["computed"] == [] and len(again["reused"]) == 2
    assert [c["std_um"] for c in again["cases"]] == [c["std_um"] for c in out["cases"]]


def test_a_study_of_real_image_folders_names_every_case_and_its_folder(tmp_path):
    for c in ("off", "on"):
        (tmp_path / f"img-{c}").mkdir()
        for k in range(3):  # three files with a PNG signature: the study file's checks read no more
            (tmp_path / f"img-{c}" / f"{k}.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    pairs = {"measured": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "nominal": [[0, 0, 4], [20, 0, 4], [0, 20, 4]]}
    f = _study(
        tmp_path,
        "artefacts: [{name: am_recess, sizes: {recess: [10, 3]}}]\nmaterials: [abs]\ncapture:\n  images:\n"
        "    - {artefact: am_recess, material: abs, condition: off, folder: img-off}\n"
        f"    - {{artefact: am_recess, material: abs, condition: on, folder: img-on, pairs: {json.dumps(pairs)}}}\n",
    )
    st = studyfile.load(f)
    assert [c["id"] for c in st["cases"]] == ["am_recess-abs-off", "am_recess-abs-on"]
    assert st["cases"][0]["sizes"] == {"recess": [10, 3]} and st["simulated"] is None
    assert st["images"]["am_recess-abs-on"]["folder"] == str((tmp_path / "img-on").resolve())
    assert st["images"]["am_recess-abs-on"]["pairs"] == pairs
    # the keys differ per case and change with a setting
    k = studyfile.case_key(st, st["cases"][1])
    assert k != studyfile.case_key(st, st["cases"][0])
    st["coverage"]["distance"] = 0.3
    assert studyfile.case_key(st, st["cases"][1]) != k
    (f.parent / "STUDY2.yaml").write_text(f.read_text().split("capture:")[0] + "capture:\n  images: []\n")
    with pytest.raises(InputError, match="STUDY2.yaml: capture.images: no image folder for case am_recess-abs-off"):
        studyfile.load(f.parent / "STUDY2.yaml")


def test_report_tables_have_the_thesis_layout_and_show_a_failed_case():
    from camcmm_plugins.studies.report import build_report

    cov = {"top": 0.9, "side": 0.2, "curved": None, "bottom": 0.0}
    ok = {"std_um": 175.4, "n_points": 1229514, "coverage_area_fraction": 0.5, "coverage_by_face": cov}
    rows = [
        {"id": "am_pyramid-nylon12-off", "artefact": "am_pyramid", "material": "nylon12", "condition": "off"}
        | {"error": "too few images registered"},
        {"id": "am_pyramid-nylon12-on", "artefact": "am_pyramid", "material": "nylon12", "condition": "on"} | ok,
        {"id": "am_recess-abs-off", "artefact": "am_recess", "material": "abs", "condition": "off"} | ok,
    ]
    o = {"cases": rows, "summary": speckle.summary(rows), "study": {"name": "t", "file": "f", "work": "w"}}
    d = build_report(o).to_dict()
    t61, t62 = ([b for b in s["blocks"] if "rows" in b][0] for s in d["sections"][:2])
    assert t61["columns"] == ["Artefact", "Nylon non-speckle", "Nylon speckle", "ABS plastic non-speckle"] + [
        "ABS plastic speckle"
    ]
    assert t61["rows"] == [["Pyramid", "failed", 175, None, None], ["Recess", None, None, 175, None]]
    assert t62["rows"][0] == ["Pyramid", "failed", "1,229,514", None, None]
