"""Scale factor against a laser interferometer (thesis 3.2.3, eq. 3.22) on generated data
with a known slope and noise; the regression's standard error against many seeded
repeats; applying the factor to a calibration."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import CameraModel, InputError, ParameterError
from camcmm_plugins.calibration.scale import apply_scale, read_interferometer_csv, scale_factor

SLOPE, NOISE = 1.000150, 0.004  # camera reads 150 ppm long; 4 um noise per position


def _run(rng, n=19, travel=90.0, three_d=False):
    x = np.linspace(0, travel, n) + 12.5  # interferometer readings, mm (offset start)
    d = SLOPE * (x - x[0]) + rng.normal(0, NOISE, n)
    if not three_d:
        return x, 100.0 + d
    u = np.array([0.6, -0.48, 0.64])  # motion direction in the camera frame
    return x, np.array([10.0, 20.0, 400.0]) + np.outer(d, u) + rng.normal(0, NOISE / 10, (n, 3))


def test_single_run_and_standard_error_against_repeats():
    rng = np.random.default_rng(0)
    fits = [scale_factor(*_run(rng)) for _ in range(400)]
    slopes = np.array([f["slope"] for f in fits])
    se = np.mean([f["runs"][0]["stderr"] for f in fits])
    assert slopes.std(ddof=1) == pytest.approx(se, rel=0.1)  # the regression's SE is the real spread
    assert abs(slopes.mean() - SLOPE) < 4 * slopes.std(ddof=1) / np.sqrt(len(slopes))
    f = fits[0]
    assert f["scale_factor"] == pytest.approx(1 / f["slope"])
    assert f["runs"][0]["rms_residual"] == pytest.approx(NOISE, rel=0.5)
    assert f["u_p"] == pytest.approx(f["runs"][0]["stderr"] * 90.0)
    assert f["u_cal"] == pytest.approx(5e-7 * 90.0 / np.sqrt(3))
    assert f["u_length"] == pytest.approx(np.hypot(f["u_cal"], f["u_p"]))
    np.testing.assert_allclose(f["residuals"]["1"].sum(), 0, atol=1e-12)  # LS with intercept


def test_repeated_runs_from_csv_with_3d_points(tmp_path):
    rng = np.random.default_rng(1)
    rows = ["run;interferometer;x;y;z"]
    for r in range(20):
        x, p = _run(rng, three_d=True)
        rows += [f"{r + 1};{a:.6f};{b[0]:.6f};{b[1]:.6f};{b[2]:.6f}" for a, b in zip(x, p)]
    (tmp_path / "scale.csv").write_text("\n".join(rows) + "\n")
    d = read_interferometer_csv(tmp_path / "scale.csv")
    assert d["camera"].shape == (380, 3)
    f = scale_factor(d["interferometer"], d["camera"], d["run"])
    assert f["n_runs"] == 20 and len(f["residual_std_per_position"]) == 19
    # each run's slope has SE ~ NOISE / (sd(x) sqrt(n)); 20 runs: the repeatability matches it
    se = np.mean([r["stderr"] for r in f["runs"]])
    assert f["repeatability"] == pytest.approx(se, rel=0.4)
    assert abs(f["slope"] - SLOPE) < 4 * f["u_slope"]
    assert f["u_p"] == pytest.approx(f["repeatability"] * 90.0)
    assert np.median(f["residual_std_per_position"]) == pytest.approx(NOISE, rel=0.3)


def test_one_dimensional_csv_and_bad_files(tmp_path):
    rng = np.random.default_rng(2)
    x, c = _run(rng)
    (tmp_path / "a.csv").write_text("interferometer,camera\n" + "".join(f"{a},{b}\n" for a, b in zip(x, c)))
    d = read_interferometer_csv(tmp_path / "a.csv")
    f = scale_factor(d["interferometer"], d["camera"], d["run"])
    assert f["n_runs"] == 1 and f["repeatability"] != f["repeatability"]  # NaN: one run
    (tmp_path / "b.csv").write_text("laser,foo\n1,2\n2,3\n")
    with pytest.raises(InputError, match="b.csv: needs a 'camera' column"):
        read_interferometer_csv(tmp_path / "b.csv")
    (tmp_path / "c.csv").write_text("interferometer,camera\n1,2\n2,x\n3,4\n")
    with pytest.raises(InputError, match="c.csv: row 3"):
        read_interferometer_csv(tmp_path / "c.csv")
    with pytest.raises(InputError, match="at least 3"):
        scale_factor([0, 1], [0, 1])
    with pytest.raises(InputError, match="^d.csv: run '1' has 2 position"):  # the data's file named
        scale_factor([0, 1], [0, 1], source="d.csv")
    for acc in (-1e-7, float("nan"), 1.0):  # a negative accuracy gave u_cal < 0 without a word
        with pytest.raises(ParameterError, match="accuracy"):
            scale_factor(x, c, accuracy=acc)
    for length in (0.0, -5.0, float("nan")):
        with pytest.raises(ParameterError, match="length"):
            scale_factor(x, c, length=length)
    with pytest.raises(InputError, match="do not change"):
        scale_factor([1, 1, 1], [0, 1, 2])


def test_apply_scale_to_a_stereo_calibration():
    r = cv2.Rodrigues(np.array([0.0, 0.2, 0.0]))[0]
    t = np.array([-100.0, 1.0, 5.0])
    k = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    size = (640, 480)
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(k, np.zeros(5), k, np.zeros(5), size, r, t.reshape(3, 1))
    tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
    cal = {
        "cameras": [CameraModel(k, image_size=size), CameraModel(k, np.zeros(5), r, t, size)],
        "R": r,
        "T": t,
        "E": tx @ r,
        "baseline": float(np.linalg.norm(t)),
        "rectification": {"R1": R1, "R2": R2, "P1": P1, "P2": P2, "Q": Q},
        "parameter_names": ["a.fx", "b.rx", "b.tx"],
        "parameter_covariance": np.eye(3),
    }
    s = 1.0002
    out = apply_scale(cal, s)
    np.testing.assert_allclose(out["cameras"][1].translation, s * t)
    np.testing.assert_allclose(out["T"], s * t)
    assert out["baseline"] == pytest.approx(s * cal["baseline"]) and out["scale_factor"] == s
    # the scaled rectification is what stereoRectify gives for the scaled T
    _, _, P1s, P2s, Qs, _, _ = cv2.stereoRectify(k, np.zeros(5), k, np.zeros(5), size, r, (s * t).reshape(3, 1))
    np.testing.assert_allclose(out["rectification"]["P2"], P2s, atol=1e-9)
    np.testing.assert_allclose(out["rectification"]["Q"], Qs, atol=1e-12)
    np.testing.assert_allclose(np.diag(out["parameter_covariance"]), [1, 1, s * s])
    np.testing.assert_allclose(cal["T"], t)  # the input is left alone
    with pytest.raises(InputError, match="positive"):
        apply_scale(cal, -1)
