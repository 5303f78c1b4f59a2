"""Compare with CAD without trame (camcmm.tasks.compare): the real inspection plugin on the
box of helpers.compare_data (a CAD box and a cloud sampled on it with 5 µm noise and a
30 µm bump, moved by a known rigid motion), run through the worker, stored in a bare
project (ProjectItems) and restored; the refusals in one line; the output contract the
Compare page reads. Every statistic is checked against numpy on the plugin's deviations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from camcmm import io as cio
from camcmm.contracts import check_outputs, contract, manifest_problem
from camcmm.errors import InputError, PluginError
from camcmm.host import PluginHost, RunResult, default_host
from camcmm.jsonable import to_jsonable
from camcmm.manifest import PluginSpec, Port
from camcmm.model import PointCloud
from camcmm.project import Project
from camcmm.tasks import compare
from camcmm.tasks.compare import CompareRequest, CompareTask
from camcmm.tasks.items import ProjectItems
from helpers.compare_data import BUMP, HI, LO, MOTION, NOISE, make_pair

if "inspect.compare" not in default_host().plugins:
    pytest.skip("the inspection plugin is not installed", allow_module_level=True)

REQUIRED = [
    "colour_limit",
    "converged",
    "deviations",
    "histogram",
    "material_ratio",
    "stats",
]


def add_file(items: ProjectItems, path) -> str:
    obj = cio.read(path)
    return str(items.add_measurement(path.name, items.project.add_file(path), obj))


@pytest.fixture
def case(tmp_path):
    """A project with box.stl and scan.ply as items: (task, items, box id, scan id, truth)."""
    stl, ply, truth = make_pair(tmp_path / "files")
    project = Project.create(tmp_path / "proj")
    items = ProjectItems(project)
    box, scan = add_file(items, stl), add_file(items, ply)
    yield CompareTask(default_host(), items, project), items, box, scan, truth
    project.close()


# -------------------------------------------------------------------------------- the contract
def test_the_contract_lists_what_the_page_reads_and_the_provider_declares_it():
    c = contract(compare.TASK)
    assert c is compare.CONTRACT and c.required_outputs() == REQUIRED
    optional = {n.key for n in c.needs if n.optional}
    assert {"stats.tolerance", "coverage", "alignment", "rms", "overlap", "held_dofs", "reason"} <= optional
    assert {n.key: n.fields for n in c.needs}["deviations"] == ("deviation",)
    spec = default_host().provider(compare.TASK)
    assert spec.id == "inspect.compare" and manifest_problem(spec, compare.TASK) == ""


def _spec(pid: str, outputs: list[str], distribution: str) -> PluginSpec:
    return PluginSpec(
        pid,
        "algorithm",
        pid,
        "1.0",
        "",
        "nowhere:compare",
        outputs=[Port(o, "json") for o in outputs],
        distribution=distribution,
        provides=[compare.TASK],
    )


def test_a_provider_whose_manifest_lacks_an_output_is_refused():
    """A lab's plugin that declares no colour_limit is passed over for the built-in one; alone,
    it is refused with the reason."""
    lacking = _spec("lab.compare", [o for o in REQUIRED if o != "colour_limit"], "lab")
    assert "declares no output 'colour_limit'" in manifest_problem(lacking, compare.TASK)
    host = PluginHost(entry_points=[])
    host.plugins = {"lab.compare": lacking}
    with pytest.raises(PluginError, match="plugin 'lab.compare' provides 'compare-with-cad' but .* 'colour_limit'"):
        host.provider(compare.TASK)
    builtin = _spec("inspect.compare", REQUIRED, "camcmm")
    host.plugins["inspect.compare"] = builtin
    assert host.provider(compare.TASK) is builtin
    host.plugins["lab.compare"] = _spec("lab.compare", REQUIRED, "lab")
    assert host.provider(compare.TASK).id == "lab.compare"  # a lab's own that fits replaces camcmm's


def _outputs(**over):
    dev = PointCloud(np.zeros((4, 3)), fields={"deviation": np.zeros(4)}, name="d")
    o = {
        "deviations": dev,
        "colour_limit": 0.01,
        "converged": True,
        "stats": {"p2_5": -0.01, "p97_5": 0.01, "n": 4},
        "histogram": {"edges": [0, 1], "counts": [4]},
        "material_ratio": {"C1": 0.0},
    }
    o.update(over)
    return {k: v for k, v in o.items() if v is not None}


def test_outputs_lacking_what_the_page_reads_are_refused_in_one_line():
    check_outputs(compare.TASK, "lab.compare", _outputs())  # all there: passes
    check_outputs(compare.TASK, "lab.compare", _outputs(coverage=None, alignment=None))  # optional
    with pytest.raises(PluginError, match="plugin 'lab.compare' ran for 'compare-with-cad' but gave no 'colour_limit'"):
        check_outputs(compare.TASK, "lab.compare", _outputs(colour_limit=None))
    with pytest.raises(PluginError, match="'colour_limit' is a str, not a float"):
        check_outputs(compare.TASK, "lab.compare", _outputs(colour_limit="10 um"))
    with pytest.raises(PluginError, match="gave no 'stats.p97_5'"):
        check_outputs(compare.TASK, "lab.compare", _outputs(stats={"p2_5": 0.0}))
    with pytest.raises(PluginError, match="'stats.tolerance' is a str"):  # optional, but checked when there
        check_outputs(compare.TASK, "lab.compare", _outputs(stats={"p2_5": 0.0, "p97_5": 0.0, "tolerance": "x"}))
    bare = PointCloud(np.zeros((4, 3)), name="d")
    with pytest.raises(PluginError, match="its 'deviations' cloud has no field 'deviation'"):
        check_outputs(compare.TASK, "lab.compare", _outputs(deviations=bare))
    with pytest.raises(PluginError, match="'converged' is a str"):
        check_outputs(compare.TASK, "lab.compare", _outputs(converged="yes"))


def test_a_run_result_survives_its_json_row():
    r = RunResult("inspect.compare", "1.2", {"align": "icp"}, {"cloud": "ab"}, {"rms": 0.1, "n": [1, 2]}, "t0", "t1")
    r.warnings.append("held: rotation about z")
    back = RunResult.from_json(r.to_json())
    assert back == r and back.to_json() == r.to_json()
    assert RunResult.from_json({}).plugin_id == "" and RunResult.from_json({}).warnings == []


# -------------------------------------------------------------------------------- the request
def test_requests_that_cannot_run_are_refused_in_one_line(case, tmp_path):
    task, items, box, scan, _ = case
    with pytest.raises(InputError, match="choose the measured cloud first"):
        task.check(CompareRequest(None, box))
    with pytest.raises(InputError, match="choose the nominal"):
        task.check(CompareRequest(scan, ""))
    with pytest.raises(InputError, match="scan.ply is chosen as both measured and nominal"):
        task.check(CompareRequest(scan, scan))
    with pytest.raises(InputError, match="needs 3 point pairs, 1 picked"):
        task.check(CompareRequest(scan, box, align="pairs", pairs={"measured": [[0, 0, 0]], "nominal": [[1, 1, 1]]}))
    with pytest.raises(Exception, match="max_iterations"):
        task.check(CompareRequest(scan, box, params={"max_iterations": "0"}))
    with pytest.raises(InputError, match="is a mesh|must be a point cloud"):
        task.run(CompareRequest(box, scan))
    with pytest.raises(InputError, match="no item with id '99'"):
        task.run(CompareRequest("99", box))
    for text, why in (("abc", "not a number"), ("-1", "≥ 0"), ("nan", "≥ 0")):
        with pytest.raises(InputError, match=why):
            compare.parse_tolerance(text)
        assert compare.parse_tolerance(text, quiet=True) is None
    assert compare.parse_tolerance("0,02") == 0.02 and compare.parse_tolerance("") is None
    assert compare.parse_tolerance("0") is None and compare.parse_tolerance(0.01) == 0.01
    # empty "More" fields are the plugin's defaults; unknown ones and the main two are not taken from params
    c = task.check(CompareRequest(scan, box, tolerance=0.01, params={"max_iterations": "", "align": "none", "x": 1}))
    assert c.values["align"] == "icp" and c.values["tolerance"] == 0.01 and c.values["max_iterations"] == 100
    assert c.mids == [int(scan), int(box)] and c.inputs == {} and c.pairs is None


# -------------------------------------------------------------------------------- a comparison
@pytest.mark.slow
def test_compare_run_store_and_restore(case, tmp_path):
    task, items, box, scan, truth = case
    seen: list[str] = []
    comparison = task.run(CompareRequest(scan, box, tolerance=0.01), progress=lambda f, m: seen.append(m))
    r, o = comparison.result, comparison.outputs
    assert r.plugin_id == "inspect.compare" and r.params["tolerance"] == 0.01 and seen
    assert comparison.measured is items.load(scan) and comparison.nominal is items.load(box)

    # the alignment undid the motion; the deviations are the noise and the bump
    dev = np.asarray(comparison.deviations.fields["deviation"], dtype=float)
    assert len(dev) == len(truth) and comparison.converged
    assert abs(o["alignment"]["rotation_angle_deg"] - 2.0) < 0.01
    assert np.abs(comparison.deviations.points - truth).max() < 0.01  # back in nominal coordinates
    assert abs(np.std(dev) - NOISE) < 0.15 * NOISE + 0.001
    assert dev.max() > 0.8 * BUMP
    assert abs(np.linalg.det(np.asarray(o["transform"])[:3, :3]) - 1.0) < 1e-9
    assert np.allclose(np.asarray(o["transform"]) @ MOTION, np.eye(4), atol=0.01)

    # the statistics are numpy's on the deviations
    st = o["stats"]
    assert st["n"] == len(dev) and st["n_invalid"] == 0
    assert st["mean"] == pytest.approx(dev.mean(), abs=1e-12)
    assert st["std"] == pytest.approx(dev.std(ddof=1), rel=1e-9)
    assert st["rms"] == pytest.approx(np.sqrt(np.mean(dev**2)), rel=1e-9)
    assert st["min"] == dev.min() and st["max"] == dev.max()
    p25, p975 = np.percentile(dev, [2.5, 97.5], method="hazen")
    assert st["p2_5"] == pytest.approx(p25, abs=1e-12) and st["p97_5"] == pytest.approx(p975, abs=1e-12)
    assert st["tolerance"] == 0.01 and st["within_tolerance"] == pytest.approx(np.mean(np.abs(dev) <= 0.01))
    assert sum(o["histogram"]["counts"]) == len(dev) and o["colour_limit"] == 0.01
    assert 0.9 < o["coverage"] <= 1.0

    # stored: the result with its deviations file, the record under inspection.current
    record = task.store(comparison)
    assert comparison.record is record and task.stored() == record
    assert record["measured"] == int(scan) and record["nominal"] == int(box)
    assert record["align"] == "icp" and record["tolerance"] == 0.01 and record["pairs"] is None
    row = task.project.result(record["result"])
    assert row["plugin"] == "inspect.compare" and row["files"]["deviations"] == record["deviations"]
    assert sorted(row["measurement_ids"]) == sorted([int(scan), int(box)])

    # a report recorded as a run (RunResult.to_json), the record noting it
    folder = tmp_path / "report"
    folder.mkdir()
    paths = {}
    for fmt in ("html", "json"):
        paths[fmt] = str(folder / f"inspection.{fmt}")
        (folder / f"inspection.{fmt}").write_text(f"a {fmt} report")
    files = task.record_report(comparison, paths)
    assert sorted(files) == ["report_html", "report_json"] and task.stored()["report"] == files
    rep = task.project.results()[-1]
    assert rep["outputs"] == {"report_of": record["result"], "formats": ["html", "json"]}
    assert rep["label"] == f"inspection report of result #{record['result']}" and rep["files"] == files
    made = RunResult.from_json(rep)
    assert made.to_json() == compare.report_run(r, record["result"], ["json", "html"])
    assert made.plugin_id == r.plugin_id and made.params == r.params and made.input_hashes == r.input_hashes

    # reopened: the same comparison back
    path = task.project.path
    task.project.close()
    project = Project.open(path)
    try:
        items2 = ProjectItems(project)
        back = compare.restore(project, items2)
        assert back is not None and back.record == compare.stored(project) and back.record["report"] == files
        b = back.result
        assert (b.plugin_id, b.plugin_version, b.params, b.input_hashes) == (
            r.plugin_id,
            r.plugin_version,
            to_jsonable(r.params),
            r.input_hashes,
        )
        assert (b.started, b.finished, b.warnings) == (r.started, r.finished, r.warnings)
        assert RunResult.from_json(b.to_json()).to_json() == b.to_json()
        assert {k: v for k, v in b.to_json()["outputs"].items() if k != "deviations"} == {
            k: v for k, v in r.to_json()["outputs"].items() if k != "deviations"
        }
        assert np.allclose(back.deviations.points, comparison.deviations.points)
        assert np.allclose(back.deviations.fields["deviation"], dev)
        assert back.converged and back.measured.n_points == len(truth) and back.nominal.n_faces > 0
        assert RunResult.from_json(r.to_json()).to_json() == r.to_json()
    finally:
        project.close()


@pytest.mark.slow
def test_three_point_pairs_align_a_turned_part(case, tmp_path):
    """Turned by 90° and moved far: plain ICP cannot, three pairs (measured corners of the
    turned box, the CAD's corners) can; the record keeps the pairs."""
    task, items, box, scan, truth = case
    T = np.array([[0, -1, 0, 100.0], [1, 0, 0, 50.0], [0, 0, 1, -30.0], [0, 0, 0, 1]])
    measured = items.load(scan)
    cio.write(PointCloud(measured.points @ T[:3, :3].T + T[:3, 3], name="turned"), tmp_path / "turned.ply")
    key = add_file(items, tmp_path / "turned.ply")
    corners = np.array([[0, 0, 20.0], [40, 0, 20.0], [0, 30, 20.0]])
    picked = (corners @ MOTION[:3, :3].T + MOTION[:3, 3]) @ T[:3, :3].T + T[:3, 3]
    pairs = {"measured": picked.tolist(), "nominal": corners.tolist()}
    comparison = task.run(CompareRequest(key, box, align="pairs+icp", pairs=pairs))
    assert comparison.converged, comparison.outputs.get("reason")
    dev = np.asarray(comparison.deviations.fields["deviation"])
    assert abs(np.std(dev) - NOISE) < 0.002
    assert np.abs(comparison.deviations.points - truth).max() < 0.01
    assert task.store(comparison)["pairs"] == pairs and task.stored()["align"] == "pairs+icp"


@pytest.mark.slow
def test_no_overlap_is_a_failed_comparison_refused_for_what_needs_valid_deviations(case, tmp_path):
    """A ball twice the box's size, 500 mm off: no alignment fits it onto the box. The run is a
    result (stored, restored as failed), but its deviations are refused for a colour map,
    a section or an export."""
    task, items, box, _, _ = case
    u = np.random.default_rng(4).normal(size=(6000, 3))
    ball = 2 * np.linalg.norm(HI - LO) * u / np.linalg.norm(u, axis=1)[:, None] + 500.0
    cio.write(PointCloud(ball, name="ball"), tmp_path / "ball.ply")
    key = add_file(items, tmp_path / "ball.ply")
    comparison = task.run(CompareRequest(key, box))
    assert not comparison.converged
    reason = comparison.outputs["reason"]
    assert reason and "\n" not in reason
    assert any("did not converge" in w for w in comparison.result.warnings)
    with pytest.raises(InputError, match="export: the alignment failed, so the deviations are not valid; nothing"):
        compare.refuse_failed(comparison, "export", "nothing is exported")
    record = task.store(comparison)
    back = task.restore()
    assert back is not None and back.record == record and not back.converged
    assert back.outputs["reason"] == reason
    with pytest.raises(InputError, match="not valid"):
        compare.refuse_failed(back, "section", "no section is drawn")


def test_a_comparison_the_project_cannot_show_is_an_error_not_a_crash(tmp_path):
    with Project.create(tmp_path / "proj") as project:
        assert compare.stored(project) is None and compare.restore(project) is None
        project.set_state(compare.STATE_KEY, {"result": 42})
        assert compare.stored(project) == {"result": 42}
        with pytest.raises(Exception, match="no result with id 42"):
            compare.restore(project)
        project.set_state(compare.STATE_KEY, "not a record")
        assert compare.stored(project) is None


def test_a_request_is_a_plain_dataclass():
    fields = [f.name for f in dataclasses.fields(CompareRequest)]
    assert fields == ["measured", "nominal", "align", "tolerance", "params", "pairs"]
