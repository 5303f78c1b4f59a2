"""Scaling reconstructions of arbitrary scale (VDI/VDE 2634 part 3 as the thesis
adapted it for turntable photogrammetry, ch. 4.4-4.5).

* By calibrated lengths of the ball plate (thesis eqs. 4.7-4.12). With L_r,i the
  reconstructed and L_c,i the calibrated lengths (L1 = |c1c2|, L2 = |c2c3|,
  L3 = |c3c1|), the metric lengths are

      L_m,1 = L_r,1 (L_c,3 / L_r,3)                              (4.10)
      L_m,2 = L_r,2 (L_c,3 / L_r,3)                              (4.11)
      L_m,3 = 0.5 L_r,3 (L_c,1 / L_r,1 + L_c,2 / L_r,2)          (4.12)

  Each length is scaled by the *other* lengths, never by itself, so its error
  L_m,i - L_c,i stays a test of the system.
* By calibrated sphere radii (thesis ch. 4.5.1): s = mean_k (r_c,k / r_fit,k) over
  the scale spheres in the same reconstruction; every length is multiplied by s.

Finding spheres at unknown scale: a RANSAC sphere (``segment.sphere`` without a
nominal radius) gives the radius in reconstruction units; the calibrated ratio of the
diameters then tells which spheres to look for.
"""

from __future__ import annotations

import itertools

import numpy as np

from camcmm.api import GeometryError, InputError, PointCloud

from .segment import detect

#: RANSAC (segment.sphere without a radius) scores every hypothesis against every point;
#: 1000 points fix a radius to well under 1 % (detection needs 10 %) in about 0.2 s.
RANSAC_POINTS = 1_000


def ball_plate_lengths(l_rec, l_cal) -> list[float]:
    """Metric lengths from reconstructed ones by thesis eqs. 4.10-4.12."""
    r1, r2, r3 = (float(x) for x in l_rec)
    c1, c2, c3 = (float(x) for x in l_cal)
    return [r1 * (c3 / r3), r2 * (c3 / r3), 0.5 * r3 * (c1 / r1 + c2 / r2)]


#: Scaled by the calibrated lengths, the plate's spheres must measure their nominal
#: diameter: within this fraction they agree (measure.SIZE_TOLERANCE, the "no such
#: sphere" bound of every fitted diameter); beyond it, but within a factor
#: PLAUSIBLE_FACTOR either way, a warning; beyond that the lengths are refused. The
#: factor is the one the shared unit rule allows a fitted diameter (docs/units.md,
#: measure._size_check: another unit must bring it within a factor 2): a slip of a digit
#: (x 10, x 0.1), of a unit (x 25.4, x 1000) or a wrong plate lands far outside it.
AGREE = 0.25
PLAUSIBLE_FACTOR = 2.0


def check_lengths(plan: str, l_cal, l_rec, fitted_radii, d_nom: float, name: str) -> str | None:
    """Are the calibrated lengths ``l_cal`` (mm) the lengths of this reconstruction?
    Scaling by lengths makes them agree with themselves whatever they are (a plan 10 x
    too long scales the cloud 10 x and passes), so the scale-free geometry decides: the
    ratio of the centre distances ``l_rec`` to the fitted radii (reconstruction units) is
    the plate's, and with the nominal sphere diameter ``d_nom`` it gives the lengths
    the spheres measure. InputError naming the plan, its longest length and that
    measured length when they differ by more than PLAUSIBLE_FACTOR; a warning (returned)
    beyond AGREE; None when they agree."""
    radii = np.asarray(list(fitted_radii), dtype=float)
    if len(radii) == 0 or not np.all(np.isfinite(radii)) or not np.all(radii > 0):
        return None  # no sphere size to judge by (the fits refuse such spheres themselves)
    i = int(np.argmax(l_cal))
    l_m = ball_plate_lengths(l_rec, l_cal)
    s = float(np.mean(np.asarray(l_m) / np.asarray(l_rec)))
    q = float(np.median(2 * radii * s) / d_nom)  # scaled sphere diameter / nominal
    measured = float(l_m[i]) / q  # the length as the spheres' size scales it (mm)
    what = (
        f"{plan}: artefacts.ball_plate.lengths[{i}] = {float(l_cal[i]):.4g} mm but {name} measures "
        f"{measured:.4g} mm (its spheres, scaled by these lengths, would be {d_nom * q:.4g} mm across, "
        f"not sphere_diameter {d_nom:g} mm)"
    )
    if not (1 / PLAUSIBLE_FACTOR <= q <= PLAUSIBLE_FACTOR):
        raise InputError(f"{what}: the calibrated lengths cannot be this plate's; check them and their unit")
    if abs(q - 1) > AGREE:
        return f"{what}: {100 * abs(q - 1):.0f} % apart; check the calibrated lengths"
    return None


def by_radii(fitted_radii, calibrated_radius: float) -> float:
    """Scale factor s = mean(r_c / r_fit) over the scale spheres."""
    r = np.asarray(list(fitted_radii), dtype=float)
    if len(r) == 0 or not (r > 0).all():
        raise GeometryError("scaling by radii needs at least one fitted scale sphere")
    return float(np.mean(calibrated_radius / r))


def order_plate(centres: np.ndarray, l_cal, name: str) -> list[int]:
    """The order of three sphere centres that makes |c1c2|, |c2c3|, |c3c1| match the
    calibrated L1, L2, L3 up to one scale: the permutation whose length ratios
    L_r,i / L_c,i agree best (smallest relative spread)."""
    l_cal = np.asarray(l_cal, dtype=float)
    best: list[int] = [0, 1, 2]  # replaced by the first finite spread; none: refused below
    spread = np.inf
    for perm in itertools.permutations(range(3)):
        c = centres[list(perm)]
        l_rec = np.array([np.linalg.norm(c[(k + 1) % 3] - c[k]) for k in range(3)])
        ratio = l_rec / l_cal
        s = float(np.std(ratio) / np.mean(ratio))
        if s < spread - 1e-12:
            best, spread = list(perm), s
    if spread > 0.1:
        raise GeometryError(
            f"{name}: the three spheres do not form the ball plate's triangle "
            f"(length ratios disagree by {100 * spread:.1f} %)"
        )
    return best


def _sub(cloud: PointCloud) -> PointCloud:
    step = max(1, cloud.n_points // RANSAC_POINTS)
    return cloud.subset(slice(None, None, step)) if step > 1 else cloud


def estimate_radius(ctx, cloud: PointCloud, name: str) -> float:
    """Radius (reconstruction units) of the best-supported sphere, by RANSAC."""
    try:
        out = ctx.algorithm("segment.sphere")(cloud=_sub(cloud))
    except GeometryError as exc:
        raise GeometryError(f"{name}: no sphere found to set the scale ({exc})") from None
    return float(out["radius"])


def find_spheres_by_ratio(ctx, cloud: PointCloud, name: str, d_main: float, d_scale: float) -> list[np.ndarray]:
    """Indices of [probing sphere, scale sphere 1, scale sphere 2] in a reconstruction
    of unknown scale, told apart by their calibrated diameters."""
    ratio = d_scale / d_main
    if 0.75 < ratio < 1 / 0.75:
        raise InputError(
            f"{name}: scale spheres ({d_scale:g} mm) and probing sphere ({d_main:g} mm) are too alike "
            "in size to be told apart; export the probing sphere alone and use scaling: none"
        )
    r1 = estimate_radius(ctx, cloud, name)
    last = None
    for big in (r1, r1 / ratio):  # the RANSAC sphere is the probing sphere, or a scale sphere
        try:
            main = detect(ctx, cloud, name, big, 1, "probing sphere")
            scale = detect(ctx, cloud, name, big * ratio, 2, "set of scale spheres")
            return main + scale
        except GeometryError as exc:
            last = exc
    raise GeometryError(f"{name}: could not find the probing sphere and two scale spheres ({last})")
