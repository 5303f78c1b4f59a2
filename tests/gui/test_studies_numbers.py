"""The Studies page's tables by the number rule (camcmm.numbers): a fit's slope and
intercept with their u (digits from u, never an exponent), counts grouped, a real minus,
zero as "0"."""

from __future__ import annotations

import re

from camcmm.gui.pages.studies import tables

M = "\u2212"
EXP = re.compile(r"\d[eE][-+]?\d")


def test_the_focal_length_fit_with_its_uncertainty():
    fit = {
        "slope": -0.000112674,
        "intercept": 0.0123456,
        "cov": [[0.000139**2, 0.0], [0.0, 2.1e-5**2]],
        "r2": 0.987654321,
        "residual_std": 3.2e-6,
        "predicted": {"focal_length": 25.0, "gradient_mm_per_lambda": 0.0095, "u": 1.1e-5, "u_new_set": 4.4e-5},
    }
    rows = {r["name"]: r["value"] for r in tables.focal_rows(fit)}
    # the "p2 −0.000112674 ± 0.000139": digits follow u
    assert rows["slope"] == f"{M}0.00011 ± 0.00014 mm λ⁻¹ per mm"
    assert rows["intercept"] == "0.012346 ± 0.000021 mm λ⁻¹"
    assert rows["residual_std"] == "0.0000032 mm λ⁻¹"
    assert "0.000011 (line)" in rows["predicted"] and "0.000044 (a new set)" in rows["predicted"]
    assert not any(EXP.search(v) for v in rows.values()), rows


def test_counts_signs_and_zero():
    cases = [
        {"id": "a", "artefact": "cube", "material": "steel", "condition": "off", "std_um": 12.4, "n_points": 123456},
        {"id": "b", "artefact": "cube", "material": "steel", "condition": "on", "std_um": 0.2, "n_points": 98765},
    ]
    t61, t62, _ = tables.speckle_tables(cases)
    assert t61["rows"][0][1:] == ["12", "0"] and t62["rows"][0][1:] == ["123 456", "98 765"]
    summary = {"steel": {"std_um_change": -12.2, "n_points_change": -24691, "coverage_area_fraction_change": -0.0004}}
    (row,) = tables.summary_rows(summary)
    assert row["value"] == f"std {M}12 µm, points {M}24 691, coverage 0 %"
