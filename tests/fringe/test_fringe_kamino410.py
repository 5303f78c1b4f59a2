"""Real captures decoded (kamino410/phase-shifting, MIT): two-frequency 3-step phase
shifting plus Gray code with inverses, white and black, from upstream's generator.

References: upstream's own decoding (``vizualized.png``: display x and y folded every
256 px, R = 128 where decoded) - a partial reference, with its own gamma artefacts; and
our decoding through a second, independent path (the 100 px phase and the code only,
the 66.7 px frames ignored), which must give the same fringe orders as the full
heterodyne chain.
A crop of the captures is in tests/data/kamino410 (see its README); the full-size
captures are read from ../shared when present.
"""

from __future__ import annotations

import copy
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from camcmm_plugins.fringe.decode import decode

DATA = Path(__file__).parents[1] / "data" / "kamino410"


def phase(direction, period):
    return {
        "type": "phase",
        "direction": direction,
        "steps": 3,
        "period": period,
        "shifts_deg": [-120, 0, 120],
        "mean": 128 / 255,
        "amplitude": 127 / 255,
    }


# upstream phase_shifting.py gen 1920 1080 200: S1 = step/3, S2 = step/2, Gray code blocks of step/2
SEQUENCE = {
    "projector": {"width": 1920, "height": 1080},
    "frames": [
        phase("vertical", 200 / 3),
        phase("vertical", 100),
        phase("horizontal", 200 / 3),
        phase("horizontal", 100),
        {"type": "gray", "direction": "vertical", "period": 100, "bits": 5, "inverse": "interleaved"},
        {"type": "gray", "direction": "horizontal", "period": 100, "bits": 4, "inverse": "interleaved"},
        "white",
        "black",
    ],
}


def load(folder: Path):
    frames = [cv2.imread(str(folder / f"pat{i:02d}.png"), cv2.IMREAD_GRAYSCALE) for i in range(32)]
    viz = cv2.imread(str(folder / "vizualized.png"))
    return frames, viz


def agreement(ours, folded, both):
    """Fraction of pixels whose decoded coordinate equals upstream's within 1 px (mod 256)."""
    d = (np.floor(ours[both]).astype(int) - folded[both].astype(int)) % 256
    d = np.where(d > 128, d - 256, d)
    return float(np.mean(np.abs(d) <= 1))


def check(frames, viz, min_agree):
    dec = decode(SEQUENCE, frames, black_threshold=20)  # upstream's -black_thr 20
    assert dec.steps["vertical"][:2] == ["code (100 px stripes)", "beat(phase v0,phase v1) (200 px)"]
    upstream = viz[:, :, 2] == 128
    both = upstream & dec.mask
    # nearly all of what upstream decoded, we decode too
    assert both.sum() > 0.85 * upstream.sum()
    au, av = agreement(dec.u, viz[:, :, 0], both), agreement(dec.v, viz[:, :, 1], both)
    assert au > min_agree and av > min_agree, (au, av)
    # an independent path: code + 100 px phase only (the 66.7 px frames ignored)
    alt = copy.deepcopy(SEQUENCE)
    alt["frames"][0] = {"type": "ignore", "count": 3}
    alt["frames"][2] = {"type": "ignore", "count": 3}
    dec2 = decode(alt, frames, black_threshold=20)
    # The projector's uncorrected gamma bends the 3-step phases (upstream's striped
    # artefacts): the two paths differ by up to ~10 px (a third harmonic of the 100 px
    # phase), but never by a fringe order (66.7 or 100 px)
    m = dec.mask & dec2.mask
    assert np.mean(np.abs(dec.u[m] - dec2.u[m]) < 20) > 0.99
    assert np.mean(np.abs(dec.v[m] - dec2.v[m]) < 20) > 0.99
    return dec, au, av


def test_the_sequence_file_round_trips(tmp_path):
    path = tmp_path / "kamino410.yaml"
    path.write_text(yaml.safe_dump(SEQUENCE))
    from camcmm_plugins.fringe.sequence import load_sequence

    seq = load_sequence(path)
    assert seq.n_frames == 32
    assert [f.name for f in seq.frames[12:14]] == ["gray_v0_bit0", "gray_v0_bit0_inv"]
    assert seq.frames[30].kind == "white" and seq.frames[31].kind == "black"


def test_crop_decodes_like_upstream():
    frames, viz = load(DATA)
    dec, au, av = check(frames, viz, 0.99)
    assert dec.valid_fraction > 0.75  # wall and mug; the shadow of the second mug is dark


@pytest.mark.slow
def test_full_captures_decode_like_upstream(shared_data):
    frames, viz = load(shared_data / "phase_shift_graycode_kamino410" / "object2")
    dec, au, av = check(frames, viz, 0.995)
    assert 0.5 < dec.valid_fraction < 0.7
