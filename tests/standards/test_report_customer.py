"""The report's customer parts (issue 28): the order's fields (camcmm.report.customer),
the overall verdict by ISO 14253-1, the signature block and the appendix after the body
(provenance its last part), in HTML, PDF and JSON alike."""

from __future__ import annotations

import io
import re

import pytest

from camcmm.api import InputError, Report


def test_fields_checked_and_in_order():
    f = Report.customer_fields({"customer": "ACME", "temperature": 20, "date": "2026-01-02"}, where="p.yaml: report")
    assert f == {"customer": "ACME", "temperature": "20 °C", "date": "2026-01-02"}
    r = Report("t", meta={"Nominal": "n.step"}).customer(f)
    assert list(r.meta)[:8] == [
        "Customer", "Part number", "Order", "Drawing revision", "Operator", "Instrument", "Date", "Temperature"
    ]  # fmt: skip
    assert r.meta["Part number"] == "\u2014" and list(r.meta)[-1] == "Nominal"
    bare = Report("t").customer({}).meta
    assert bare["Date"] == Report("t").created[:10] and "Temperature" not in bare  # today; temperature where given
    for doc, needle in (
        ({"custmer": "x"}, "p.yaml: report.custmer: unknown key"),
        ({"order": [1, 2]}, "p.yaml: report.order: expected a text or a number"),
        ({"temperature": 1e4}, "p.yaml: report.temperature"),
        (["customer"], "p.yaml: report: expected a mapping"),
    ):
        with pytest.raises(InputError, match=re.escape(needle)):
            Report.customer_fields(doc, where="p.yaml: report")


@pytest.mark.parametrize(
    "verdicts, word, sentence",
    [
        ([("a", "conform"), ("b", "conform")], "pass", "All 2 characteristics are in tolerance"),
        ([("a", "conform"), ("b", "undecided")], "inconclusive", "1 of 2 characteristics in tolerance. Undecided"),
        (
            [("a", "not conform"), ("b", "undecided")],
            "fail",
            "Out of tolerance: a. Undecided (within U of a limit): b.",
        ),
        ([("a", "conform"), ("b", "not evaluated")], "incomplete", "Not evaluated: b."),
        ([], "incomplete", "No characteristic"),
    ],
)
def test_overall_verdict(verdicts, word, sentence):
    w, s = Report.overall_verdict(verdicts)
    assert w == word and sentence in s


def test_appendix_after_the_body_and_signature():
    from pypdf import PdfReader

    r = Report("Title")
    r.section("Alignment", appendix=True).paragraph("records")
    r.section("Result").paragraph("results")
    r.section("Signatures").signature((("Inspected by", "A. B."), ("Approved by", "")))
    d = r.to_dict()
    assert [s.get("appendix", False) for s in d["sections"]] == [True, False, False]
    assert d["sections"][2]["blocks"][0] == {
        "type": "signature",
        "parties": [{"role": "Inspected by", "name": "A. B."}, {"role": "Approved by", "name": ""}],
    }
    html = r.render_html()
    order = [html.index(x) for x in ("1\u2002Result", "2\u2002Signatures", '<h2 class="appendix">',
                                     "Appendix A\u2002Alignment", "Appendix B\u2002Provenance")]  # fmt: skip
    assert order == sorted(order) and 'class="signature"' in html
    pages = [p.extract_text() for p in PdfReader(io.BytesIO(r.render_pdf())).pages]
    assert len(pages) == 2  # the body on one page, the appendix starts another
    assert "Signature" in pages[0] and "A. B." in pages[0] and "Appendix A" in pages[1] and "Provenance" in pages[1]
    # without an appendix the provenance stays the last, unnumbered section
    plain = Report("t")
    plain.section("One").paragraph("x")
    assert "<h2>Provenance</h2>" in plain.render_html() and '<h2 class="appendix">' not in plain.render_html()
