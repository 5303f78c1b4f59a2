"""Material-ratio (Abbott-Firestone) curve and the ISO 13565-2 / ISO 25178-2 parameters,
on surfaces with known answers.

- A hand-worked 10-point profile (the construction done on paper, below).
- A piecewise-linear material-ratio curve whose parameters follow from geometry.
- Gaussian heights: c(mr) = σ Φ⁻¹(1 - mr), the flattest 40 % secant is centred at 50 %,
  Sk = 2 σ Φ⁻¹(0.7) / 0.4 = 2.6220 σ; C1 = Sk / 2 = 1.3110 σ; Smr1 = 1 - Φ(1.3110) =
  9.4929 %; the peak area A1 = σ (φ(a) - a (1 - Φ(a))) with a = C1 / σ, Spk = 2 A1 / Smr1
  = 0.93698 σ. With the heights at the Gaussian quantiles of N = 10⁶ equal shares we get
  Sk = 2.622003 σ (exact to 1e-6); with 10⁶ random heights (seed 11) Sk = 2.6191 σ,
  within the 0.01 σ tolerance set from the sampling error of two quantiles (~0.004 σ).
- Uniform heights over a range R: the curve is a straight line, every 40 % secant lies on
  it, and extended to 0 and 100 % it spans the whole range: Sk = R × 1, Smr1 = 0 %,
  Smr2 = 100 %, Spk = Svk = 0.
- surfalize's synthetic fixture, where two surfalize versions disagree (see
  tests/data/surfalize/README.md): our values must lie inside the band the two versions
  span, widened by half their difference on each side.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

from camcmm.api import InputError
from camcmm.host import PluginHost
from camcmm_plugins.inspection import material_ratio as mr
from camcmm_plugins.inspection.stats import deviation_stats, histogram

DATA = Path(__file__).parents[1] / "data" / "surfalize"


def test_hand_worked_profile():
    """Heights 0.2, 3.0, -0.6, 0.6, -3.0, 1.0, -0.2, -1.0, 1.4, -1.4 (10 points).

    Sorted: 3.0, 1.4, 1.0, ..., -1.4, -3.0 at material ratios 5, 15, ..., 95 %; the curve
    is flat at 3.0 on [0, 5 %] and at -3.0 on [95, 100 %].
    Secants over 40 %: from 0 %: (3.0 - 0.4) / 40 = 0.065 per %; from 10 %: c(10 %) = 2.2,
    (2.2 - 0) / 40 = 0.055; every start in [15, 45 %] lies on the straight core from
    (15, 1.4) to (85, -1.4): 0.04 per %, the least; the first, 15 %, is kept.
    Equivalent line c = 1.4 - 0.04 (mr - 15): C1 = c(0) = 2.0, C2 = c(100) = -2.0, Sk = 4.0.
    Smr1: the curve falls from 3.0 at 5 % to 1.4 at 15 % (0.16 per %), 2.0 at 11.25 %.
    Smr2: symmetric, 88.75 %.
    A1 = (3.0 - 2.0) × 5 % + ½ × 6.25 % × 1.0 = 8.125 (height × %); Spk = 2 × 8.125 / 11.25
    = 13/9 = 1.4444; Svk the same by symmetry.
    Vmp = ∫_0^10% (c - c(10 %)) = 0.8 × 0.05 + ½ (0.8 + 0) × 0.05 = 0.06.
    """
    p = mr.parameters([0.2, 3.0, -0.6, 0.6, -3.0, 1.0, -0.2, -1.0, 1.4, -1.4])
    assert p["secant_start"] == pytest.approx(15.0)
    assert p["C1"] == pytest.approx(2.0, abs=1e-12)
    assert p["C2"] == pytest.approx(-2.0, abs=1e-12)
    assert p["Sk"] == pytest.approx(4.0, abs=1e-12)
    assert p["Smr1"] == pytest.approx(11.25, abs=1e-10)
    assert p["Smr2"] == pytest.approx(88.75, abs=1e-10)
    assert p["Spk"] == pytest.approx(13 / 9, abs=1e-12)
    assert p["Svk"] == pytest.approx(13 / 9, abs=1e-12)
    assert p["Vmp"] == pytest.approx(0.06, abs=1e-12)


def test_piecewise_linear_curve():
    """Heights sampled from c(mr) = 3 - 0.2 mr (0-10 %), 1 - 0.025 (mr - 10) (10-90 %),
    -1 - 0.3 (mr - 90) (90-100 %): the core line is the middle segment, C1 = 1.25,
    C2 = -1.25, Sk = 2.5; Smr1 = (3 - 1.25) / 0.2 = 8.75 %, Smr2 = 90 + 0.25 / 0.3 =
    90.833 %; peak and valley regions are triangles: Spk = 3 - 1.25 = 1.75,
    Svk = -1.25 - (-4) = 2.75."""

    def c(m):
        return np.where(m < 10, 3 - 0.2 * m, np.where(m < 90, 1 - 0.025 * (m - 10), -1 - 0.3 * (m - 90)))

    n = 100_000
    h = c(100 * (np.arange(n) + 0.5) / n)
    p = mr.parameters(np.random.default_rng(0).permutation(h))
    assert p["Sk"] == pytest.approx(2.5, rel=1e-6)
    assert p["Smr1"] == pytest.approx(8.75, abs=1e-4)
    assert p["Smr2"] == pytest.approx(90 + 0.25 / 0.3, abs=1e-4)
    assert p["Spk"] == pytest.approx(1.75, rel=1e-4)
    assert p["Svk"] == pytest.approx(2.75, rel=1e-4)


def _gauss_expected(sigma=1.0):
    a = 2.5 * norm.ppf(0.7)
    smr1 = norm.sf(a)
    spk = 2 * sigma * (norm.pdf(a) - a * norm.sf(a)) / smr1
    return {"Sk": 5 * norm.ppf(0.7) * sigma, "Smr1": 100 * smr1, "Smr2": 100 * (1 - smr1), "Spk": spk, "Svk": spk}


def test_gaussian_quantiles_exact():
    sigma = 0.013
    n = 1_000_000
    h = sigma * norm.ppf((np.arange(n) + 0.5) / n)
    p = mr.parameters(h)
    e = _gauss_expected(sigma)
    assert e["Sk"] / sigma == pytest.approx(2.62200, abs=1e-5)
    for k in ("Sk", "Spk", "Svk"):
        assert p[k] == pytest.approx(e[k], rel=1e-5), k
    for k in ("Smr1", "Smr2"):
        assert p[k] == pytest.approx(e[k], abs=1e-4), k


def test_gaussian_random_sample():
    """10⁶ random heights: Sk/σ = 2.6220 ± 0.01 (sampling error of the two quantiles at
    30 % and 70 %: sqrt(0.21 / N) / φ(0.524) ≈ 0.0013 σ each, ×2.5 for the extension)."""
    sigma = 2.0
    h = np.random.default_rng(11).normal(0, sigma, 1_000_000)
    p = mr.parameters(h)
    e = _gauss_expected(sigma)
    assert p["Sk"] / sigma == pytest.approx(e["Sk"] / sigma, abs=0.01)
    assert p["Spk"] / sigma == pytest.approx(e["Spk"] / sigma, abs=0.01)
    assert p["Svk"] / sigma == pytest.approx(e["Svk"] / sigma, abs=0.01)
    assert p["Smr1"] == pytest.approx(e["Smr1"], abs=0.15)
    assert p["Smr2"] == pytest.approx(e["Smr2"], abs=0.15)


def test_uniform_heights():
    lo, hi = -0.7, 2.3
    n = 50_000
    h = lo + (hi - lo) * (np.arange(n) + 0.5) / n
    p = mr.parameters(np.random.default_rng(1).permutation(h))
    # the construction's line is the curve itself, from (0, hi) to (100 %, lo) ...
    assert p["Sk"] == pytest.approx(hi - lo, abs=1e-9)
    assert p["Smr1"] == pytest.approx(0.0, abs=1e-6)
    assert p["Smr2"] == pytest.approx(100.0, abs=1e-6)
    assert p["Spk"] == pytest.approx(0.0, abs=1e-9)
    assert p["Svk"] == pytest.approx(0.0, abs=1e-9)
    # ... and random uniform heights come close
    u = np.random.default_rng(2).uniform(lo, hi, 1_000_000)
    q = mr.parameters(u)
    assert q["Sk"] == pytest.approx(hi - lo, rel=5e-3)
    assert q["Spk"] < 3e-3 * (hi - lo) and q["Svk"] < 3e-3 * (hi - lo)


def _fixture_heights() -> np.ndarray:
    """The surfalize fixture surface, regenerated from its published recipe."""
    rs = np.random.RandomState(0)
    step = 0.1
    period, period_lipss = 20 / step, 1 / step
    x, y = np.meshgrid(np.arange(1000), np.arange(700))
    z = np.sin(x / period * 2 * np.pi) + 10
    z += (
        0.5
        * (np.sin((x - period / 2) / period * 2 * np.pi) + 1)
        * 0.3
        * np.sin((np.sin(y / 10) + x) / period_lipss * 2 * np.pi)
    )
    z += rs.normal(size=z.shape) / 5
    return z


def test_surfalize_fixture_regenerates_exactly(shared_data):
    f = shared_data / "surfalize_synthetic_fixture" / "fixture_heightmap_um.npy"
    assert np.array_equal(np.load(f), _fixture_heights())


def test_surfalize_fixture_within_their_disagreement():
    v = json.loads((DATA / "values.json").read_text())
    a, b = v["test_file_014912c1"], v["pypi_0_19_2"]
    z = _fixture_heights()
    # the height parameters pin the regeneration down (both versions agree on them)
    assert np.mean(np.abs(z - z.mean())) == pytest.approx(a["Sa"], abs=2e-6)
    assert np.sqrt(np.mean((z - z.mean()) ** 2)) == pytest.approx(a["Sq"], abs=2e-6)
    p = mr.parameters(z)
    for k in ("Sk", "Spk", "Svk", "Smr1", "Smr2"):
        lo, hi = sorted((a[k], b[k]))
        half = 0.5 * (hi - lo)
        assert lo - half <= p[k] <= hi + half, f"{k} = {p[k]:.6g} outside [{lo - half:.6g}, {hi + half:.6g}]"
    # observed: the construction here reproduces the values of surfalize's test file
    for k in ("Sk", "Spk", "Svk", "Smr1", "Smr2"):
        assert p[k] == pytest.approx(a[k], rel=5e-3), k
    # the volume parameters (sign aside) agree between the versions; so do ours, to 1 %
    for k in ("Vmp", "Vmc", "Vvc", "Vvv"):
        assert p[k] == pytest.approx(abs(b[k]), rel=1e-2), k
        assert p[k] == pytest.approx(abs(a[k]), rel=1e-2), k


def test_curve_is_the_hazen_quantile_and_smr_inverts_smc():
    h = np.random.default_rng(3).gamma(2.0, 1.0, 10001)
    c = mr.material_ratio_curve(h)
    m = np.linspace(0.001, 0.999, 97)
    assert np.allclose(c.smc(m), np.percentile(h, 100 * (1 - m), method="hazen"), rtol=0, atol=1e-12)
    assert np.allclose(c.smr(c.smc(m)), m, atol=1e-12)
    s = deviation_stats(h)
    p = mr.parameters(h)
    assert p["Smc"]["2.5"] == pytest.approx(s["p97_5"], abs=1e-12)
    assert p["Smc"]["97.5"] == pytest.approx(s["p2_5"], abs=1e-12)
    assert c.smr(h.max() + 1) == 0.0 and c.smr(h.min() - 1) == 1.0


def test_weights():
    h = np.random.default_rng(4).normal(size=5000)
    base = mr.parameters(h)
    same = mr.parameters(h, weights=np.full(h.size, 7.0))
    for k in ("Sk", "Spk", "Svk", "Smr1", "Smr2"):
        assert same[k] == pytest.approx(base[k], rel=1e-12)
    # zero weights and NaN heights leave those entries out
    hh = np.concatenate([h, [50.0, np.nan]])
    ww = np.concatenate([np.ones(h.size), [0.0, 1.0]])
    out = mr.parameters(hh, weights=ww)
    assert out["Sk"] == pytest.approx(base["Sk"], rel=1e-12)
    # weighting the upper half double shifts the curve up
    w = np.where(h > 0, 2.0, 1.0)
    assert mr.material_ratio_curve(h, w).smc(0.5) > mr.material_ratio_curve(h).smc(0.5)


def test_levelling_removes_a_tilt():
    rng = np.random.default_rng(5)
    z = rng.normal(0, 1e-3, (60, 80))
    yy, xx = np.indices(z.shape)
    tilted = z + 0.01 * xx - 0.02 * yy + 3.0
    flat = mr.level(tilted)
    assert np.allclose(flat, mr.level(z), atol=1e-12)
    assert mr.parameters(flat)["Sk"] == pytest.approx(mr.parameters(mr.level(z))["Sk"], rel=1e-9)


def test_errors():
    with pytest.raises(InputError, match="at least 2"):
        mr.parameters([1.0, np.nan])
    with pytest.raises(InputError, match="weights"):
        mr.parameters([1.0, 2.0, 3.0], weights=[1.0, -1.0, 1.0])
    with pytest.raises(InputError, match="no finite"):
        deviation_stats([np.nan])


def test_stats_and_histogram():
    d = np.random.default_rng(6).normal(0.01, 0.02, 20000)
    s = deviation_stats(np.append(d, np.nan), tolerance=0.03)
    assert s["n"] == 20000 and s["n_invalid"] == 1
    assert s["mean"] == pytest.approx(d.mean()) and s["std"] == pytest.approx(d.std(ddof=1))
    assert s["rms"] == pytest.approx(np.sqrt(np.mean(d**2)))
    assert s["p2_5"] == pytest.approx(np.percentile(d, 2.5, method="hazen"))
    assert s["within_tolerance"] == pytest.approx(np.mean(np.abs(d) <= 0.03))
    hist = histogram(d, limit=0.05)
    assert hist["counts"].sum() == d.size
    assert hist["edges"][0] == pytest.approx(-hist["edges"][-1])


def test_plugin_on_a_height_map(tmp_path):
    """inspect.material-ratio through the host: a µm height map gives mm results."""
    f = tmp_path / "map.npy"
    z = _fixture_heights()[:200, :300]
    np.save(f, z)
    res = PluginHost().run(
        "inspect.material-ratio", {"source": str(f)}, {"unit": "um", "smc_at": [2.5, 97.5], "smr_at": [0.0105]}
    )
    ref = mr.parameters(z)
    assert res.outputs["Smc"]["2.5"] == pytest.approx(np.percentile(z, 97.5, method="hazen") * 1e-3, rel=1e-12)
    assert res.outputs["Smr"]["0.0105"] == pytest.approx(100 * np.mean(z > 10.5), abs=1e-3)
    assert res.outputs["Sk"] == pytest.approx(ref["Sk"] * 1e-3, rel=1e-12)
    assert res.outputs["Smr1"] == pytest.approx(ref["Smr1"], rel=1e-12)
    assert len(res.outputs["material_ratio"]["curve"]["height"]) == 1001
