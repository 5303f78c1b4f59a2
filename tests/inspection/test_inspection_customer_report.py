"""The inspection report a customer receives (issue 28): ``camcmm inspect --report`` with
the order's options (``--customer``, ``--part-number`` …) heads the report with them, states
the overall verdict (every deviation within ±tolerance, or not) and the profile of the
surface as on a drawing, carries the signature fields, in HTML and PDF; the body holds no
internal key, plugin id or JSON — the statistics' keys and the provenance are in the
appendix.

Reference, by construction: an L-shaped block sampled exactly (the nominal's own surface)
with one top patch raised by 0.03 mm, so the deviations lie in [0, 0.03] mm: within ±0.05
the part conforms, within ±0.02 it does not."""

from __future__ import annotations

import json

import numpy as np
import pytest

from camcmm.api import PointCloud, TriangleMesh, write
from camcmm_plugins.inspection.coverage import sample_surface
from helpers import customer_report as cr
from helpers.cli import main_json, main_refused
from helpers.shapes import Polycube, l_block

RAISE = 0.03
OPTIONS = (
    ("--customer", "Nordwerk AG"),
    ("--part-number", "LB-12"),
    ("--order", "4500012345"),
    ("--drawing-revision", "B"),
    ("--operator", "J. Berg"),
    ("--instrument", "structured-light scanner S1"),
    ("--date", "2026-11-28"),
    ("--temperature", "20.1"),
)


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    d = tmp_path_factory.mktemp("inspectcustomer")
    pc = Polycube(l_block(), 10.0, 2)
    write(TriangleMesh(pc.vertices, pc.faces, name="block"), d / "block.stl")
    pts, tid = sample_surface(pc.vertices, pc.faces, 6000, seed=3)
    tri = pc.vertices[pc.faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    fn /= np.linalg.norm(fn, axis=1)[:, None]
    up = (fn[tid, 2] > 0.99) & (pts[:, 2] > 19.99) & (pts[:, 0] > 12.0)
    write(PointCloud(pts + np.where(up, RAISE, 0.0)[:, None] * fn[tid], name="scan"), d / "scan.ply")
    return d


def _inspect(capfd, d, tolerance, name):
    argv = ["inspect", d / "scan.ply", "--nominal", d / "block.stl", "--align", "none", "--tolerance", tolerance]
    argv += ["--coverage-samples", "2000", "--report", d / name, "--json"]
    return main_json(capfd, *argv, *[x for pair in OPTIONS for x in pair])


def test_out_of_tolerance_named_fields_and_signature(capfd, block):
    out = _inspect(capfd, block, "0.02", "fail")
    assert out["stats"]["max"] == pytest.approx(RAISE, abs=1e-6) and out["stats"]["min"] > -1e-5
    html = (block / "fail" / "report.html").read_text("utf-8")
    body, pdf = cr.html_body(html), " ".join(cr.pdf_body(block / "fail" / "report.pdf").split())
    for text in (" ".join(body.split()), pdf):
        for _, value in OPTIONS[:-1]:
            assert value in text, value
        assert "20.1 °C" in text and "Signature" in text and "Inspected by" in text
        assert "Out of tolerance: the surface profile" in text and "Profile of the surface" in text
        assert "±0.02" in text and "not conform" in text
    data = json.loads((block / "fail" / "report.json").read_text("utf-8"))
    assert data["data"]["verdict"] == "fail" and data["data"]["customer"]["part_number"] == "LB-12"
    assert cr.internal_tokens(body) == [] and cr.internal_tokens(cr.pdf_body(block / "fail" / "report.pdf")) == []
    appendix = html.split('<h2 class="appendix">')[1]
    assert "inspect.compare" in appendix and "p97_5" in appendix  # the records, after the body


def test_in_tolerance(capfd, block):
    _inspect(capfd, block, "0.05", "pass")
    body = " ".join(cr.html_body((block / "pass" / "report.html").read_text("utf-8")).split())
    assert (
        "Every measured deviation is in tolerance." in body and "v-pass" in (block / "pass" / "report.html").read_text()
    )
    assert cr.internal_tokens(body) == []


def test_a_bad_temperature_is_refused(capfd, block):
    err = main_refused(capfd, "inspect", block / "scan.ply", "--nominal", block / "block.stl", "--temperature", "-500")
    assert "--temperature" in err
