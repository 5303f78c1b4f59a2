"""The laser speckle stability test (thesis ch. 4.2; issue 16): SIFT motion of a series
relative to its first image, checked on series exact by construction (a speckle image
shifted by known amounts with cv2.warpAffine)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from camcmm.api import InputError, default_host
from camcmm.cli.main import main
from camcmm_plugins.photogrammetry.stability import stability
from camcmm_plugins.virtuallab.speckle import speckle
from helpers.cli import refused

SHAPE = (360, 480)  # (h, w)


def _series(shifts, seed: int = 3, noise: float = 1.0) -> list[np.ndarray]:
    """A speckle image (grain 7 px) shifted by each (dx, dy) px, with sensor-like noise."""
    base = speckle(SHAPE, 7.0, seed=seed, mean=0.4) * 230 + 10
    rng = np.random.default_rng(seed)
    out = []
    for dx, dy in shifts:
        M = np.float32([[1, 0, dx], [0, 1, dy]])
        w = cv2.warpAffine(base, M, SHAPE[::-1], flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
        out.append(np.clip(np.rint(w + rng.normal(0, noise, w.shape)), 0, 255).astype(np.uint8))
    return out


@pytest.mark.slow
def test_known_shifts_are_recovered():
    # sub-pixel and pixel shifts; the mean radial motion of a rigid shift is |(dx, dy)|
    shifts = [(0, 0), (0.3, 0.0), (0.6, -0.8), (1.0, 1.0), (-1.5, 2.0)]
    res = stability(_series(shifts), [f"s{i}.png" for i in range(len(shifts))])
    want = [float(np.hypot(*s)) for s in shifts]
    # SIFT's localisation on noisy speckle (~0.05-0.1 px per feature, thousands averaged)
    # and the bias of a magnitude of a noisy vector (σ²/2|d|) at 0.3 px
    assert res["mean_motion_px"][0] == 0.0
    assert np.allclose(res["mean_motion_px"], want, atol=0.05), (res["mean_motion_px"], want)
    # a rigid shift moves every grain alike: the spread is SIFT's own noise
    assert max(res["std_px_per_image"]) < 0.15
    assert res["std_px"] == max(res["std_px_per_image"])
    assert min(res["n_features"][1:]) > 200
    assert res["verdict"] == "pass" and res["reasons"] == [] and res["warnings"] == []


@pytest.mark.slow
def test_a_jump_beyond_the_limit_fails_and_names_the_image(tmp_path, capsys):
    shifts = [(0, 0), (0.5, 0.0), (4.0, 0.0)]
    files = []
    for i, img in enumerate(_series(shifts)):
        p = tmp_path / f"t{i:02d}.png"
        cv2.imwrite(str(p), img)
        files.append(p)
    plot = tmp_path / "motion.png"
    assert main(["speckle", "stability", *map(str, files), "--limit", "3", "--plot", str(plot), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["verdict"] == "fail"
    assert res["mean_motion_px"][2] == pytest.approx(4.0, abs=0.05)
    assert len(res["reasons"]) == 1 and res["reasons"][0].startswith("t02.png: mean motion 4.")
    assert plot.stat().st_size > 1000 and plot.read_bytes()[:4] == b"\x89PNG"
    # the same series passes a 5 px limit; through the host as well
    out = default_host().run("speckle.stability", {"images": [str(f) for f in files]}, {"limit": 5.0})
    assert out.outputs["verdict"] == "pass"


def test_bad_input_is_refused_in_one_line(tmp_path, capsys):
    a, b = _series([(0, 0), (1, 0)])
    pa, pb, bad, small = tmp_path / "a.png", tmp_path / "b.png", tmp_path / "broken.png", tmp_path / "small.png"
    cv2.imwrite(str(pa), a)
    cv2.imwrite(str(pb), b)
    bad.write_bytes(b"not a png at all")
    cv2.imwrite(str(small), a[:200, :300])
    refused(capsys, ["speckle", "stability", pa, bad], "broken.png")
    line = refused(capsys, ["speckle", "stability", pa, small], "small.png")
    assert "300 x 200 px" in line and "a.png is 480 x 360 px" in line
    refused(capsys, ["speckle", "stability", pa, pb, "--limit", "0"], "--limit")
    with pytest.raises(InputError, match="at least 2 images"):
        stability([a])
    flat = np.full(SHAPE, 90, np.uint8)
    with pytest.raises(InputError, match="flat0: only 0 SIFT features"):
        stability([flat, flat], ["flat0", "flat1"])
