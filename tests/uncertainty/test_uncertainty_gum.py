"""GUM budgets and ISO 15530-3: published worked examples, the thesis's own tables, the
CLI's JSON contract and bad input.

Findings recorded here (numbers recomputed from the thesis's tables):

* Thesis table 3.2 (ch. 3.3.1). The combined standard uncertainties 10.1, 6.0 and
  14.8 um (eq. 3.23) follow from the tabulated contributions. Welch–Satterthwaite on the
  tabulated contributions and dof gives nu_eff = 36.1 (y) and 95.3 (z) against the
  thesis's 37 and 96 (the tabulated contributions are rounded to 0.1 um; the ratios
  are within 3 %), with k = 2.03 and 1.985 — the thesis's 2.03 and 1.98 — and
  U = 12.1 and 29.3 um (thesis 12.1 and 29.2 = 1.98 x 14.77). The x column does NOT
  check: its contributions and dof give nu_eff = 21.2, k = 2.08, U = 21.0 um, whereas the
  thesis states nu_eff = 3, k = 3.18 and U = 32.1 um. k = 3.18 is indeed t_0.975(3) and
  32.1 = 3.18 x 10.1, so the x error is in the dof alone: nu_eff = 3 would need
  sum(u_i^4/nu_i) about 7 times larger, e.g. the rotation's 9.1 um with 2 dof instead of
  14. The discussion (ch. 3.4.1) also quotes u_c(x) = 5.9 um, which contradicts the
  10.1 um of the results section and of the table.
* Thesis table 4.1 / eq. 4.1: position A (4.993, 5.003, 5.001 mm) has mean 4.999 mm =
  the calibrated radius, so b = 0 and u_p = 5.29 um; all 15 radii give s = 4.2 um
  ("4 um") and U = 2 sqrt(u_cal^2 + u_p^2) = 8.4 um for u_cal = 0.2 um, the thesis's
  "8 um with a coverage factor of two". The thesis's mean "5.001" is 5.0016 mm.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from camcmm.api import InputError
from camcmm.host import PluginHost
from camcmm_plugins.uncertainty import cli, gum, iso15530

DATA = Path(__file__).parents[1] / "data" / "uncertainty"
TABLE_32 = {  # thesis table 3.2: contribution per axis (um) and dof, in table order
    "x": [3.1, 1.7, 9.1, 1.5, 2.1],
    "y": [2.3, 1.3, 4.7, 0.4, 2.5],
    "z": [6.7, 3.6, 9.1, 3.2, 8.2],
}
DOF_32 = [math.inf, 2244, 14, 14, 2244]


def _budget(axis):
    return gum.evaluate([gum.Contribution(f"f{i}", u, 1.0, d) for i, (u, d) in enumerate(zip(TABLE_32[axis], DOF_32))])


def test_gum_h1_end_gauge_published_numbers():
    """JCGM 100:2008 (GUM) Annex H.1, the end-gauge calibration: with the standard
    uncertainties, sensitivity coefficients and dof of table H.1 the GUM states
    u_c(l) = 32 nm, nu_eff = 16 (16.7 truncated, H.1.6), t_99(16) = 2.92 and
    U_99 = t_99 u_c = 93 nm. We reproduce those four published figures exactly at the
    GUM's rounding."""
    b = gum.budget_from_dict(yaml.safe_load((DATA / "budget_gum_h1.yaml").read_text()))
    assert round(b.combined) == 32
    assert 16 <= b.dof_eff < 17 and math.floor(b.dof_eff) == 16
    assert round(b.k, 2) == 2.92
    assert round(b.expanded) == 93
    # contributions with c = 0 (alpha_s, theta: first order only) carry no share
    assert b.shares[2] == 0 and b.shares[3] == 0
    assert math.isclose(sum(b.shares), 1.0)


def test_gum_h1_measured_difference_sub_budget():
    """GUM H.1.3.2: d combines the repeated observations (5.8 nm, 24 dof), the comparator's
    random (3.9 nm, 5 dof) and systematic effects (6.7 nm, 8 dof) to u(d) = 9.7 nm with
    nu(d) = 25.6. From the rounded published components we get 9.68 nm and 25.4 dof."""
    b = gum.evaluate(
        [
            {"name": "d_mean", "u": 5.8, "dof": 24},
            {"name": "d1", "u": 3.9, "dof": 5},
            {"name": "d2", "u": 6.7, "dof": 8},
        ]
    )
    assert round(b.combined, 1) == 9.7
    assert abs(b.dof_eff - 25.6) < 0.3


@pytest.mark.parametrize("axis,uc,dof,k,U", [("y", 6.0, 37, 2.03, 12.1), ("z", 14.8, 96, 1.98, 29.2)])
def test_thesis_table_32_y_and_z_check(axis, uc, dof, k, U):
    b = _budget(axis)
    assert round(b.combined, 1) == uc
    assert abs(b.dof_eff - dof) / dof < 0.03  # rounded table entries; see the module docstring
    assert abs(b.k - k) < 0.006
    assert abs(b.expanded - U) < 0.15


def test_thesis_table_32_x_column_does_not_check():
    """u_c(x) = 10.1 um checks; nu_eff = 3 (hence k = 3.18, U = 32.1 um) does not."""
    b = _budget("x")
    assert round(b.combined, 1) == 10.1
    assert 21 < b.dof_eff < 21.5  # thesis: 3
    assert round(b.k, 2) == 2.08  # thesis: 3.18
    assert round(b.expanded, 1) == 21.0  # thesis: 32.1
    assert round(gum.coverage_factor(3), 2) == 3.18 and round(3.18 * b.combined, 1) == 32.1
    # the stated dof of 3 would follow if the rotation had 2 dof instead of 14
    dofs = list(DOF_32)
    dofs[2] = 2
    assert math.floor(gum.welch_satterthwaite(TABLE_32["x"], dofs)) == 3


def test_half_width_and_distributions():
    b = gum.evaluate(
        [
            {"name": "r", "a": math.sqrt(3), "distribution": "rectangular"},
            {"name": "t", "a": math.sqrt(6), "distribution": "triangular"},
            {"name": "n", "a": 2.0, "k_a": 2.0},
        ]
    )
    assert [c.u for c in b.contributions] == pytest.approx([1.0, 1.0, 1.0])
    assert b.dof_eff == math.inf and b.k == pytest.approx(1.959964, abs=1e-6)
    d = b.to_dict()
    assert d["dof_eff_infinite"] is True


def test_welch_satterthwaite_vectorised():
    import numpy as np

    u = np.array([[1.0, 2.0], [1.0, 0.0]])
    out = gum.welch_satterthwaite(u, [4, 4])
    # column 0: two equal terms with 4 dof each -> (2)^2 / (2/4) = 8; column 1: one term -> its own 4 dof
    assert out == pytest.approx([8.0, 4.0])


@pytest.mark.parametrize(
    "entry,needle",
    [
        ({"name": "focal", "u": -1.0}, "'focal'"),
        ({"name": "focal"}, "missing standard uncertainty"),
        ({"name": "rot", "u": 1.0, "dof": 0}, "dof = 0"),
        ({"name": "rot", "u": 1.0, "dof": -3}, "must be > 0"),
        ({"name": "p", "u": "abc"}, "not a number"),
        ({"name": "p", "u": 1.0, "distribution": "cauchy"}, "unknown distribution"),
    ],
)
def test_budget_bad_input_names_the_entry(entry, needle):
    with pytest.raises(InputError) as err:
        gum.evaluate([{"name": "ok", "u": 1.0}, entry])
    assert needle in str(err.value) and "contribution 2" in str(err.value)


def test_budget_cli_json(capsys):
    from camcmm.cli.main import main

    assert main(["uncertainty", "budget", str(DATA / "budget_example.yaml"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"combined", "dof_eff", "k", "expanded", "coverage_probability", "contributions"} <= set(out)
    assert out["contributions"][0]["dof"] is None and out["contributions"][0]["dof_infinite"] is True
    uc = math.sqrt(3.1**2 + (1.2 * 1.4) ** 2 + 9.1**2)
    assert out["combined"] == pytest.approx(uc)
    assert out["expanded"] == pytest.approx(out["k"] * uc)
    assert out["coverage_probability"] == 0.95
    assert sum(c["share"] for c in out["contributions"]) == pytest.approx(1.0)


def test_budget_through_the_host():
    host = PluginHost()
    res = host.run("uncertainty.budget", {"spec": DATA / "budget_thesis_table32_x.yaml"}, {"dof_rounding": "none"})
    assert round(res.outputs["combined"], 1) == 10.1
    res = host.run(
        "uncertainty.budget",
        {"spec": {"contributions": [{"name": "a", "u": 1, "dof": 10}]}},
        {"coverage_probability": 0.99},
    )
    assert res.outputs["k"] == pytest.approx(3.169, abs=1e-3)


def test_budget_of_zeros_warns_that_the_combined_uncertainty_is_zero(tmp_path, capsys):
    """u_c = 0 is legal arithmetic but no measurement is exact: CLI, JSON and host warn."""
    from camcmm.cli.main import main

    b = gum.evaluate([{"name": "a", "u": 0, "dof": 10}, {"name": "b", "u": 2.0, "c": 0}])
    assert b.combined == 0 and len(b.warnings) == 1 and "u_c is 0" in b.warnings[0]
    assert gum.evaluate([{"name": "a", "u": 1e-300, "dof": 10}]).warnings == []
    f = tmp_path / "b.yaml"
    f.write_text("quantity: x\nunit: um\ncontributions:\n  - {name: a, u: 0, dof: 10}\n")
    assert main(["uncertainty", "budget", str(f), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == b.warnings
    assert main(["uncertainty", "budget", str(f)]) == 0
    assert "warning: the combined standard uncertainty u_c is 0" in capsys.readouterr().out
    res = PluginHost().run("uncertainty.budget", {"spec": f})
    assert res.warnings == b.warnings and "warnings" not in res.outputs


@pytest.mark.slow
def test_budget_cli_subprocess_text():
    out = subprocess.run(
        [sys.executable, "-m", "camcmm", "uncertainty", "budget", str(DATA / "budget_gum_h1.yaml")],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    assert "U = 92.6" in out.stdout


# ---------------------------------------------------------------- ISO 15530-3
def test_iso15530_position_a_eq_41():
    r = iso15530.from_dict(yaml.safe_load((DATA / "iso15530_example.yaml").read_text()))
    assert r["n"] == 3 and r["mean"] == pytest.approx(4.999, abs=1e-12)
    assert r["bias"] == pytest.approx(0.0, abs=1e-12)
    assert r["u_p"] == pytest.approx(math.sqrt(28) * 1e-3)  # s of 4.993, 5.003, 5.001 = 5.29 um
    assert r["u_b"] == pytest.approx(r["u_p"] / math.sqrt(3))  # default: standard error of the mean
    assert r["U"] == pytest.approx(2 * math.sqrt(0.0002**2 + r["u_p"] ** 2 + r["u_b"] ** 2))
    assert "note" in r  # fewer than the 20 measurements ISO 15530-3 asks for


def test_iso15530_thesis_table_41_all_positions(tmp_path):
    """15 radii from a file, u_b = u_w = 0 as in the thesis: s = 4.2 um ("4 um") and
    U = 8.4 um, the thesis's "8 um" (k = 2)."""
    host = PluginHost()
    r = host.run("uncertainty.iso15530-3", {"spec": DATA / "iso15530_table41.yaml"}).outputs
    assert r["n"] == 15 and round(r["u_p"] * 1000) == 4
    assert r["u_cal"] == pytest.approx(0.0002)
    assert round(r["U"] * 1000) == 8
    assert r["mean"] == pytest.approx(5.0016)
    assert r["U_uncorrected_bias"] == pytest.approx(2 * math.sqrt(0.0002**2 + r["u_p"] ** 2) + abs(r["bias"]))


def test_iso15530_thermal_u_w():
    doc = {
        "calibrated_value": 100.0,
        "u_cal": 0.0,
        "measurements": [100.0, 100.0],
        "u_b": 0,
        "thermal": {"length": 100.0, "cte": 11.5e-6, "u_cte": 1e-6, "temperature": 21.0, "u_temperature": 0.5},
    }
    r = iso15530.from_dict(doc)
    assert r["u_w"] == pytest.approx(100 * math.hypot(1.0 * 1e-6, 11.5e-6 * 0.5))
    assert r["U"] == pytest.approx(2 * r["u_w"])


def test_iso15530_cli_json(capsys):
    from camcmm.cli.main import main

    assert main(["uncertainty", "iso15530-3", str(DATA / "iso15530_example.yaml"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"mean", "bias", "u_cal", "u_p", "u_b", "u_w", "k", "U", "n"} <= set(out)


@pytest.mark.parametrize(
    "doc,needle",
    [
        ({"calibrated_value": 5, "u_cal": 0.1, "measurements": [5.0]}, "at least two"),
        ({"calibrated_value": 5, "u_cal": -0.1, "measurements": [5.0, 5.1]}, "u_cal"),
        ({"calibrated_value": 5, "measurements": [5.0, 5.1]}, "u_cal: missing"),
        ({"u_cal": 0.1, "measurements": [5.0, 5.1]}, "calibrated_value"),
        ({"calibrated_value": 5, "u_cal": 0.1}, "measurements: missing"),
        ({"calibrated_value": 5, "u_cal": 0.1, "measurements": [5.0, 5.1], "u_w": -1}, "u_w"),
        ({"calibrated_value": 5, "u_cal": 0.1, "measurements": [5.0, 5.1], "k": 0}, "k = 0"),
    ],
)
def test_iso15530_bad_input(doc, needle):
    with pytest.raises(InputError) as err:
        iso15530.from_dict(doc)
    assert needle in str(err.value)


def test_cli_configure_has_three_subcommands():
    p = argparse.ArgumentParser()
    cli.configure(p)
    for sub in ("budget", "iso15530-3", "montecarlo"):
        assert p.parse_args([sub, "f.yaml"]).what == sub
