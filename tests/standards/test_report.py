"""The report document and its HTML, PDF and JSON renderings (camcmm.report)."""

from __future__ import annotations

import hashlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from camcmm.errors import InputError
from camcmm.report import Report, charts
from camcmm.report.blocks import CONTENT_WIDTH_MM, FigureRow, layout, png_size

EVIL = "<script>alert(1)</script>"


def _pdf_text(path) -> str:
    """The PDF's text, pages separated by form feeds (as pdftotext writes them), read by
    pypdf (a test dependency), so a fresh machine runs these tests without poppler."""
    from pypdf import PdfReader

    return "\f".join(page.extract_text() for page in PdfReader(str(path)).pages)


def _embedded_json(html_text: str):
    m = re.search(r'<script type="application/json" id="camcmm-data">(.*?)</script>', html_text, re.S)
    assert m, "no embedded JSON"
    return json.loads(m.group(1))


@pytest.fixture(scope="module")
def small_png() -> bytes:
    return charts.bar_chart(["1", "2", "3"], [0.1, 0.15, 0.2], limit=0.186, width_mm=80, height_mm=50)


def _sample(small_png) -> Report:
    r = Report(
        "VDI/VDE 2634-2 acceptance test", subtitle="Stereo FP", meta={"date": "2025-06-01", "operator": "A. Müller"}
    )
    s = r.section("Probing error form P_F")
    s.paragraph("Seven positions in the measuring volume.")
    s.keyvalues({"MPE": "0.186 mm", "Sphere": "S1 (25.0012 mm)"})
    s.table(
        columns=["Position", "P_F [mm]", "Points used"],
        rows=[[1, 0.1234, 18001], [2, "0.0987", 17654], [3, None, 0]],
        caption="Per position",
    )
    s.figure(small_png, caption="P_F per position")
    s.verdict(
        label="P_F", simple="pass", guarded="inconclusive", value="0.120 mm", limit="0.186 mm", uncertainty="0.020 mm"
    )
    s.verdict(label="P_S", simple="fail", guarded="fail", value="0.220 mm", limit="0.100 mm")
    s.warning("Position 3 has no points on the sphere.")
    r.provenance(
        software="camcmm 0.1.0",
        plugins=[{"id": "fit.sphere", "version": "0.1.0"}],
        inputs=[{"file": "pos1.ply", "sha256": "a" * 64}],
        extra={"seed": 7},
    )
    r.data = {
        "verdict": "fail",
        "values": np.array([0.1, 0.2]),
        "undefined": float("nan"),
        "nested": {"k": [1, 2, {"x": "y"}]},
    }
    return r


@pytest.fixture(scope="module")
def written(tmp_path_factory, small_png):
    r = _sample(small_png)
    out = tmp_path_factory.mktemp("report")
    return r, r.write(out), out


# ----------------------------------------------------------------------------- files
def test_write_creates_three_files_and_no_leftovers(written):
    r, paths, out = written
    assert set(paths) == {"html", "pdf", "json"}
    for ext, p in paths.items():
        assert Path(p) == out / f"report.{ext}" and Path(p).stat().st_size > 0
    assert sorted(os.listdir(out)) == ["report.html", "report.json", "report.pdf"]


def test_json_file_is_to_dict(written):
    r, paths, _ = written
    doc = json.loads(Path(paths["json"]).read_text(encoding="utf-8"))
    assert doc == r.to_dict()
    assert doc["title"] == "VDI/VDE 2634-2 acceptance test" and doc["meta"]["operator"] == "A. Müller"
    assert doc["data"] == {
        "verdict": "fail",
        "values": [0.1, 0.2],
        "undefined": None,
        "nested": {"k": [1, 2, {"x": "y"}]},
    }
    blocks = doc["sections"][0]["blocks"]
    assert [b["type"] for b in blocks] == ["paragraph", "keyvalues", "table", "figure", "verdict", "verdict", "warning"]
    table = blocks[2]
    assert table["rows"] == [[1, 0.1234, 18001], [2, "0.0987", 17654], [3, None, 0]]
    assert table["align"] == ["right", "right", "right"]
    fig = blocks[3]
    assert fig["caption"] == "P_F per position"
    assert fig["info"]["chart"] == "bar" and fig["info"]["n_beyond_limit"] == 1
    prov = doc["provenance"]
    assert prov["software"] == "camcmm 0.1.0" and prov["plugins"] == [{"id": "fit.sphere", "version": "0.1.0"}]
    assert prov["inputs"] == [{"file": "pos1.ply", "sha256": "a" * 64}] and prov["extra"] == {"seed": 7}
    assert prov["environment"]["python"]


def test_figure_hash_is_that_of_the_embedded_png(written, small_png):
    r, paths, _ = written
    fig = r.to_dict()["sections"][0]["blocks"][3]
    assert fig["sha256"] == hashlib.sha256(small_png).hexdigest()
    html_text = Path(paths["html"]).read_text(encoding="utf-8")
    import base64

    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html_text)
    assert [hashlib.sha256(base64.b64decode(u)).hexdigest() for u in uris] == [fig["sha256"]]


# ----------------------------------------------------------------------------- HTML
def test_html_has_every_cell_and_verdict_and_nothing_external(written):
    r, paths, _ = written
    h = Path(paths["html"]).read_text(encoding="utf-8")
    for cell in [
        "Position",
        "P_F [mm]",
        "Points used",
        "1",
        "0.1234",
        "18001",
        "0.0987",
        "17654",
        "\u2014",
        "Per position",
        "MPE",
        "0.186 mm",
        "S1 (25.0012 mm)",
        "A. Müller",
        "pos1.ply",
        "a" * 64,
        "fit.sphere",
        "Seven positions in the measuring volume.",
        "Position 3 has no points on the sphere.",
    ]:
        assert cell in h, cell
    for word in ("pass", "inconclusive", "fail", "0.120 mm", "0.020 mm", "0.220 mm"):
        assert word in h
    assert re.search(r'<span class="badge v-inconclusive"', h)
    # self-contained: nothing fetched; http only ever in text, never in src/href/url()
    assert not re.search(r'(?:src|href)\s*=\s*["\']?\s*(?:https?:|//)', h, re.I)
    assert not re.search(r"url\(\s*['\"]?\s*(?:https?:|//)", h, re.I)
    assert "<link" not in h and "@import" not in h
    assert all(src.startswith("data:") for src in re.findall(r'src="([^"]*)"', h))


def test_html_embedded_json_equals_data(written):
    r, paths, _ = written
    h = Path(paths["html"]).read_text(encoding="utf-8")
    assert _embedded_json(h) == r.to_dict()["data"]


def test_html_escapes_names_from_files(tmp_path, small_png):
    r = Report(f"Report {EVIL}", subtitle=EVIL, meta={EVIL: EVIL})
    s = r.section(EVIL)
    s.paragraph(EVIL)
    s.keyvalues({EVIL: EVIL})
    s.table([EVIL], [[EVIL]], caption=EVIL)
    s.figure(small_png, caption=EVIL + '" onerror="alert(2)')
    s.verdict(label=EVIL, simple="pass", value=EVIL, note=EVIL)
    s.warning(EVIL)
    r.provenance(inputs=[{"file": EVIL, "sha256": "0" * 64}], extra={EVIL: EVIL})
    r.data = {"name": "</script><script>alert(3)</script>", EVIL: "<!--"}
    h = r.render_html()
    assert "<script>alert" not in h
    assert 'onerror="alert' not in h
    assert h.count("<script") == 1  # only the inert JSON block
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in h
    assert _embedded_json(h) == r.to_dict()["data"]
    paths = r.write(tmp_path)  # the PDF (reportlab parses a little XML) survives it too
    assert EVIL in _pdf_text(paths["pdf"])


def test_figures_side_by_side_when_they_fit(small_png):
    r = Report("t")
    s = r.section("figures")
    for w in (80, 80, 80, 170):
        s.figure(small_png, width_mm=w)
    s.paragraph("between")
    s.figure(small_png, width_mm=500)  # capped at the text width
    rows = [b for b in layout(s.blocks) if isinstance(b, FigureRow)]
    assert [[f.width_mm for f in row.figures] for row in rows] == [[80, 80], [80], [170], [CONTENT_WIDTH_MM]]
    # a chart keeps the width it was drawn at (dpi in the PNG)
    r.section("natural").figure(small_png)
    assert r.sections[-1].blocks[0].width_mm == pytest.approx(80, abs=0.5)


def test_matplotlib_figure_and_png_file_are_accepted(tmp_path, small_png):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2))
    fig.add_subplot().plot([0, 1], [1, 0])
    (tmp_path / "f.png").write_bytes(small_png)
    s = Report("t").section("s")
    s.figure(fig, caption="mpl").figure(tmp_path / "f.png", caption="file")
    w, h, dpi = png_size(s.blocks[0].png)
    assert (w, h) == (450, 300) and dpi == pytest.approx(150, abs=1)
    assert s.blocks[1].png == small_png


# ----------------------------------------------------------------------------- PDF
def test_pdf_is_valid_and_has_the_table_values(written):
    r, paths, _ = written
    pdf = Path(paths["pdf"]).read_bytes()
    assert pdf.startswith(b"%PDF-") and pdf.rstrip().endswith(b"%%EOF")
    text = _pdf_text(paths["pdf"])
    for cell in [
        "VDI/VDE 2634-2 acceptance test",
        "Probing error form P_F",
        "Per position",
        "0.1234",
        "18001",
        "0.0987",
        "17654",
        "0.186 mm",
        "A. Müller",
        "P_F per position",
        "PASS",
        "INCONCLUSIVE",
        "FAIL",
        "0.020 mm",
        "Position 3 has no points on the sphere.",
        "a" * 64,
        "fit.sphere",
        "page 1 of",
    ]:
        assert cell in text, cell


def test_pdf_long_table_splits_and_repeats_header(tmp_path):
    r = Report("Long table report")
    rows = [[i, f"{0.001 * i:.4f}", f"row-{i:03d}"] for i in range(1, 151)]
    r.section("All positions").table(["Index", "Value [mm]", "Label"], rows, caption="150 rows")
    paths = r.write(tmp_path, formats=("pdf",))
    assert set(paths) == {"pdf"}
    text = _pdf_text(paths["pdf"])
    pages = text.split("\f")
    assert len([p for p in pages if p.strip()]) >= 3
    assert text.count("Value [mm]") >= 3  # header repeated on each page
    assert all(f"row-{i:03d}" in text for i in range(1, 151))
    assert "page 3 of" in text and "Long table report" in pages[2]


def test_pdf_unicode_text(tmp_path):
    r = Report("Unicode \u2212 \u00b5m \u2264 \u00b1 \u03c3")
    r.section("Bediener").paragraph("Лаборатория \u2014 Müller \u2206L = \u22120.003 \u00b5m")
    text = _pdf_text(r.write(tmp_path, formats=("pdf",))["pdf"])
    assert "Лаборатория" in text and "\u00b5m" in text and "\u22120.003" in text and "\u03c3" in text


# ----------------------------------------------------------------------------- errors and atomicity
def test_bad_input_gets_a_clear_error(tmp_path, small_png):
    s = Report("t").section("s")
    with pytest.raises(InputError, match="not one of pass, fail, inconclusive, incomplete"):
        s.verdict("P_F", simple="ok")
    with pytest.raises(InputError, match="guarded verdict 'PASS'"):
        s.verdict("P_F", simple="pass", guarded="PASS")
    with pytest.raises(InputError, match="row 1 has 1 cells for 2 columns"):
        s.table(["a", "b"], [[1, 2], [3]])
    with pytest.raises(InputError, match="align"):
        s.table(["a"], [[1]], align=["middle"])
    with pytest.raises(InputError, match="not a PNG"):
        s.figure(b"GIF89a....")
    with pytest.raises(InputError, match="plain file name"):
        Report("t").write(tmp_path, basename="../x")
    with pytest.raises(InputError, match="no sha256 given and no such file"):
        Report("t").provenance(inputs=[{"file": str(tmp_path / "missing.ply")}])
    r = Report("t")
    r.data = {"x": object()}
    with pytest.raises(TypeError, match=r"report data\['x'\]"):
        r.to_dict()


def test_input_hash_is_computed_from_the_file(tmp_path):
    f = tmp_path / "scan.ply"
    f.write_bytes(b"ply\nformat ascii 1.0\n")
    r = Report("t").provenance(inputs=[{"file": str(f)}, {"file": str(f)}])
    assert r.to_dict()["provenance"]["inputs"] == [
        {"file": str(f), "sha256": hashlib.sha256(f.read_bytes()).hexdigest()}
    ]


def test_failed_render_writes_nothing(tmp_path, small_png, monkeypatch):
    r = _sample(small_png)
    old = r.write(tmp_path)
    before = {k: Path(p).read_bytes() for k, p in old.items()}
    r.section("added later").paragraph("new")

    def boom(self):
        raise RuntimeError("disk full")

    monkeypatch.setattr(Report, "render_pdf", boom)
    with pytest.raises(RuntimeError):
        r.write(tmp_path)
    assert {k: Path(p).read_bytes() for k, p in old.items()} == before
    assert sorted(os.listdir(tmp_path)) == ["report.html", "report.json", "report.pdf"]


def test_importing_report_loads_no_plotting_or_pdf_library():
    code = (
        "import sys, camcmm.report; r = camcmm.report.Report('t'); r.section('s').table(['a'], [[1]]);"
        "r.to_dict(); r.render_html();"
        "print(','.join(m for m in ('matplotlib', 'reportlab') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_cell_text_keeps_certified_digits_and_shortens_computed_ones():
    from camcmm.report.blocks import text

    assert text(300.0451) == "300.0451"  # a certified length keeps its 0.1 µm digit
    assert text(0.1 + 0.2) == "0.3" and text(0.189432123456) == "0.1894321"
    assert text(np.int64(12345678)) == "12345678" and text(np.float32(0.1)) == "0.1"
    assert text(None) == text(float("nan")) == "\u2014"
    assert text(True) == "yes" and text({"a": [1, 2]}) == '{"a": [1, 2]}'


def test_unwritable_directory_is_a_one_line_error(tmp_path):
    from camcmm.errors import CamcmmError

    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(CamcmmError, match="cannot write the report into"):
        Report("t").write(blocker / "sub", formats=("json",))
