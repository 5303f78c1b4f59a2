"""Fringe decoding against exact-by-construction captures.

A camera whose pixels see known projector coordinates u(x, y), v(x, y) is rendered
analytically (eq. 5.2 at the pixel's coordinate, code bits from the stripe index), then
decoded; the decoded coordinates must equal the truth within the noise the phase-shifting
model predicts: sigma_x = period / (2 pi) * sigma_I / (I'' sqrt(N / 2)).
"""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.fringe.decode import decode
from camcmm_plugins.fringe.patterns import generate_patterns, gray_decode, gray_encode
from camcmm_plugins.fringe.phase import wrapped_phase
from camcmm_plugins.fringe.sequence import load_sequence
from camcmm_plugins.fringe.synthetic import render_captures
from camcmm_plugins.fringe.unwrap import Level, beat

H, W = 180, 240
PW, PH = 640, 480


def true_maps():
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    u = 7.3 + 2.31 * x + 0.17 * y + 9.0 * np.sin(y / 23.0)  # 7 .. 570 px
    v = 11.1 + 0.21 * x + 2.2 * y + 5.0 * np.cos(x / 31.0)  # 6 .. 455 px
    return u, v


def seq_with(frames, **proj):
    return {"projector": {"width": PW, "height": PH, **proj}, "frames": frames}


def predicted_sigma(period, noise, modulation, steps):
    return period / (2 * np.pi) * noise / (modulation * np.sqrt(steps / 2))


# -- phase (eq. 5.3) ---------------------------------------------------------------------
@pytest.mark.parametrize(
    "steps,shifts", [(3, None), (4, None), (5, None), (8, None), (3, [-120, 0, 120]), (4, [90, 180, 270, 0])]
)
def test_wrapped_phase_is_exact_without_noise(steps, shifts):
    entry = {"type": "phase", "direction": "vertical", "steps": steps, "period": 37.5, "offset": 3.0}
    if shifts:
        entry["shifts_deg"] = shifts
    seq = load_sequence(seq_with([entry]))
    u, _ = true_maps()
    frames = render_captures(seq, u=u, mean=90.0, modulation=60.0, dtype=np.float64)
    frac, mean, mod = wrapped_phase(frames, seq.phase_groups[0].shifts)
    truth = ((u - 3.0) / 37.5) % 1.0
    d = (frac - truth + 0.5) % 1.0 - 0.5
    assert np.abs(d).max() < 2e-6
    assert np.allclose(mean, 90.0, atol=1e-3) and np.allclose(mod, 60.0, atol=1e-3)


def test_shifts_must_be_even():
    with pytest.raises(InputError, match="evenly spread"):
        load_sequence(
            seq_with([{"type": "phase", "direction": "vertical", "steps": 3, "period": 20, "shifts_deg": [0, 90, 180]}])
        )


# -- codes ---------------------------------------------------------------------------------
def test_gray_code_table_and_round_trip():
    # the reflected binary code of thesis fig. 5.2
    assert gray_encode(np.arange(8)).tolist() == [0, 1, 3, 2, 6, 7, 5, 4]
    c = np.arange(1 << 12)
    g = gray_encode(c)
    assert np.array_equal(gray_decode(g, 12), c)
    flips = g[1:] ^ g[:-1]
    assert np.all((flips & (flips - 1)) == 0)  # neighbours differ in exactly one bit


def test_generated_patterns_decode_to_their_own_pixel_coordinates():
    """A camera that is the projector (one pixel per projector pixel) must decode every
    pixel to its own column and row, through the 8-bit patterns as written."""
    seq = seq_with(
        [
            "white",
            "black",
            {"type": "phase", "direction": "vertical", "steps": 4, "period": 32},
            {"type": "gray", "direction": "vertical", "period": 16, "inverse": "after"},
            {"type": "phase", "direction": "horizontal", "steps": 3, "period": 24, "offset": 5},
            {"type": "binary", "direction": "horizontal", "period": 24, "bit_order": "lsb_first"},
        ]
    )
    pats = generate_patterns(seq)
    assert pats.shape == (2 + 4 + 2 * 6 + 3 + 5, PH, PW) and pats.dtype == np.uint8
    dec = decode(seq, list(pats), saturation=256)  # the sinusoids' peaks are at 255 by design
    yy, xx = np.mgrid[0:PH, 0:PW]
    assert dec.valid_fraction > 0.999
    m = dec.mask
    # 8-bit rounding of the sinusoids costs < 0.5 grey level -> a few hundredths of a px
    assert np.abs(dec.u[m] - xx[m]).max() < 0.05
    assert np.abs(dec.v[m] - yy[m]).max() < 0.05


# -- unwrapping ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kind,inverse,order",
    [("gray", "none", "msb_first"), ("gray", "interleaved", "msb_first"), ("binary", "after", "lsb_first")],
)
def test_complementary_code_unwraps_without_order_errors(kind, inverse, order):
    """Code stripes of half the fringe period: boundaries shifted by 0.9 px (blur,
    misregistration) still give the right order everywhere, with no correction."""
    period, noise, mod, steps = 32.0, 1.5, 70.0, 4
    seq = seq_with(
        [
            "white",
            "black",
            {"type": "phase", "direction": "vertical", "steps": steps, "period": period},
            {"type": kind, "direction": "vertical", "period": period / 2, "inverse": inverse, "bit_order": order},
        ]
    )
    u, _ = true_maps()
    frames = render_captures(seq, u=u, mean=110.0, modulation=mod, noise=noise, code_shift=0.9, seed=3)
    dec = decode(seq, frames, boundary_correction="none")
    assert dec.valid_fraction == 1.0
    err = dec.u - u
    sigma = predicted_sigma(period, noise, mod * 2 * 0.5, steps)
    assert abs(np.std(err) / sigma - 1) < 0.15  # 8-bit rounding adds a little
    assert np.abs(err).max() < 6 * sigma


def test_code_of_the_fringe_period_needs_the_boundary_correction():
    """Code stripes equal to the period (as most Gray + phase systems): shifted boundaries
    leave strips of +-1 period order error; the median correction removes all of them."""
    period = 20.0
    seq = seq_with(
        [
            {"type": "phase", "direction": "vertical", "steps": 3, "period": period},
            {"type": "gray", "direction": "vertical", "period": period},
        ]
    )
    u, _ = true_maps()
    for shift in (1.6, -1.6):
        frames = render_captures(seq, u=u, mean=100.0, modulation=80.0, noise=1.0, code_shift=shift, seed=5)
        raw = decode(seq, frames, boundary_correction="none").u - u
        wrong = np.abs(raw) > period / 2
        assert wrong.sum() > 500  # strips along every code boundary
        assert np.allclose(np.abs(raw[wrong]), period, atol=0.5)  # exactly one fringe off
        fixed = decode(seq, frames, boundary_correction="auto").u - u
        assert np.abs(fixed).max() < 0.3


def test_heterodyne_beat_has_the_analytic_period():
    x = np.linspace(0.0, 2000.0, 20001)
    t1, t2 = 28.0, 30.0
    a = Level(t1, 0.0, ((x / t1) % 1).astype(np.float32), "a")
    b = Level(t2, 0.0, ((x / t2) % 1).astype(np.float32), "b")
    bt = beat(b, a)  # order does not matter
    assert bt.period == pytest.approx(t1 * t2 / (t2 - t1))  # 420 px
    d = (bt.frac - (x / 420.0) % 1 + 0.5) % 1 - 0.5
    assert np.abs(d).max() < 1e-5


def test_three_frequency_heterodyne_decodes_without_a_code():
    periods, noise, mod, steps = (28.0, 30.0, 32.0), 1.0, 70.0, 4
    frames_decl = [{"type": "phase", "direction": "vertical", "steps": steps, "period": t} for t in periods]
    frames_decl += [{"type": "phase", "direction": "horizontal", "steps": steps, "period": t} for t in periods]
    seq = seq_with(frames_decl)
    u, v = true_maps()
    frames = render_captures(seq, u=u, v=v, mean=110.0, modulation=mod, noise=noise, seed=11)
    dec = decode(seq, frames)
    # beats 420 and 480 px, their beat 3360 px >= the 640 px span
    assert dec.steps["vertical"][0].startswith("beat(beat(")
    assert dec.valid_fraction > 0.999
    m = dec.mask
    sigma = predicted_sigma(28.0, noise, mod, steps)
    assert np.abs(dec.u[m] - u[m]).max() < 6 * sigma
    assert np.abs(dec.v[m] - v[m]).max() < 6 * sigma


def test_two_frequencies_whose_beat_is_shorter_than_the_span_are_refused():
    seq = seq_with([{"type": "phase", "direction": "vertical", "steps": 3, "period": t} for t in (20.0, 24.0)])
    u, _ = true_maps()
    with pytest.raises(InputError, match="beat.*120 px.*shorter than the projector span 640"):
        decode(seq, render_captures(seq, u=u))


def test_kamino_style_two_frequencies_and_code():
    """Two periods (200/3 and 100 px) and a 100 px Gray code with inverses: the code fixes
    the 200 px beat, the beat the 100 px phase, that one the 66.7 px phase."""
    ph = [
        {"type": "phase", "direction": d, "steps": 3, "period": t, "shifts_deg": [-120, 0, 120]}
        for d in ("vertical", "horizontal")
        for t in (200 / 3, 100.0)
    ]
    seq = seq_with(
        ph
        + [
            {"type": "gray", "direction": d, "period": 100, "inverse": "interleaved"}
            for d in ("vertical", "horizontal")
        ]
        + ["white", "black"]
    )
    u, v = true_maps()
    frames = render_captures(seq, u=u, v=v, mean=100.0, modulation=70.0, noise=1.0, code_shift=2.0, seed=2)
    dec = decode(seq, frames)
    assert dec.steps["vertical"][1].startswith("beat(")
    assert dec.valid_fraction == 1.0
    sigma = predicted_sigma(200 / 3, 1.0, 70.0, 3)
    assert np.abs(dec.u - u).max() < 6 * sigma and np.abs(dec.v - v).max() < 6 * sigma


# -- masks, bad input ----------------------------------------------------------------------
def test_dark_and_saturated_pixels_are_masked_and_reported():
    seq = seq_with(
        [
            "white",
            "black",
            {"type": "phase", "direction": "vertical", "steps": 4, "period": 32},
            {"type": "gray", "direction": "vertical", "period": 16},
        ]
    )
    u, _ = true_maps()
    mean = np.full((H, W), 100.0)
    mod = np.full((H, W), 70.0)
    mean[:, :40], mod[:, :40] = 4.0, 2.0  # 1/6 of the image gets no projector light
    mean[:30, 200:], mod[:30, 200:] = 200.0, 90.0  # white = 290 > 255: saturated
    warnings = []
    dec = decode(seq, render_captures(seq, u=u, mean=mean, modulation=mod, noise=0.5), warn=warnings.append)
    assert dec.rejected["dark"] == pytest.approx(40 / W)
    assert dec.rejected["saturated"] == pytest.approx(30 * 40 / (H * W))
    assert not dec.mask[:, :40].any() and not dec.mask[:30, 200:].any()
    assert dec.valid_fraction == pytest.approx(1 - 40 / W - 30 * 40 / (H * W))
    assert any("2.78 % of the pixels are saturated" in w for w in warnings)
    assert np.isnan(dec.u[~dec.mask]).all()


def test_all_dark_captures_are_an_input_error():
    seq = seq_with(
        [
            {"type": "phase", "direction": "vertical", "steps": 3, "period": 32},
            {"type": "gray", "direction": "vertical", "period": 32},
        ]
    )
    u, _ = true_maps()
    with pytest.raises(InputError, match="no pixel decodes"):
        decode(seq, render_captures(seq, u=u, mean=3.0, modulation=1.0))


def test_frame_count_and_sizes_are_checked():
    seq = seq_with(
        [
            {"type": "phase", "direction": "vertical", "steps": 4, "period": 32},
            {"type": "gray", "direction": "vertical", "period": 32, "inverse": "interleaved"},
            "white",
        ]
    )
    u, _ = true_maps()
    frames = render_captures(seq, u=u)
    assert len(frames) == 4 + 2 * 5 + 1
    with pytest.raises(InputError, match="14 frames given, too few .* declares 15"):
        decode(seq, frames[:-1])
    with pytest.raises(InputError, match="too many"):
        decode(seq, frames + frames[:1])
    bad = list(frames)
    bad[6] = bad[6][:, :-1]
    with pytest.raises(InputError, match=r"images\[6\]: frame of 239x180 px, frame 0 has 240x180 px"):
        decode(seq, bad)


@pytest.mark.parametrize(
    "doc,msg",
    [
        ({"frames": ["white"]}, "'projector"),
        ({"projector": {"width": 100, "height": 50}, "frames": []}, "non-empty"),
        ({"projector": {"width": 100, "height": 50}, "frames": ["grey"]}, "type"),
        (
            {
                "projector": {"width": 100, "height": 50},
                "frames": [{"type": "phase", "direction": "vertical", "steps": 2, "period": 10}],
            },
            "N >= 3",
        ),
        (
            {
                "projector": {"width": 100, "height": 50},
                "frames": [{"type": "phase", "direction": "diagonal", "steps": 3, "period": 10}],
            },
            "direction",
        ),
        (
            {
                "projector": {"width": 1000, "height": 50},
                "frames": [
                    {"type": "phase", "direction": "vertical", "steps": 3, "period": 10},
                    {"type": "gray", "direction": "vertical", "period": 10, "bits": 6},
                ],
            },
            "needs 7",
        ),
        (
            {
                "projector": {"width": 100, "height": 50},
                "frames": [{"type": "gray", "direction": "horizontal", "period": 10}],
            },
            "needs a horizontal phase",
        ),
    ],
)
def test_bad_sequences_are_refused_with_one_line(doc, msg):
    with pytest.raises(InputError, match=msg) as exc:
        load_sequence(doc)
    assert "\n" not in str(exc.value)


def test_decode_plugin_by_id():
    from camcmm.api import get_algorithm

    seq = seq_with(
        [
            {"type": "phase", "direction": "vertical", "steps": 4, "period": 32},
            {"type": "gray", "direction": "vertical", "period": 16},
        ]
    )
    u, _ = true_maps()
    out = get_algorithm("fringe.decode")(sequence=seq, images=render_captures(seq, u=u, noise=0.5))
    assert out["v"] is None and out["mask"].all() and out["valid_fraction"] == 1.0
    assert np.abs(out["u"] - u).max() < 0.2  # 6 sigma of noise and 8-bit rounding
    assert abs(np.mean(out["modulation"]) - 80.0) < 0.05 and np.std(out["modulation"]) < 0.5
    assert set(out["masks"]) == {"saturated", "low_modulation", "dark", "code", "order"}


def test_a_code_coarser_than_the_fringes_is_refused():
    seq = seq_with(
        [
            {"type": "phase", "direction": "vertical", "steps": 3, "period": 20},
            {"type": "gray", "direction": "vertical", "period": 40},
        ]
    )
    u, _ = true_maps()
    with pytest.raises(InputError, match="code's 40 px stripes are wider than the longest .* 20 px"):
        decode(seq, render_captures(seq, u=u))
