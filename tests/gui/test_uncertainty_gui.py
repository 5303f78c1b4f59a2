"""The Uncertainty page's logic, without a browser: the budget editor gives the CLI's
numbers (GUM H.1 and the thesis table; the task's own numbers against the GUM and the CLI
are tests/tasks/test_uncertainty_task.py), a Monte Carlo run publishes its table, charts
and volume maps from the plugin's own numbers, is stored and comes back on reopen;
bad input gets one-line reasons and the page keeps working."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("trame")
pytest.importorskip("pyvista")
pytest.importorskip("trame_plotly")

from camcmm.gui.pages.uncertainty import figures as figs  # noqa: E402
from camcmm.numbers import unit_text  # noqa: E402
from camcmm.tasks import uncertainty as unc  # noqa: E402
from helpers.cli import run_camcmm  # noqa: E402

DATA = Path(__file__).parents[1] / "data" / "uncertainty"


def cli_json(*args) -> dict:
    return json.loads(run_camcmm(*args, "--json").stdout)


def run_mc(page, spec, params):
    """Run the study of the system file text ``spec`` (the form's "load YAML" option),
    or of the form's fields when ``spec`` is None; None when it cannot start or fails."""
    if spec is None:
        page.use_fields()
    elif not page.load_system(spec, "system.yaml"):
        return None
    return asyncio.run(page.run_montecarlo_async(params))


@pytest.mark.slow
def test_budget_editor_reproduces_gum_h1_and_the_cli(gui_app):
    server, _ = gui_app()
    page, s = server.pages["uncertainty"], server.state
    # the starting budget is the shipped thesis table 3.2 (x column): already evaluated
    assert s.unc_b_result is not None and len(s.unc_b_rows) == 5
    doc = yaml.safe_load((DATA / "budget_gum_h1.yaml").read_text())
    assert page.load_budget((DATA / "budget_gum_h1.yaml").read_bytes(), "h1.yaml")
    # GUM H.1.6: u_c = 32 nm, nu_eff = 16, k = t_99(16) = 2.92, U_99 = 93 nm
    assert page.budget["combined"] == pytest.approx(31.7, abs=0.05)
    assert float(s.unc_b_result["dof_eff"]) == pytest.approx(16.7, abs=0.05)  # truncated to 16 for t
    assert float(s.unc_b_result["k"]) == pytest.approx(2.92, abs=0.005)
    assert round(page.budget["expanded"]) == 93
    # the task's numbers (tests/tasks/test_uncertainty_task.py: the task's are the CLI's)
    task = unc.evaluate(server.session.host, unc.read_budget((DATA / "budget_gum_h1.yaml").read_bytes())).outputs
    for key in ("combined", "dof_eff", "k", "expanded"):
        assert page.budget[key] == pytest.approx(task[key], rel=1e-12)
    # the bar chart carries every contribution with its share
    bar = s.unc_b_fig["data"][0]
    assert len(bar["y"]) == len(doc["contributions"])
    # bars and labels are one number: each contribution's share of u_c² in % (they add up to 100)
    shares = [100 * (c["contribution"] / page.budget["combined"]) ** 2 for c in page.budget["contributions"]]
    assert sorted(bar["x"]) == pytest.approx(sorted(shares), rel=1e-9) and sum(bar["x"]) == pytest.approx(100.0)


@pytest.mark.slow
def test_budget_edits_evaluate_live_and_bad_cells_name_the_entry(gui_app, tmp_path):
    server, _ = gui_app()
    page, s = server.pages["uncertainty"], server.state
    rows = [
        {"name": "a", "u": "3", "c": "1", "dof": "inf", "distribution": "normal"},
        {"name": "b", "u": "4", "c": "1", "dof": "inf", "distribution": "rectangular"},
    ]
    page.set_budget("length", "um", 0.95, rows)
    assert page.budget["combined"] == pytest.approx(5.0)
    assert page.budget["k"] == pytest.approx(1.959964, abs=1e-5) and s.unc_b_result["k"] == "1.96"
    bad = [dict(rows[0], u="-1"), rows[1]]
    assert page.set_budget("length", "um", 0.95, bad) is None
    assert "a" in s.unc_b_error and "u" in s.unc_b_error and "\n" not in s.unc_b_error
    zero = [rows[0], dict(rows[1], dof="0")]
    assert page.set_budget("length", "um", 0.95, zero) is None
    assert "dof" in s.unc_b_error
    # the draft is in the project: a reopened page shows the edited (bad) table again
    proj = server.session.project.path
    server2, _ = gui_app(proj)
    assert server2.state.unc_b_rows[1]["dof"] == "0"
    assert page.load_budget(b"contributions: 3", "x.yaml") is False
    assert "x.yaml" in s.unc_error


@pytest.mark.slow
def test_budget_rows_entered_as_half_width_or_expanded_show_the_conversion(gui_app):
    """Each row is entered as u, a half-width a with its distribution or an expanded U with
    k; the table shows the u the plugin made of it and how (GUM 4.3.3-4.3.9)."""
    server, _ = gui_app()
    page, s = server.pages["uncertainty"], server.state
    row = {"name": "rot", "kind": "a", "value": "2.0", "distribution": "rectangular", "k": "", "c": "1", "dof": "14"}
    plain = dict(row, kind="u", value=repr(2.0 / math.sqrt(3)))
    first = {"name": "feature", "kind": "u", "value": "3.1", "distribution": "normal", "k": "", "c": "1", "dof": "inf"}
    page.set_budget("x", "um", 0.95, [first, row])
    assert s.unc_b_result["rows"][1]["conversion"] == "a = 2 µm, rectangular → u = a/√3 = 1.155 µm"
    assert s.unc_b_result["rows"][1]["u"] == "1.155" and s.unc_b_result["rows"][0]["entered_as"] == "u"
    stated = dict(page.budget)
    page.set_budget("x", "um", 0.95, [first, plain])  # the same row entered as u = a/√3
    for key in ("combined", "dof_eff", "k", "expanded"):
        assert page.budget[key] == stated[key]
    page.set_budget("x", "um", 0.95, [first, dict(row, kind="U", distribution="normal", value="3", k="2")])
    assert s.unc_b_result["rows"][1]["conversion"] == "U = 3 µm, normal with k = 2 → u = U/k = 1.5 µm"
    # bad combinations: one line naming the row; the page keeps working
    for bad, needle in (
        (dict(row, value="-2"), "half-width a = -2"),
        (dict(row, distribution="cauchy"), "unknown distribution"),
        (dict(row, kind="U", distribution="normal", value="3"), "needs its coverage factor k"),
        (dict(row, distribution="student-t"), "student-t"),
    ):
        assert page.set_budget("x", "um", 0.95, [first, bad]) is None
        assert needle in s.unc_b_error and "'rot'" in s.unc_b_error and "\n" not in s.unc_b_error
    # the rows come back from the stored draft as entered
    page.set_budget("x", "um", 0.95, [first, row])
    server2, _ = gui_app(server.session.project.path)
    assert server2.state.unc_b_rows[1]["kind"] == "a" and server2.state.unc_b_rows[1]["value"] == "2.0"


@pytest.mark.slow
def test_gum_h1_entered_as_the_gum_states_it_through_the_editor(gui_app):
    """GUM H.1 with U = 75 nm (k = 3) and the rectangular bounds typed as half-widths:
    u_c 31.7 nm, nu_eff 16.8 (16 for t; GUM 16.7 from its rounded u), U 92.5 nm (GUM: 93 nm
    = 2.92 x 32 nm); the same numbers as the CLI on the file."""
    server, _ = gui_app()
    page, s = server.pages["uncertainty"], server.state
    assert page.load_budget((DATA / "budget_gum_h1_half_widths.yaml").read_bytes(), "h1.yaml")
    assert [r["kind"] for r in s.unc_b_rows] == ["U", "u", "a", "u", "a", "a"]
    assert page.budget["combined"] == pytest.approx(31.7, abs=0.05)
    assert page.budget["dof_eff"] == pytest.approx(16.7, abs=0.1) and math.floor(page.budget["dof_eff"]) == 16
    assert float(s.unc_b_result["k"]) == pytest.approx(2.92, abs=0.005)
    assert abs(page.budget["expanded"] - 93) < 1
    assert "u = a/√3 = 0.02887 °C" in s.unc_b_result["rows"][5]["conversion"]
    doc = (DATA / "budget_gum_h1_half_widths.yaml").read_bytes()
    task = unc.evaluate(server.session.host, unc.read_budget(doc)).outputs  # = the CLI's (tests/tasks)
    for key in ("combined", "dof_eff", "k", "expanded"):
        assert page.budget[key] == pytest.approx(task[key], rel=1e-12)


@pytest.mark.slow
def test_montecarlo_form_is_the_plugins_declared_fields(gui_app):
    """No YAML box: the system is the plugin's declared fields (defaults: the thesis system),
    each unit once in its label; a run from the fields is stored with them and shown again."""
    server, session = gui_app()
    page, s = server.pages["uncertainty"], server.state
    assert "unc_mc_spec" not in s.to_dict()
    declared = {p.name: p for p in session.host.provider("monte-carlo-uncertainty").parameters}
    fields = s.unc_mc_fields_system + s.unc_mc_fields_errors + s.unc_mc_fields_run
    names = {f["name"] for f in fields}
    assert {"focal_length", "pixel_pitch", "baseline", "axes_angle", "u_rotation", "u_translation"} <= names
    assert names == set(declared) - {"studies"}
    for f in fields:
        unit = declared[f["name"]].unit
        shown = unit_text(unit)  # µm, µrad, ° as a person reads them (issue 30)
        assert f["label"].count("[") == (1 if unit else 0) and f["label"].endswith(f"[{shown}]" if unit else "")
        assert f.get("help"), f["name"]  # the tooltip (param_form's title)
    assert s.unc_mc_params["focal_length"] == "16.74, 16.66" and s.unc_mc_params["u_rotation"] == "184, 152, 71"
    params = dict(s.unc_mc_params, grid_points="4, 3, 3", iterations=200, studies=[])
    full = run_mc(page, None, params)
    assert full is not None, s.unc_error
    assert full["system"]["grid"]["n"] == [4, 3, 3] and full["system"]["stereo"]["baseline"] == 199.35
    assert full["form"]["grid_points"] == [4.0, 3.0, 3.0]
    server2, _ = gui_app(session.project.path)
    assert server2.state.unc_mc_params["grid_points"] == "4, 3, 3" and not server2.state.unc_mc_loaded
    # a bad field: one line naming it, nothing runs
    assert run_mc(page, None, dict(params, baseline="-5")) is None
    assert "baseline" in s.unc_error and "\n" not in s.unc_error


@pytest.mark.slow
def test_every_control_of_the_page_has_a_tooltip_and_run_its_shortcut(gui_app):
    import re

    from trame.ui.vuetify3 import VAppLayout

    from camcmm.gui.pages.uncertainty import layout

    server, _ = gui_app()
    with VAppLayout(server, template_name="unc_probe") as lay:
        layout.build(server.pages["uncertainty"])
    html = lay.html
    controls = re.findall(r"<(VTextField|VSelect|VBtn|VFileInput|VTab|VSwitch|VBtnToggle|VTextarea)\b([^>]*)>", html)
    assert len(controls) > 30
    assert [c for c, attrs in controls if "title" not in attrs] == []
    run = re.search(r"<VBtn[^>]*data-testid=\"unc-mc-run\"[^>]*>", html).group(0)
    assert 'data-shortcut="run"' in run
    assert "VTextarea" not in html  # no raw YAML box


@pytest.mark.slow
def test_budget_store_and_export(gui_app):
    server, session = gui_app()
    page, s = server.pages["uncertainty"], server.state
    page.load_budget((DATA / "budget_example.yaml").read_bytes())
    out = page.save_budget()
    assert out is not None
    rid = out["result_id"]
    stored = session.project.result(rid)
    assert stored["plugin"] == "uncertainty.budget"
    assert stored["outputs"]["combined"] == pytest.approx(page.budget["combined"])
    names = {l["name"] for l in s.unc_b_links}
    assert names == {f"budget-{rid}.{x}" for x in ("yaml", "csv", "json", "png")}
    folder = page.offered.folder
    assert (folder / f"budget-{rid}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = yaml.safe_load((folder / f"budget-{rid}.yaml").read_text())
    assert cli_json("uncertainty", "budget", str(folder / f"budget-{rid}.yaml"))["combined"] == pytest.approx(
        page.budget["combined"]
    )
    assert len(again["contributions"]) == 3


def small_spec() -> str:
    doc = yaml.safe_load((DATA / "montecarlo_thesis.yaml").read_text())
    doc["grid"] = {"size": [60, 40, 40], "n": [4, 3, 3]}
    return yaml.safe_dump(doc)


@pytest.mark.slow
def test_montecarlo_run_publishes_plugin_numbers_is_stored_and_restored(gui_app):
    server, session = gui_app()
    page, s = server.pages["uncertainty"], server.state
    spec = small_spec()
    params = {"iterations": 500, "seed": 3, "method": "linear", "studies": ["convergence", "volume_maps", "sweep"]}
    full = run_mc(page, spec, params)
    assert full is not None, s.unc_error
    # the same numbers as the plugin called directly with the same seed
    direct = session.host.run(
        session.host.provider("monte-carlo-uncertainty").id,
        {"spec": yaml.safe_load(spec)},
        {"iterations": 500, "seed": 3, "method": "linear", "studies": ""},
    ).outputs
    for f, u in direct["contributions"].items():
        assert np.allclose(full["contributions"][f], u, rtol=1e-12)
    table = {r["factor"]: r for r in s.unc_mc_rows}
    # u_c with two significant digits (the number rule); k goes in U's name, not in a u column
    assert table["combined standard uncertainty u_c"]["x"] == figs.u_text(direct["combined"][0])
    assert any(name.startswith("expanded U = k·u_c (k = ") for name in table)
    # charts: bars per factor and axis, a convergence curve per factor
    assert len(s.unc_mc_fig_contrib["data"]) == 3
    assert len(s.unc_mc_fig_contrib["data"][0]["y"]) == len(direct["contributions"])
    conv = s.unc_mc_fig_conv["data"]
    assert len(conv) == len(direct["contributions"])
    assert conv[0]["x"][-1] == 500
    assert s.unc_mc_fig_sweep["data"] and len(s.unc_mc_fig_sweep["data"][0]["x"]) == 11
    # the measuring volume: distortion arrows of the first volume map
    assert s.unc_mc_map.startswith("distortion:")
    assert "magnified" in s.unc_mc_map_note
    img = page.view.screenshot()
    assert img.std() > 5  # something is drawn
    page.show_map("uncertainty:feature_location")
    assert "grid points" in s.unc_mc_map_note
    page.set_axis("z")
    assert s.unc_mc_fig_conv["layout"]["yaxis"]["title"]["text"].startswith("u_z")
    # exports: CSV, JSON, PNGs
    names = {l["name"] for l in s.unc_mc_links}
    rid = s.unc_mc_summary["result_id"]
    assert {
        f"montecarlo-{rid}.csv",
        f"montecarlo-{rid}.json",
        f"montecarlo-{rid}-contributions.png",
        f"montecarlo-{rid}-convergence.png",
        f"montecarlo-{rid}-sweep.png",
    } <= names
    csv = (page.offered.folder / f"montecarlo-{rid}.csv").read_text().splitlines()
    assert csv[0].startswith("factor,u_x (um)") and len(csv) == len(s.unc_mc_rows) + 1
    # stored: the row holds the summary, the file every array; a new page shows it again
    row = session.project.result(rid)
    assert row["outputs"]["combined"] == pytest.approx(direct["combined"])
    server2, _ = gui_app(session.project.path)
    s2 = server2.state
    assert s2.unc_mc_summary["result_id"] == rid
    assert s2.unc_mc_rows == s.unc_mc_rows
    assert s2.unc_mc_maps == s.unc_mc_maps


@pytest.mark.slow
def test_montecarlo_bad_input_is_one_line_and_the_page_keeps_working(gui_app):
    server, _ = gui_app()
    page, s = server.pages["uncertainty"], server.state
    assert run_mc(page, "cameras: [", {}) is None
    assert "YAML" in s.unc_error and "line" in s.unc_error and "system.yaml" in s.unc_error
    doc = yaml.safe_load(small_spec())
    doc["uncertainties"]["focal_length"] = [-0.8, 0.8]
    assert run_mc(page, yaml.safe_dump(doc), {"iterations": 50}) is None
    assert "focal_length" in s.unc_error and s.unc_mc_running is False
    assert run_mc(page, small_spec(), {"iterations": "many"}) is None
    assert "iterations" in s.unc_error
    assert run_mc(page, small_spec(), {"iterations": 50, "studies": []}) is not None


def test_png_export_draws_the_figure():
    fig = figs.contributions_figure(
        {
            "contributions": {"rotation": [9.1, 3.0, 4.0], "focal_length": [1.7, 1, 2]},
            "combined": [9.3, 3.2, 4.5],
            "unit": "um",
        }
    )
    png = figs.figure_png(fig)
    assert png[:4] == b"\x89PNG" and len(png) > 5000
    assert math.isclose(fig["data"][0]["y"][0], 9.1)


@pytest.mark.slow
def test_montecarlo_cancel_is_said_and_the_next_run_works(gui_app):
    server, _ = gui_app()
    page, s = server.pages["uncertainty"], server.state

    assert page.load_system(small_spec(), "small.yaml")

    async def cancel_soon():
        task = asyncio.ensure_future(page.run_montecarlo_async({"iterations": 5_000_000}))
        while not s.unc_mc_running and not task.done():
            await asyncio.sleep(0.02)
        await asyncio.sleep(0.3)
        page.cancel()
        return await task

    assert asyncio.run(cancel_soon()) is None
    assert s.unc_mc_message == "cancelled" and s.unc_mc_running is False
    assert "cancel" in s.unc_error and "\n" not in s.unc_error
    assert run_mc(page, small_spec(), {"iterations": 50, "studies": []}) is not None
    assert s.unc_mc_message.startswith("done")
