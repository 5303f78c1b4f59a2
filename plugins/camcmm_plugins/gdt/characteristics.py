"""ISO 1101 characteristics of measured features: value, standard uncertainty, verdicts.

:func:`evaluate_characteristic` computes one :class:`~.model.CharacteristicSpec` on the
evaluated cloud (points (N, 3) mm in the evaluation frame, with each feature's
:class:`~.model.Associated` in the same coordinates). A characteristic with datums is
evaluated in the plan's coordinates through its datum frame (``frames(labels)``,
:mod:`.datums`): the true position / required orientation is the feature's NOMINAL
there. Values, as computed (mm):

Form (no datums; the minimum-zone association of :func:`.features.associate`) —
straightness (smallest cylinder
containing a line's points, diametral), flatness (two parallel planes), roundness (two
concentric circles; a circle's section, or the worst of ``sections`` equal slices of a
cylinder/cone), cylindricity (two coaxial cylinders); line-profile / surface-profile
without datums: 2·max|d| of the points' signed distances d from the nominal surface
after the nominal is floated (rigid least-squares best fit) onto the points.

Orientation (parallelism, perpendicularity, angularity) — the required direction is the
feature's nominal direction in the datum frame (option ``angle``, degrees, overrides
the angle to the primary datum's direction, keeping the nominal's azimuth); a rotation
the datums leave free (about the primary's direction) is chosen to minimise the value.
A plane: width of the zone of two planes normal to the required direction containing
the points, max − min of the points' projections. An axis (cylinder, cone, line): the
diametral zone, the diameter of the cylinder of the required direction containing the
derived axis between the feature's ends = |Δ − (Δ·d)d|, Δ the axis from end to end.

Location — position: a point/sphere/circle centre 2·|c − c₀|; an axis 2·max over its
two ends (at the feature's extent) of the radial offset from the nominal axis; a plane
2·max|d_i| of its points from the nominal plane. Coaxiality: an axis's two ends,
concentricity: a centre (circle, sphere, the middle of an axis), 2·radial distance from
the datum axis. Symmetry: the median of the associated planes of ``feature`` and option
``other`` (heights along the nominal normal at every point of both) against the datum's
median plane (through the datum frame's origin, normal to the nominal normal), 2·max
|median offset|. Profile (with datums, no float): 2·max|d_i| from the nominal.

Runout about the datum axis (frame origin and z): circular — for a cylinder/cone/
sphere/circle the radial range max ρ − min ρ in each of ``sections`` equal slices along
the axis (default: one per 50 points, at most 20), the largest; for a plane the axial
range in annular slices; total — the range over all points.

Size (ISO 14405-1) — diameter: the associated diameter (the feature's association,
default least squares; option ``criterion`` ls | mincircumscribed | maxinscribed uses
size.global_size); width: the distance of two opposite planes (``feature`` and
``other``), the mean of each one's centroid (projected on it) from the other plane;
distance: between ``feature`` and option ``other`` (plane > axis > point decides: the
distance of the lower's reference point — a plane's projected centroid, an axis's
middle, a centre — from the higher element; two planes or two axes: the mean both
ways). ``lower``/``upper`` are deviations from the nominal (option ``nominal`` or the
nominal geometry); details carry nominal, deviation and the two-point sizes' min/max.

Uncertainty and verdicts: :mod:`.uncertainty`. A result that cannot be meaningful (too
few points, an axis of no extent, a datum that gives no axis) has value None, verdicts
"not evaluated" and a warning saying why.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from camcmm.api import GeometryError, InputError

from . import elements as el
from . import features, size
from . import uncertainty as unc
from .datums import datum_frame, nominal_frame
from .model import (
    CHARACTERISTICS,
    Associated,
    CharacteristicResult,
    CharacteristicSpec,
    DatumFrame,
    FeatureSpec,
    Plan,
)

_AXES = ("cylinder", "cone", "line")
_CENTRES = ("sphere", "point", "circle")
_LS = "covariance of the least-squares fit"
_MC = f"monte-carlo: {unc.MC_REPLICATES} replicates of the feature's points with their estimated noise"
_NEAR = 8  # decisive points reported near an axis end
#: Located characteristics whose zone a free degree of freedom of the datums would move.
_HELD = ("position", "profile", "symmetry", "line-profile", "surface-profile")


class NotEvaluated(Exception):
    """The characteristic cannot be given a meaningful value (the message says why)."""


@dataclass
class _Out:
    value: float
    decisive: np.ndarray  # indices into the evaluated cloud
    details: dict[str, Any]
    # value as a function of (associated, points by feature id, transform) for u
    fn: Callable[[dict[str, Associated], dict[str, np.ndarray], np.ndarray], float]
    mc: tuple[str, ...] = ()  # features whose points enter by Monte Carlo
    ls: tuple[str, ...] = ()  # features whose parameters enter by their covariance
    warnings: list[str] = field(default_factory=list)


@dataclass
class _Case:
    spec: CharacteristicSpec
    plan: Plan
    points: np.ndarray
    associated: dict[str, Associated]
    frames: Callable[[tuple[str, ...]], DatumFrame]
    _base_inv: np.ndarray | None = None

    @property
    def where(self) -> str:
        return f"{self.plan.source or 'plan'}: characteristics: {self.spec.id}"

    def assoc(self, fid: str | None = None) -> Associated:
        fid = fid or self.spec.feature
        a = self.associated.get(fid)
        if a is None:
            raise NotEvaluated(f"{self.spec.id}: feature {fid} was not measured")
        return a

    def pts(self, fid: str | None = None) -> np.ndarray:
        return self.points[self.assoc(fid).indices]

    def nominal(self, fid: str | None = None) -> tuple[str, dict[str, Any]]:
        f = self.plan.features.get(fid or self.spec.feature)
        if f is None:
            raise InputError(f"{self.where}: no feature {fid or self.spec.feature}")
        return f.type, f.nominal

    def other(self) -> str:
        o = self.spec.options.get("other") or self.spec.options.get("to")
        if not o:
            raise InputError(f"{self.where}: other: {self.spec.type} needs option other (the second feature)")
        if str(o) not in self.plan.features:
            raise InputError(f"{self.where}: other: no feature {o}")
        return str(o)

    def transform(self) -> np.ndarray:
        return self.frames(self.spec.datums).transform if self.spec.datums else np.eye(4)

    def transform_of(self, associated: dict[str, Associated], t: np.ndarray) -> np.ndarray:
        """The transform ``t`` corrected for datum features moved in ``associated``
        (the frame is rebuilt only when one of its features was moved)."""
        if not self.spec.datums or all(associated.get(f) is self.associated.get(f) for f in self.datum_features()):
            return t
        if self._base_inv is None:
            self._base_inv = np.linalg.inv(datum_frame(self.plan, self.associated, self.spec.datums).transform)
        moved = datum_frame(self.plan, associated, self.spec.datums).transform
        return moved @ self._base_inv @ t

    def datum_features(self) -> tuple[str, ...]:
        out: list[str] = []
        for label in self.spec.datums:
            out += [f for f in self.plan.datums.get(label, ()) if f not in out]
        return tuple(out)

    def frame_axis(self) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Origin, primary direction (plan coordinates) and free dofs of the datums."""
        f, free = nominal_frame(self.plan, self.spec.datums)
        return f[:3, 3], f[:3, 2], free


def _need(n: int, minimum: int, what: str) -> None:
    if n < minimum:
        raise NotEvaluated(f"{what}: {n} points, at least {minimum} needed")


def _global(a: Associated, local: np.ndarray) -> np.ndarray:
    return np.asarray(a.indices)[np.asarray(local, dtype=np.int64)]


def _rot(axis: np.ndarray, phi: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(phi) * k + (1 - math.cos(phi)) * (k @ k)


def _min_over_rotation(
    f: Callable[[np.ndarray], float], d: np.ndarray, axis: np.ndarray | None, measured: np.ndarray | None = None
) -> tuple[float, np.ndarray]:
    """min over φ of f(R(axis, φ) d) (a rotation the datums leave free), or f(d). The
    search starts where d's projection normal to the axis meets the ``measured``
    direction's (the feature as measured, in the same coordinates) and covers ±0.2 rad."""
    if axis is None or np.linalg.norm(np.cross(axis, d)) < 1e-9:
        return f(d), d
    phi0 = 0.0
    if measured is not None:
        u, v = d - (d @ axis) * axis, measured - (measured @ axis) * axis
        if np.linalg.norm(u) > 1e-6 and np.linalg.norm(v) > 1e-6:
            v = v if u @ v >= 0 else -v
            phi0 = math.atan2(float(np.cross(u, v) @ axis), float(u @ v))
    grid = phi0 + np.linspace(-0.2, 0.2, 41)
    vals = [f(_rot(axis, p) @ d) for p in grid]
    i = int(np.argmin(vals))
    # golden section (the value is a max of smooth functions: a kink at the minimum,
    # where Brent's parabolas help little) to 1e-15 rad about the best grid point
    lo, hi = float(grid[max(i - 1, 0)]), float(grid[min(i + 1, 40)])
    g = (math.sqrt(5) - 1) / 2
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(_rot(axis, x1) @ d), f(_rot(axis, x2) @ d)
    for _ in range(200):
        if hi - lo <= 1e-15:
            break
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = f(_rot(axis, x1) @ d)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = f(_rot(axis, x2) @ d)
    best = 0.5 * (lo + hi) if min(f1, f2) <= vals[i] else float(grid[i])
    return f(_rot(axis, best) @ d), _rot(axis, best) @ d


# ---- form --------------------------------------------------------------------------


_FORM_TYPES = {
    "flatness": ("plane",),
    "straightness": ("line",),
    "cylindricity": ("cylinder",),
    "roundness": ("circle", "cylinder", "cone"),
}
_FORM_MIN = {"flatness": 4, "straightness": 3, "cylindricity": 6, "roundness": 4}


def _zone(spec: FeatureSpec, pts: np.ndarray, start: dict | None = None) -> tuple[float, np.ndarray, dict]:
    """Minimum-zone width of the points, the indices of the points on the zone's
    boundaries and the zone's element: features.associate "minzone" (a line: the thinnest
    cylinder); with ``start`` (an earlier solution, for the Monte Carlo replicates) a
    circle, cylinder or line goes straight to its sequential LP from there."""
    if start is not None and spec.type in ("circle", "cylinder", "line"):
        t = "cylinder" if spec.type == "line" else spec.type
        crit = "mincircumscribed" if spec.type == "line" else "minzone"
        params = features._radial_association(pts, t, start, crit, spec.id)  # noqa: SLF001 - warm start
        w = pts - params["centre" if t == "circle" else "point"]
        d = el.unit(params["normal" if t == "circle" else "axis"])
        r = np.linalg.norm(w - np.outer(w @ d, d), axis=1)
    else:
        z = features.associate(pts, np.arange(len(pts)), spec, "minzone")
        params, r = dict(z.params), z.residuals
        if spec.type == "line":
            params = {"point": params["point"], "axis": params["direction"], "diameter": params["zone"]}
    eps = 1e-9 * max(1.0, float(np.ptp(pts, axis=0).max()))
    if spec.type == "line":  # the thinnest cylinder: its diameter, the outermost points
        return 2.0 * float(r.max()), np.flatnonzero(r >= r.max() - eps), params
    return float(r.max() - r.min()), np.flatnonzero((r >= r.max() - eps) | (r <= r.min() + eps)), params


def _sections(c: _Case, a: Associated, pts: np.ndarray) -> list[tuple[np.ndarray, FeatureSpec]]:
    """The roundness sections of a cylinder or cone: ``sections`` equal slices along the
    axis (default one per 50 points, at most 20), each as a circle feature."""
    d = el.direction(a.type, a.params)
    assert d is not None
    p0 = el.location(a.type, a.params)
    h = (pts - p0) @ d
    n = int(c.spec.options.get("sections") or max(1, min(20, len(pts) // 50)))
    edges = np.linspace(h.min(), h.max(), n + 1)
    out = []
    for i in range(n):
        sel = np.flatnonzero((h >= edges[i]) & (h <= edges[i + 1]))
        if len(sel) >= 8:
            centre = p0 + float(np.mean(h[sel])) * d
            nominal = {"centre": centre, "normal": d, "diameter": float(a.params.get("diameter", 0.0))}
            out.append((sel, FeatureSpec(a.id, "circle", nominal, band=1.0)))
    if not out:
        raise NotEvaluated(f"{c.spec.id}: roundness: no section holds 8 points")
    return out


def _form(c: _Case) -> _Out:
    a = c.assoc()
    pts = c.pts()
    kind = c.spec.type
    if a.type not in _FORM_TYPES[kind]:
        raise InputError(f"{c.where}: {kind} needs a {' or '.join(_FORM_TYPES[kind])}, not a {a.type}")
    _need(len(pts), _FORM_MIN[kind], f"{c.spec.id}: {kind}")
    spec = c.plan.features[a.id]
    if kind == "roundness" and a.type != "circle":
        parts = _sections(c, a, pts)
    else:
        parts = [(np.arange(len(pts)), spec)]
    starts: list[dict | None] = [None] * len(parts)

    def solve(p: np.ndarray, keep: bool = False) -> tuple[float, np.ndarray]:
        best: tuple[float, np.ndarray] = (-1.0, np.zeros(0, dtype=np.int64))
        for i, (sel, sp) in enumerate(parts):
            v, dec, params = _zone(sp, p[sel], starts[i])
            if keep:
                starts[i] = params
            if v > best[0]:
                best = (v, sel[dec])
        return best

    value, dec = solve(pts, keep=True)
    return _Out(value, _global(a, dec), {"zone": "minimum zone"}, lambda A, P, t: solve(P[a.id])[0], mc=(a.id,))


def _float_fit(etype: str, params: dict, pts: np.ndarray) -> dict:
    """The nominal element moved rigidly (rotation about the points' centroid, shift) to
    its least-squares fit to the points (Gauss-Newton, numerical Jacobian)."""
    centre = pts.mean(axis=0)
    cur = dict(params)

    def moved(x: np.ndarray) -> dict:
        t = np.eye(4)
        t[:3, :3] = _rot(el.unit(x[:3]), float(np.linalg.norm(x[:3]))) if np.linalg.norm(x[:3]) > 0 else np.eye(3)
        t[:3, 3] = centre - t[:3, :3] @ centre + x[3:]
        return el.rigid(t, etype, cur)

    h = 1e-7
    for _ in range(30):
        r = features.surface_distance(pts, etype, cur)
        jac = np.column_stack(
            [
                (
                    features.surface_distance(pts, etype, moved(h * e))
                    - features.surface_distance(pts, etype, moved(-h * e))
                )
                / (2 * h)
                for e in np.eye(6)
            ]
        )
        # rcond: a rotation that does not move the surface (a sphere, an axis) is no step
        step = -np.linalg.lstsq(jac, r, rcond=1e-8)[0]
        cur = moved(step)
        if np.max(np.abs(step)) < 1e-13 * max(1.0, float(np.ptp(pts, axis=0).max())):
            break
    return cur


def _profile(c: _Case) -> _Out:
    a = c.assoc()
    pts = c.pts()
    etype, nominal = c.nominal()
    el.supported(etype, c.where)
    floating = not c.spec.datums
    _need(len(pts), 7 if floating else 1, f"{c.spec.id}: {c.spec.type}")
    t0 = c.transform()

    def deviations(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> np.ndarray:
        q = el.apply(c.transform_of(A, t), P[a.id])
        ref = _float_fit(etype, nominal, q) if floating else nominal
        return features.surface_distance(q, etype, ref)

    dev = deviations(c.associated, {a.id: pts}, t0)
    i = int(np.argmax(np.abs(dev)))
    return _Out(
        2.0 * float(np.abs(dev[i])),
        _global(a, np.array([i])),
        {"max": float(dev.max()), "min": float(dev.min()), "floated": floating},
        lambda A, P, t: 2.0 * float(np.abs(deviations(A, P, t)).max()),
        mc=(a.id,),
        ls=c.datum_features(),
    )


# ---- orientation -------------------------------------------------------------------


def _required_direction(c: _Case, etype: str, nominal: dict) -> tuple[np.ndarray, np.ndarray | None]:
    """Required direction of the feature (plan coordinates) and the axis of a rotation
    the datums leave free (None when fixed)."""
    if not c.spec.datums:
        raise InputError(f"{c.where}: {c.spec.type} needs datums")
    d = el.direction(etype, nominal)
    if d is None:
        raise InputError(f"{c.where}: {c.spec.type} needs a feature with a direction, not a {etype}")
    _, z, free = c.frame_axis()
    angle = c.spec.options.get("angle")
    if angle is not None:
        prim = c.plan.features[c.plan.datums[c.spec.datums[0]][0]]
        same = (prim.type == "plane") == (etype == "plane")
        theta = math.radians(float(angle) if same else 90.0 - float(angle))
        zz = z if d @ z >= 0 else -z  # the angle is between lines / planes: no sign
        h = d - (d @ zz) * zz
        if np.linalg.norm(h) < 1e-9:
            h = el.complement(zz)[0]
        d = math.cos(theta) * zz + math.sin(theta) * el.unit(h)
    rot_free = any(f.startswith("rotation") for f in free)
    if sum(f.startswith("rotation") for f in free) > 1:
        raise NotEvaluated(f"{c.spec.id}: the datums {'|'.join(c.spec.datums)} fix no direction")
    return d, (z if rot_free else None)


AxisEnds = Callable[[dict[str, Associated], np.ndarray], tuple[np.ndarray, np.ndarray]]


def _axis(c: _Case, a: Associated, pts: np.ndarray) -> tuple[AxisEnds, np.ndarray]:
    """The derived axis's two ends in plan coordinates, as a function of the associated
    features and the transform, and each point's axial coordinate (for the decisive
    points). The feature's extent: where the axis crosses the planes normal to the
    nominal axis through the nominal's ends when the nominal states a ``length`` (the
    issue's "at its bottom and top faces"), else the extent of the points along it."""
    etype, nominal = c.nominal(a.id)
    d0 = el.direction(a.type, a.params)
    assert d0 is not None
    h = (pts - el.location(a.type, a.params)) @ d0
    _check_extent(c, h)
    length = float(nominal.get("length") or 0.0)
    nd = el.direction(etype, nominal) if etype in _AXES else None
    lo, hi = float(h.min()), float(h.max())

    def ends(A: dict[str, Associated], t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        aa = A[a.id]
        p = t[:3, :3] @ el.location(aa.type, aa.params) + t[:3, 3]
        d = t[:3, :3] @ el.direction(aa.type, aa.params)
        if length > 0 and nd is not None and abs(float(d @ nd)) > 1e-3:
            n0 = el.location(etype, nominal)
            return tuple(p + d * float((n0 + s * nd - p) @ nd) / float(d @ nd) for s in (0.0, length))  # type: ignore[return-value]
        return p + lo * d, p + hi * d

    return ends, h


def _check_extent(c: _Case, h: np.ndarray) -> None:
    if float(np.ptp(h)) < 1e-6:
        raise NotEvaluated(f"{c.spec.id}: the axis has no extent (its points span {float(np.ptp(h)):.3g} mm)")


def _near_end(a: Associated, h: np.ndarray, which: int) -> np.ndarray:
    order = np.argsort(h if which == 0 else -h)
    return _global(a, order[:_NEAR])


def _orientation(c: _Case) -> _Out:
    a = c.assoc()
    pts = c.pts()
    etype, nominal = c.nominal()
    d_req, free_axis = _required_direction(c, etype, nominal)
    t0 = c.transform()

    def measured(A: dict[str, Associated], t: np.ndarray) -> np.ndarray:
        d = el.direction(a.type, A[a.id].params)
        assert d is not None
        return c.transform_of(A, t)[:3, :3] @ d

    if a.type == "plane":
        _need(len(pts), 4, f"{c.spec.id}: {c.spec.type}")

        def plane_value(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
            q = el.apply(c.transform_of(A, t), P[a.id])
            return _min_over_rotation(lambda d: float(np.ptp(q @ d)), d_req, free_axis, measured(A, t))[0]

        q0 = el.apply(t0, pts)
        value, d = _min_over_rotation(lambda d: float(np.ptp(q0 @ d)), d_req, free_axis, measured(c.associated, t0))
        s = q0 @ d
        dec = np.concatenate([np.flatnonzero(s >= s.max() - 1e-9), np.flatnonzero(s <= s.min() + 1e-9)])
        return _Out(value, _global(a, dec), {"direction": d.tolist()}, plane_value, mc=(a.id,), ls=c.datum_features())
    if a.type not in _AXES:
        raise InputError(f"{c.where}: {c.spec.type} needs a plane or an axis (cylinder, cone, line), not a {a.type}")
    _need(len(pts), 6 if a.type != "line" else 2, f"{c.spec.id}: {c.spec.type}")
    ends, h = _axis(c, a, pts)

    def axis_value(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
        e0, e1 = ends(A, c.transform_of(A, t))
        delta = e1 - e0
        return _min_over_rotation(lambda d: float(np.linalg.norm(delta - (delta @ d) * d)), d_req, free_axis, delta)[0]

    value = axis_value(c.associated, {}, t0)
    dec = np.concatenate([_near_end(a, h, 0), _near_end(a, h, 1)])
    return _Out(value, dec, {"zone": "diametral"}, axis_value, ls=(a.id, *c.datum_features()))


# ---- location ----------------------------------------------------------------------


def _radial(v: np.ndarray, d: np.ndarray) -> float:
    return float(np.linalg.norm(v - (v @ d) * d))


def _position(c: _Case) -> _Out:
    a = c.assoc()
    pts = c.pts()
    etype, nominal = c.nominal()
    t0 = c.transform()
    kind = c.spec.type
    ref_d: np.ndarray | None
    if kind in ("coaxiality", "concentricity"):
        if not c.spec.datums:
            raise InputError(f"{c.where}: {kind} needs a datum axis")
        o, z, _ = c.frame_axis()
        ref_p, ref_d = o, z
    else:
        ref_p = el.location(etype, nominal)
        ref_d = el.direction(etype, nominal)
    if a.type in _CENTRES or (kind == "concentricity" and a.type in _AXES):
        _need(len(pts), {"point": 1, "sphere": 4, "circle": 3}.get(a.type, 6), f"{c.spec.id}: {kind}")
        ends = _axis(c, a, pts)[0] if a.type in _AXES else None

        def centre_value(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
            tt = c.transform_of(A, t)
            aa = A[a.id]
            if ends is not None:
                cen = 0.5 * sum(ends(A, tt))
            else:
                cen = tt[:3, :3] @ el.location(aa.type, aa.params) + tt[:3, 3]
            v = cen - ref_p
            if kind == "concentricity":
                assert ref_d is not None
                return 2.0 * _radial(v, ref_d)
            return 2.0 * float(np.linalg.norm(v))

        return _Out(centre_value(c.associated, {}, t0), a.indices[:0], {}, centre_value, ls=(a.id, *c.datum_features()))
    if a.type in _AXES:
        if ref_d is None:
            raise InputError(f"{c.where}: {kind} of an axis needs a nominal axis, not a {etype}")
        _need(len(pts), 6 if a.type != "line" else 2, f"{c.spec.id}: {kind}")
        ends, h = _axis(c, a, pts)

        def offsets(A: dict[str, Associated], t: np.ndarray) -> list[np.ndarray]:
            out = []
            for e in ends(A, c.transform_of(A, t)):
                v = e - ref_p
                out.append(v - (v @ ref_d) * ref_d)
            return out

        def axis_value(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
            return 2.0 * max(float(np.linalg.norm(v)) for v in offsets(A, t))

        offs = offsets(c.associated, t0)
        which = int(np.argmax([np.linalg.norm(v) for v in offs]))
        return _Out(
            axis_value(c.associated, {}, t0),
            _near_end(a, h, which),
            {"offsets": [v.tolist() for v in offs], "zone": "diametral"},
            axis_value,
            ls=(a.id, *c.datum_features()),
        )
    if a.type == "plane" and kind == "position":
        return _profile(c) if c.spec.datums else _no_datums(c)
    raise InputError(f"{c.where}: {kind} of a {a.type} is not supported")


def _no_datums(c: _Case) -> _Out:
    raise InputError(f"{c.where}: {c.spec.type} needs datums")


def _median_heights(
    A: dict[str, Associated], fids: tuple[str, str], q: np.ndarray, n0: np.ndarray, o: np.ndarray, t: np.ndarray
) -> np.ndarray:
    """Heights along n0 (from o) of the median of the two associated planes at the
    lateral positions of the points q (plan coordinates)."""
    hs = []
    for fid in fids:
        pa = el.rigid(t, "plane", A[fid].params)
        n, p = el.unit(pa["normal"]), np.asarray(pa["point"])
        s = ((p - q) @ n) / float(n0 @ n)
        hs.append((q - o) @ n0 + s)
    return 0.5 * (hs[0] + hs[1])


def _symmetry(c: _Case) -> _Out:
    a = c.assoc()
    other = c.other()
    b = c.assoc(other)
    if a.type != "plane" or b.type != "plane":
        raise InputError(f"{c.where}: symmetry needs two planes (feature and other)")
    if not c.spec.datums:
        raise InputError(f"{c.where}: symmetry needs a datum")
    etype, nominal = c.nominal()
    n0 = el.direction(etype, nominal)
    assert n0 is not None
    o, _, _ = c.frame_axis()
    t0 = c.transform()
    pts = np.vstack([c.pts(), c.pts(other)])
    idx = np.concatenate([a.indices, b.indices])
    _need(len(pts), 6, f"{c.spec.id}: symmetry")

    def medians(A: dict[str, Associated], t: np.ndarray) -> np.ndarray:
        tt = c.transform_of(A, t)
        return _median_heights(A, (a.id, other), el.apply(t0, pts), n0, o, tt)

    m = medians(c.associated, t0)
    i = int(np.argmax(np.abs(m)))
    return _Out(
        2.0 * float(np.abs(m[i])),
        idx[[i]],
        {"median_max": float(m.max()), "median_min": float(m.min())},
        lambda A, P, t: 2.0 * float(np.abs(medians(A, t)).max()),
        ls=(a.id, other, *c.datum_features()),
    )


# ---- runout ------------------------------------------------------------------------


def _runout(c: _Case) -> _Out:
    a = c.assoc()
    pts = c.pts()
    if not c.spec.datums:
        raise InputError(f"{c.where}: {c.spec.type} needs a datum axis")
    o, z, _ = c.frame_axis()
    t0 = c.transform()
    axial = a.type == "plane"
    _need(len(pts), 3, f"{c.spec.id}: {c.spec.type}")
    n_sec = int(c.spec.options.get("sections") or max(1, min(20, len(pts) // 50)))
    total = c.spec.type == "total-runout"

    def coords(P: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = el.apply(t, P) - o
        h = q @ z
        rho = np.linalg.norm(q - np.outer(h, z), axis=1)
        return (h, rho) if axial else (rho, h)  # (measured, slicing coordinate)

    def runout(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> tuple[float, np.ndarray]:
        m, s = coords(P[a.id], c.transform_of(A, t))
        if total:
            return float(np.ptp(m)), np.array([int(np.argmax(m)), int(np.argmin(m))])
        edges = np.linspace(s.min(), s.max(), n_sec + 1)
        best, dec = -1.0, np.zeros(0, dtype=np.int64)
        for i in range(n_sec):
            sel = np.flatnonzero((s >= edges[i]) & (s <= edges[i + 1]))
            if len(sel) < 3:
                continue
            r = float(np.ptp(m[sel]))
            if r > best:
                best, dec = r, sel[[int(np.argmax(m[sel])), int(np.argmin(m[sel]))]]
        return best, dec

    value, dec = runout(c.associated, {a.id: pts}, t0)
    if value < 0:
        raise NotEvaluated(f"{c.spec.id}: no section holds 3 points")
    return _Out(
        value,
        _global(a, dec),
        {"sections": 1 if total else n_sec, "direction": "axial" if axial else "radial"},
        lambda A, P, t: runout(A, P, t)[0],
        mc=(a.id,),
        ls=c.datum_features(),
    )


# ---- size --------------------------------------------------------------------------


def _reference(etype: str, params: dict, pts: np.ndarray | None) -> tuple[int, np.ndarray, np.ndarray | None]:
    """(rank, reference point, direction): plane 2 (projected centroid), axis 1 (middle
    at the extent), centre 0."""
    d = el.direction(etype, params)
    p = el.location(etype, params)
    if etype == "plane":
        assert d is not None
        cen = pts.mean(axis=0) if pts is not None and len(pts) else p
        return 2, cen - ((cen - p) @ d) * d, d
    if etype in _AXES:
        assert d is not None
        lo, hi = el.axial_extent(etype, params, pts)
        return 1, p + 0.5 * (lo + hi) * d, d
    return 0, p, None


def _point_to(rank: int, p: np.ndarray, d: np.ndarray | None, x: np.ndarray) -> float:
    v = x - p
    if rank == 2:
        assert d is not None
        return abs(float(v @ d))
    if rank == 1:
        assert d is not None
        return _radial(v, d)
    return float(np.linalg.norm(v))


def element_distance(
    e1: tuple[int, np.ndarray, np.ndarray | None], e2: tuple[int, np.ndarray, np.ndarray | None]
) -> float:
    """Distance (mm) between two references of :func:`_reference` (module docstring)."""
    if e1[0] == e2[0] and e1[0] > 0:
        return 0.5 * (_point_to(*e2, e1[1]) + _point_to(*e1, e2[1]))
    hi, lo = (e1, e2) if e1[0] > e2[0] else (e2, e1)
    return _point_to(*hi, lo[1])


def _local(a: Associated, pts: np.ndarray, start: int = 0) -> Associated:
    """``a`` indexing ``pts`` placed at ``start`` of a cloud of its own (for size.py,
    which takes the whole cloud and the feature's indices)."""
    return replace(a, indices=np.arange(start, start + len(pts)))


def _size(c: _Case) -> _Out:
    a = c.assoc()
    pts = c.pts()
    kind = c.spec.type
    etype, nominal = c.nominal()
    details: dict[str, Any] = {}
    if kind == "diameter":
        if "diameter" not in a.params:
            raise InputError(f"{c.where}: diameter needs a circle, cylinder or sphere, not a {a.type}")
        _need(len(pts), {"circle": 4, "sphere": 5}.get(a.type, 6), f"{c.spec.id}: diameter")
        criterion = str(c.spec.options.get("criterion") or a.association)
        nom = float(c.spec.options.get("nominal", nominal.get("diameter", math.nan)))
        if criterion == "ls" and a.association == "ls":

            def value_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                return float(A[a.id].params["diameter"])

            extremes = np.array([int(np.argmax(a.residuals)), int(np.argmin(a.residuals))])
            out = _Out(value_fn(c.associated, {}, np.eye(4)), _global(a, extremes), details, value_fn, ls=(a.id,))
        else:

            def value_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                return float(size.global_size(P[a.id], _local(A[a.id], P[a.id]), criterion))

            out = _Out(value_fn(c.associated, {a.id: pts}, np.eye(4)), a.indices[:0], details, value_fn, mc=(a.id,))
        details["criterion"] = criterion
        try:
            local = size.two_point_sizes(c.points, a)
        except GeometryError:
            local = np.zeros(0)
        if len(local):
            details["two_point_min"], details["two_point_max"] = float(local.min()), float(local.max())
    else:
        other = c.other()
        b = c.assoc(other)
        pb = c.pts(other)
        o_type, o_nom = c.nominal(other)
        nom_default = element_distance(_reference(etype, nominal, None), _reference(o_type, o_nom, None))
        nom = float(c.spec.options.get("nominal", nom_default))
        if kind == "width":
            if a.type != "plane" or b.type != "plane":
                raise InputError(f"{c.where}: width needs two planes (feature and other)")
            _need(min(len(pts), len(pb)), 3, f"{c.spec.id}: width")

            def width_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                both = np.vstack([P[a.id], P[other]])
                return size.width(both, _local(A[a.id], P[a.id]), _local(A[other], P[other], len(P[a.id])))

            out = _Out(width_fn(c.associated, {a.id: pts, other: pb}, np.eye(4)), a.indices[:0], details, width_fn)
            out.mc = (a.id, other)
        else:

            def value_fn(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
                return element_distance(
                    _reference(a.type, A[a.id].params, pts), _reference(b.type, A[other].params, pb)
                )

            out = _Out(value_fn(c.associated, {}, np.eye(4)), a.indices[:0], details, value_fn, ls=(a.id, other))
    details["nominal"] = nom
    details["deviation"] = out.value - nom if math.isfinite(nom) else None
    return out


# ---- dispatch ----------------------------------------------------------------------

_EVALUATORS: dict[str, Callable[[_Case], _Out]] = {
    "straightness": _form,
    "flatness": _form,
    "roundness": _form,
    "cylindricity": _form,
    "line-profile": _profile,
    "surface-profile": _profile,
    "profile": _profile,
    "parallelism": _orientation,
    "perpendicularity": _orientation,
    "angularity": _orientation,
    "position": _position,
    "coaxiality": _position,
    "concentricity": _position,
    "symmetry": _symmetry,
    "circular-runout": _runout,
    "total-runout": _runout,
    "diameter": _size,
    "width": _size,
    "distance": _size,
}
assert set(_EVALUATORS) == {t for ts in CHARACTERISTICS.values() for t in ts}


def _uncertainty(c: _Case, out: _Out) -> tuple[float, str, dict[str, float]]:
    """u (k = 1), its method and each part (see :mod:`.uncertainty`)."""
    t0 = c.transform()
    parts: dict[str, float] = {}
    base_pts = {fid: c.pts(fid) for fid in out.mc}
    covs = {}
    for fid in out.ls:
        cv = unc.covariance(c.assoc(fid), c.pts(fid))
        if cv is None:
            return float("nan"), _LS, parts
        covs[fid] = cv
    if covs:
        parts["covariance"] = unc.propagate(lambda A: out.fn(A, base_pts, t0), c.associated, covs)
    if out.mc:
        clouds = {fid: (p, unc.noise_sigma(p, c.assoc(fid).residuals)) for fid, p in base_pts.items()}
        parts["monte-carlo"] = unc.monte_carlo(lambda moved: out.fn(c.associated, moved, t0), clouds)
    method = (_MC + (" (+ datums: " + _LS + ")" if covs else "")) if out.mc else _LS
    return unc.combined(*parts.values()), method, parts


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
    c = _Case(spec, plan, np.asarray(points, dtype=float), associated, frames)
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
