"""Both report formats write numbers by the number rule (camcmm.numbers): a table cell
never in exponent form and with a real minus; chart headings in µm for deviations; the
inspection report's statistics in words ("percentile 2.5 %", not p2_5) and in µm, while
the JSON keeps its keys."""

from __future__ import annotations

import re

from camcmm.api import Report
from camcmm.report import blocks, charts
from camcmm_plugins.inspection import report as inspection_report

M = "\u2212"
EXP = re.compile(r"\d[eE][-+]?\d")


def test_table_cells_and_chart_numbers():
    assert blocks.text(1e-05) == "0.00001" and blocks.text(-0.5) == f"{M}0.5"
    assert blocks.text(300.0451) == "300.0451"  # a certified value keeps its digits
    assert blocks.text(0.1 + 0.2) == "0.3" and blocks.text(-1.234567891234e-7) == f"{M}0.0000001234568"
    assert blocks.text(12) == "12" and blocks.text(float("nan")) == "\u2014"
    # "mean +6.55e-12 µm, std +7.43e-05 µm" of the issue: in µm, 0.01 µm resolution
    assert charts._num(6.55e-9, "µm") == "0" and charts._num(7.43e-5, "µm") == "0"
    assert charts._num(-12.345, "µm") == f"{M}12.3" and charts._num(1.23e-5) == "0.0000123"
    assert charts._display_unit(0.5) == "µm" and charts._display_unit(1e-7) == "µm"


def _stats():
    keys = ["mean", "std", "rms", "min", "max", "p0_5", "p2_5", "p5", "p25", "p50", "p75", "p95", "p97_5", "p99_5"]
    st = {k: (i - 6) * 0.00123 for i, k in enumerate(keys)}
    st["std"], st["rms"], st["n"] = 0.0042, 0.0051, 59997
    mr = {"Sk": 0.0123, "Spk": 0.0021, "Svk": 0.0034, "Smr1": 8.123, "Smr2": 91.5, "C1": 0.0061, "C2": -0.0062}
    mr.update({"secant_start": 30.0, "secant_end": 70.0, "Smc": {"2.5": 0.009, "97.5": -0.011}})
    mr.update({"Vmp": 1.2e-4, "Vmc": 4.1e-3, "Vvc": 5.2e-3, "Vvv": 3.3e-4})
    return st, mr


def test_the_inspection_reports_statistics_in_words_and_micrometres():
    st, mr = _stats()
    r = Report("t")
    inspection_report._appendix_sections(r, st, mr)
    tables = [b for sec in r.sections for b in sec.blocks if isinstance(b, blocks.Table)]
    stats, material = tables[0], tables[1]
    names = [row[0] for row in stats.rows]
    assert names[:6] == ["points", "mean", "standard deviation", "RMS", "minimum", "maximum"]
    assert names[6:] == [f"percentile {p} %" for p in ("0.5", "2.5", "5", "25", "50", "75", "95", "97.5", "99.5")]
    values = dict(stats.rows)
    assert values["points"] == "59 997" and values["standard deviation"] == "4.20 µm"
    assert values["mean"] == f"{M}7.38 µm" and values["percentile 97.5 %"] == "+7.38 µm"
    rows = {row[0]: (row[1], row[2]) for row in material.rows}
    assert rows["Sk"] == ("12.3", "µm") and rows["C2"] == (f"{M}6.20", "µm")
    cells = [str(c) for t in tables for row in t.rows for c in row]
    assert not any(EXP.search(c) for c in cells) and not any("p2_5" in c or "um" == c for c in cells)


def test_the_inspect_commands_summary_lines():
    from camcmm_plugins.inspection.cli import _um

    # "mean +6.55e-12 µm, std +7.43e-05 µm" of the issue: 0, never an exponent
    assert _um(6.55e-15) == "0 µm" and _um(7.43e-8, False) == "0 µm"
    assert _um(-0.0123) == f"{M}12.3 µm" and _um(0.0123) == "+12.3 µm" and _um(2.5) == "+2.5000 mm"


def test_the_gdt_reports_lengths():
    from camcmm_plugins.gdt import report as gdt_report

    # "−0.000" of the issue: a value that rounds to zero is 0
    assert gdt_report._mm(-0.00001) == "0" and gdt_report._mm(-0.0123) == f"{M}0.0123"
    assert gdt_report._limits({"tolerance": 1e-05}) == "0.00001"
