"""Chapter 4's acceptance test (thesis ch. 4.4-4.5): VDI/VDE 2634-3 as the thesis
modified it, the report's tables 4.1/4.2, and the simulated DSLR + turntable + laser
speckle photogrammetry system (``virtuallab.photogrammetry-system``) that acquires it.

* The table blocks fed the thesis's own printed values (tables 4.1 and 4.2) give the
  thesis's summary figures: mean radius 5.001 mm, 4 µm spread, U = 8 µm (size) and
  17 µm (form); length spreads 13/13/10 µm and U = 25/25/20 µm.
* The simulated system (slow): rendered turntable series with speckle, reconstructed by
  ``photogrammetry.reconstruct``, scaled by the calibrated spheres / lengths; the
  radius and lengths agree with the virtual lab's truth within what the spread of the
  repeats (different speckle patterns and noise seeds: our Monte Carlo) predicts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camcmm_plugins.vdi2634 import tables_ch4

# thesis table 4.1: fitted radius r (mm) and std of Δr (µm), positions A-E, 3 repeats
T41_R = [
    [4.993, 5.003, 5.001],
    [5.003, 5.007, 4.998],
    [5.006, 5.006, 5.001],
    [5.000, 5.000, 4.998],
    [5.005, 4.996, 5.007],
]
T41_S = [[7.8, 8.3, 7.6], [8.9, 8.5, 8.4], [7.6, 8.5, 8.3], [7.6, 7.1, 8.3], [9.4, 8.1, 10.7]]
# thesis table 4.2: L_m,1 x3, L_m,2 x3, L_m,3 x3 (mm), positions 1-7
T42 = [
    [5.937, 5.943, 5.946, 7.953, 7.961, 7.964, 9.964, 9.954, 9.949],
    [5.917, 5.941, 5.914, 7.960, 7.956, 7.974, 9.977, 9.959, 9.970],
    [5.928, 5.938, 5.924, 7.946, 7.971, 7.953, 9.976, 9.952, 9.975],
    [5.941, 5.953, 5.936, 7.920, 7.925, 7.957, 9.982, 9.968, 9.962],
    [5.952, 5.942, 5.945, 7.952, 7.957, 7.955, 9.952, 9.957, 9.956],
    [5.947, 5.950, 5.943, 7.962, 7.959, 7.956, 9.950, 9.949, 9.957],
    [5.970, 5.943, 5.934, 7.956, 7.956, 7.946, 9.960, 9.957, 9.971],
]
L_CAL = [5.942, 7.956, 9.957]
# the tungsten-carbide balls: radius uncertainty 0.2 µm (ch. 4.3) -> diameter u 0.4 µm
ARTEFACTS = {
    "sphere": {"certificates": {"diameter": {"value": 10.0, "uncertainty": 0.0008, "k": 2.0}}},
    "ball_plate": {
        "certificates": {
            "sphere_diameter": {"value": 5.0, "uncertainty": 0.0008, "k": 2.0},
            **{f"length_{i + 1}": {"value": v, "uncertainty": 0.0005, "k": 2.0} for i, v in enumerate(L_CAL)},
        }
    },
}


def _thesis_result() -> dict:
    sphere = [
        {"position": f"sphere-{i + 1:02d}", "repeat": r + 1, "radius": T41_R[i][r], "form": {"std": T41_S[i][r] / 1e3}}
        for i in range(5)
        for r in range(3)
    ]
    plate = [
        {"position": f"ball-plate-{i + 1:02d}", "repeat": r + 1, "lengths": [T42[i][3 * j + r] for j in range(3)]}
        for i in range(7)
        for r in range(3)
    ]
    return {
        "standard": "vdi2634-3",
        "scaling": {"sphere": "radii", "ball_plate": "lengths"},
        "artefacts": ARTEFACTS,
        "measurements": {"sphere": sphere, "ball_plate": plate},
    }


def test_table_4_1_of_the_thesis_values_gives_its_8_and_17_um():
    t = tables_ch4.table_4_1(_thesis_result())
    assert [r[0] for r in t["rows"]] == ["A", "B", "C", "D", "E", "Mean", "Standard deviation / µm"]
    assert t["rows"][0][1:] == [4.993, 5.003, 5.001, 7.8, 8.3, 7.6]  # the printed layout, row A
    s = t["summary"]
    assert round(s["mean_radius"], 3) in (5.001, 5.002)  # thesis: 5.001 (mean of printed radii 5.0016)
    assert round(s["std_radius"] * 1e3) == 4  # thesis: 4 µm
    assert round(s["mean_form_std"] * 1e3, 1) == 8.3  # thesis: 8.3 µm
    assert round(s["U_size"] * 1e3) == 8  # thesis: 8 µm
    assert round(s["U_form"] * 1e3) == 17  # thesis: 17 µm
    assert s["u_cal"] == pytest.approx(0.0002)  # the 5 mm spheres' radius uncertainty (ch. 4.3)


def test_table_4_2_of_the_thesis_values_gives_its_spreads_and_25_25_20_um():
    t = tables_ch4.table_4_2(_thesis_result())
    assert [r[0] for r in t["rows"][:7]] == [str(i) for i in range(1, 8)]
    assert t["rows"][1][1:] == T42[1]
    per = t["lengths"]
    # thesis "Uncertainty / µm" row: 13, 13, 10 (the spread of the 21 values) and U 25, 25, 20 µm
    assert [round(p["std"] * 1e3) for p in per] == [13, 13, 10]
    assert [round(p["U"] * 1e3) for p in per] == [25, 25, 20]
    # means: 7.954 as printed; the thesis's 5.939 and 10.037 do not follow from its own
    # printed values (5.9402, 9.9618), so those are checked against numpy on the values
    arr = np.array(T42)
    for j in range(3):
        assert per[j]["mean"] == pytest.approx(arr[:, 3 * j : 3 * j + 3].mean(), abs=1e-12)
        assert per[j]["deviation"] == pytest.approx(arr[:, 3 * j : 3 * j + 3].mean() - L_CAL[j], abs=1e-12)
    assert round(per[1]["mean"], 3) == 7.954
    rows = {r[0]: r for r in t["rows"]}
    assert rows["Uncertainty U (k=2) / µm"][1] == pytest.approx(per[0]["U"] * 1e3, abs=0.05)
    assert math.isclose(rows["Standard deviation / µm"][7], per[2]["std"] * 1e3, abs_tol=0.05)


@pytest.mark.slow
def test_the_tables_are_in_the_part3_report(tmp_path):
    from camcmm.api import Report
    from camcmm_plugins.vdi2634.tables_ch4 import add_sections

    r = Report("chapter 4")
    add_sections(r, _thesis_result())
    paths = r.write(tmp_path)
    html = open(paths["html"], encoding="utf-8").read()
    assert "Table 4.1: sphere form and sizing errors" in html and "Table 4.2: sphere spacing errors" in html
    assert "thesis: 17 µm" in html


# -- the simulated photogrammetry system against the virtual lab's truth ----------------------------
#: What the slow tests run: 12 views through 180° of 500 x 333 px (the D3300 frame down-scaled
#: 12 x), speckle on, the DSLR calibration held fixed; camera position A and plate orientation 1,
#: three repeats each (new speckle pattern and noise: the Monte Carlo of the rendered noise).
SYSTEM = {"n_images": 12, "downscale": 12.0, "seed": 4}
PLAN = {
    "standard": "vdi2634-3",
    "system": {"name": "virtual DSLR", "measuring_volume": [30, 30, 30]},
    "mpe": {"PF": 0.3, "PS": 0.15, "SD": 0.15},
    "artefacts": {
        "sphere": {"diameter": 10.0, "uncertainty": 0.0008, "k": 2},
        "ball_plate": {
            "sphere_diameter": 5.0,
            "sphere_diameter_uncertainty": 0.0008,
            "lengths": L_CAL,
            "uncertainty": 0.0005,
            "k": 2,
        },
    },
    "outliers": {"sphere": "percent:5", "ball_plate": "percent:5"},
    "scaling": {"sphere": "radii", "ball_plate": "lengths"},
}
N_REPEATS = 3
#: One pixel of the down-scaled image on the object (mm): 3.9 µm x 12 at magnification 1:3. A
#: spread above it would be a broken chain, not a measurement (seen: 10-70 µm).
PIXEL_ON_OBJECT = 0.0039 * 12 * 3
T_975 = {2: 12.71, 3: 4.303, 4: 3.182}  # Student's t, two-sided 95 %, by the number of values


def _usable(host) -> bool:
    try:
        host.algorithm("photogrammetry.reconstruct")
        import camcmm_plugins.photogrammetry.plugin  # noqa: F401
    except Exception:
        return False
    return True


_ACQUIRED: dict = {}


def _acquire(test: str) -> list:
    """The evaluations (as the wizard's import makes them) of three repeats of the test's
    first position, measured by the simulated system; computed once per test."""
    from camcmm.api import RunContext
    from camcmm.host import default_host
    from camcmm_plugins.vdi2634 import plan as plans

    if test in _ACQUIRED:
        return _ACQUIRED[test]
    host = default_host()
    if "virtuallab.photogrammetry-system" not in host.plugins or not _usable(host):
        pytest.skip("needs photogrammetry.reconstruct (pycolmap)")
    std = host.load("vdi2634-3")
    plan = plans.load(PLAN)
    position = next(r["positions"][0] for r in std.requirements() if r["test"] == test)
    evs = []
    for r in range(1, N_REPEATS + 1):
        placement = {"test": test, "position": position, "repeat": r, "artefacts": PLAN["artefacts"]}
        res = host.run("virtuallab.photogrammetry-system", {"placement": placement}, SYSTEM)
        o = res.outputs
        assert o["n_registered"] == SYSTEM["n_images"], res.warnings
        assert o["scale"]["u"] > 0 and o["cloud"].n_points > 1000
        ctx = RunContext(host, "vdi2634-3")
        evs.append(std.evaluate_measurement(ctx, test, o["cloud"], plan, file=f"{test}-{r}", repeat=r))
    _ACQUIRED[test] = evs
    return evs


def _within_repeats(values: np.ndarray, truth: float) -> tuple[float, float, float]:
    """(mean error, spread s, the 95 % bound t s / sqrt(n) the repeats predict for the mean)."""
    n = len(values)
    s = float(np.std(values, ddof=1))
    return float(values.mean() - truth), s, T_975[n] * s / math.sqrt(n)


@pytest.mark.slow
def test_sphere_radius_within_what_the_repeats_predict():
    """Thesis table 4.1's measurement: the 10 mm sphere scaled by the two 5 mm spheres."""
    evs = _acquire("sphere")
    radii = np.array([e["radius"] for e in evs])
    err, s, bound = _within_repeats(radii, 5.0)
    print(f"radius: error {err * 1e3:+.1f} µm, spread {s * 1e3:.1f} µm, bound {bound * 1e3:.1f} µm")
    assert 0 < s < PIXEL_ON_OBJECT, radii
    assert abs(err) <= bound, f"radius error {err * 1e3:+.1f} µm; spread {s * 1e3:.1f} µm; bound {bound * 1e3:.1f} µm"
    for e in evs:
        assert e["n_removed"] == pytest.approx(0.05 * e["n_points"], abs=2)  # ISO 10360-8's 5 %


@pytest.mark.slow
def test_ball_plate_lengths_within_what_the_repeats_predict():
    """Thesis table 4.2's measurement: L_m,i by eqs. 4.10-4.12 against the calibrated lengths."""
    lengths = np.array([e["lengths"] for e in _acquire("ball_plate")])
    for i in range(3):
        err, s, bound = _within_repeats(lengths[:, i], L_CAL[i])
        print(f"L{i + 1}: error {err * 1e3:+.1f} µm, spread {s * 1e3:.1f} µm, bound {bound * 1e3:.1f} µm")
        assert 0 < s < PIXEL_ON_OBJECT, lengths[:, i]
        assert abs(err) <= bound, f"L{i + 1}: error {err * 1e3:+.1f} µm; spread {s * 1e3:.1f} µm"
