"""The GD&T report a customer receives (issue 28): the order's fields from the plan's
``report:`` mapping and the command's options (an option wins), the overall verdict
naming the characteristic out of tolerance, the drawing table, the signature field, in
HTML and PDF; no internal key, plugin id or JSON in the body — they are in the appendix.

Reference: the issue's block (tests/helpers/gdt_parts.py) whose bore H1 is 0.116619 mm
off its true position; with a position tolerance of 0.1 mm it is the one characteristic
out of tolerance, by construction."""

from __future__ import annotations

import json

import pytest

from helpers import customer_report as cr
from helpers import gdt_parts as g
from helpers.cli import main_json, main_refused

FIELDS = {
    "customer": "Müller Präzisionsteile GmbH",
    "part_number": "BL-4711",
    "order": "PO 2026-0815",
    "drawing_revision": "C",
    "operator": "A. Schmidt",
    "instrument": "fringe projector FP-2",
    "temperature": 20.4,
}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The block evaluated with --report: (CLI JSON, report folder)."""
    d = tmp_path_factory.mktemp("customer")
    doc = g.plan_document(tolerance_position=0.1, report=FIELDS)
    plan, cloud = g.write_case(d, g.block(), doc)
    return d, plan, cloud


def _run(capfd, written, *extra):
    d, plan, cloud = written
    out = main_json(
        capfd,
        "gdt",
        "evaluate",
        plan,
        cloud,
        "--align",
        "none",
        "--report",
        d / "rep",
        "--order",
        "PO 99",
        "--json",
        *extra,
    )
    return out, d / "rep"


def test_fields_verdict_and_signature_in_html_and_pdf(capfd, written):
    out, rep = _run(capfd, written)
    verdicts = {c["id"]: c["verdict_guarded"] for c in out["characteristics"]}
    assert verdicts["pos-H1"] == "not conform"
    others = sorted(k for k, v in verdicts.items() if v != "conform")
    assert others == ["pos-H1"], verdicts
    html = (rep / "report.html").read_text("utf-8")
    body = cr.html_body(html)
    pdf = cr.pdf_body(rep / "report.pdf")
    n = len(verdicts)
    line = f"{n - 1} of {n} characteristics in tolerance. Out of tolerance: pos-H1."
    for text in (body, " ".join(pdf.split())):
        # the plan's fields, the option over the plan's order, °C from a number
        for needle in ("Müller Präzisionsteile GmbH", "BL-4711", "A. Schmidt", "fringe projector FP-2", "20.4 °C"):
            assert needle in text, needle
        assert "PO 99" in text and "PO 2026-0815" not in text
        assert "Drawing revision" in text and "Signature" in text and "Approved by" in text
        assert line in " ".join(text.split())
        assert "⊕" in text and "Position" in text and "A|B|C" in text and "0.1166" in text
    # the badge: the part fails
    assert 'class="badge v-fail"' in body or "v-fail" in html.split('<h2 class="appendix">')[0]
    data = json.loads((rep / "report.json").read_text("utf-8"))
    assert data["data"]["verdict"] == "fail" and data["data"]["customer"]["order"] == "PO 99"
    assert data["meta"]["Date"][:4].isdigit()  # today, as the report was made


def test_no_internal_tokens_in_the_body(capfd, written):
    out, rep = _run(capfd, written)
    html = (rep / "report.html").read_text("utf-8")
    assert cr.internal_tokens(cr.html_body(html)) == []
    assert cr.internal_tokens(cr.pdf_body(rep / "report.pdf")) == []
    # the provenance is there, after the body: plugin id, parameters, hashes
    appendix = html.split('<h2 class="appendix">')[1]
    assert "gdt.evaluate" in appendix and "sha256" in appendix.lower() and "Transform measured" in appendix
    # the check itself finds what it looks for
    assert {k for k, _ in cr.internal_tokens('gdt.evaluate {"max_iterations": 50}')} == set(cr.INTERNAL)


def test_a_misspelt_report_key_is_refused(capfd, written, tmp_path):
    doc = g.plan_document(report={"custmer": "x"})
    plan, cloud = g.write_case(tmp_path, g.block(density=0.02, n_min=10), doc)
    err = main_refused(capfd, "gdt", "evaluate", plan, cloud, "--align", "none")
    assert "report.custmer" in err and "plan.yaml" in err
    err = main_refused(capfd, "gdt", "evaluate", *written[1:], "--temperature", "900")
    assert "--temperature" in err
