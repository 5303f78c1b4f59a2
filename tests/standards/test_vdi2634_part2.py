"""VDI/VDE 2634 part 2 on simulated measurement sets with known truth.

* a good system (no distortion, small noise) passes, P_S and SD are zero within noise,
  P_F is the expected range of the noise;
* a known scale error s makes SD = s L_r and P_S = s D_r, and both fail;
* the JSON contract; simple and guarded verdicts side by side; artefact rules.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from camcmm.api import InputError, RunContext
from camcmm.host import default_host

N_SPHERE, N_BAR, N_FLAT = 4000, 3000, 5000
SIGMA = 0.01


def make_set(directory, **kw):
    params = {
        "directory": str(directory),
        "standard": "vdi2634-2",
        "n_sphere": N_SPHERE,
        "n_ball_bar": N_BAR,
        "n_flat": N_FLAT,
        "noise": SIGMA,
        **kw,
    }
    return default_host().run("virtuallab.acceptance-set", {}, params).outputs


def verify(plan):
    return default_host().run("vdi2634-2", {"plan": plan}).outputs


# One xdist work unit: the tests share the simulated part 2 sets (good, scaled) (module fixtures),
# built once per run instead of once per worker (under --dist loadgroup an ungrouped test is
# scheduled alone).
pytestmark = pytest.mark.xdist_group("vdi2634-part2")


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    d = tmp_path_factory.mktemp("good")
    make_set(d, seed=11)
    return d, verify(d / "plan.yaml")


@pytest.fixture(scope="module")
def scaled(tmp_path_factory):
    d = tmp_path_factory.mktemp("scaled")
    make_set(d, seed=12, scale_error=0.008)
    return d, verify(d / "plan.yaml")


def expected_range(n: int, sigma: float, trials: int = 400, seed: int = 0) -> float:
    """Mean range of n normal samples after removing the floor(3n/1000) of largest |x|
    (what the 3-per-1000 rule does to pure noise), by Monte Carlo."""
    rng = np.random.default_rng(seed)
    m = (3 * n) // 1000
    x = rng.normal(0, sigma, (trials, n))
    keep = np.sort(np.abs(x), axis=1)[:, n - m - 1 : n - m]  # |x| threshold per trial
    x = np.where(np.abs(x) <= keep, x, np.nan)
    return float(np.mean(np.nanmax(x, axis=1) - np.nanmin(x, axis=1)))


@pytest.mark.slow
def test_good_system_passes_with_values_at_the_noise_level(good):
    _, res = good
    assert res["standard"] == "vdi2634-2"
    assert res["verdict"] == "pass" and res["verdict_guarded"] == "pass"
    p = res["parameters"]
    assert abs(p["PS"]["value"]) < 0.01  # u(D) of a partial sphere at 4000 points, sigma 10 um: ~2 um
    assert abs(p["SD"]["value"]) < 0.005
    assert all(len(p[k]["per_measurement"]) == n for k, n in (("PF", 10), ("PS", 10), ("SD", 7), ("F", 6)))


def test_probing_form_is_the_expected_range_of_the_noise(good):
    _, res = good
    want = expected_range(N_SPHERE, SIGMA)
    pf = [r["value"] for r in res["parameters"]["PF"]["per_measurement"]]
    assert np.mean(pf) == pytest.approx(want, rel=0.08)
    assert res["parameters"]["PF"]["value"] == max(pf)
    f = [r["value"] for r in res["parameters"]["F"]["per_measurement"]]
    assert np.mean(f) == pytest.approx(expected_range(N_FLAT, SIGMA), rel=0.08)


@pytest.mark.slow
def test_scale_error_shows_in_SD_and_PS_by_the_expected_amounts(scaled):
    _, res = scaled
    s, l_r, d_r = 0.008, 49.944, 20.001
    p = res["parameters"]
    for row in p["SD"]["per_measurement"]:
        assert row["value"] == pytest.approx(s * l_r, abs=0.005)
    for row in p["PS"]["per_measurement"]:
        assert row["value"] == pytest.approx(s * d_r, abs=0.01)
    assert p["SD"]["verdict"] == "fail" and p["PS"]["verdict"] == "fail"
    assert p["PF"]["verdict"] == "pass" and p["F"]["verdict"] == "pass"  # a scale error leaves form alone
    assert res["verdict"] == "fail" and res["verdict_guarded"] == "fail"


def test_json_contract(good):
    _, res = good
    for key in ("standard", "verdict", "parameters", "warnings"):
        assert key in res
    assert set(res["parameters"]) == {"PF", "PS", "SD", "F"}
    for key, p in res["parameters"].items():
        for k in ("value", "mpe", "verdict", "per_measurement", "verdict_guarded", "U"):
            assert k in p, (key, k)
        for row in p["per_measurement"]:
            assert {"file", "value"} <= set(row)
    mpe = {"PF": 0.186, "PS": 0.143, "SD": 0.096, "F": 0.243}
    assert {k: p["mpe"] for k, p in res["parameters"].items()} == mpe


def test_value_is_signed_largest_for_PS_SD_and_largest_for_PF_F(scaled):
    _, res = scaled
    for key in ("PS", "SD"):
        vals = [r["value"] for r in res["parameters"][key]["per_measurement"]]
        assert res["parameters"][key]["value"] == max(vals, key=abs)
    for key in ("PF", "F"):
        vals = [r["value"] for r in res["parameters"][key]["per_measurement"]]
        assert res["parameters"][key]["value"] == max(vals)


def test_guarded_acceptance_beside_the_simple_rule(good):
    """Same measurements, MPE moved into the guard band: simple pass, guarded inconclusive."""
    d, res = good
    std = default_host().load("vdi2634-2")
    plan = yaml.safe_load((d / "plan.yaml").read_text())
    plan["base_dir"] = str(d)
    sd = res["parameters"]["SD"]
    plan2 = copy.deepcopy(plan)
    plan2["mpe"]["SD"] = abs(sd["value"]) + 0.5 * sd["U"]
    res2 = std.summarize(RunContext(default_host(), "vdi2634-2"), plan2, res["measurements"])
    assert res2["parameters"]["SD"]["verdict"] == "pass"
    assert res2["parameters"]["SD"]["verdict_guarded"] == "inconclusive"
    assert res2["verdict"] == "pass" and res2["verdict_guarded"] == "inconclusive"
    plan2["mpe"]["SD"] = abs(sd["value"]) - 0.5 * sd["U"]
    res3 = std.summarize(None, plan2, res["measurements"])
    assert res3["parameters"]["SD"]["verdict"] == "fail"
    assert res3["parameters"]["SD"]["verdict_guarded"] == "inconclusive"


def test_test_uncertainty_comes_from_the_certificates(good):
    _, res = good
    p = res["parameters"]
    assert p["PS"]["U"] == pytest.approx(0.001)  # U(D_r), k = 2
    assert p["SD"]["U"] == pytest.approx(0.0008)  # U(L_r)
    assert p["F"]["U"] == pytest.approx(0.0026)  # certified flatness, no U given
    assert p["PF"]["U"] == 0.0  # sphere form not certified
    assert "not certified" in p["PF"]["uncertainty"]["basis"]


def test_artefact_rules_are_stated_but_the_evaluation_runs(good, tmp_path):
    d, res = good
    # the thesis's 49.944 mm ball bar is shorter than 0.3 x the 173.2 mm diagonal of 100 mm^3
    bad = [c for c in res["artefact_checks"] if not c["ok"]]
    assert [c["artefact"] for c in bad] == ["ball bar"]
    assert any("ball bar: length 49.94 mm is below 0.3 L0" in w for w in res["warnings"])
    assert res["parameters"]["SD"]["value"] is not None
    # a much larger volume: the sphere is too small, the flat too short
    plan = yaml.safe_load((d / "plan.yaml").read_text())
    plan["system"]["measuring_volume"] = [600, 600, 600]
    plan["base_dir"] = str(d)
    res2 = default_host().load("vdi2634-2").summarize(None, plan, res["measurements"])
    failed = {(c["artefact"], c["rule"].split()[0]) for c in res2["artefact_checks"] if not c["ok"]}
    assert ("sphere", "diameter") in failed and ("flat", "length") in failed
    assert res2["verdict"] == "pass"  # a broken artefact rule is no verdict


def test_plan_errors_name_the_key(good):
    d, _ = good
    std = default_host().load("vdi2634-2")
    plan = yaml.safe_load((d / "plan.yaml").read_text())
    cases = [
        (lambda p: p["mpe"].pop("PF"), "mpe.PF is missing"),
        (lambda p: p["system"].update(measuring_volume=[100, 100]), "system.measuring_volume"),
        (lambda p: p["artefacts"]["sphere"].update(diameter=-1), "artefacts.sphere.diameter must be > 0"),
        (lambda p: p.update(outliers="trim:5"), "outliers.sphere"),
        (lambda p: p.update(standard="vdi2634-3"), "standard is 'vdi2634-3'"),
        (lambda p: p["artefacts"].pop("flat"), "artefacts.flat is missing"),
        (lambda p: p["mpe"].update(XY=1), "mpe.XY is not a quality parameter"),
    ]
    for change, message in cases:
        p = copy.deepcopy(plan)
        change(p)
        with pytest.raises(InputError, match=message.replace(".", r"\.").replace("(", r"\(")):
            std(None, p)


def test_requirements_list_the_positions(good):
    std = default_host().load("vdi2634-2")
    reqs = {r["test"]: r for r in std.requirements()}
    assert {t: r["min_count"] for t, r in reqs.items()} == {"sphere": 10, "ball_bar": 7, "flat": 6}
    for r in reqs.values():
        ids = [p["id"] for p in r["positions"]]
        assert len(ids) == r["min_count"] == len(set(ids))
        assert all(p["label"] and p["hint"] and len(p["where"]) == 3 for p in r["positions"])
    d, _ = good
    reqs = {r["test"]: r for r in std.requirements(d / "plan.yaml")}
    assert reqs["sphere"]["planned"] == 10
    assert reqs["sphere"]["artefact"]["certificates"]["diameter"]["value"] == 20.001
