"""``camcmm inspect`` and the inspection plugins through the host: the JSON contract,
the outputs a GUI builds on, the coloured cloud, the report, failures and bad input.

The data are exact by construction: points on the faces of an L-shaped block (STL), a
patch of its top raised by 30 µm, moved by a known transform.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from camcmm.api import PointCloud, TriangleMesh, read, write
from camcmm.host import PluginHost
from camcmm_plugins.inspection.align import apply, similarity
from camcmm_plugins.inspection.coverage import sample_surface
from camcmm_plugins.inspection.report import build_report
from helpers.cli import cli_json, cli_refused, run_camcmm
from helpers.shapes import Polycube, l_block, rotation

RAISE = 0.03
STATS = {"mean", "std", "rms", "min", "max", "p2_5", "p97_5"}
MR = {"Sk", "Spk", "Svk", "Smr1", "Smr2"}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("inspect")
    pc = Polycube(l_block(), 10.0, 4)
    write(TriangleMesh(pc.vertices, pc.faces, name="block"), d / "block.stl")
    pts, tid = sample_surface(pc.vertices, pc.faces, 60000, seed=5)
    tri = pc.vertices[pc.faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    fn /= np.linalg.norm(fn, axis=1)[:, None]
    # a patch of the top of the wall is raised (small enough that the rest fixes the pose)
    up = (fn[tid, 2] > 0.99) & (pts[:, 2] > 19.99) & (pts[:, 0] > 12.0)
    truth = np.where(up, RAISE, 0.0)
    pts = pts + truth[:, None] * fn[tid]
    c = pts.mean(axis=0)
    R = rotation([1.0, -2.0, 1.5])
    T = similarity(1.0, R, c - R @ c + np.array([0.6, -0.4, 0.3]))
    write(PointCloud(apply(np.linalg.inv(T), pts), name="scan"), d / "scan.ply")
    S = similarity(1 / 0.4, rotation([30.0, 100.0, -60.0]), np.array([20.0, 5.0, -7.0]))
    write(PointCloud(apply(np.linalg.inv(S), pts), name="photo"), d / "photo.ply")
    write(PointCloud(pts + 2000.0, name="far"), d / "far.ply")
    # a shape no alignment fits onto the block: a ball of twice its size, far off
    u = np.random.default_rng(8).normal(size=(20000, 3))
    ball = 60.0 * u / np.linalg.norm(u, axis=1)[:, None] + 2000.0
    write(PointCloud(ball, name="ball"), d / "ball.ply")
    picks = [0, 20000, 40000]
    (d / "pairs.json").write_text(
        json.dumps({"measured": apply(np.linalg.inv(S), pts[picks]).tolist(), "nominal": pts[picks].tolist()})
    )
    return {"dir": d, "T": T, "S": S, "truth": truth, "up": up, "pts": pts}


@pytest.mark.slow
def test_cli_json_out_and_report(files):
    d = files["dir"]
    r = cli_json(
        "inspect",
        d / "scan.ply",
        "--nominal",
        d / "block.stl",
        "--tolerance",
        "0.05",
        "--json",
        "--out",
        d / "col.ply",
        "--report",
        d / "rep",
    )
    assert r["converged"] is True and r["reason"] == ""
    T = np.array(r["transform"])
    assert T.shape == (4, 4) and np.abs(T - files["T"]).max() < 1e-3
    assert r["scale"] == pytest.approx(1.0, abs=1e-12)
    assert STATS <= set(r["stats"]) and MR <= set(r["material_ratio"])
    assert 0 < r["coverage"] <= 1 and r["rms"] < 0.03 and r["overlap"] > 0.99
    # the deviations are the construction: +30 µm on the top faces, 0 elsewhere
    col = read(d / "col.ply")
    assert col.field_units.get("deviation") == "mm" and col.colors is not None
    dev = col.fields["deviation"]
    assert np.abs(dev - files["truth"]).max() < 1e-4  # file order is kept
    st = r["stats"]
    assert st["max"] == pytest.approx(RAISE, abs=1e-4) and st["min"] > -1e-4
    for ext in ("html", "pdf", "json"):
        assert Path(r["report"][ext]).is_file()
    rep = json.loads(Path(r["report"]["json"]).read_text())
    assert MR <= set(rep["data"]["material_ratio"]) and rep["data"]["converged"] is True
    figs = [b for s in rep["sections"] for b in s["blocks"] if b["type"] == "figure"]
    assert len(figs) >= 4
    assert "Material-ratio curve" in Path(r["report"]["html"]).read_text()


@pytest.mark.slow
def test_cli_text_and_similarity(files):
    d = files["dir"]
    out = run_camcmm("inspect", d / "photo.ply", "--nominal", d / "block.stl", "--align", "global+similarity")
    assert "converged" in out.stdout and "Sk" in out.stdout
    r = cli_json("inspect", d / "photo.ply", "--nominal", d / "block.stl", "--align", "global+similarity", "--json")
    assert r["converged"]
    assert r["scale"] == pytest.approx(1 / 0.4, rel=1e-4)  # the factor applied to the measured cloud
    assert np.abs(np.array(r["transform"]) - files["S"]).max() < 1e-2


@pytest.mark.slow
def test_cli_pairs(files):
    d = files["dir"]
    r = cli_json(
        "inspect",
        d / "photo.ply",
        "--nominal",
        d / "block.stl",
        "--align",
        "pairs+similarity",
        "--pairs",
        d / "pairs.json",
        "--json",
    )
    assert r["converged"] and r["scale"] == pytest.approx(1 / 0.4, rel=1e-4)
    assert r["alignment"]["stages"][0]["stage"] == "pairs"


@pytest.mark.slow
def test_cli_no_overlap_reports_failure(files):
    """A ball is not the block: the alignment fails, the JSON says so (no statistics at the
    top level, the unaligned ones under 'unaligned'), the exit code is 3 with the reason on
    stderr; the report shows no deviation figures and says why."""
    d = files["dir"]
    out = run_camcmm(
        "inspect", d / "ball.ply", "--nominal", d / "block.stl", "--json", "--report", d / "failed", ok=False
    )
    assert out.returncode == 3, out.stderr
    r = json.loads(out.stdout)
    assert r["converged"] is False and r["aligned"] is False and r["reason"]
    assert r["failure"] == f"alignment failed: {r['reason']}"
    assert out.stderr.strip() == f"camcmm: {r['failure']}" and "\n" not in out.stderr.strip()
    for k in ("stats", "coverage", "coverage_info", "material_ratio", "histogram"):
        assert r[k] is None and r["unaligned"][k] is not None
    assert any("did not converge" in w for w in r["warnings"])
    rep = json.loads(Path(r["report"]["json"]).read_text())
    assert rep["data"]["aligned"] is False and rep["data"]["stats"] is None
    assert rep["data"]["unaligned"]["stats"]["n"] == 20000
    titles = [s["title"] for s in rep["sections"]]
    assert "Deviations" not in titles and "Unaligned comparison (diagnosis only, not results)" in titles
    assert not [b for s in rep["sections"] for b in s["blocks"] if b["type"] == "figure"]
    assert f"alignment failed: {r['reason']}" in Path(r["report"]["html"]).read_text()
    text = run_camcmm("inspect", d / "ball.ply", "--nominal", d / "block.stl", ok=False)
    assert text.returncode == 3 and "NOT CONVERGED" in text.stdout and "no deviations" in text.stdout


@pytest.mark.slow
def test_cli_far_off_exact_copy_is_aligned(files):
    """The same cloud 2000 mm away (≈ 50 nominal diagonals) is found by the coarse start:
    how far off a cloud lies does not matter once its centroid is moved."""
    d = files["dir"]
    r = cli_json("inspect", d / "far.ply", "--nominal", d / "block.stl", "--json")
    assert r["aligned"] is True and r["converged"] is True and r["stats"] is not None
    assert r["alignment"]["stages"][0]["stage"] == "coarse"
    assert np.abs(np.array(r["transform"])[:3, 3] + 2000.0).max() < 1e-3


@pytest.mark.slow
def test_report_states_held_dofs_in_words():
    """A ball's rotations are held: the report says so in words (summary and alignment)."""
    mesh = _ball_mesh(10.0)
    u = np.random.default_rng(2).normal(size=(6000, 3))
    pts = 10.0 * u / np.linalg.norm(u, axis=1)[:, None]
    pts = pts[pts[:, 2] > -3.0] + np.array([1.0, -2.0, 0.5])
    res = PluginHost().run("inspect.compare", {"cloud": PointCloud(pts, name="ball"), "nominal": mesh}, {})
    o = res.outputs
    assert o["converged"] and o["held_dofs"] and "rotation about any axis" in o["held_dofs"][0]
    rep = build_report(o, run=res)
    kv = {
        k: v
        for s in rep.to_dict()["sections"]
        for b in s["blocks"]
        if b["type"] == "keyvalues"
        for k, v in b["items"].items()
    }
    assert kv["held by the part's symmetry"] == "; ".join(o["held_dofs"])
    assert rep.data["held_dofs"] == o["held_dofs"] and rep.data["aligned"] is True


def _ball_mesh(radius: float) -> TriangleMesh:
    from camcmm.demo import _icosphere

    m = _icosphere(radius, 4)
    return TriangleMesh(m.vertices, m.faces, name="ball")


@pytest.mark.slow
def test_cli_bad_input(files, tmp_path):
    d = files["dir"]
    assert "--pairs" in cli_refused("inspect", d / "scan.ply", "--nominal", d / "block.stl", "--align", "pairs", code=2)
    assert "missing.stl" in cli_refused("inspect", d / "scan.ply", "--nominal", tmp_path / "missing.stl", code=2)
    out = run_camcmm("inspect", d / "block.stl", "--nominal", d / "block.stl", ok=False)
    assert out.returncode == 2 and "point cloud" in out.stderr
    bad = tmp_path / "pairs.json"
    bad.write_text("{not json")
    out = run_camcmm(
        "inspect", d / "scan.ply", "--nominal", d / "block.stl", "--align", "pairs+icp", "--pairs", bad, ok=False
    )
    assert out.returncode == 2 and "JSON" in out.stderr


@pytest.mark.parametrize(
    "doc,needle",
    [
        ('{"measured": [[0,0,0],[1,0,0],[0,1,0]], "nominal": [[0,0,0],[1,0,0],[0,NaN,0]]}', "finite"),
        ('{"measured": [[0,0,0],[1,0,0]], "nominal": [[0,0,0],[1,0,0]]}', "2 pairs"),
        ('{"measured": [[0,0,0],[1,0,0],[2,0,0]], "nominal": [[0,0,0],[1,0,0],[2,0,0]]}', "one line"),
        ('{"measured": [[0,0,"x"],[1,0,0],[0,1,0]], "nominal": [[0,0,0],[1,0,0],[0,1,0]]}', "'measured'"),
        ('{"measured": [[0,0,0],[1,0,0],[0,1,0]]}', '"nominal"'),
        ("[1, 2, 3]", '"measured"'),
    ],
)
def test_cli_pairs_file_errors_name_the_file(files, tmp_path, capsys, doc, needle):
    from camcmm.cli.main import main

    d = files["dir"]
    (tmp_path / "p.json").write_text(doc)
    rc = main(
        [
            "inspect",
            str(d / "scan.ply"),
            "--nominal",
            str(d / "block.stl"),
            "--align",
            "pairs",
            "--pairs",
            str(tmp_path / "p.json"),
        ]
    )
    lines = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and "p.json" in lines[0] and needle in lines[0], lines


def test_cli_tolerance_must_be_above_zero(files, capsys):
    from camcmm.cli.main import main

    d = files["dir"]
    assert main(["inspect", str(d / "scan.ply"), "--nominal", str(d / "block.stl"), "--tolerance", "0"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "'tolerance'" in lines[0] and "above 0" in lines[0]


@pytest.mark.slow
def test_plugins_through_the_host(files):
    """What a GUI gets: inspect.align, then inspect.deviations with its transform; the
    coloured cloud, histogram, coverage samples and the material-ratio curve arrays."""
    d = files["dir"]
    host = PluginHost()
    a = host.run("inspect.align", {"cloud": str(d / "scan.ply"), "nominal": str(d / "block.stl")}, {})
    n = read(d / "scan.ply").n_points
    assert a.outputs["converged"] and a.outputs["aligned"].n_points == n
    res = host.run(
        "inspect.deviations",
        {"cloud": str(d / "scan.ply"), "nominal": str(d / "block.stl"), "transform": a.outputs["transform"].tolist()},
        {"tolerance": 0.05},
    )
    o = res.outputs
    cloud = o["deviations"]
    assert cloud.field_units["deviation"] == "mm" and cloud.colors.shape == (n, 3)
    assert np.allclose(cloud.points, a.outputs["aligned"].points)
    h = o["histogram"]
    assert len(h["edges"]) == len(h["counts"]) + 1 and h["counts"].sum() == n
    curve = o["material_ratio"]["curve"]
    assert len(curve["mr_percent"]) == len(curve["height"]) == 1001
    cov = o["coverage_cloud"]
    assert cov.fields["covered"].mean() == pytest.approx(o["coverage"])
    assert o["colour_limit"] == 0.05 and o["stats"]["within_tolerance"] == 1.0
    doc = res.to_json()  # JSON-able, with clouds summarised
    assert doc["outputs"]["deviations"]["kind"] == "pointcloud"
    json.dumps(doc)
    # the material ratio of the deviations, from the coloured cloud
    m = host.run("inspect.material-ratio", {"source": cloud}, {})
    assert m.outputs["Sk"] == pytest.approx(o["material_ratio"]["Sk"])


@pytest.mark.slow
def test_compare_against_a_reference_cloud(files):
    d = files["dir"]
    pc = Polycube(l_block(), 10.0, 4)
    ref, _ = sample_surface(pc.vertices, pc.faces, 150000, seed=9)
    res = PluginHost().run(
        "inspect.compare", {"cloud": str(d / "scan.ply"), "nominal": PointCloud(ref)}, {"distance": "plane"}
    )
    o = res.outputs
    assert o["converged"], o["reason"]
    assert np.abs(o["transform"] - files["T"]).max() < 5e-3
    dev = o["deviations"].fields["deviation"]
    # sign from the reference normals (oriented outward): the raised patch reads positive
    assert np.median(dev[files["up"]]) == pytest.approx(RAISE, abs=2e-3)
    assert np.median(np.abs(dev[~files["up"]])) < 2e-3


@pytest.mark.slow
def test_report_renders(files, tmp_path):
    d = files["dir"]
    res = PluginHost().run(
        "inspect.compare", {"cloud": str(d / "scan.ply"), "nominal": str(d / "block.stl")}, {"tolerance": 0.05}
    )
    rep = build_report(
        res.outputs, cloud_file=str(d / "scan.ply"), nominal_file=str(d / "block.stl"), run=res, tolerance=0.05
    )
    paths = rep.write(tmp_path)
    assert Path(paths["pdf"]).read_bytes()[:4] == b"%PDF"
    data = json.loads(Path(paths["json"]).read_text())
    names = [s["title"] for s in data["sections"]]
    # the body for the customer, then the appendix (issue 28)
    assert names[:5] == ["Result", "Summary", "Deviations", "Coverage", "Signatures"]
    appendix = [s["title"] for s in data["sections"] if s.get("appendix")]
    assert appendix[-3:] == ["Alignment", "Deviation statistics", "Material ratio (ISO 13565-2 / ISO 25178-2)"]
    assert {i["file"] for i in data["provenance"]["inputs"]} == {str(d / "scan.ply"), str(d / "block.stl")}


# -- the options are the comparison's declared parameters (issue 25) -------------------
def _help(capsys, argv) -> str:
    """``camcmm ARGV --help`` in this process: its text (argparse exits 0 after printing)."""
    from camcmm.cli.main import main

    with pytest.raises(SystemExit) as stop:
        main([*argv, "--help"])
    assert stop.value.code == 0
    return capsys.readouterr().out


def test_help_lists_every_declared_parameter_of_the_comparison(capsys):
    from camcmm.host import default_host

    params = default_host().provider("compare-with-cad").parameters
    text = _help(capsys, ["inspect"])
    flags = set(text.split())
    missing = [p.name for p in params if "--" + p.name.replace("_", "-") not in flags]
    assert not missing, missing
    assert len(params) >= 16  # kernel_k, max_iterations, max_points, neighbours, coverage_samples, bins too
    # the declaration's limits and defaults are in the help, read from the manifest
    assert "(3 <= x <= 200) (default: 12)" in " ".join(text.split())
    # the command's own options stay
    for flag in ("--nominal", "--pairs", "--out", "--report", "--unit", "--nominal-unit", "--curve", "--json"):
        assert flag in flags, flag


def test_every_old_flag_parses_as_before():
    """The flags of before the declarations, in their old shapes: --region six numbers."""
    from camcmm.cli.parser import Parser
    from camcmm.host import default_host
    from camcmm_plugins.inspection import cli

    p = Parser(prog="camcmm inspect")
    cli.configure(p)
    old = [
        *("--align", "global+similarity", "--tolerance", "0.05", "--kernel", "huber", "--max-distance", "2"),
        *("--inlier-distance", "0.5", "--min-overlap", "0.3", "--distance", "nn", "--coverage-distance", "1"),
        *("--seed", "7", "--region", "0", "0", "0", "10", "20", "30"),
    ]
    new = ["--kernel-k", "0.2", "--max-iterations", "30", "--max-points", "2000", "--neighbours", "8"]
    new += ["--coverage-samples", "5000", "--bins", "40"]
    args = p.parse_args(["c.ply", "--nominal", "n.stl", *old, *new, "--out", "o.ply", "--report", "r", "--curve"])
    from camcmm.api import declared_values

    values = declared_values(args, default_host().provider("compare-with-cad").parameters)
    assert values == {
        "align": "global+similarity",
        "tolerance": 0.05,
        "kernel": "huber",
        "max_distance": 2.0,
        "inlier_distance": 0.5,
        "min_overlap": 0.3,
        "distance": "nn",
        "coverage_distance": 1.0,
        "seed": 7,
        "region": [0.0, 0.0, 0.0, 10.0, 20.0, 30.0],
        "kernel_k": 0.2,
        "max_iterations": 30,
        "max_points": 2000,
        "neighbours": 8,
        "coverage_samples": 5000,
        "bins": 40,
    }
    assert args.out == "o.ply" and args.report == "r" and args.curve and args.nominal == "n.stl"


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--neighbours", "2"], "--neighbours: parameter 'neighbours' = 2 is below its minimum 3"),
        (["--bins", "many"], "--bins: parameter 'bins': 'many' is not a valid int"),
        (["--kernel-k", "nan"], "--kernel-k: parameter 'kernel_k': nan is not finite"),
        (["--align", "magic"], "--align: parameter 'align': 'magic' is not a valid choice"),
        (["--region", "0", "0", "0", "1", "1", "inf"], "--region: parameter 'region'"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_option(capsys, tmp_path, argv, needle):
    """Checked by the declaration before any file is read (the files here do not exist)."""
    from helpers.cli import refused

    refused(capsys, ["inspect", tmp_path / "c.ply", "--nominal", tmp_path / "n.stl", *argv], needle)


@pytest.mark.slow
def test_new_options_reach_the_plugin(files, capsys):
    """--max-iterations, --max-points, --neighbours, --coverage-samples, --bins, --kernel-k:
    in the run's parameters (its provenance), the histogram with the bins asked for."""
    from camcmm.cli.main import main

    d = files["dir"]
    argv = ["inspect", str(d / "scan.ply"), "--nominal", str(d / "block.stl"), "--json"]
    argv += ["--max-iterations", "60", "--max-points", "20000", "--neighbours", "9", "--coverage-samples", "20000"]
    argv += ["--bins", "25", "--kernel-k", "0.5", "--region", "-100", "-100", "-100", "100", "100", "100"]
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    params = r["plugin"]["params"]
    assert params["max_iterations"] == 60 and params["max_points"] == 20000 and params["neighbours"] == 9
    assert params["coverage_samples"] == 20000 and params["bins"] == 25 and params["kernel_k"] == 0.5
    assert params["region"] == [-100.0, -100.0, -100.0, 100.0, 100.0, 100.0]
    assert r["plugin"]["id"] == "inspect.compare" and len(r["plugin"]["input_hashes"]["cloud"]) == 64
    assert r["aligned"] and len(r["histogram"]["counts"]) == 25
    assert r["coverage_info"]["n_samples"] == pytest.approx(20000, rel=0.01)  # by area: not exactly (default 200000)
