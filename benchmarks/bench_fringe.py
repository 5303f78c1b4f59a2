"""Benchmark: decode and reconstruct a 12-megapixel stereo pair (fringe projection).

Two 4000 x 3000 px cameras (60 mm apart, toed in) and a 1920 x 1080 projector look at a
20 mm-radius sphere before a plane. Per camera 16 frames, synthetic and exact by
construction: 8-step phase shifting (24 px period) and an 8-bit complementary Gray code
(12 px stripes) thresholded by the sinusoids' mean, with noise, as 8-bit images.

In one run:

* camcmm: ``decode`` of both cameras (float32, in place) and ``stereo_points``
  (rectification with the curvature-corrected resampling, one binary search over all
  rows, sub-pixel phase crossing, Q matrix);
* as the reference, the straightforward implementation in the same process: decoding
  pixel by pixel in Python (eq. 5.3 sums, bits, Gray to binary, eq. 5.4) timed on
  ``--ref-pixels`` pixels, and the thesis's matching as written (fig. 5.5: for every left
  pixel the absolute phase difference to the whole right row, the two lowest, a linear
  fit) timed on ``--ref-rows`` rows; both extrapolated to the full pair;

with the seconds, their ratio, and the accuracy of the points (distance to the true
sphere and plane, mean radial residual on the sphere). The cost of the fringe-order
checks (``fringe/orders.py``) is shown against ``boundary_correction: none`` (the plain
rounding of eq. 5.4) decoding the same frames in the same process, alternately, best of
``--repeat`` each. ``--code period`` replaces the complementary code by a Gray code of
the fringe period (24 px stripes, 7 bits), which leaves half the pixels doubtful.

    .venv/bin/python benchmarks/bench_fringe.py [--width 4000 --height 3000] [--ref-pixels 20000] [--ref-rows 2]
                                                [--code complementary|period] [--repeat 2]

Target: <= 15 s for the 12-megapixel pair on the 2-core development machine. The
curvature correction of the phase resampling (which removes a sphere-radius bias at
coarse pixels) costs ~1 s here: 7.9-8.0 s without it, 8.8-9.2 s with it (two runs
each, alternating, the machine shared with other work); it also raises the points'
scatter (median distance 28 -> 34 um at this noise).
"""

from __future__ import annotations

import argparse
import math
import time

import cv2
import numpy as np

from camcmm.api import CameraModel
from camcmm_plugins.fringe.decode import decode
from camcmm_plugins.fringe.reconstruct import stereo_points
from camcmm_plugins.fringe.sequence import load_sequence
from camcmm_plugins.fringe.synthetic import render_captures
from camcmm_plugins.fringe.triangulate import camera_rays, project

SEQ = {
    "projector": {"width": 1920, "height": 1080},
    "frames": [
        {"type": "phase", "direction": "vertical", "steps": 8, "period": 24},
        {"type": "gray", "direction": "vertical", "period": 12, "bits": 8},
    ],
}
SEQ_PERIOD = {
    "projector": {"width": 1920, "height": 1080},
    "frames": [
        {"type": "phase", "direction": "vertical", "steps": 8, "period": 24},
        {"type": "gray", "direction": "vertical", "period": 24},
    ],
}
CENTRE, RADIUS, PLANE_Z = np.array([30.0, 0.0, 400.0]), 20.0, 440.0


def rig(w: int, h: int):
    f = 8650.0 * w / 4000  # 16 mm lens, 1.85 um pixels (thesis ch. 5)
    k = np.array([[f, 0, w / 2 - 0.5], [0, f, h / 2 - 0.5], [0, 0, 1]])

    def rot(deg):
        r, _ = cv2.Rodrigues(np.array([0.0, math.radians(deg), 0.0]))
        return r

    cam1 = CameraModel(k, np.zeros(5), image_size=(w, h), name="cam1")
    r2, c2 = rot(8.5), np.array([60.0, 0, 0])
    cam2 = CameraModel(k, np.zeros(5), r2, -r2 @ c2, (w, h), name="cam2")
    rp, cp = rot(4.3), np.array([30.0, -20.0, 0])
    proj = CameraModel(
        [[2400.0, 0, 960], [0, 2400.0, 540], [0, 0, 1]],
        [0.02, -0.01, 0, 0, 0],
        rp,
        -rp @ cp,
        (1920, 1080),
        name="projector",
    )
    return cam1, cam2, proj


def scene_u(cam: CameraModel, proj: CameraModel):
    w, h = cam.image_size
    yy, xx = np.mgrid[0:h, 0:w]
    o, d = camera_rays(cam, np.c_[xx.ravel(), yy.ravel()].astype(float))
    del xx, yy
    oc = o - CENTRE
    b = d @ oc
    disc = b * b - (oc @ oc - RADIUS**2)
    t = np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), (PLANE_Z - o[2]) / d[:, 2])
    u = project(proj, o + t[:, None] * d)[:, 0].reshape(h, w)
    return np.clip(u, 0, 1919.0)


def surface_distance(p):
    return np.minimum(np.abs(np.linalg.norm(p - CENTRE, axis=1) - RADIUS), np.abs(p[:, 2] - PLANE_Z))


def naive_decode_pixel(vals, seq):
    """Eqs. 5.3 and 5.4 for one pixel, in plain Python (the reference)."""
    g, c = seq.phase_groups[0], seq.code_groups[0]
    s = sum(vals[i] * math.sin(d) for i, d in zip(g.frames, g.shifts))
    co = sum(vals[i] * math.cos(d) for i, d in zip(g.frames, g.shifts))
    frac = (math.atan2(-s, co) / (2 * math.pi)) % 1.0
    mean = sum(vals[i] for i in g.frames) / g.steps
    word = 0
    for i in c.frames:
        word = (word << 1) | (1 if vals[i] > mean else 0)
    shift = 1
    while shift < c.bits:
        word ^= word >> shift
        shift <<= 1
    x_code = (word + 0.5) * c.period + c.offset
    k = round((x_code - g.offset) / g.period - frac)
    return g.offset + g.period * (k + frac)


def naive_match_row(lrow, rrow):
    """Thesis fig. 5.5 as written: for every left phase, |right row - phase|, the two
    lowest, a linear fit between them."""
    out = np.full(lrow.shape, np.nan)
    for x, phi in enumerate(lrow):
        if not np.isfinite(phi):
            continue
        diff = np.abs(rrow - phi)
        diff[~np.isfinite(diff)] = np.inf
        a, b = np.argpartition(diff, 1)[:2]
        if not np.isfinite(diff[b]) or rrow[a] == rrow[b]:
            continue
        out[x] = a + (phi - rrow[a]) * (b - a) / (rrow[b] - rrow[a])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=4000)
    ap.add_argument("--height", type=int, default=3000)
    ap.add_argument("--ref-pixels", type=int, default=20000)
    ap.add_argument("--ref-rows", type=int, default=2)
    ap.add_argument("--code", choices=("complementary", "period"), default="complementary")
    ap.add_argument("--repeat", type=int, default=2, help="decodes with and without the order checks")
    args = ap.parse_args()
    w, h = args.width, args.height
    seq = load_sequence(SEQ if args.code == "complementary" else SEQ_PERIOD)
    cam1, cam2, proj = rig(w, h)

    t0 = time.perf_counter()
    frames = []
    for i, cam in enumerate((cam1, cam2)):
        u = scene_u(cam, proj)
        frames.append(render_captures(seq, u=u, mean=110.0, modulation=70.0, noise=1.0, seed=i))
        del u
    print(
        f"set-up: 2 x {len(frames[0])} frames of {w}x{h} px ({w * h / 1e6:.1f} MP) rendered in "
        f"{time.perf_counter() - t0:.1f} s"
    )

    t0 = time.perf_counter()
    d1 = decode(seq, frames[0])
    d2 = decode(seq, frames[1])
    t_dec = time.perf_counter() - t0
    pts, fields, _ = stereo_points(d1, d2, cam1, cam2)
    t_all = time.perf_counter() - t0
    e = surface_distance(pts)
    print(
        f"camcmm   : decode 2 cameras {t_dec:.2f} s + match/triangulate {t_all - t_dec:.2f} s = {t_all:.2f} s "
        f"(target <= 15 s); {len(pts):,} points, valid {d1.valid_fraction:.3f}/{d2.valid_fraction:.3f}"
    )
    print(
        f"           distance to the true surface: median {np.median(e) * 1e3:.2f} um, "
        f"95 % {np.percentile(e, 95) * 1e3:.2f} um, beyond 0.1 mm {np.mean(e > 0.1) * 100:.3f} %"
    )
    r = np.linalg.norm(pts - CENTRE, axis=1)
    on = np.abs(r - RADIUS) < 0.1
    print(
        f"           sphere ({on.sum():,} points within 0.1 mm of it): mean radial residual "
        f"{(r[on] - RADIUS).mean() * 1e3:+.3f} um"
    )

    # the order checks against the plain rounding, alternately on the same frames
    times = {"auto": [t_dec], "none": []}
    for i in range(2 * max(args.repeat, 1) - 1):
        corr = "none" if i % 2 == 0 else "auto"
        t0 = time.perf_counter()
        for f in frames:
            decode(seq, f, boundary_correction=corr)
        times[corr].append(time.perf_counter() - t0)
    t_auto, t_none = min(times["auto"]), min(times["none"])
    orders = {k: d1.orders[k] + d2.orders[k] for k in d1.orders}
    print(
        f"order checks ({args.code} code): decode 2 cameras {t_auto:.2f} s, without them "
        f"(boundary_correction: none) {t_none:.2f} s, ratio {t_auto / t_none:.2f} (best of "
        f"{len(times['auto'])}/{len(times['none'])}); {orders['corrected']:,} orders corrected, "
        f"{orders['dropped']:,} pixels dropped"
    )

    # reference 1: per-pixel decoding in Python on a sample of pixels
    rng = np.random.default_rng(0)
    flat = [f.ravel() for f in frames[0]]
    idx = rng.choice(w * h, args.ref_pixels, replace=False)
    t0 = time.perf_counter()
    ref_u = [naive_decode_pixel([float(f[i]) for f in flat], seq) for i in idx]
    t_ref_dec = (time.perf_counter() - t0) / args.ref_pixels * (2 * w * h)
    agree = np.nanmax(np.abs(np.asarray(ref_u) - d1.u.ravel()[idx]))

    # reference 2: the thesis's per-pixel row search on rectified rows
    r, t = cam2.rotation, cam2.translation
    r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(
        cam1.camera_matrix, cam1.dist_coeffs, cam2.camera_matrix, cam2.dist_coeffs, (w, h), r, t.reshape(3, 1)
    )
    m1 = cv2.initUndistortRectifyMap(cam1.camera_matrix, cam1.dist_coeffs, r1, p1, (w, h), cv2.CV_32FC1)
    m2 = cv2.initUndistortRectifyMap(cam2.camera_matrix, cam2.dist_coeffs, r2, p2, (w, h), cv2.CV_32FC1)
    rows = np.linspace(h * 0.3, h * 0.7, args.ref_rows).astype(int)
    t0 = time.perf_counter()
    for y in rows:
        lrow = cv2.remap(d1.u, m1[0][y : y + 1], m1[1][y : y + 1], cv2.INTER_LINEAR, borderValue=np.nan)[0]
        rrow = cv2.remap(d2.u, m2[0][y : y + 1], m2[1][y : y + 1], cv2.INTER_LINEAR, borderValue=np.nan)[0]
        naive_match_row(lrow, rrow)
    t_ref_match = (time.perf_counter() - t0) / len(rows) * h
    t_ref = t_ref_dec + t_ref_match
    print(
        f"reference: per-pixel Python decoding {t_ref_dec:.0f} s (timed on {args.ref_pixels} px, "
        f"agrees to {agree:.1e} px) + fig. 5.5 row search {t_ref_match:.0f} s (timed on {len(rows)} rows) "
        f"= {t_ref:.0f} s extrapolated"
    )
    print(f"ratio reference / camcmm: {t_ref / t_all:.0f}x")


if __name__ == "__main__":
    main()
