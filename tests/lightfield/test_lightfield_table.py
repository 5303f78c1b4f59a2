"""Light-field scale numerics (thesis ch. 6.3): table 6.3 recomputed from its own numbers,
the set statistics, the first-order focal-length fit and its prediction uncertainty."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.lightfield import fit, study

# Table 6.3 as printed: gradient / mm λ⁻¹, rows Pillars, Pyramid, Recess, Sphere, columns Set 1..6
TABLE_6_3 = {
    "Pillars": [3.8357, 3.6521, 5.0192, 7.7975, 5.9465, 5.1287],
    "Pyramid": [3.9422, 3.5772, 5.0437, 7.7361, 5.9335, 5.2545],
    "Recess": [3.9641, 3.6645, 5.0728, 7.7887, 6.0401, 5.1974],
    "Sphere": [3.9327, 3.6616, 5.0378, 7.7872, 5.9790, 5.2184],
}
PRINTED_STD_UM = [57, 41, 22, 28, 48, 53]


def test_table_6_3_std_row_is_the_sample_std_of_each_sets_four_gradients():
    runs = [
        {"set": f"Set {j + 1}", "artefact": a, "gradient_mm_per_lambda": g}
        for a, row in TABLE_6_3.items()
        for j, g in enumerate(row)
    ]
    t = study.table(runs)
    assert t["artefacts"] == list(TABLE_6_3) and t["sets"] == [f"Set {j}" for j in range(1, 7)]
    assert t["std_ddof"] == 1
    # the printed row is rounded to whole µm λ⁻¹: the sample std (n - 1) rounds to it, every set
    assert [round(s * 1000) for s in t["std"]] == PRINTED_STD_UM
    # ... and the population std (n) does not: it is 13 % smaller (sqrt(3/4)) and misses every set
    pop = np.std(np.array(list(TABLE_6_3.values())), axis=0, ddof=0) * 1000
    assert all(round(p) != s for p, s in zip(pop, PRINTED_STD_UM))
    assert t["n"] == [4] * 6
    assert t["mean"][3] == pytest.approx(np.mean([7.7975, 7.7361, 7.7887, 7.7872]), abs=1e-12)
    # "variations on the order of 1 % to 2 %" (ch. 6.3.3): std / mean of each set
    rel = np.array(t["std"]) / np.array(t["mean"])
    assert rel.max() < 0.02 and rel.min() > 0.003


def test_set_stats_missing_and_single():
    assert fit.set_stats([4.0])["std"] is None
    s = fit.set_stats([1.0, 2.0, np.nan, 3.0])
    assert s["n"] == 3 and s["mean"] == 2.0 and s["std"] == pytest.approx(1.0)


@pytest.mark.slow  # scipy.stats' first import takes seconds
def test_focal_fit_matches_the_textbook_line_and_its_prediction_band():
    rng = np.random.default_rng(1)
    f = np.array([30.0, 33.0, 36.0, 40.0, 44.0, 47.0, 50.0])
    g = -1.0 + 0.15 * f + rng.normal(scale=0.02, size=len(f))
    out = fit.focal_fit(f, g, predict_mm=60.0)
    from scipy.stats import linregress

    ref = linregress(f, g)
    assert out["slope"] == pytest.approx(ref.slope, rel=1e-12)
    assert out["intercept"] == pytest.approx(ref.intercept, rel=1e-12)
    assert np.sqrt(out["cov"][0][0]) == pytest.approx(ref.stderr, rel=1e-10)
    assert np.sqrt(out["cov"][1][1]) == pytest.approx(ref.intercept_stderr, rel=1e-10)
    # the line's standard uncertainty at x0: s sqrt(1/n + (x0 - mean)^2 / Sxx)
    n, s = len(f), out["residual_std"]
    u = s * np.sqrt(1 / n + (60.0 - f.mean()) ** 2 / ((f - f.mean()) ** 2).sum())
    p = out["predicted"]
    assert p["u"] == pytest.approx(u, rel=1e-10)
    assert p["u_new_set"] == pytest.approx(np.hypot(u, s), rel=1e-12)
    assert p["gradient_mm_per_lambda"] == pytest.approx(ref.intercept + 60 * ref.slope, rel=1e-12)


def test_focal_fit_exact_line_and_refusals():
    out = fit.focal_fit([30.0, 50.0], [3.5, 6.5], predict_mm=40.0)
    assert out["slope"] == pytest.approx(0.15) and out["cov"] is None
    assert out["predicted"]["gradient_mm_per_lambda"] == pytest.approx(5.0) and out["predicted"]["u"] is None
    with pytest.raises(InputError, match="same focal length"):
        fit.focal_fit([40.0, 40.0, 40.0], [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="two or more"):
        fit.focal_fit([40.0], [1.0])


def test_view_fit_band_and_robust_reject_what_they_should():
    rng = np.random.default_rng(3)
    lam = rng.uniform(-8, 12, size=(120, 100))
    depth = 300.0 + 4.0 * lam + rng.normal(scale=0.05, size=lam.shape)
    # the focal-plane band: values there squeezed towards 0 (the thesis's worst region)
    band = np.abs(lam) < 0.5
    lam_meas = np.where(band, 0.3 * lam, lam)
    # a few rear-surface pixels: 20 mm too far
    depth[:2, :] += 20.0
    plain = fit.fit_view(depth, lam_meas, band=0.0, robust=False)
    good = fit.fit_view(depth, lam_meas, band=0.5, robust=True)
    assert abs(plain["gradient_mm_per_lambda"] - 4.0) > 10 * good["u_gradient"]
    assert good["gradient_mm_per_lambda"] == pytest.approx(4.0, abs=4 * good["u_gradient"])
    assert good["n_rejected"] >= int((~band[:2]).sum()) and good["n_band"] == int(band.sum())
    assert good["r2"] > 0.9999
    with pytest.raises(InputError, match="fewer than"):
        fit.fit_view(np.full((5, 5), np.nan), lam_meas[:5, :5])


def test_study_of_table_6_3_through_the_plugin(tmp_path):
    """lightfield.study on table 6.3's own gradients (runs measured before): the table and its
    std row as printed; no focal lengths, so no fit (warned)."""
    import yaml

    from camcmm.api import default_host

    runs = [
        {"set": f"Set {j + 1}", "artefact": a, "gradient_mm_per_lambda": g}
        for a, row in TABLE_6_3.items()
        for j, g in enumerate(row)
    ]
    f = tmp_path / "t63.yaml"
    f.write_text(yaml.safe_dump({"name": "table 6.3", "runs": runs}))
    res = default_host().run("lightfield.study", {"study": str(f)}, {})
    t = res.outputs["table"]
    assert [round(s * 1000) for s in t["std"]] == PRINTED_STD_UM
    assert t["gradients"][1] == TABLE_6_3["Pyramid"]
    assert res.outputs["focal"] is None and any("focal" in w for w in res.warnings)
    f.write_text(yaml.safe_dump({"runs": [{"set": "Set 1", "artefact": "A", "cloud": "c.ply"}]}))
    with pytest.raises(
        InputError, match=r"t63\.yaml: runs\[0\]: no views, depth_maps; a run needs cloud, views and depth_maps"
    ):
        default_host().run("lightfield.study", {"study": str(f)}, {})


def test_study_focal_length_from_fx_and_pixel_pitch_and_truth(tmp_path, monkeypatch):
    """run_study with a stand-in for lightfield.gradient: a run without focal_length_mm gets
    fx × pitch; the truth differences; the prediction. (The study's files must exist: they
    are checked before any run starts; a study given as a dict starts from the working folder.)"""
    monkeypatch.chdir(tmp_path)
    for f in ("a", "b", "c", "v"):
        (tmp_path / f).write_text("")
    (tmp_path / "d").mkdir()
    grads = {"a": 3.5, "b": 5.0, "c": 6.5}
    fx = {"a": 30.0 / 0.0014, "b": 40.0 / 0.0014, "c": 50.0 / 0.0014}

    def fake(cloud, views, depth_maps, **params):
        k = cloud.split("/")[-1]
        return {
            "result": {"mean": grads[k], "std": 0.01, "n_views": 3, "views": [], "focal_length_px": fx[k]},
            "scatter": [],
        }

    doc = {
        "pixel_pitch_um": 1.4,
        "runs": [{"set": s, "artefact": "P", "cloud": s, "views": "v", "depth_maps": "d"} for s in "abc"],
        "truth": {"sets": [{"set": "b", "gradient_mm_per_lambda": 5.01}]},
    }
    out = study.run_study(doc, fake, predict_focal_mm=45.0)
    assert out["table"]["focal_length_mm"] == pytest.approx([30.0, 40.0, 50.0])
    assert out["focal"]["slope"] == pytest.approx(0.15) and out["focal"]["intercept"] == pytest.approx(-1.0)
    assert out["focal"]["predicted"]["gradient_mm_per_lambda"] == pytest.approx(5.75)
    assert out["truth"]["sets"] == [pytest.approx({"set": "b", "true": 5.01, "mean": 5.0, "difference": -0.01})]
