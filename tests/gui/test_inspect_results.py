"""The Inspect page's result as a report reads (issue 15), and what feeds its form.

Pure functions first (numbers.py, report.py, results.py, form.py: no trame), on a real
sphere fit of points with a known radius; then the page on a real project (slow): a
fit's report, its residuals coloured in µm, a derived item named once, the picker
staying on the imported cloud, and a run that cannot start saying why.
"""

from __future__ import annotations

import asyncio
import os

import numpy as np
import pytest

from camcmm.gui.pages.inspect import numbers as fmt
from camcmm.gui.pages.inspect.form import inputs_of, run_blocker
from camcmm.gui.pages.inspect.report import parameters_line, report_rows
from camcmm.gui.pages.inspect.results import derived_name, residual_fields
from camcmm.host import default_host
from camcmm.jsonable import to_jsonable
from camcmm.model import PointCloud

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def ball(n: int = 3000, r: float = 10.0, noise: float = 0.002, seed: int = 3) -> PointCloud:
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    pts = d * (r + noise * rng.normal(size=n))[:, None] + [1.0, 2.0, 3.0]
    return PointCloud(pts, name="ball")


# -- numbers -------------------------------------------------------------------------------
def test_numbers_read_as_a_report_writes_them():
    assert fmt.decimals_for(1.89e-5) == 6 and fmt.decimals_for(0.004) == 4 and fmt.decimals_for(None) == 4
    assert fmt.mm(9.99998341, 1.89e-5) == "9.999983"
    assert fmt.mm(-5.00000723, 2.7e-5) == "\u22125.000007"  # a real minus
    assert (
        fmt.micro(0.0157) == "15.7"
        and fmt.micro(0.00399) == "3.99"
        and fmt.micro(0.0315) == "31.5"
        and fmt.micro(0.1234) == "123"
    )
    assert fmt.micro(-0.0157, signed=True) == "\u221215.7" and fmt.micro(0.0157, signed=True) == "+15.7"
    assert fmt.uncertainty_parts(1.89e-5) == ("0.019", "µm")
    assert fmt.uncertainty_parts(0.0042) == ("4.2", "µm") and fmt.uncertainty_parts(2.5) == ("2.5", "mm")
    assert fmt.uncertainty_parts(float("nan")) == ("not defined", "")
    assert fmt.count(59997) == "59 997"
    assert fmt.vector([1.0, -2.0, 3.0], [1e-5, 2e-5, 3e-5]) == "(1.000000, \u22122.000000, 3.000000)"
    assert fmt.uncertainty_vector([2.7e-5, 3.8e-5]) == ("(0.027, 0.038)", "µm")


# -- the report ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sphere_fit():
    host = default_host()
    res = host.run("fit.sphere", {"cloud": ball()}, {"nominal_radius": 10.0})
    return host.get("fit.sphere"), res


@pytest.mark.slow  # the host and one fit: seconds on a busy machine
def test_a_sphere_fit_reports_diameter_radius_u_and_form_in_micrometres(sphere_fit):
    spec, res = sphere_fit
    out = res.outputs
    rows = report_rows(to_jsonable(out), spec.outputs, {"deviations": "ball deviations"})
    by = {r["name"]: r for r in rows}
    names = [r["name"] for r in rows]
    # declared outputs only, in the declaration's order; u feeds a column, not a row
    assert names[:3] == ["center", "diameter", "radius"]
    assert "std_uncertainty" not in by and "removed_indices" not in by and "element" not in by
    r, ur = out["radius"], out["std_uncertainty"]["radius"]
    assert by["radius"]["value"] == fmt.mm(r, ur) and by["radius"]["unit"] == "mm"
    assert by["radius"]["u"] == " ".join(fmt.uncertainty_parts(ur))
    assert by["diameter"]["value"] == fmt.mm(2 * r, 2 * ur) and by["diameter"]["u"] == " ".join(
        fmt.uncertainty_parts(2 * ur)
    )
    assert float(by["diameter"]["value"]) == pytest.approx(2 * r, abs=2e-6)
    # "u" says what it is: a standard uncertainty, k = 1, from the fit's covariance
    assert by["radius"]["u_what"].startswith("standard uncertainty u (k = 1) from the fit's residuals")
    assert by["n_points"]["u_what"] == ""  # no u, no words about it
    assert by["center"]["unit"] == "mm" and by["center"]["u"].endswith("µm") and by["center"]["label"] == "centre"
    # form in µm, one row per figure; the range as the plugin computed it
    assert by["form_range"]["unit"] == "µm" and float(by["form_range"]["value"]) == pytest.approx(
        out["form"]["range"] * 1e3, rel=0.01
    )
    assert by["form_max"]["value"].startswith("+")
    # a small deviation without its own u reads in µm; counts are grouped
    assert by["radius_deviation"]["unit"] == "µm" and by["radius_deviation"]["label"] == "radius \u2212 nominal"
    assert by["n_points"]["value"] == "3 000" and by["n_points"]["label"] == "points"
    assert by["deviations"]["value"].startswith("item 'ball deviations'")
    # a stored result (JSON, as the project gives it back) reads the same
    assert report_rows(res.to_json()["outputs"], spec.outputs, {"deviations": "ball deviations"}) == rows


@pytest.mark.slow  # the host and one fit: seconds on a busy machine
def test_undeclared_outputs_give_no_report_and_parameters_read_with_units(sphere_fit):
    spec, res = sphere_fit
    assert report_rows(to_jsonable(res.outputs), []) == []
    line = parameters_line({"outliers": "none", "nominal_radius": 10.0, "extract": True, "x": None}, spec.parameters)
    assert line == "outliers none · nominal radius 10 mm · extract on"


# -- derived items -------------------------------------------------------------------------
def test_derived_items_are_named_once_and_never_twice_the_same():
    assert derived_name("ball deviations deviations", "ball deviations", "f", set()) == "ball deviations"
    assert derived_name("ball deviations", "ball", "f", set()) == "ball deviations"
    assert derived_name("ball deviations", "ball", "f", {"ball deviations"}) == "ball deviations (2)"
    assert derived_name("x", "x", "fit.sphere deviations of x", set()) == "fit.sphere deviations of x"
    taken = {"ball deviations", "ball deviations (2)"}
    assert derived_name("ball deviations deviations", "ball deviations", "f", taken) == "ball deviations (3)"


@pytest.mark.slow  # the host and one fit: seconds on a busy machine
def test_the_fits_residuals_are_the_field_to_colour_by_in_micrometres(sphere_fit):
    _, res = sphere_fit
    src = ball()
    assert residual_fields(res.outputs["deviations"], {"cloud": src}) == {"deviation": "µm"}
    big = PointCloud(src.points, fields={"d": np.full(src.n_points, 2.0)}, field_units={"d": "mm"})
    assert residual_fields(big, {"cloud": src}) == {"d": "mm"}
    assert residual_fields(big, {"cloud": big}) == {}  # the input had it: nothing the run added


# -- the form ------------------------------------------------------------------------------
ITEMS = [
    {"id": "1", "name": "scan", "kind": "pointcloud", "derived": False},
    {"id": "2", "name": "cad", "kind": "mesh", "derived": False},
    {"id": "3", "name": "scan 2", "kind": "pointcloud", "derived": False},
    {"id": "4", "name": "scan deviations", "kind": "pointcloud", "derived": True},
]


@pytest.mark.slow  # the host and one fit: seconds on a busy machine
def test_the_picker_offers_the_users_item_not_the_newest_derived(sphere_fit):
    spec, _ = sphere_fit
    _, values = inputs_of(spec, ITEMS, {}, None)
    assert values == {"cloud": "3"}  # the newest imported, not the derived 4
    assert inputs_of(spec, ITEMS, {}, "1")[1] == {"cloud": "1"}  # the one the user picked
    assert inputs_of(spec, ITEMS, {"cloud": "4"}, "1")[1] == {"cloud": "4"}  # a choice made in the form stays
    assert inputs_of(spec, ITEMS[3:], {}, None)[1] == {"cloud": "4"}  # only derived ones: take it


def test_input_ports_are_labelled_in_words():
    """A port reads as words and its kind as a person says it ("depth maps (files)", not
    "depth_maps (file)"): the manifest's keys stay the names."""
    from types import SimpleNamespace as NS

    spec = NS(
        inputs=[
            NS(name="depth_maps", type="files", optional=False, help=""),
            NS(name="cloud", type="geometry", optional=True, help="the scan"),
        ]
    )
    inputs, _ = inputs_of(spec, ITEMS, {}, None)
    assert [i["label"] for i in inputs] == ["depth maps (files) *", "cloud (cloud or mesh)"]
    assert [i["name"] for i in inputs] == ["depth_maps", "cloud"]
    assert inputs[0]["help"] == "the input depth maps (files)"


@pytest.mark.slow  # the host and one fit: seconds on a busy machine
def test_a_run_that_cannot_start_says_why(sphere_fit):
    spec, _ = sphere_fit
    assert run_blocker(spec, {"nominal_radius": "10"}, {"cloud": "1"}, ITEMS) == ""
    assert run_blocker(spec, {"nominal_radius": ""}, {"cloud": "2"}, ITEMS) == ""  # a mesh is a geometry
    assert "nominal_radius" in run_blocker(spec, {"nominal_radius": "-1"}, {"cloud": "1"}, ITEMS)
    assert "nominal_radius" in run_blocker(spec, {"nominal_radius": "abc"}, {"cloud": "1"}, ITEMS)
    assert "import a file or choose an item" in run_blocker(spec, {}, {"cloud": None}, ITEMS)
    assert "not in the project" in run_blocker(spec, {}, {"cloud": "99"}, ITEMS)


# -- the page ------------------------------------------------------------------------------
@pytest.mark.slow
def test_the_page_reports_a_fit_colours_it_and_keeps_the_picker(gui_app, tmp_path):
    pytest.importorskip("trame")
    from camcmm import io as cio

    f = tmp_path / "ball.ply"
    cio.write(ball(), f)
    server, s = gui_app()
    page, state = server.pages["inspect"], server.state
    imported = s.import_file(f)
    page.select_plugin("fit.sphere")
    assert state.input_values == {"cloud": imported} and state.run_reason == ""
    assert asyncio.run(page.run_form("fit.sphere", {"nominal_radius": "10"}, state.input_values)) is not None
    assert [r["name"] for r in state.report_rows][:3] == ["center", "diameter", "radius"]
    assert "nominal radius 10 mm" in state.result_params and state.run_status.startswith("done")
    derived = state.selected_item
    assert derived != imported and state.legend_title == "deviation [µm]"  # the residuals, in µm
    assert state.input_values == {"cloud": imported}
    page.select_plugin("fit.plane")  # a new form offers the imported cloud, not the fit's output
    assert state.input_values == {"cloud": imported}
    # fitting the derived item again names its output once
    page.select_plugin("fit.sphere")
    assert asyncio.run(page.run_plugin("fit.sphere", {}, {"cloud": derived})) is not None
    names = [it["name"] for it in state.items]
    assert names == ["ball.ply", "ball.ply deviations", "ball.ply deviations (2)"], names
    # refused runs: a bad value, a run going; nothing stored
    n = len(s.project.results())
    assert asyncio.run(page.run_form("fit.sphere", {"nominal_radius": "-2"}, state.input_values)) is None
    assert "nominal_radius" in state.run_reason and "nominal_radius" in s.page_error("inspect")
    page.job.begin()
    try:
        assert asyncio.run(page.run_form("fit.sphere", {}, state.input_values)) is None
        assert state.run_reason.startswith("a run is going")
    finally:
        page.job.end()
    assert asyncio.run(page.run_form(None, {}, {})) is None and state.run_reason == "choose a plugin first"
    assert len(s.project.results()) == n


def test_a_stored_results_cloud_output_reads_as_its_summary():
    ports = [{"name": "deviations", "type": "pointcloud"}, {"name": "n_points", "type": "int"}]
    stored = {"deviations": {"kind": "pointcloud", "name": "ball deviations", "n_points": 59997}, "n_points": 3}
    rows = report_rows(stored, ports)
    assert [r["value"] for r in rows] == ["point cloud 'ball deviations', 59 997 points", "3"]
