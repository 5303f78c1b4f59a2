"""``camcmm gdt batch`` (issue 28) on the exact-by-construction batch of
helpers/gdt_batch.py: ten blocks whose bore position, side perpendicularity and bore
diameter take chosen values part to part (one out of tolerance, one undecided), a file
that is not a cloud and a part without its bore's points, each delivered in a small pose
and aligned on its datums.

Checked: each part's values against the constructed ones (1e-8 mm), the verdicts, the
failed parts and their reasons (the batch goes on), the capability figures against a
direct computation from the constructed values (numpy; scipy.stats.chi2 for Cp's
interval), the records' provenance (file SHA-256 by hashlib, camcmm version, plugin),
resume (a second run evaluates nothing; a changed file only that part), the project
(each part's run and the batch's summary), the CSV rows and the QIF Results files.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest
from scipy import stats

from camcmm.cli.main import main
from helpers import gdt_batch as gb
from helpers.cli import main_json, main_refused, main_run

EXPECTED = {"pos-H1": gb.POSITION, "perp-D": gb.PERP_D, "dia-H1": gb.DIAMETER}


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """The batch run once through the CLI: (its JSON, plan, clouds, folder, project, tmp)."""
    tmp = tmp_path_factory.mktemp("batch")
    plan, clouds = gb.write(tmp / "in")
    folder, project = tmp / "work", tmp / "proj"
    argv = ["gdt", "batch", plan, *clouds, "--align", "datums", "--folder", folder, "--project", project]
    argv += ["--csv", tmp / "rows.csv", "--qif", tmp / "qif", "--json"]
    return argv, plan, clouds, folder, project, tmp


def _cli(argv):
    """``camcmm ARGV`` in this process for a module fixture (capfd is per test): exit
    code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def doc(batch):
    rc, out, err = _cli(batch[0])
    assert rc == 0, err
    return json.loads(out)


def _parts(d):
    return {p["part"]: p for p in d["parts"]}


def _chars(p):
    return {c["id"]: c for c in p["evaluation"]["characteristics"]}


def test_each_part_gives_its_constructed_values_and_verdicts(doc):
    assert [p["part"] for p in doc["parts"]] == gb.ORDER
    assert doc["counts"] == {"parts": 12, "evaluated": 10, "failed": 2, "resumed": 0}
    parts = _parts(doc)
    for i, name in enumerate(gb.GOOD):
        p = parts[name]
        assert p["status"] == "evaluated" and p["reason"] is None, name
        chars = _chars(p)
        for cid, values in EXPECTED.items():
            c = chars[cid]
            assert c["value"] == pytest.approx(values[i], abs=1e-8), (name, cid)
            if (name, cid) == (gb.OUT, "pos-H1"):  # 0.22 against 0.2
                assert c["verdict"] == c["verdict_guarded"] == "not conform"
            elif (name, cid) == (gb.UNDECIDED, "perp-D"):  # 0.0495 against 0.05, U about 3 µm
                assert c["verdict"] == "conform" and c["verdict_guarded"] == "undecided"
                assert 0.0005 < c["U"] < 0.01 and c["value"] > c["tolerance"] - c["U"]
            else:
                assert c["verdict"] == c["verdict_guarded"] == "conform", (name, cid)
    # the failing files: recorded with their one-line reason, the batch went on
    broken, nobore = parts["broken"], parts["nobore"]
    assert broken["status"] == "failed" and "broken.xyz" in broken["reason"] and broken["evaluation"] is None
    assert nobore["status"] == "failed" and nobore["reason"].startswith("feature H1 not evaluated")
    assert _chars(nobore)["pos-H1"]["verdict"] == "not evaluated"  # its evaluation is kept
    assert "\n" not in broken["reason"] + nobore["reason"]
    assert len(doc["warnings"]) == 2 and "broken" in doc["warnings"][0] and "nobore" in doc["warnings"][1]


def test_capability_against_direct_computation(doc):
    s = {x["id"]: x for x in doc["summary"]}
    assert list(s) == ["pos-H1", "perp-D", "dia-H1"]
    n = 10
    z = stats.norm.ppf(0.975)
    for cid, values in EXPECTED.items():
        x = np.array(values)
        mean, sd = x.mean(), x.std(ddof=1)
        e = s[cid]
        assert e["n"] == n and e["mean"] == pytest.approx(mean, abs=1e-8) and e["s"] == pytest.approx(sd, rel=1e-6)
        if cid == "dia-H1":  # 10 ± 0.01: two-sided
            cp = 0.02 / (6 * sd)
            lo = cp * math.sqrt(stats.chi2.ppf(0.025, n - 1) / (n - 1))
            hi = cp * math.sqrt(stats.chi2.ppf(0.975, n - 1) / (n - 1))
            assert e["cp"] == pytest.approx(cp, rel=1e-6) and e["cp_ci"] == pytest.approx([lo, hi], rel=1e-6)
            cpk = min(10.01 - mean, mean - 9.99) / (3 * sd)
        else:  # a zone: USL the tolerance, natural bound 0
            assert e["cp"] is None and e["cp_ci"] is None
            cpk = ((gb.TOL_POSITION if cid == "pos-H1" else gb.TOL_PERP) - mean) / (3 * sd)
        half = z * math.sqrt(1 / (9 * n) + cpk**2 / (2 * (n - 1)))
        assert e["cpk"] == pytest.approx(cpk, rel=1e-6)
        assert e["cpk_ci"] == pytest.approx([cpk - half, cpk + half], rel=1e-6)
        mr = np.abs(np.diff(x)).mean()
        ctl = e["control"]
        assert ctl["kind"] == "individuals" and ctl["centre"] == pytest.approx(mean, abs=1e-8)
        assert ctl["ucl"] == pytest.approx(mean + 2.66 * mr, abs=1e-8)
        lcl = mean - 2.66 * mr
        assert ctl["lcl"] == (None if cid != "dia-H1" and lcl < 0 else pytest.approx(lcl, abs=1e-8))
        assert ctl["beyond"] == [p for p, v in zip(gb.GOOD, values) if not lcl <= v <= mean + 2.66 * mr]
        assert [p["part"] for p in e["points"]] == gb.GOOD  # the failed parts are not counted
    assert (s["pos-H1"]["out"], s["pos-H1"]["undecided"]) == ([gb.OUT], [])
    assert (s["perp-D"]["out"], s["perp-D"]["undecided"]) == ([], [gb.UNDECIDED])
    assert (s["dia-H1"]["out"], s["dia-H1"]["undecided"]) == ([], [])


def test_records_carry_provenance(doc, batch):
    from importlib import metadata

    folder = batch[3]
    assert json.loads((folder / "batch.json").read_text("utf-8"))["summary"] == doc["summary"]
    for p in doc["parts"]:
        rec = json.loads(open(p["record"], encoding="utf-8").read())
        assert rec["kind"] == "camcmm gdt batch part" and rec["status"] == p["status"]
        sha = hashlib.sha256(open(p["file"], "rb").read()).hexdigest()
        assert rec["sha256"] == p["sha256"] == sha
        assert rec["started"] <= rec["finished"]
        prov = rec["provenance"]
        assert prov["camcmm"] == metadata.version("camcmm")
        if p["evaluation"] is not None:
            assert prov["id"] == "gdt.evaluate" and prov["params"]["align"] == "datums"
            assert prov["input_hashes"]["cloud"] == sha and prov["started"] <= prov["finished"]


def test_project_csv_and_qif(doc, batch):
    from camcmm.project.store import Project

    project, tmp = batch[4], batch[5]
    with Project.open(project) as pr:
        runs = pr.results("gdt.evaluate")
        summaries = pr.results("gdt.batch")
    with_evaluation = [p for p in doc["parts"] if p["evaluation"] is not None]
    assert sorted(r["id"] for r in runs) == sorted(p["result_id"] for p in with_evaluation)
    assert [r["id"] for r in summaries] == [doc["result_id"]]
    out = summaries[0]["outputs"]
    assert [x["id"] for x in out["summary"]] == ["pos-H1", "perp-D", "dia-H1"]
    assert out["summary"][0]["out"] == [gb.OUT] and out["counts"]["failed"] == 2
    assert summaries[0]["input_hashes"]["part part03"] == _parts(doc)["part03"]["sha256"]
    # CSV: one row a part with an evaluation and characteristic
    with open(tmp / "rows.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 * len(with_evaluation) == 33
    row = next(r for r in rows if r["part"] == gb.OUT and r["id"] == "pos-H1")
    assert float(row["value"]) == pytest.approx(0.22, abs=1e-8) and row["verdict"] == "not conform"
    # QIF Results: one file a part, the part's values read back
    assert len(doc["qif"]) == len(with_evaluation)
    from camcmm_plugins.gdt.qif.results import read_results

    got = read_results(tmp / "qif" / f"{gb.OUT}.qif")
    assert got["characteristics"]["pos-H1"]["value"] == pytest.approx(0.22, abs=1e-8)
    assert got["part"] == gb.OUT


def test_resume_skips_the_recorded_parts(doc, batch, capfd, tmp_path):
    from camcmm.project.store import Project

    argv, plan, clouds, folder, project = batch[:5]
    with Project.open(project) as pr:
        before = len(pr.results("gdt.evaluate"))
    again = main_json(capfd, *argv[:-5], "--json")  # without --csv/--qif
    assert again["counts"] == {"parts": 12, "evaluated": 10, "failed": 2, "resumed": 12}
    assert again["summary"] == doc["summary"]
    assert [w.split(":")[0] for w in again["warnings"]] == [  # the failed parts still said
        "part broken failed (recorded earlier)",
        "part nobore failed (recorded earlier)",
    ]
    # a changed file (the same part, its points in reverse order): only it is evaluated again
    changed = clouds[gb.ORDER.index("part03")]
    pts = np.loadtxt(changed)[::-1]
    np.savetxt(changed, pts, fmt="%.10f")
    third = main_json(capfd, *argv[:-5], "--subgroup", "5", "--json")
    assert third["counts"]["resumed"] == 11 and not _parts(third)["part03"]["resumed"]
    assert _chars(_parts(third)["part03"])["pos-H1"]["value"] == pytest.approx(gb.POSITION[2], abs=1e-8)
    with Project.open(project) as pr:
        assert len(pr.results("gdt.evaluate")) == before + 1
    # subgroups of 5: the X̄/s chart of the two subgroups
    x = np.array(gb.POSITION).reshape(2, 5)
    ctl = third["summary"][0]["control"]
    assert ctl["kind"] == "xbar-s" and ctl["centre"] == pytest.approx(x.mean(), abs=1e-8)
    assert ctl["s_bar"] == pytest.approx(x.std(axis=1, ddof=1).mean(), rel=1e-6)
    # without resume every part is evaluated (two parts, a folder of their own)
    from camcmm_plugins.gdt.batch import run_batch

    b = run_batch(plan, clouds[:2], align="datums", folder=folder, resume=False)
    assert b.counts() == {"parts": 2, "evaluated": 2, "failed": 0, "resumed": 0}


def test_text_table(batch, doc, capfd):
    argv = batch[0][:-5]  # resumed: no evaluation
    rc, out, err = main_run(capfd, *argv)
    assert rc == 0, err
    lines = out.splitlines()
    row = next(x for x in lines if x.startswith(gb.OUT))
    assert "0.2200 OUT" in row
    assert "0.0495 ok/undecided" in next(x for x in lines if x.startswith(gb.UNDECIDED))
    assert any(x.startswith("broken") and "FAILED: " in x and "broken.xyz" in x for x in lines)
    assert f"  out of tolerance: {gb.OUT}; undecided: none" in lines
    assert f"  out of tolerance: none; undecided: {gb.UNDECIDED}" in lines
    assert any(x.startswith("  Cp 0.") and "Cpk" in x for x in lines)  # the diameter's


def test_a_missing_cloud_is_a_failed_part(batch, doc, capfd, tmp_path):
    plan, clouds, folder = batch[1], batch[2], batch[3]
    d = main_json(
        capfd, "gdt", "batch", plan, tmp_path / "gone.xyz", clouds[0], "--align", "datums", "--folder", folder, "--json"
    )
    assert d["counts"] == {"parts": 2, "evaluated": 1, "failed": 1, "resumed": 1}
    assert "gone.xyz" in _parts(d)["gone"]["reason"]


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--subgroup", "0"], "--subgroup"),
        (["--confidence", "1.5"], "--confidence"),
        (["--align", "sideways"], "--align"),
        (["--nominal", "nothere.step"], "nothere.step"),
    ],
)
def test_bad_options_refused_in_one_line(batch, capfd, tmp_path, extra, needle):
    plan, clouds = batch[1], batch[2]
    err = main_refused(capfd, "gdt", "batch", plan, clouds[0], "--folder", tmp_path, *extra, code=2)
    assert needle in err


def test_bad_plan_refused_before_any_part(batch, capfd, tmp_path):
    bad = tmp_path / "bad.yaml"
    doc = gb.plan_document()
    doc["features"]["A"]["type"] = "hexagon"
    bad.write_text(json.dumps(doc), "utf-8")
    err = main_refused(capfd, "gdt", "batch", bad, batch[2][0], "--folder", tmp_path / "w", code=2)
    assert "bad.yaml" in err and "features.A.type" in err
    assert not (tmp_path / "w").exists()
    err = main_refused(capfd, "gdt", "batch", tmp_path / "none.yaml", batch[2][0], code=2)
    assert "none.yaml" in err


def test_parts_named_by_the_caller(batch, doc):
    """run_batch as the GUI calls it: the parts named as the project's items (resumed)."""
    from camcmm.api import InputError
    from camcmm_plugins.gdt.batch import run_batch

    plan, clouds, folder = batch[1], batch[2], batch[3]
    b = run_batch(plan, clouds[:2], align="datums", folder=folder, names=["cast 1", "cast 2"])
    d = b.to_json()
    assert [p["part"] for p in d["parts"]] == ["cast 1", "cast 2"] and d["counts"]["resumed"] == 2
    assert [p["part"] for p in d["summary"][0]["points"]] == ["cast 1", "cast 2"]
    with pytest.raises(InputError, match="names"):
        run_batch(plan, clouds[:2], align="datums", folder=folder, names=["x", "x"])


def test_trend_report(batch, doc, capfd, tmp_path):
    """--report: the run charts and figures of each characteristic, the parts out of
    tolerance and undecided named, the failed parts with their reasons (HTML, PDF, JSON)."""
    d = main_json(capfd, *batch[0][:-5], "--report", tmp_path / "rep", "--json")  # resumed: no evaluation
    html = (tmp_path / "rep" / "report.html").read_text("utf-8")
    assert (tmp_path / "rep" / "report.pdf").read_bytes().startswith(b"%PDF")
    for needle in ("Run chart of pos-H1", "Run chart of perp-D", "Run chart of dia-H1", "Bissell"):
        assert needle in html, needle
    assert f"pos-H1: out of tolerance: {gb.OUT}." in html
    assert f"perp-D: undecided (ISO 14253-1): {gb.UNDECIDED}." in html
    assert "feature H1 not evaluated" in html and html.count("data:image/png") == 3
    rep = json.loads((tmp_path / "rep" / "report.json").read_text("utf-8"))
    assert rep["data"]["summary"] == d["summary"]  # (part03 re-evaluated by the resume test: not doc's bits)


def test_why_a_part_fails():
    from camcmm_plugins.gdt.batch import failure

    ok = {"id": "c", "value": 0.1, "verdict": "conform"}
    value_only = {"id": "v", "value": 0.2, "verdict": "not evaluated", "details": {"reason": "no tolerance"}}
    missing = {"id": "m", "value": None, "verdict": "not evaluated", "details": {"reason": "too few points"}}
    feats = [{"id": "A", "status": "evaluated"}]
    assert failure({"aligned": True, "features": feats, "characteristics": [ok, value_only]}) is None
    assert failure({"aligned": False, "failure": "alignment datums did not settle"}).endswith("did not settle")
    assert failure({"features": feats, "characteristics": [ok, missing]}) == "m not evaluated: too few points"
    gone = [{"id": "B", "status": "not evaluated", "reason": "0 points"}, {"id": "C", "status": "not evaluated"}]
    assert failure({"features": feats + gone, "characteristics": [missing]}) == (
        "feature B not evaluated: 0 points (+1 more)"
    )
