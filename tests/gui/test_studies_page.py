"""The Studies page's logic without a browser (issue 18).

The light-field study is the virtual lab's (virtuallab.lightfield-set, written through
the page's "Make a virtual-lab study" into the project folder), whose true gradient
law g = -1 + 0.15 f (mm/λ, f in mm) is set by construction: the page must run it through
the plugin, show table 6.3 with the plugin's numbers (each set's std the sample std of
its gradients), the fit and the prediction at 45 mm near the law's 5.75 mm/λ, the
depth-vs-λ scatter with its line and the focal-length plot with error bars; store the
run and show it again in a reopened project; export the plugin's report. A study file
outside the project folder and data roots is refused in one line before it is read;
a cancelled run stores nothing. The speckle study's tables and side-by-side maps are
checked on a record exact by construction (the study itself runs minutes).
"""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("trame")

from camcmm.host import Cancelled  # noqa: E402

pytestmark = pytest.mark.slow  # each test builds a GUI server (several seconds)

LAW = (-1.0, 0.15)  # virtuallab.lightfield-set's default gradient law g = a + b f


@pytest.fixture
def app(gui_app):
    def make(project_dir=None):
        server, session = gui_app(project_dir)
        return server.pages["studies"], session

    return make


def test_opens_with_both_kinds_and_the_declared_form(app):
    page, session = app()
    s = page.state
    assert {k["value"] for k in s.st_kinds} == {"lightfield", "speckle"}
    names = {f["name"] for f in s.st_fields}
    assert "predict_focal_mm" in names and "study" not in names  # the file is the page's own field
    assert s.st_tables == [] and s.st_error == ""
    page.set_kind("speckle")
    assert {f["name"] for f in s.st_fields} == {"fresh"}
    from camcmm.gui.pages.studies.page import check_params

    # the speckle study's required 'study' parameter is the page's file field, not the form's
    assert check_params(page.spec(), s.st_params) == {"fresh": False}
    page.set_kind("nonsense")  # ignored
    assert s.st_kind == "speckle"


def test_a_study_file_outside_the_roots_is_refused_in_one_line(app, tmp_path):
    page, session = app()
    n = len(session.project.results())
    outside = tmp_path / "elsewhere" / "study.yaml"
    outside.parent.mkdir()
    outside.write_text("runs: []\n")
    assert asyncio.run(page.run_async(file=str(outside))) is None
    err = page.state.st_error
    assert "\n" not in err and "study file" in err and "outside the folders" in err
    assert asyncio.run(page.run_async(file="../elsewhere/study.yaml")) is None
    assert "outside the folders" in page.state.st_error
    assert asyncio.run(page.run_async(file="missing.yaml")) is None
    assert "no such file" in page.state.st_error
    assert asyncio.run(page.run_async(file="")) is None
    assert "give the path" in page.state.st_error
    assert asyncio.run(page.run_async({"predict_focal_mm": -3}, file=str(outside))) is None
    assert "predict_focal_mm" in page.state.st_error
    assert len(session.project.results()) == n


def test_the_virtual_light_field_study_through_the_page(app, tmp_path):
    page, session = app(tmp_path / "proj")
    s = page.state
    n = len(session.project.results())
    path = asyncio.run(page.make_virtual_async())
    assert path and Path(path).is_file() and Path(path).resolve().is_relative_to((tmp_path / "proj").resolve())
    assert s.st_file == path and s.st_error == ""

    rec = asyncio.run(page.run_async({"predict_focal_mm": 45}))
    assert rec is not None, s.st_error
    assert len(session.project.results()) == n + 1 and s.st_progress == 100.0

    t = rec["outputs"]["table"]
    g = np.array(t["gradients"], float)  # [artefact][set]
    true = LAW[0] + LAW[1] * np.array(t["focal_length_mm"])
    assert np.allclose(g, true[None, :], atol=0.02)  # the lambda noise of 0.02 over ~hundreds of pixels
    (t63,) = s.st_tables
    assert t63["header"] == ["Artefact", *t["sets"]]
    assert [r[0] for r in t63["rows"][-3:]] == ["Standard deviation / µm λ⁻¹", "Mean / mm λ⁻¹", "Focal length / mm"]
    std_um = 1000 * np.std(g, axis=0, ddof=1)  # table 6.3's last row: the sample std of each set's gradients
    # the number rule: a value that rounds to zero is written "0"
    assert t63["rows"][-3][1:] == [f"{v:.1f}" if round(v, 1) else "0" for v in std_um]
    assert t63["rows"][0][1:] == [f"{v:.4f}" for v in g[0]]

    numbers = {r["name"]: r["value"] for r in s.st_numbers}
    pred = rec["outputs"]["focal"]["predicted"]
    assert abs(pred["gradient_mm_per_lambda"] - (LAW[0] + LAW[1] * 45)) < 0.02
    assert numbers["predicted"].startswith(f"{pred['gradient_mm_per_lambda']:.5f} mm λ⁻¹, u ")
    assert "slope" in numbers and any(k.startswith("truth-") for k in numbers)

    scatter = s.st_fig_scatter["data"]
    assert [d["name"] for d in scatter[:2]] == ["left out", "fitted"] and len(scatter[1]["x"]) > 50
    line = scatter[2]
    view = rec["outputs"]["scatter"][0]["views"][0]
    assert np.allclose(line["y"], [view["gradient_mm_per_lambda"] * x + view["intercept"] for x in line["x"]])
    assert len(s.st_views) == sum(len(r["views"]) for r in rec["outputs"]["scatter"]) > 1
    page.show_view(s.st_views[-1]["value"])
    assert s.st_fig_scatter["data"][2]["name"] != line["name"] or len(s.st_views) == 1

    focal = s.st_fig_focal["data"]
    assert focal[0]["x"] == t["focal_length_mm"] and focal[0]["error_y"]["array"] == [
        p["std"] for p in rec["outputs"]["focal"]["points"]
    ]
    f = rec["outputs"]["focal"]
    assert np.allclose(focal[1]["y"], [f["slope"] * x + f["intercept"] for x in focal[1]["x"]])
    assert focal[2]["x"] == [45.0]

    links = asyncio.run(page.report_async())
    assert links and [x["kind"] for x in links] == ["html", "pdf", "json"], s.st_error
    html = (page.offered.folder / links[0]["name"]).read_text()
    assert "table 6.3" in html and f"{g[0][0]:.4f}" in html

    page2, _ = app(tmp_path / "proj")  # the project reopened: the run is shown again
    assert page2.state.st_tables == s.st_tables and page2.state.st_file == path
    assert page2.state.st_fig_focal["data"][0]["x"] == t["focal_length_mm"]


def test_a_cancelled_study_stores_nothing(app, tmp_path):
    page, session = app()
    study = Path(session.roots.project) / "study.yaml"
    study.write_text("runs: []\n")
    started = threading.Event()

    def waits(host, req, params, progress=None, cancel=None):
        started.set()
        while not cancel.is_set():
            time.sleep(0.01)
        raise Cancelled("the study: cancelled")

    page.runner = waits
    n = len(session.project.results())

    async def go():
        task = asyncio.ensure_future(page.run_async(file=str(study)))
        while not started.is_set():
            await asyncio.sleep(0.01)
        page.cancel()
        return await task

    assert asyncio.run(go()) is None
    assert page.state.st_message == "cancelled" and not page.state.st_running
    assert len(session.project.results()) == n and page.state.st_tables == []


def test_speckle_tables_and_side_by_side_maps(app):
    """A record exact by construction: two cases of one artefact/material, each deviation
    cloud a plane whose deviation is x/100 mm (off) and x/200 mm (on)."""
    page, _ = app()
    x, y = np.meshgrid(np.linspace(-10, 10, 30), np.linspace(-10, 10, 30))
    x, y = x.ravel(), y.ravel()

    def cloud(k):
        return {"x": x.tolist(), "y": y.tolist(), "z": [0.0] * len(x), "d": (x / k).tolist()}

    cases = [
        {"id": "p-n-off", "artefact": "am_pyramid", "material": "nylon12", "condition": "off", "std_um": 231.4,
         "n_points": 12345, "coverage_area_fraction": 0.5, "coverage_by_face": {"top": 1.0, "side": 0.25}},
        {"id": "p-n-on", "artefact": "am_pyramid", "material": "nylon12", "condition": "on", "std_um": 120.0,
         "n_points": 54321, "coverage_area_fraction": 0.75, "coverage_by_face": {"top": 1.0, "side": 0.5}},
    ]  # fmt: skip
    rec = {
        "result": 7, "kind": "speckle", "name": "s/study.yaml", "warnings": [],
        "outputs": {"cases": cases, "summary": {"nylon12": {"std_um_change": -111.4, "n_points_change": 41976,
                                                            "coverage_area_fraction_change": 0.25}}},
        "maps": {"p-n-off": cloud(100.0), "p-n-on": cloud(200.0)},
    }  # fmt: skip
    rec["warnings"] = [f"image{k:03d}.png: 1 % of the pixels saturate" for k in range(24)] + ["grain"] * 2
    page.show_record(rec)
    w = page.state.st_warnings  # 25 distinct: four shown and a line for the rest
    assert w[:4] == rec["warnings"][:4] and w[4] == "… and 21 more warning(s): see the report" and len(w) == 5
    t61, t62, cov = page.state.st_tables
    # the study file's keys in words (issue 30): am_pyramid, nylon12, the case ids
    assert t61["header"] == ["Artefact", "nylon 12 non-speckle", "nylon 12 speckle"]
    assert t61["rows"] == [["AM pyramid", "231", "120"]] and t62["rows"] == [["AM pyramid", "12 345", "54 321"]]
    assert cov["rows"] == [
        ["AM pyramid · nylon 12 · non-speckle", "50.0", "100.0", "25.0", "—"],
        ["AM pyramid · nylon 12 · speckle", "75.0", "100.0", "50.0", "—"],
    ]
    assert page.state.st_numbers[0]["value"] == "std \u2212111 µm, points +41 976, coverage +25.0 %"
    off, on = page.state.st_fig_off["data"][0], page.state.st_fig_on["data"][0]
    assert off["marker"]["cmax"] == on["marker"]["cmax"]  # one colour range for the pair
    assert max(off["marker"]["color"]) == pytest.approx(100.0) and max(on["marker"]["color"]) == pytest.approx(50.0)
