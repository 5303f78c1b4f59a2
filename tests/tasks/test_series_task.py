"""The Series view's task without trame (camcmm.tasks.series): one plan over four parts
with known diameters (helpers/series_parts.py) run through the provider of
``gdt-series``, the parts × characteristics table's verdicts and colours as constructed,
the run chart's limits and capability against a direct computation from the parts'
values, the plan taken from the project, the run stored and restored, and the refusals
in one line."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.errors import InputError
from camcmm.host import PluginHost
from camcmm.project import Project
from camcmm.tasks import gdt, series
from camcmm.tasks.items import ProjectItems
from camcmm.tasks.series import SeriesRequest, SeriesTask
from helpers import series_parts as sp


class InProcess(PluginHost):
    """camcmm's plugins, run in the calling thread (camcmm.worker sends only a PluginHost
    itself to a worker process): the test measures the task, not the worker's start."""


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    d = tmp_path_factory.mktemp("series")
    plan, clouds = sp.write(d / "parts")
    project = Project.create(d / "proj")
    from camcmm.io import read

    # two parts as project items, two as files on the server
    ids = []
    for f in clouds[:2]:
        h = project.add_file(f)
        ids.append(str(project.add_measurement(f.stem, h, "pointcloud")))
    gdt.save_plan(project, sp.plan())
    task = SeriesTask(InProcess(), ProjectItems(project), project)
    req = SeriesRequest(plan="project", clouds=[*ids, *map(str, clouds[2:])], align="none")
    run = task.run(req)
    rec = task.store(run)
    assert read(clouds[0]).n_points == 1500
    return d, project, task, run, rec


def test_table_verdicts_and_colours_as_constructed(ran):
    _, _, _, run, _ = ran
    ids, rows = series.table(run.batch)
    assert ids == ["dia-S1", "prof-S1"]
    assert [r["part"] for r in rows] == list(sp.DELTAS)
    for r in rows:
        assert r["status"] == "evaluated", r["reason"]
        cell = r["cells"]["dia-S1"]
        assert cell["verdict"] == sp.EXPECTED[r["part"]], (r["part"], cell)
        assert cell["colour"] == gdt.VERDICT_COLOURS[sp.EXPECTED[r["part"]]]
        # the constructed diameter within the expanded uncertainty (k = 2) of the value
        assert abs(cell["value"] - 2 * (sp.RADIUS + sp.DELTAS[r["part"]])) <= cell["U"]
        assert r["cells"]["prof-S1"]["verdict"] == "conform"


def test_chart_against_a_direct_computation(ran):
    _, _, _, run, _ = ran
    c = series.chart(run.batch, "dia-S1")
    x = np.array(c["values"], float)
    assert c["parts"] == list(sp.DELTAS) and len(x) == 4
    assert c["lsl"] == pytest.approx(19.99, abs=1e-12) and c["usl"] == pytest.approx(20.01, abs=1e-12)
    s = x.std(ddof=1)
    assert c["mean"] == pytest.approx(x.mean(), rel=1e-12) and c["s"] == pytest.approx(s, rel=1e-12)
    assert c["cp"] == pytest.approx(0.02 / (6 * s), rel=1e-9)
    assert c["cpk"] == pytest.approx(min(20.01 - x.mean(), x.mean() - 19.99) / (3 * s), rel=1e-9)
    mr = np.abs(np.diff(x)).mean()  # individuals / moving range: x̄ ± 2.66 MR̄
    assert c["control"] == "individuals" and c["ucl"] == pytest.approx(x.mean() + 2.66 * mr, rel=1e-9)
    # out: the simple verdict (outside the limits: part3 lies on the limit, either side);
    # undecided: within U of a limit (ISO 14253-1)
    assert c["out"] == [p for p, v in zip(c["parts"], x, strict=True) if not 19.99 <= v <= 20.01]
    assert "part4" in c["out"] and "part1" not in c["out"] and c["undecided"] == ["part3"]
    assert c["cpk_ci"][0] < c["cpk"] < c["cpk_ci"][1]
    # a zone: upper limit the tolerance, no lower limit, no Cp
    z = series.chart(run.batch, "prof-S1")
    assert z["usl"] == 0.05 and z["lsl"] is None and z["cp"] is None and z["cpk"] is not None
    assert series.chart(run.batch, "nothing") is None


def test_stored_and_restored(ran):
    d, project, _, run, rec = ran
    again = Project.open(d / "proj")
    req, back = SeriesTask(InProcess(), ProjectItems(again), again).restore()
    assert back["result"] == rec["result"] and back["names"] == list(sp.DELTAS)
    assert series.table(back["batch"]) == series.table(run.batch)
    assert req.align == "none" and len(req.clouds) == 4 and req.plan["characteristics"][0]["id"] == "dia-S1"
    row = again.result(rec["result"])
    assert row["plugin"] == "gdt.series"
    assert (d / "proj" / series.FOLDER / "batch.json").is_file()  # the work folder: a rerun resumes


@pytest.mark.parametrize(
    "change, words",
    [
        ({"clouds": ["1"]}, "at least two parts"),
        ({"clouds": ["1", "99"]}, "no item with id 99"),
        ({"clouds": ["1", "nowhere.xyz"]}, "cloud nowhere.xyz: no such file"),
        ({"align": "sideways"}, "align: 'sideways'"),
        ({"plan": "missing.yaml"}, "plan missing.yaml: no such file"),
        ({"nominal": "77"}, "no item with id '77'"),
    ],
)
def test_refusals_in_one_line(ran, change, words):
    _, _, task, _, _ = ran
    req = SeriesRequest(**{"plan": "project", "clouds": ["1", "2"], "align": "none", **change})
    with pytest.raises(InputError, match=words) as err:
        task.run(req)
    assert "\n" not in str(err.value)


def test_no_plan_in_the_project(tmp_path):
    project = Project.create(tmp_path / "p")
    with pytest.raises(InputError, match="the project holds no plan"):
        SeriesTask(InProcess(), ProjectItems(project), project).run(SeriesRequest(clouds=["1", "2"]))
