"""The Series page without a browser (camcmm.gui.pages.series): a run on four simulated
parts (helpers/series_parts.py) fills the table with the constructed verdicts and their
colours; a click on a cell shows the part's labels over its aligned cloud and the
characteristic's chart and capability; a path outside the server's roots is refused in
one line; the series comes back when the project is opened again."""

from __future__ import annotations

import asyncio

import pytest

pytest.importorskip("trame")

from camcmm.tasks import series  # noqa: E402
from helpers import series_parts as sp  # noqa: E402


@pytest.fixture
def ran(gui_app, tmp_path, monkeypatch):
    from camcmm.project import Project

    monkeypatch.setenv("CAMCMM_ISOLATE", "0")  # the plugins in this process: the page is tested, not the worker
    Project.create(tmp_path / "proj").close()
    sp.write(tmp_path / "proj")
    server, session = gui_app(tmp_path / "proj")
    page = server.pages["series"]
    assert server.state.se_rows == [] and "Run" in server.state.se_empty_hint
    files = "\n".join(f"{n}.xyz" for n in sp.DELTAS)
    rec = asyncio.run(page.run_async("plan.yaml", [], files, "none"))
    assert rec is not None, server.state.se_error
    return server, page, rec


def test_table_cell_click_chart_and_labels(ran):
    server, page, rec = ran
    s = server.state
    assert s.se_ids == ["dia-S1", "prof-S1"] and [r["part"] for r in s.se_rows] == list(sp.DELTAS)
    for r in s.se_rows:
        cell = r["cells"][0]
        assert cell["verdict"] == sp.EXPECTED[r["part"]] and cell["colour"] == series.VERDICT_COLOURS[cell["verdict"]]
    page.open_cell("part4", "dia-S1")
    assert s.se_cell == {"part": "part4", "id": "dia-S1"} and s.se_part_title.startswith("part4")
    cap = {r["name"]: r["value"] for r in s.se_capability}
    assert "part4" in cap["out"] and cap["undecided"] == "part3" and cap["cpk"].count("[") == 1
    names = [t["name"] for t in s.se_fig_labels["data"]]
    assert names[0] == "the part, aligned" and len(s.se_fig_labels["data"][0]["x"]) == 1500
    assert [t["name"] for t in s.se_fig_chart["data"]][:3] == [
        "value",
        "upper tolerance limit",
        "lower tolerance limit",
    ]
    assert s.se_fig_chart["data"][0]["marker"]["color"][3] == series.VERDICT_COLOURS["not conform"]
    # numbers as the Compare page writes them: a size (the diameter) in mm, a zone (the profile) in µm
    texts = {c["id"]: c["text"] for c in s.se_rows[0]["cells"]}
    assert texts["dia-S1"].endswith(" mm") and texts["prof-S1"].endswith(" µm"), texts
    assert s.se_fig_chart["layout"]["yaxis"]["title"]["text"] == "value [mm]"
    page.open_cell("part4", "prof-S1")
    assert s.se_fig_chart["layout"]["yaxis"]["title"]["text"] == "value [µm]"
    prof = next(r for r in s.se_part_rows if r["id"] == "prof-S1")
    assert prof["value"].endswith(" µm") and "e-" not in prof["value"]
    cap = {r["name"]: r["value"] for r in s.se_capability}
    assert cap["mean"].endswith(" µm") and "e-" not in cap["s"]


def test_outside_the_roots_refused_and_restored_on_reopening(ran, gui_app, tmp_path):
    server, page, rec = ran
    assert asyncio.run(page.run_async("/etc/passwd", [], "part1.xyz\npart2.xyz", "none")) is None
    err = server.state.se_error
    assert "/etc/passwd" in err and "\n" not in err
    again, _ = gui_app(tmp_path / "proj")
    s = again.state
    assert [r["part"] for r in s.se_rows] == list(sp.DELTAS) and f"#{rec['result']}" in s.se_message
    assert s.se_align == "none" and s.se_files.splitlines()[0].endswith("part1.xyz")
