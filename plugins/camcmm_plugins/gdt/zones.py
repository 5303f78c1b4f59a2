"""Zone characteristics of ISO 1101: form, orientation and location (the definitions as
computed are in :mod:`.characteristics`' docstring). Each evaluator takes a
:class:`.case.Case` and returns an :class:`.case.Out`."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from camcmm.api import InputError

from . import elements as el
from . import features
from .case import AXES, CENTRES, Case, NotEvaluated, Out, need, to_global
from .model import Associated, FeatureSpec

_NEAR = 8  # decisive points reported near an axis end


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


def _sections(c: Case, a: Associated, pts: np.ndarray) -> list[tuple[np.ndarray, FeatureSpec]]:
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


def form(c: Case) -> Out:
    a = c.assoc()
    pts = c.pts()
    kind = c.spec.type
    if a.type not in _FORM_TYPES[kind]:
        raise InputError(f"{c.where}: {kind} needs a {' or '.join(_FORM_TYPES[kind])}, not a {a.type}")
    need(len(pts), _FORM_MIN[kind], f"{c.spec.id}: {kind}")
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
    return Out(value, to_global(a, dec), {"zone": "minimum zone"}, lambda A, P, t: solve(P[a.id])[0], mc=(a.id,))


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


def profile(c: Case) -> Out:
    a = c.assoc()
    pts = c.pts()
    etype, nominal = c.nominal()
    el.supported(etype, c.where)
    floating = not c.spec.datums
    need(len(pts), 7 if floating else 1, f"{c.spec.id}: {c.spec.type}")
    t0 = c.transform()

    def deviations(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> np.ndarray:
        q = el.apply(c.transform_of(A, t), P[a.id])
        ref = _float_fit(etype, nominal, q) if floating else nominal
        return features.surface_distance(q, etype, ref)

    dev = deviations(c.associated, {a.id: pts}, t0)
    i = int(np.argmax(np.abs(dev)))
    return Out(
        2.0 * float(np.abs(dev[i])),
        to_global(a, np.array([i])),
        {"max": float(dev.max()), "min": float(dev.min()), "floated": floating},
        lambda A, P, t: 2.0 * float(np.abs(deviations(A, P, t)).max()),
        mc=(a.id,),
        ls=c.datum_features(),
    )


# ---- orientation -------------------------------------------------------------------


def _required_direction(c: Case, etype: str, nominal: dict) -> tuple[np.ndarray, np.ndarray | None]:
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


def _axis(c: Case, a: Associated, pts: np.ndarray) -> tuple[AxisEnds, np.ndarray]:
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
    nd = el.direction(etype, nominal) if etype in AXES else None
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


def _check_extent(c: Case, h: np.ndarray) -> None:
    if float(np.ptp(h)) < 1e-6:
        raise NotEvaluated(f"{c.spec.id}: the axis has no extent (its points span {float(np.ptp(h)):.3g} mm)")


def _near_end(a: Associated, h: np.ndarray, which: int) -> np.ndarray:
    order = np.argsort(h if which == 0 else -h)
    return to_global(a, order[:_NEAR])


def orientation(c: Case) -> Out:
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
        need(len(pts), 4, f"{c.spec.id}: {c.spec.type}")

        def plane_value(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
            q = el.apply(c.transform_of(A, t), P[a.id])
            return _min_over_rotation(lambda d: float(np.ptp(q @ d)), d_req, free_axis, measured(A, t))[0]

        q0 = el.apply(t0, pts)
        value, d = _min_over_rotation(lambda d: float(np.ptp(q0 @ d)), d_req, free_axis, measured(c.associated, t0))
        s = q0 @ d
        dec = np.concatenate([np.flatnonzero(s >= s.max() - 1e-9), np.flatnonzero(s <= s.min() + 1e-9)])
        return Out(value, to_global(a, dec), {"direction": d.tolist()}, plane_value, mc=(a.id,), ls=c.datum_features())
    if a.type not in AXES:
        raise InputError(f"{c.where}: {c.spec.type} needs a plane or an axis (cylinder, cone, line), not a {a.type}")
    need(len(pts), 6 if a.type != "line" else 2, f"{c.spec.id}: {c.spec.type}")
    ends, h = _axis(c, a, pts)

    def axis_value(A: dict[str, Associated], P: dict[str, np.ndarray], t: np.ndarray) -> float:
        e0, e1 = ends(A, c.transform_of(A, t))
        delta = e1 - e0
        return _min_over_rotation(lambda d: float(np.linalg.norm(delta - (delta @ d) * d)), d_req, free_axis, delta)[0]

    value = axis_value(c.associated, {}, t0)
    dec = np.concatenate([_near_end(a, h, 0), _near_end(a, h, 1)])
    return Out(value, dec, {"zone": "diametral"}, axis_value, ls=(a.id, *c.datum_features()))


# ---- location ----------------------------------------------------------------------


def _radial(v: np.ndarray, d: np.ndarray) -> float:
    return float(np.linalg.norm(v - (v @ d) * d))


def position(c: Case) -> Out:
    a = c.assoc()
    pts = c.pts()
    etype, nominal = c.nominal()
    t0 = c.transform()
    kind = c.spec.type
    ref_d: np.ndarray | None
    if kind in ("coaxiality", "concentricity"):
        o, z = c.datum_axis()
        ref_p, ref_d = o, z
    else:
        ref_p = el.location(etype, nominal)
        ref_d = el.direction(etype, nominal)
    if a.type in CENTRES or (kind == "concentricity" and a.type in AXES):
        need(len(pts), {"point": 1, "sphere": 4, "circle": 3}.get(a.type, 6), f"{c.spec.id}: {kind}")
        ends = _axis(c, a, pts)[0] if a.type in AXES else None

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

        return Out(centre_value(c.associated, {}, t0), a.indices[:0], {}, centre_value, ls=(a.id, *c.datum_features()))
    if a.type in AXES:
        if ref_d is None:
            raise InputError(f"{c.where}: {kind} of an axis needs a nominal axis, not a {etype}")
        need(len(pts), 6 if a.type != "line" else 2, f"{c.spec.id}: {kind}")
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
        return Out(
            axis_value(c.associated, {}, t0),
            _near_end(a, h, which),
            {"offsets": [v.tolist() for v in offs], "zone": "diametral"},
            axis_value,
            ls=(a.id, *c.datum_features()),
        )
    if a.type == "plane" and kind == "position" and c.spec.options.get("other"):
        return symmetry(c)  # a width's median plane (a slot, a tab) at its true position
    if a.type == "plane" and kind == "position":
        return profile(c) if c.spec.datums else _no_datums(c)
    raise InputError(f"{c.where}: {kind} of a {a.type} is not supported")


def _no_datums(c: Case) -> Out:
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


def symmetry(c: Case) -> Out:
    """Symmetry: the median of ``feature`` and ``other`` against the datum median plane
    (through the frame's origin, normal to the feature's nominal normal); position of the
    same median (ASME Y14.5 §7: a width's centre plane): against its true position, the
    median of the two nominal planes."""
    a = c.assoc()
    other = c.other()
    b = c.assoc(other)
    kind = c.spec.type
    if a.type != "plane" or b.type != "plane":
        raise InputError(f"{c.where}: {kind} of a median plane needs two planes (feature and other)")
    if not c.spec.datums:
        raise InputError(f"{c.where}: {kind} needs a datum")
    etype, nominal = c.nominal()
    n0 = el.direction(etype, nominal)
    assert n0 is not None
    o, _, _ = c.frame_axis()
    if kind == "position":
        o_type, o_nominal = c.nominal(other)
        o = 0.5 * (el.location(etype, nominal) + el.location(o_type, o_nominal))
    t0 = c.transform()
    pts = np.vstack([c.pts(), c.pts(other)])
    idx = np.concatenate([a.indices, b.indices])
    need(len(pts), 6, f"{c.spec.id}: {kind}")

    def medians(A: dict[str, Associated], t: np.ndarray) -> np.ndarray:
        tt = c.transform_of(A, t)
        return _median_heights(A, (a.id, other), el.apply(t0, pts), n0, o, tt)

    m = medians(c.associated, t0)
    i = int(np.argmax(np.abs(m)))
    return Out(
        2.0 * float(np.abs(m[i])),
        idx[[i]],
        {"median_max": float(m.max()), "median_min": float(m.min())},
        lambda A, P, t: 2.0 * float(np.abs(medians(A, t)).max()),
        ls=(a.id, other, *c.datum_features()),
    )
