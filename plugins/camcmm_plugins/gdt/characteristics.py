"""ISO 1101 characteristics of measured features: value, standard uncertainty, verdicts.

:func:`evaluate_characteristic` computes one :class:`~.model.CharacteristicSpec` on the
evaluated cloud (points (N, 3) mm in the evaluation frame, with each feature's
:class:`~.model.Associated` in the same coordinates). A characteristic with datums is
evaluated in the plan's coordinates through its datum frame (``frames(labels)``,
:mod:`.datums`): the true position / required orientation is the feature's NOMINAL
there. The evaluators are in :mod:`.zones` (form, orientation, location, profile),
:mod:`.runout` and :mod:`.dimensions`. Values, as computed (mm):

Form (no datums; the minimum-zone association of :func:`.features.associate`) —
straightness: the diameter of the thinnest cylinder holding a line's points; flatness:
two parallel planes; roundness: two concentric circles — a circle's section, or the
worst of ``sections`` equal slices of a cylinder/cone (default one per 50 points, at
most 20); cylindricity: two coaxial cylinders. Line-profile / surface-profile without
datums: 2·max|d| of the points' signed distances d from the nominal surface after the
nominal is floated onto the points (rigid least-squares best fit).

Orientation (parallelism, perpendicularity, angularity) — the required direction is the
feature's nominal direction in the datum frame; option ``angle`` (degrees, the angle
between the feature and the primary datum as the drawing states it: plane-plane and
axis-axis between their directions, axis-plane from the plane) replaces its angle to the
primary datum's direction, keeping its azimuth. A rotation the datums leave free (about
the primary's direction) is chosen to minimise the value. A plane: the width of the
zone of two planes normal to the required direction holding the points, max − min of
their projections. An axis (cylinder, cone, line): the diametral zone — the diameter of
the cylinder of the required direction holding the derived axis between the feature's
ends, |Δ − (Δ·d)d| with Δ the axis from end to end.

The ends of an axis: where the associated axis crosses the planes normal to the nominal
axis through the nominal's ends when the nominal states a ``length`` (the issue's "at
its bottom and top faces"), else the extent of the feature's points along it.

Location — position: a point/sphere/circle centre 2·|c − c₀|; an axis 2·max over its
two ends of the radial offset from the nominal axis; a plane 2·max|d_i| of its points
from the nominal plane. Coaxiality: an axis's two ends, concentricity: a centre (circle,
sphere, the middle of an axis), 2·radial distance from the datum axis (the datum
frame's origin and z). Symmetry: the median of the associated planes of ``feature`` and
option ``other`` (their heights along the nominal normal at every point of both)
against the datum's median plane (through the frame's origin, normal to the nominal
normal), 2·max|median offset|. Profile (with datums, no float): 2·max|d_i| from the
nominal. Degrees of freedom the datums leave free are held at the nominal (warned).

Runout about the datum axis (frame origin and z): circular — for a cylinder/cone/
sphere/circle the radial range max ρ − min ρ in each of ``sections`` equal slices along
the axis (default as for roundness), the largest; for a plane the axial range in
annular slices; total — the range over all points.

Size (ISO 14405-1) — diameter: the associated diameter (the feature's association,
default least squares; option ``criterion`` ls | mincircumscribed | maxinscribed |
minzone: :func:`.size.global_size`); width: :func:`.size.width`, the least-squares
distance of two opposite planes (``feature`` and ``other``) of one common normal;
distance: between ``feature`` and option ``other`` (plane > axis > point decides: the
distance of the lower's reference point — a plane's projected centroid, an axis's
middle, a centre — from the higher element; two planes or two axes: the mean both
ways). ``lower``/``upper`` are deviations from the nominal (option ``nominal``, else the
nominal geometry); details carry nominal, deviation and the two-point sizes' min/max.

Uncertainty (``u``, k = 1, with ``u_method`` and ``details["u_parts"]``) and the ISO
14253-1 verdicts: :mod:`.uncertainty`. A result that cannot be meaningful (too few
points, an axis of no extent) has value None, verdicts "not evaluated", the reason in
``details["reason"]`` and a warning; a value without tolerance or limits has verdicts
"not evaluated" (value only). ``modifier`` MMC/LMC is not applied (evaluated RFS,
warned).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from camcmm.api import GeometryError, InputError

from . import dimensions, features, runout, zones
from . import uncertainty as unc
from .case import Case, NotEvaluated, Out
from .model import CHARACTERISTICS, Associated, CharacteristicResult, CharacteristicSpec, DatumFrame, Plan

_LS = "covariance of the least-squares fit"
_MC = f"monte-carlo: {unc.MC_REPLICATES} replicates of the feature's points with their estimated noise"
_MC_DATUMS = f"monte-carlo of the datum frame: {unc.MC_DATUM_REPLICATES} replicates of the datum features' points"
#: Located characteristics whose zone a free degree of freedom of the datums would move.
_HELD = ("position", "profile", "symmetry", "line-profile", "surface-profile")


# ---- dispatch ----------------------------------------------------------------------

_EVALUATORS: dict[str, Callable[[Case], Out]] = {
    "straightness": zones.form,
    "flatness": zones.form,
    "roundness": zones.form,
    "cylindricity": zones.form,
    "line-profile": zones.profile,
    "surface-profile": zones.profile,
    "profile": zones.profile,
    "parallelism": zones.orientation,
    "perpendicularity": zones.orientation,
    "angularity": zones.orientation,
    "position": zones.position,
    "coaxiality": zones.position,
    "concentricity": zones.position,
    "symmetry": zones.symmetry,
    "circular-runout": runout.runout,
    "total-runout": runout.runout,
    "diameter": dimensions.size,
    "width": dimensions.size,
    "distance": dimensions.size,
}
assert set(_EVALUATORS) == {t for ts in CHARACTERISTICS.values() for t in ts}


_REPLICATE_FRAMES: dict[tuple[int, tuple[str, ...]], tuple[dict[str, Associated], list[np.ndarray]]] = {}


def _datum_replicates(c: Case, fids: list[str]) -> list[np.ndarray]:
    """The transform of ``c``'s datum frame in MC_REPLICATES Monte Carlo replicates of the
    points of its datum features ``fids`` that are not least-squares (each re-associated
    by its own criterion, e.g. the ISO 5459 tangent plane). Kept per evaluation (the
    associated features' dict) and datum labels: every characteristic on the same datums
    shares them."""
    key = (id(c.associated), tuple(c.spec.datums))
    hit = _REPLICATE_FRAMES.get(key)
    if hit is not None and hit[0] is c.associated:
        return hit[1]
    rng = np.random.default_rng(unc.MC_SEED + 1)
    clouds = {f: (c.pts(f), c.noise(f)) for f in fids}
    clouds = {f: ps for f, ps in clouds.items() if not ps[1] <= unc.NOISELESS}
    t0 = c.transform()
    out = []
    for _ in range(unc.MC_DATUM_REPLICATES if clouds else 0):
        moved = dict(c.associated)
        try:
            for f, (p, sigma) in clouds.items():
                q = p + rng.normal(0.0, sigma, p.shape)
                moved[f] = features.associate(q, np.arange(len(q)), c.plan.features[f], c.assoc(f).association)
        except GeometryError:  # a replicate that does not associate: left out
            continue
        out.append(c.transform_of(moved, t0))
    if any(held is not c.associated for held, _ in _REPLICATE_FRAMES.values()):
        _REPLICATE_FRAMES.clear()  # one evaluation's frames at a time: they hold its features
    _REPLICATE_FRAMES[key] = (c.associated, out)
    return out


def _uncertainty(c: Case, out: Out) -> tuple[float, str, dict[str, float]]:
    """u (k = 1), its method and each part (see :mod:`.uncertainty`): the covariance of
    the least-squares features the value depends on, the Monte Carlo of the points of a
    value that is an extreme of them, and the Monte Carlo of the datum frame for datum
    features associated otherwise than by least squares (the tangent default)."""
    t0 = c.transform()
    parts: dict[str, float] = {}
    base_pts = {fid: c.pts(fid) for fid in out.mc}
    mc_datums = [f for f in c.datum_features() if c.assoc(f).association != "ls"]
    covs = {}
    for fid in out.ls:
        if fid in mc_datums:
            continue
        cv = unc.covariance(c.assoc(fid), c.pts(fid))
        if cv is None:
            return float("nan"), _LS, parts
        covs[fid] = cv
    if covs:
        parts["covariance"] = unc.propagate(lambda A: out.fn(A, base_pts, t0), c.associated, covs)
    if out.mc:
        clouds = {fid: (p, c.noise(fid)) for fid, p in base_pts.items()}
        parts["monte-carlo"] = unc.monte_carlo(lambda moved: out.fn(c.associated, moved, t0), clouds)
    if mc_datums:
        frames = _datum_replicates(c, mc_datums)
        pts = base_pts or {fid: c.pts(fid) for fid in (c.spec.feature,)}
        if frames:
            if len(frames) < unc.MC_DATUM_REPLICATES // 2:
                return float("nan"), _MC_DATUMS, parts
            parts["datums monte-carlo"] = float(np.std([out.fn(c.associated, pts, t) for t in frames], ddof=1))
        else:  # noiseless datum features
            parts["datums monte-carlo"] = 0.0
    methods = []
    if out.mc:
        methods.append(_MC)
    if covs:
        methods.append(_LS)
    if mc_datums:
        methods.append(_MC_DATUMS)
    return unc.combined(*parts.values()), " + ".join(methods), parts


def evaluate_characteristic(
    spec: CharacteristicSpec,
    plan: Plan,
    points: np.ndarray,
    associated: dict[str, Associated],
    frames: Callable[[tuple[str, ...]], DatumFrame],
) -> CharacteristicResult:
    """Evaluate one characteristic (module docstring): value (mm), u (k = 1), verdicts,
    the decisive points (indices into ``points``). A plan error is a one-line
    InputError; a characteristic that cannot be meaningful comes back "not evaluated"
    with a warning."""
    c = Case(spec, plan, np.asarray(points, dtype=float), associated, frames)
    if spec.type not in _EVALUATORS:
        raise InputError(f"{c.where}: type: unknown characteristic {spec.type}")
    size_like = spec.type in CHARACTERISTICS["size"]
    res = CharacteristicResult(
        id=spec.id,
        type=spec.type,
        feature=spec.feature,
        datums=tuple(spec.datums),
        value=None,
        unit="mm",
        tolerance=spec.tolerance,
        lower=spec.lower,
        upper=spec.upper,
        u=None,
        u_method="",
        k=spec.k,
        verdict="not evaluated",
        verdict_guarded="not evaluated",
    )
    try:
        out = _EVALUATORS[spec.type](c)
        u, method, parts = _uncertainty(c, out)
    except (NotEvaluated, GeometryError) as exc:
        reason = str(exc).removeprefix(f"{spec.id}: ")
        res.warnings.append(f"not evaluated: {reason}")
        res.details["reason"] = reason
        return res
    res.value, res.u, res.u_method = float(out.value), (u if math.isfinite(u) else None), method
    res.decisive = np.asarray(out.decisive, dtype=np.int64)
    res.details = {**out.details, "u_parts": parts}
    res.warnings += out.warnings
    if res.u is None:
        res.warnings.append(
            "no uncertainty (too few points for the fit's degrees of freedom, or a zone that does not converge)"
        )
    if spec.modifier in ("MMC", "LMC"):
        res.warnings.append(f"modifier {spec.modifier} not applied: the zone is evaluated regardless of size (RFS)")
    if spec.datums and spec.type in _HELD:
        free = c.frame_axis()[2]
        if free:
            res.warnings.append(
                f"the datums {'|'.join(spec.datums)} leave {', '.join(free)} free: held at the nominal, not floated"
            )
    if size_like:
        if spec.lower is None and spec.upper is None:
            res.warnings.append("no limits: value only")
            res.details["reason"] = "no limits: value only"
        dev = out.details.get("deviation")
        res.verdict, res.verdict_guarded = unc.size_verdicts(dev, spec.lower, spec.upper, res.u, spec.k)
    else:
        if spec.tolerance is None:
            res.warnings.append("no tolerance: value only")
            res.details["reason"] = "no tolerance: value only"
        res.verdict, res.verdict_guarded = unc.zone_verdicts(res.value, spec.tolerance, res.u, spec.k)
    return res
