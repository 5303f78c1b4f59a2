"""A lab's own standard (examples/lab_standard, "LAB-1 length check") through the acceptance
page, end to end: found only by its entry point, set up from its declaration, one
measurement per position (gauge-block clouds exact by construction), verdicts, report.

The package is not installed: a PluginHost gets the entry point its pyproject.toml
declares, and the package folder goes on sys.path for this test only (.venv untouched).
"""

from __future__ import annotations

import asyncio
import importlib.metadata as md
import json
import os
import tomllib
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from camcmm.api import Standard, write  # noqa: E402
from camcmm.host import PluginHost  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "lab_standard"
LENGTH, U, MPE = 50.0012, 0.0004, 0.005  # mm


def _entry_points() -> list[md.EntryPoint]:
    """The entry points the package's pyproject.toml declares for camcmm."""
    doc = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())
    group = "camcmm.plugins"
    return [md.EntryPoint(name, value, group) for name, value in doc["project"]["entry-points"][group].items()]


@pytest.fixture
def host(monkeypatch):
    installed = set(PluginHost().plugins)  # before the folder is on sys.path (a build's egg-info there counts)
    monkeypatch.syspath_prepend(str(EXAMPLE))
    lab = PluginHost(entry_points=_entry_points())
    lab.installed_before = installed
    return lab


def block_cloud(direction, length: float) -> PointCloud:
    """A gauge block 35 × 9 mm in cross-section, ``length`` mm long along ``direction``:
    a symmetric grid of points, so its principal axis and extent are exact."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    a = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(d, a)
    t, u, w = np.meshgrid(
        np.linspace(-length / 2, length / 2, 41), np.linspace(-17.5, 17.5, 7), np.linspace(-4.5, 4.5, 3), indexing="ij"
    )
    return PointCloud(np.outer(t.ravel(), d) + np.outer(u.ravel(), a) + np.outer(w.ravel(), b))


def test_found_only_by_its_entry_point(host):
    assert "lab-1" in host.plugins and host.get("lab-1").kind == "standard"
    assert "lab-1" not in host.installed_before  # not installed here: only the entry point above finds it
    for path in (ROOT / "app" / "camcmm").rglob("*.py"):  # and camcmm does not name it
        text = path.read_text(errors="replace")
        assert "lab-1" not in text and "camcmm_lab_standard" not in text, path
    std = host.load("lab-1")
    assert isinstance(std, Standard)
    decl = std.declare()
    assert [p.key for p in decl.parameters] == ["E"] and decl.parameter("E").signed
    assert [f.key for f in decl.artefact("gauge_block").fields] == ["length", "uncertainty", "k"]


def test_the_acceptance_page_runs_it_end_to_end(tmp_path, host, gui_app):
    server, session = gui_app(tmp_path / "proj", host=host)
    page, state = server.pages["acceptance"], server.state
    assert [s["value"] for s in state.wz_standards] == ["lab-1"]
    page.choose_standard("lab-1", state.wz_form)
    assert [f["label"] for f in state.wz_mpe_fields] == ["MPE E"]
    assert [f["key"] for f in state.wz_form_tests[0]["fields"]] == ["length", "uncertainty", "k"]
    form = json.loads(json.dumps(state.wz_form))
    form["system_name"] = "Lab scanner"
    form["mpe"] = {"E": str(MPE)}
    form["artefacts"]["gauge_block"].update({"length": "0.1", "uncertainty": str(U), "k": "2"})
    assert not page.start(form) and "0.1 is outside" in state.wz_setup_error  # the declared range
    form["artefacts"]["gauge_block"]["length"] = str(LENGTH)
    assert page.start(form), state.wz_setup_error
    assert state.wz_progress[0]["text"] == "0 of 3 gauge block positions"
    assert len(state.wz_svgs) == 3 and all(s.startswith("<svg") for s in state.wz_svgs.values())

    errors = {"block-x": 0.002, "block-y": -0.003, "block-diagonal": 0.001}  # E by construction, mm
    for pos in page.wizard.requirements()[0]["positions"]:
        path = tmp_path / f"{pos['id']}.ply"
        write(block_cloud(pos["direction"], LENGTH + errors[pos["id"]]), path)
        card = asyncio.run(page.import_async("gauge_block", pos["id"], path))
        assert card is not None and card["status"] == "done" and card["verdict"] == "pass", state.error_message
        value = card["repeats"][0]["values"][0]
        # E in µm by the number rule (issue 30): +0.002 mm is "+2.00 µm", with a real minus
        want = f"{errors[pos['id']] * 1e3:+.2f} µm".replace("-", "\u2212")
        assert value["symbol"] == "E" and value["text"] == want
    assert state.wz_complete and state.wz_verdict == "pass"
    e = state.wz_parameters[0]
    assert (e["key"], e["value"], e["verdict"]) == ("E", "\u22123.00 µm", "pass")
    assert e["verdict_guarded"] == "pass"  # |E| 0.003 <= MPE - U = 0.0046

    out = asyncio.run(page.report_async())
    assert out is not None, state.error_message
    assert [link["kind"] for link in state.wz_report_links] == ["html", "pdf", "json"]
    html = (page.downloads / state.wz_report_links[0]["name"]).read_text()
    assert "LAB-1 length check" in html
    assert page.wizard.project.result(out["summary_result"])["outputs"]["verdict"] == "pass"
