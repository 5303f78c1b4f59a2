"""The Uncertainty page writes its numbers by the number rule (camcmm.numbers): u_c, U and
each u with two significant digits (GUM 7.2.6), never an exponent; the budget's bars and
percentages are one quantity (the share of u_c²) and the chart says so; the Monte Carlo
table keeps k out of the µm columns; a form default of 1e-05 is shown as 0.00001.
Pure functions on hand-made results: no server."""

from __future__ import annotations

import math
import re

import pytest

from camcmm.gui.pages.uncertainty import budget, study
from camcmm.gui.pages.uncertainty import figures as figs

EXP = re.compile(r"\d[eE][-+]?\d")


def _budget_result():
    # u_c² = 3.1² + 9.1² = 92.42: shares 10.4 % and 89.6 %; k = 2.08, p = 95 %
    uc = math.hypot(3.1, 9.1)
    return {
        "combined": uc,
        "dof_eff": 21.234,
        "k": 2.0796,
        "expanded": 2.0796 * uc,
        "coverage_probability": 0.95,
        "unit": "um",
        "contributions": [
            {"name": "feature", "u": 3.1, "c": 1, "contribution": 3.1, "share": 3.1**2 / uc**2},
            {"name": "rotation", "u": 9.1, "c": 1, "contribution": -9.1, "share": 9.1**2 / uc**2},
        ],
    }


def test_the_budget_card_two_significant_digits_and_shares_of_the_variance():
    shown = budget.shown(_budget_result())
    assert shown["combined"] == "9.6" and shown["expanded"] == "20"  # 9.613 and 19.99 µm
    assert shown["k"] == "2.08" and shown["dof_eff"] == "21.2" and shown["p"] == "95 %"
    assert shown["unit"] == "µm"  # not "um"
    assert [r["share"] for r in shown["shares"]] == ["10 %", "90 %"]
    assert [r["contribution"] for r in shown["shares"]] == ["3.1", "9.1"]
    assert "variance" in shown["share_meaning"]


def test_the_budget_bars_are_the_percentages_and_the_title_says_which():
    fig = figs.budget_figure(_budget_result())
    (bar,) = fig["data"]
    shares = [100 * 9.1**2 / (3.1**2 + 9.1**2), 100 * 3.1**2 / (3.1**2 + 9.1**2)]  # drawn bottom-up
    assert bar["x"] == pytest.approx(shares)
    assert bar["text"] == ["90 %", "10 %"]
    assert "share of the variance" in fig["layout"]["title"]["text"]
    assert fig["layout"]["xaxis"]["title"]["text"] == "share of u_c² / %"


def test_the_monte_carlo_table_keeps_k_out_of_the_micrometre_columns():
    full = {
        "contributions": {"rotation": [3.712, 0.0000123, 12.34], "focal_length": [1.7, 1.0, 2.0]},
        "factor_dof": {"rotation": 14, "focal_length": None},
        "factor_distribution": {"rotation": "rectangular", "focal_length": "normal"},
        "combined": [4.09, 1.41, 12.5],
        "dof_eff": [20.1, 30.2, 15.0],
        "k": [2.086, 2.042, 2.131],
        "expanded": [8.53, 2.88, 26.6],
        "coverage_probability": 0.95,
    }
    rows = study.table_rows(full)
    assert [r["factor"] for r in rows][:2] == ["rotation (camera 2)", "focal length"]
    assert (rows[0]["x"], rows[0]["y"], rows[0]["z"]) == ("3.7", "0.000012", "12")
    assert rows[1]["dof"] == "∞" and rows[0]["dof"] == "14"  # not 14.00
    assert not any(r["factor"] == "k" for r in rows)  # no "k" row with 2.09 in the u_x column
    total = {r["factor"]: r for r in rows if r.get("total")}
    (u_row,) = [r for name, r in total.items() if name.startswith("combined")]
    (U_row,) = [r for name, r in total.items() if name.startswith("expanded")]
    assert U_row["factor"] == "expanded U = k·u_c (k = 2.09 / 2.04 / 2.13, 95 %)"
    assert (U_row["x"], u_row["x"]) == ("8.5", "4.1") and u_row["dof"] == "ν_eff 20.1 / 30.2 / 15"
    cells = [str(v) for r in rows for v in r.values()]
    assert not any(EXP.search(c) for c in cells), cells


def test_form_defaults_and_plain_numbers_never_in_exponent_form():
    assert study._shown(1e-05) == "0.00001" and study._shown([1e-05, 0.0362]) == "0.00001, 0.0362"
    assert study._shown([-0.135, -0.13]) == "-0.135, -0.13"  # typed into a field: parsed back, ASCII minus
    assert figs.fmt(1.23e-7, 3) == "0.000000123" and figs.fmt(float("inf")) == "∞"
    assert figs.shown_unit("urad") == "µrad" and figs.u_text(0.0) == "0"
