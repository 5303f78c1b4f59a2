"""Type B entries of a GUM budget and the Uncertainty page's two starting points.

An entry states u, or a half-width a with its distribution, or an expanded U with its k;
the uncertainty plugin converts (JCGM 100:2008 4.3.3, 4.3.7, 4.3.9; JCGM 101:2008 6.4.6),
checked here against the GUM's own factors and worked numbers. Bad combinations get one
line naming the entry.

The page's defaults are one system, thesis ch. 3.3.1 with table 3.2: the budget quotes the
thesis's tabulated x contributions (rotation 9.1 um), the Monte Carlo starts from the
tabulated parameter uncertainties (rotation 1.84, 1.52, 0.71 x 10^-4 rad) and computes the
contributions (rotation 3.7-3.8 um in x on its 60 x 40 x 40 mm grid). The numbers below
are read from the thesis (../shared/seed/000_87be58b06a4e004c.txt, ch. 3.3.1), not from
the files they check.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from camcmm.api import InputError
from camcmm.assets import resources_dir
from camcmm.host import default_host
from camcmm_plugins.uncertainty import gum
from camcmm_plugins.uncertainty.declared_system import system_document
from camcmm_plugins.uncertainty.distributions import standard_uncertainty

DATA = Path(__file__).parents[1] / "data" / "uncertainty"
EPS = np.finfo(float).eps


def u_of(**entry) -> float:
    return standard_uncertainty(entry, "t", gum._number).u


# ------------------------------------------------------------------ the conversions
@pytest.mark.parametrize("dist,variance_factor", [("rectangular", 3), ("triangular", 6), ("u-shaped", 2)])
def test_half_width_divisors_are_the_gums_factors(dist, variance_factor):
    """GUM 4.3.7: u^2 = a^2/3; 4.3.9 (beta = 0): u^2 = a^2/6; JCGM 101 6.4.6 arcsine: a^2/2."""
    for a in (1.0, 2.0, 0.4e-6, 75.0, 3.0):
        u = u_of(half_width=a, distribution=dist)
        assert u == a / math.sqrt(variance_factor)  # exactly the GUM's divisor
        assert u * u * variance_factor == pytest.approx(a * a, rel=4 * EPS)
    assert u_of(a=2.0, distribution=dist) == u_of(half_width=2.0, distribution=dist)
    assert u_of(half_width=2.0, distribution="arcsine") == u_of(half_width=2.0, distribution="u-shaped")


def test_the_gums_worked_numbers():
    # 4.3.3: "240 ug at the three standard deviation level": u = 240/3 = 80 ug
    assert u_of(expanded=240.0, k=3) == 80.0
    # 4.3.7: alpha_20(Cu), error not exceeding 0.40e-6 /degC: u = 0.23e-6 /degC
    assert round(u_of(half_width=0.40e-6, distribution="rectangular") * 1e6, 2) == 0.23
    # H.1.3.1: U = 0.075 um with k = 3 -> u(l_s) = 25 nm
    assert u_of(expanded=75.0, k=3) == 25.0
    # H.1.3.3: alpha_s in 9.5 .. 13.5e-6 -> 1.2e-6; H.1.3.5: ±1e-6 -> 0.58e-6; H.1.3.6: ±0.05 -> 0.029 degC
    assert round(u_of(half_width=2e-6, distribution="rectangular") * 1e6, 1) == 1.2
    assert round(u_of(half_width=1e-6, distribution="rectangular") * 1e6, 2) == 0.58
    assert round(u_of(half_width=0.05, distribution="rectangular"), 3) == 0.029
    # H.1.3.4: the cyclic temperature of amplitude 0.5 degC: u = 0.5/sqrt(2) = 0.35 degC
    assert round(u_of(half_width=0.5, distribution="u-shaped"), 2) == 0.35


ROWS = [
    {"name": "feature", "u": 3.1},
    {"name": "focal", "u": 1.2, "c": 1.4, "dof": 2244},
]


@pytest.mark.parametrize(
    "entry,u",
    [
        ({"half_width": 2.0, "distribution": "rectangular"}, 2.0 / math.sqrt(3)),
        ({"half_width": 2.0, "distribution": "triangular"}, 2.0 / math.sqrt(6)),
        ({"half_width": 2.0, "distribution": "u-shaped"}, 2.0 / math.sqrt(2)),
        ({"expanded": 2.0, "k": 2.5}, 2.0 / 2.5),
    ],
)
def test_a_row_entered_as_a_half_width_equals_the_row_entered_as_u(entry, u):
    stated = gum.evaluate([*ROWS, {"name": "rot", "dof": 14, **entry}]).to_dict()
    plain = gum.evaluate([*ROWS, {"name": "rot", "dof": 14, "u": u}]).to_dict()
    for key in ("combined", "dof_eff", "k", "expanded"):
        assert stated[key] == plain[key]
    assert [c["share"] for c in stated["contributions"]] == [c["share"] for c in plain["contributions"]]
    assert stated["contributions"][2]["u"] == u


def test_the_conversion_in_words():
    res = gum.evaluate([{"name": "x", "half_width": 2.0, "distribution": "rectangular"}], unit="um").to_dict()
    c = res["contributions"][0]
    assert c["conversion"] == "a = 2 µm, rectangular → u = a/√3 = 1.155 µm"
    assert c["entered_as"] == "half_width" and c["entered_value"] == 2.0 and c["divisor"] == math.sqrt(3)
    res = gum.evaluate([{"name": "l_s", "expanded": 75, "k": 3}], unit="nm").to_dict()
    assert res["contributions"][0]["conversion"] == "U = 75 nm, normal with k = 3 → u = U/k = 25 nm"
    res = gum.evaluate([{"name": "t", "u": 0.5, "c": 2.0, "distribution": "rectangular"}], unit="um").to_dict()
    # an input with c != 1 is not in the measurand's unit: no unit unless the entry states one
    assert res["contributions"][0]["conversion"] == "u = 0.5 (rectangular: entered as u)"


def test_gum_h1_entered_as_the_gum_states_each_input():
    """H.1 with the certificate's U = 75 nm (k = 3) and the rectangular bounds of alpha_s,
    delta_alpha and delta_theta: u_c = 32 nm (31.7), nu_eff = 16 after truncation (16.8 with
    the exact a/sqrt(3); the GUM's 16.7 comes from its rounded components), t_99(16) = 2.92;
    U = 92.5 nm against the GUM's 93 = 2.92 x 32 nm (its u_c rounded first)."""
    b = gum.budget_from_dict(yaml.safe_load((DATA / "budget_gum_h1_half_widths.yaml").read_text()))
    assert [c.entered.entered_as for c in b.contributions] == ["expanded", "u", "half_width", "u"] + ["half_width"] * 2
    assert round(b.combined) == 32 and round(b.combined, 1) == 31.7
    assert math.floor(b.dof_eff) == 16 and abs(b.dof_eff - 16.7) < 0.1
    assert round(b.k, 2) == 2.92
    assert abs(b.expanded - 93) < 1
    same = gum.budget_from_dict(yaml.safe_load((DATA / "budget_gum_h1.yaml").read_text()))
    assert abs(b.combined - same.combined) < 0.05  # the GUM's rounded u: 31.71 nm


@pytest.mark.parametrize(
    "entry,needle",
    [
        ({"u": 1.0, "half_width": 2.0, "distribution": "rectangular"}, "not u and half_width"),
        ({"half_width": 1.0, "expanded": 2.0, "k": 2}, "not half_width and expanded"),
        ({"half_width": -1.0, "distribution": "rectangular"}, "half-width a = -1 must be"),
        ({"expanded": -1.0, "k": 2}, "expanded U = -1 must be"),
        ({"half_width": 1.0, "distribution": "cauchy"}, "unknown distribution 'cauchy'"),
        ({"half_width": 1.0, "distribution": "student-t"}, "no student-t divisor"),
        ({"expanded": 1.0}, "needs its coverage factor k"),
        ({"expanded": 1.0, "k": 0}, "k = 0 must be"),
        ({"expanded": 1.0, "k": 2, "distribution": "rectangular"}, "not rectangular"),
        ({"u": 1.0, "k": 2}, "applies to an expanded uncertainty"),
        ({"half_width": 1.0, "distribution": "rectangular", "k": 2}, "does not apply to a rectangular"),
        ({"half_width": "wide", "distribution": "rectangular"}, "not a number"),
    ],
)
def test_bad_combinations_get_one_line_naming_the_entry(entry, needle):
    with pytest.raises(InputError) as err:
        gum.evaluate([{"name": "ok", "u": 1.0}, {"name": "rot", **entry}])
    msg = str(err.value)
    assert needle in msg and "contribution 2 ('rot')" in msg and "\n" not in msg


@pytest.mark.slow
def test_cli_json_keeps_its_keys_and_adds_how_each_entry_was_stated(capfd):
    from helpers.cli import main_json, main_text  # in-process (the CLI's main): only the output counts

    out = main_json(capfd, "uncertainty", "budget", DATA / "budget_gum_h1_half_widths.yaml", "--json")
    assert {"combined", "dof_eff", "k", "expanded", "coverage_probability", "contributions"} <= set(out)
    old = {"name", "u", "c", "dof", "dof_infinite", "distribution", "contribution", "share"}
    new = {"entered_as", "entered_value", "divisor", "coverage_factor", "conversion", "input_unit"}
    for c in out["contributions"]:
        assert old | new <= set(c)
    assert out["contributions"][5]["conversion"] == "a = 0.05 °C, rectangular → u = a/√3 = 0.02887 °C"
    text = main_text(capfd, "uncertainty", "budget", DATA / "budget_gum_h1_half_widths.yaml")
    assert "entered as U = 75 nm, normal with k = 3 → u = U/k = 25 nm" in text


def test_the_manifest_declares_the_entry_forms():
    spec = default_host().provider("uncertainty-budget")
    help_text = next(p.help for p in spec.inputs if p.name == "spec")
    for word in ("half_width", "expanded", "GUM 4.3.7", "GUM 4.3.9", "4.3.3", "arcsine"):
        assert word in help_text
    assert "entered_as" in next(p.help for p in spec.outputs if p.name == "contributions")


# ------------------------------------------------------------- the page's starting points
#: Thesis ch. 3.3.1 (text) and table 3.2 ("Value" and "DoF" columns; x contributions in um).
THESIS_TABLE_32_X = [3.1, 1.7, 9.1, 1.5, 2.1]
THESIS_DOF = {"feature_location": math.inf, "focal_length": 2244, "rotation": 14, "translation": 14}
THESIS_DOF["radial_distortion"] = 2244
THESIS_SYSTEM = {
    "focal_length": [16.74, 16.66],  # mm, "found to be 16.74 mm and 16.66 mm when calibrated"
    "pixel_pitch": 1.85,  # um
    "image_size": [4024, 3036],  # px
    "k1": [-0.135, -0.13],
    "k2": [0.24, 0.17],
    "baseline": 199.35,  # mm
    "axes_angle": 38.64,  # deg
    "u_feature_location": 0.1,  # px
    "u_focal_length": [0.82, 0.84],  # px
    "u_rotation": [184, 152, 71],  # urad = 1.84, 1.52, 0.71 x 10^-4 rad
    "u_translation": [13, 8, 27],  # um
    "u_radial_distortion": [0.001, 0.0362],
    "dof_focal_length": 2244,
    "dof_rotation": 14,
    "dof_translation": 14,
    "dof_radial_distortion": 2244,
}


def test_the_default_budget_is_the_x_column_of_thesis_table_32():
    doc = yaml.safe_load((resources_dir() / "uncertainty" / "budget.yaml").read_text())
    rows = doc["contributions"]
    assert [r["u"] for r in rows] == THESIS_TABLE_32_X
    dofs = [math.inf if r["dof"] in ("inf", math.inf) else r["dof"] for r in rows]
    assert dofs == list(THESIS_DOF.values())
    assert round(gum.budget_from_dict(doc).combined, 1) == 10.1  # the thesis's u_c(x), eq. 3.23


def test_the_default_montecarlo_system_is_the_thesis_system_of_the_budget():
    """The form's defaults (the manifest) are the thesis's numbers, make the same document
    as the shipped stereo_system.yaml (the "load YAML" example), and carry the dof of the
    default budget's rows: one system on both tabs."""
    spec = default_host().provider("monte-carlo-uncertainty")
    defaults = {p.name: p.default for p in spec.parameters}
    for name, value in THESIS_SYSTEM.items():
        assert defaults[name] == value, name
    made = system_document(defaults | {"grid_size": [60, 40, 40], "grid_points": [10, 10, 10]})
    shipped = yaml.safe_load((resources_dir() / "uncertainty" / "stereo_system.yaml").read_text())
    for key in ("cameras", "stereo", "grid", "uncertainties", "dof"):
        assert made[key] == shipped[key], key
    assert system_document(defaults) == made  # the declared grid is the shipped one
    assert made["dof"] == {f: d for f, d in THESIS_DOF.items() if math.isfinite(d)}


@pytest.mark.slow
def test_what_the_page_says_about_the_difference_holds():
    """The Monte Carlo tab's words (texts.MC_SOURCE): on the default system feature location
    and focal length come out near table 3.2's x values, rotation 3.7-3.8 um against the
    table's 9.1, radial distortion well below 2.1; a larger grid (80 x 60 x 60 mm) raises the
    rotation to about 5.0, 4.7, 8.8 um (table: 9.1, 4.7, 9.1)."""
    from camcmm.gui.pages.uncertainty import texts

    host = default_host()
    pid = host.provider("monte-carlo-uncertainty").id
    out = host.run(pid, {}, {"iterations": 400, "seed": 1}).outputs
    u = out["contributions"]
    assert out["combined"][0] == pytest.approx(5.4, rel=0.04)  # ch. 3.4.1: 5.9 um; table 3.2: 10.1 um
    # Monte Carlo noise: 400 trials give each contribution to about 1/sqrt(2*400) = 3.5 %
    assert u["feature_location"][0] == pytest.approx(3.1, rel=0.15)  # table 3.2: 3.1 um
    assert u["focal_length"][0] == pytest.approx(1.7, rel=0.15)  # table 3.2: 1.7 um
    assert u["radial_distortion"][0] < 2.1 / 5  # table 3.2: 2.1 um
    only_rotation = {"u_feature_location": 0, "u_focal_length": [0, 0], "u_translation": [0, 0, 0]}
    only_rotation |= {"u_radial_distortion": [0, 0], "iterations": 4000, "seed": 1}  # 1.1 % noise
    rot = host.run(pid, {}, only_rotation).outputs["contributions"]["rotation"]
    assert rot[0] == pytest.approx(u["rotation"][0], rel=0.12)
    assert 3.7 * 0.97 < rot[0] < 3.8 * 1.03 and rot[0] < 9.1 / 2  # table 3.2: 9.1 um
    big = host.run(pid, {}, only_rotation | {"grid_size": [80, 60, 60]}).outputs["contributions"]["rotation"]
    assert big == pytest.approx([5.0, 4.7, 8.8], rel=0.03)  # table 3.2: 9.1, 4.7, 9.1 um
    for words in ("table 3.2", "9.1 µm", "3.7–3.8 µm", "60 × 40 × 40 mm", "5.0, 4.7, 8.8 µm", "about 5.4 µm"):
        assert words in texts.MC_SOURCE, words
    for words in ("table 3.2", "rotation 9.1", "same system"):
        assert words in texts.BUDGET_SOURCE, words


@pytest.mark.slow
def test_the_declared_system_is_a_cli_option_too(capfd):
    """One declaration, three faces: the fields of the page's form are `camcmm run` options."""
    from helpers.cli import main_json  # in-process (the CLI's main): only the output counts

    out = main_json(
        capfd,
        "run",
        "uncertainty.montecarlo",
        "--grid-points",
        "3,3,3",
        "--iterations",
        "20",
        "--baseline",
        "250",
        "--json",
    )
    system = out["outputs"]["system"]
    assert system["stereo"] == {"baseline": 250.0, "angle_deg": 38.64} and system["grid"]["n"] == [3, 3, 3]
    assert system["uncertainties"]["rotation"] == [1.84e-4, 1.52e-4, 0.71e-4]  # table 3.2, rad
