"""The uncertainty task without trame (camcmm.tasks.uncertainty): the GUM budget against
a hand computation, GUM H.1 and the CLI, its draft and stored row; a tiny Monte Carlo
study through the worker, stored and restored, the same numbers as the plugin called
directly; one-line refusals; the two output contracts the Uncertainty page reads."""

from __future__ import annotations

import json
import math
import threading
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from camcmm.contracts import check_outputs, contract, manifest_problem
from camcmm.errors import CamcmmError, InputError, PluginError
from camcmm.host import RunResult, default_host
from camcmm.project import Project
from camcmm.tasks import uncertainty as unc
from helpers.cli import run_camcmm
from helpers.paths import REPO

DATA = REPO / "tests" / "data" / "uncertainty"


@pytest.fixture
def project(tmp_path):
    p = Project.create(tmp_path / "proj")
    yield p
    p.close()


def small_system(n=(3, 2, 2)) -> dict:
    doc = yaml.safe_load((DATA / "montecarlo_thesis.yaml").read_text())
    doc["grid"] = {"size": [60, 40, 40], "n": list(n)}
    return doc


def test_the_contracts_list_what_the_page_reads_and_the_built_in_plugins_declare_it():
    host = default_host()
    b, m = contract(unc.BUDGET_TASK), contract(unc.MONTECARLO_TASK)
    assert b is unc.BUDGET_CONTRACT and m is unc.MONTECARLO_CONTRACT
    assert b.required_outputs() == ["combined", "contributions", "coverage_probability", "dof_eff", "expanded", "k"]
    assert m.required_outputs() == ["combined", "contributions", "dof_eff", "expanded", "iterations", "k"]
    assert {n.key for n in m.needs if n.optional} >= {"studies", "per_point", "per_point_norm", "unit", "factor_dof"}
    for task in (unc.BUDGET_TASK, unc.MONTECARLO_TASK):
        assert manifest_problem(host.provider(task), task) == ""
    lacking = SimpleNamespace(id="lab.budget", outputs=[SimpleNamespace(name="combined")])
    assert "declares no output 'contributions'" in manifest_problem(lacking, unc.BUDGET_TASK)
    # a run's outputs lacking a key the page reads: one line naming plugin, task and key
    good = {"combined": 5.0, "dof_eff": 10.0, "k": 2.0, "expanded": 10.0, "coverage_probability": 0.95}
    with pytest.raises(PluginError, match="lab.budget.*gave no 'contributions'"):
        check_outputs(unc.BUDGET_TASK, "lab.budget", good)
    with pytest.raises(PluginError, match="'k' is a str, not a float"):
        check_outputs(unc.BUDGET_TASK, "lab.budget", {**good, "contributions": [], "k": "2"})
    mc = {"contributions": {}, "combined": [1, 1, 1], "dof_eff": [9, 9, 9], "k": [2, 2, 2], "expanded": [2, 2, 2]}
    with pytest.raises(PluginError, match="lab.mc.*gave no 'iterations'"):
        check_outputs(unc.MONTECARLO_TASK, "lab.mc", mc)
    with pytest.raises(PluginError, match="'studies' is a list, not a dict"):
        check_outputs(unc.MONTECARLO_TASK, "lab.mc", {**mc, "iterations": 5, "studies": []})
    check_outputs(unc.MONTECARLO_TASK, "lab.mc", {**mc, "iterations": 5})


@pytest.mark.slow  # the plugins load
def test_budget_by_hand_its_draft_and_its_stored_row(project):
    host = default_host()
    rows = [
        {"name": "a", "kind": "u", "value": "3", "c": "1", "dof": "inf", "distribution": "normal"},
        {
            "name": "b",
            "kind": "a",
            "value": repr(4 * math.sqrt(3)),
            "c": "1",
            "dof": "inf",
            "distribution": "rectangular",
        },
    ]
    req = unc.BudgetRequest("length", "um", 0.95, rows)
    run = unc.evaluate(host, req)
    out = run.outputs
    # u_c = sqrt(3² + (4√3/√3)²) = 5; infinite dof: k = z_0.975; U = k u_c
    assert out["combined"] == pytest.approx(5.0, rel=1e-12)
    assert out["k"] == pytest.approx(1.959963985, abs=1e-8)
    assert out["expanded"] == pytest.approx(5.0 * out["k"], rel=1e-12)
    assert [c["share"] for c in out["contributions"]] == pytest.approx([9 / 25, 16 / 25])
    assert out["contributions"][1]["u"] == pytest.approx(4.0)
    # the draft keeps the rows as typed; the editor opens with it
    unc.save_draft(project, req)
    back = unc.start_budget(project)
    assert (back.quantity, back.unit, back.p) == ("length", "um", 0.95)
    assert [r["kind"] for r in back.rows] == ["u", "a"] and back.rows[1]["value"] == rows[1]["value"]
    # stored as RunResult.to_json(); restored with the same numbers
    rid = unc.store_budget(project, run, req)
    row = project.result(rid)
    assert row["plugin"] == "uncertainty.budget" and row["label"] == "GUM budget: length"
    again = unc.restore_budget(project, rid)
    assert isinstance(again, RunResult)
    for key in ("combined", "k", "expanded"):
        assert again.outputs[key] == pytest.approx(out[key], rel=1e-12)
    assert again.outputs["dof_eff_infinite"] is True  # JSON has no ∞: the row says so


def test_a_project_without_a_draft_opens_the_shipped_thesis_budget(project):
    req = unc.start_budget(project)
    assert len(req.rows) == 5 and req.rows[0]["name"]
    assert unc.evaluate(default_host(), req).outputs["combined"] > 0
    assert req.unit == "µm" and req.rows[0]["dof"] == "∞"  # written as a metrologist writes them


def test_infinite_degrees_of_freedom_read_as_typed_and_kept_as_inf_in_the_file():
    """The editor writes ∞; the budget file and the plugin keep "inf"; either typed reads the same:
    two type-B inputs known exactly give ν_eff = ∞ and k = 1.96 for 95 % (GUM G.3)."""
    rows = [
        {"name": "a", "kind": "u", "value": "3", "distribution": "normal", "k": "", "c": "1", "dof": "∞"},
        {"name": "b", "kind": "u", "value": "4", "distribution": "normal", "k": "", "c": "1", "dof": "inf"},
    ]
    req = unc.BudgetRequest("x", "µm", 0.95, rows)
    assert [c["dof"] for c in req.doc()["contributions"]] == ["inf", "inf"]
    assert [r["dof"] for r in unc.rows_from_doc(req.doc())] == ["∞", "∞"]
    out = unc.evaluate(default_host(), req).outputs
    assert out["combined"] == pytest.approx(5.0) and out["k"] == pytest.approx(1.96, abs=0.001)


@pytest.mark.slow  # the CLI runs in its own process
def test_gum_h1_by_the_task_is_the_gum_and_the_cli(project):
    """GUM H.1.6: u_c = 32 nm, nu_eff = 16, k = t_99(16) = 2.92, U_99 = 93 nm — stated as in
    the GUM (U with k, half-widths) or as plain u: the same numbers as the CLI on the file."""
    host = default_host()
    for name in ("budget_gum_h1.yaml", "budget_gum_h1_half_widths.yaml"):
        req = unc.read_budget((DATA / name).read_bytes(), name)
        out = unc.evaluate(host, req).outputs
        assert out["combined"] == pytest.approx(31.7, abs=0.05)
        assert out["dof_eff"] == pytest.approx(16.7, abs=0.1) and math.floor(out["dof_eff"]) == 16
        assert out["k"] == pytest.approx(2.92, abs=0.005)
        assert abs(out["expanded"] - 93) < 1
        cli = json.loads(run_camcmm("uncertainty", "budget", str(DATA / name), "--json").stdout)
        for key in ("combined", "dof_eff", "k", "expanded"):
            assert out[key] == pytest.approx(cli[key], rel=1e-12), (name, key)


def test_budget_refusals_are_one_line_naming_the_entry_or_the_file():
    host = default_host()
    row = {"name": "rot", "kind": "a", "value": "2", "distribution": "rectangular", "c": "1", "dof": "14"}
    for bad, needle in (
        (dict(row, value="-2"), "half-width a = -2"),
        (dict(row, distribution="cauchy"), "unknown distribution"),
        (dict(row, dof="0"), "dof"),
    ):
        with pytest.raises(CamcmmError) as err:
            unc.evaluate(host, unc.BudgetRequest("x", "um", 0.95, [bad]))
        assert needle in str(err.value) and "'rot'" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(InputError, match="x.yaml: expected a mapping with a 'contributions' list"):
        unc.read_budget(b"contributions: 3", "x.yaml")
    with pytest.raises(InputError, match="bad.yaml"):
        unc.read_budget(b"contributions: [", "bad.yaml")


@pytest.mark.slow  # a worker process may start first
def test_a_tiny_monte_carlo_is_the_plugins_numbers_stored_and_restored(project):
    host = default_host()
    system = small_system()
    req = unc.MonteCarloRequest({"iterations": 60, "seed": 3, "method": "linear", "studies": ["convergence"]}, system)
    checked = unc.check_montecarlo(host, req)
    assert checked.inputs == {"spec": system} and checked.form is None
    assert checked.values["iterations"] == 60 and checked.values["studies"] == "convergence"
    seen: list[float] = []
    run = unc.run_montecarlo(host, checked, progress=lambda f, m: seen.append(f), cancel=threading.Event())
    direct = host.run(
        host.provider(unc.MONTECARLO_TASK).id,
        {"spec": system},
        {"iterations": 60, "seed": 3, "method": "linear", "studies": "convergence"},
    ).outputs
    for f, u in direct["contributions"].items():
        assert np.allclose(run.outputs["contributions"][f], u, rtol=1e-12)
    assert run.outputs["n_points"] == 12 and run.outputs["iterations"] == 60
    assert unc.stored_montecarlo(project) is None and unc.restore_montecarlo(project) is None
    rid, h = unc.store_montecarlo(project, run, checked)
    # the row holds the summary, the file every array and the system simulated
    row = project.result(rid)
    assert row["files"]["montecarlo"] == h and "per_point" not in row["outputs"]
    assert row["outputs"]["combined"] == pytest.approx(direct["combined"])
    back = unc.restore_montecarlo(project)
    assert back is not None and back.result_id == rid and back.file == h
    assert back.full["system"]["grid"]["n"] == [3, 2, 2] and back.full["form"] is None
    assert back.full["studies"]["convergence"] and back.full["per_point"]
    assert back.full["combined"] == pytest.approx(direct["combined"])
    assert unc.done_message(back.full).startswith("done: 60 iterations × 12 points")


@pytest.mark.slow  # a worker process may start first
def test_a_monte_carlo_of_the_fields_keeps_its_form(project):
    """No system file: the declared fields are the system; the run keeps them (the form)."""
    host = default_host()
    spec = host.provider(unc.MONTECARLO_TASK)
    params = {p.name: p.default for p in spec.parameters if p.default is not None}
    params.update(grid_points="3, 2, 2", iterations=40, seed=1, studies=[])
    task = unc.UncertaintyTask(host, project)  # the steps bound, as the page holds them
    checked = task.check_montecarlo(unc.MonteCarloRequest(params))
    assert checked.inputs == {} and checked.form is not None and checked.form["grid_points"] == [3.0, 2.0, 2.0]
    rid, h = task.store_montecarlo(task.run_montecarlo(checked), checked)
    assert task.read(h)["form"] == checked.form
    back = task.restore_montecarlo()
    assert back is not None and back.result_id == rid
    assert back.full["form"]["grid_points"] == [3.0, 2.0, 2.0]
    assert back.full["system"]["grid"]["n"] == [3, 2, 2] and back.full["system"]["stereo"]["baseline"] == 199.35


def test_monte_carlo_refusals_are_one_line_naming_the_field():
    host = default_host()
    for params, system, needle in (
        ({"iterations": "many"}, small_system(), "iterations"),
        ({"iterations": 50, "baseline": -5}, None, "baseline"),
        ({"iterations": 1}, small_system(), "iterations"),
    ):
        with pytest.raises(CamcmmError) as err:
            unc.check_montecarlo(host, unc.MonteCarloRequest(params, system))
        assert needle in str(err.value) and "\n" not in str(err.value), (needle, err.value)
    with pytest.raises(InputError, match="system.yaml"):
        unc.load_system("cameras: [", "system.yaml")
    with pytest.raises(InputError, match="expected a mapping"):
        unc.load_system("- 1\n- 2\n", "list.yaml")
