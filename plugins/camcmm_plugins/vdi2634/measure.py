"""Evaluate one measurement of an acceptance test: sphere, ball bar, flat, ball plate.

Every fit is asked of the host by id (``fit.sphere``, ``fit.plane``, ``segment.spheres``,
``segment.sphere``), so a lab can substitute its own certified fitting. Lengths in mm.

Each ``evaluate_*`` returns a JSON-able dict with ``values`` (the quality parameters
this measurement yields: ``{"PF": ..., "PS": ...}``, ``{"SD": ...}``, ``{"F": ...}``,
or ``{"SD": [SD1, SD2, SD3]}`` for a ball plate), the fit details, ``warnings``, and
``deviations``: a PointCloud with the per-point field ``deviation`` (mm) for the
colour map. Bad input raises InputError/GeometryError with one line naming the file.

Quality parameters (VDI/VDE 2634 part 2, thesis ch. 2.7.1, eqs. 2.28, 2.29):
P_F = range of the radial deviations from the least-squares sphere after the outlier
rule; P_S = D_a - D_r; SD = L_a - L_r (distance of the least-squares centres);
F = range of the distances from the least-squares plane.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any, cast

import numpy as np

from camcmm.api import CamcmmError, GeometryError, InputError, PointCloud, decide_unit, read, suggest_unit

from . import scaling
from .plan import Plan, PlannedMeasurement
from .segment import detect

#: A fitted diameter this far from the calibrated one means "no such sphere here".
SIZE_TOLERANCE = 0.25


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def load(item: PlannedMeasurement) -> tuple[PointCloud, str]:
    """Read a planned measurement's cloud (mm) and hash its file."""
    if item.file is None or not item.file.is_file():
        raise InputError(f"{item.name}: file not found ({item.key}: {item.file})")
    cloud = read(item.file, unit=item.unit)
    if not hasattr(cloud, "n_points"):
        raise InputError(f"{item.name}: holds a {type(cloud).__name__}, not a point cloud")
    return cast(PointCloud, cloud), sha256(item.file)


def _name(cloud: PointCloud, name: str | None) -> str:
    return name or str(getattr(cloud, "name", "cloud"))


#: The units an acceptance test's files come in (a scanner's mm or m; µm from a fine
#: instrument): the candidates of the shared unit rule (camcmm.api.decide_unit) here.
UNITS = ("m", "mm", "um")


def _unit_words(name: str, found: str, unit: str, size: str) -> str:
    """The wizard's wording of a unit the shared rule suggests instead of ``unit``."""
    if found == "m" and unit != "m":
        return f"{size}; it looks like metres; convert it or give its unit (unit: m in the plan)"
    if unit == "m" and found == "mm":
        return f"{size}; it looks like a file in mm read as metres; check the unit the plan gives it"
    return f"{size}; it looks like {found.replace('um', 'µm')}; convert it or give its unit (unit: {found} in the plan)"


def _unit(cloud: PointCloud) -> str:
    """The unit the cloud's file was read in (the plan's ``unit``, the file's, else mm)."""
    return getattr(cloud, "source_unit", "mm") or "mm"


def _span(points: np.ndarray) -> list[float]:
    """(3,) extent of points (N, 3), mm: max - min per axis, exactly as np.ptp(axis=0) but on
    a transposed copy, whose contiguous rows numpy reduces ~40x faster than columns."""
    t = np.ascontiguousarray(points.T)
    return (t.max(axis=1) - t.min(axis=1)).tolist()


def check_extent(cloud: PointCloud, expected: float, name: str, what: str) -> None:
    """Refuse a cloud whose size says it is in the wrong unit (or is no such artefact).

    ``expected`` is the artefact's size in mm. The decision is camcmm's one unit rule
    (``decide_unit`` with the expected size, docs/units.md): the cloud's diagonal must
    lie within expected/50 .. 50 x expected, else a unit that brings it to 0.05 .. 20 x
    expected is named: a cloud 1000 times too small is a file in metres read as mm, one
    1000 times too large a file in mm read as metres (``unit: m`` in the plan on mm files)."""
    if cloud.n_points < 10:
        raise GeometryError(f"{name}: only {cloud.n_points} points; too few for a {what}")
    span = _span(cloud.points)
    unit = _unit(cloud)
    check = decide_unit(span, unit, unit=unit, expected=expected, name=name, what=what, units=UNITS)
    if check.asks and check.suggested:
        extent = float(np.linalg.norm(span))
        size = f"{name}: the cloud spans {extent:.4g} mm but a {what} of {expected:g} mm was expected"
        raise InputError(_unit_words(name, check.suggested, unit, size))


def _fit(ctx, plugin: str, name: str, expect: str = "", **kw) -> dict[str, Any]:
    """Run a fit by id; its GeometryError becomes one line naming the file (and what
    was expected there, e.g. "no sphere of diameter 20.001 mm: ...")."""
    try:
        return ctx.algorithm(plugin)(**kw)
    except GeometryError as exc:
        raise GeometryError(f"{name}: {expect + ': ' if expect else ''}{exc}") from None


def _plain(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items()}


def _scaled(cloud: PointCloud | None, s: float) -> PointCloud | None:
    """A deviations cloud scaled by s (points and the deviation field)."""
    if cloud is None or s == 1.0:
        return cloud
    fields = dict(cloud.fields)
    if "deviation" in fields:
        fields["deviation"] = fields["deviation"] * s
    return PointCloud(cloud.points * s, cloud.colors, cloud.normals, fields, dict(cloud.field_units), cloud.name)


def _sphere_summary(fit: dict[str, Any], s: float = 1.0) -> dict[str, Any]:
    form = {k: v * s for k, v in fit["form"].items()}
    return {
        "center": (np.asarray(fit["center"]) * s).tolist(),
        "diameter": 2 * fit["radius"] * s,
        "radius": fit["radius"] * s,
        "form": form,
        "n_points": fit["n_points"],
        "n_used": fit["n_used"],
        "n_removed": fit["n_removed"],
        "std_uncertainty": {k: (np.asarray(v) * s).tolist() for k, v in fit["std_uncertainty"].items()},
    }


# -- sphere -----------------------------------------------------------------------------------
def _size_check(d_fit: float, d_ref: float, name: str, what: str, unit: str = "mm") -> None:
    if abs(d_fit - d_ref) <= SIZE_TOLERANCE * d_ref:
        return
    # the shared unit rule, narrowed to a fitted diameter: another unit must bring it
    # within a factor 2 of the calibrated one (VDI 2634's 500-2000 ratios for m <-> mm)
    found = suggest_unit(d_fit, d_ref, unit, within=(0.5, 2.0), units=UNITS)
    if found is not None:
        size = f"{name}: the fitted {what} diameter is {d_fit:.4g} mm, about {_ratio(d_fit, d_ref)} {d_ref:g} mm"
        raise InputError(_unit_words(name, found, unit, size))
    raise GeometryError(
        f"{name}: no {what} of diameter {d_ref:g} mm in it (the least-squares sphere has "
        f"diameter {d_fit:.4g} mm); is this the right file?"
    )


def _ratio(a: float, b: float) -> str:
    return f"1/{b / a:.0f} of" if a < b else f"{a / b:.0f} x"


def evaluate_sphere(ctx, cloud: PointCloud, plan: Plan, name: str | None = None) -> dict[str, Any]:
    """P_F and P_S of one sphere measurement (scaled by calibrated radii in part 3)."""
    name = _name(cloud, name)
    d_ref = plan.required("sphere", "diameter")
    rule = plan.rule("sphere")
    warnings: list[str] = []
    if plan.scaling.get("sphere", "none") == "radii":
        return _sphere_scaled(ctx, cloud, plan, name, rule)
    check_extent(cloud, d_ref, name, "sphere")
    kw = {"extract": True, "nominal_radius": d_ref / 2} if plan.options.get("extract_sphere") else {}
    fit = _fit(ctx, "fit.sphere", name, f"no sphere of diameter {d_ref:g} mm", cloud=cloud, outliers=rule, **kw)
    _size_check(2 * fit["radius"], d_ref, name, "sphere", _unit(cloud))
    if fit["n_points"] < 334 and rule == "vdi2634":
        warnings.append(f"{name}: {fit['n_points']} points; below 334 the 3 per 1000 rule removes nothing")
    out = _sphere_summary(fit)
    out.update(
        {
            "test": "sphere",
            "outliers": rule,
            "diameter_calibrated": d_ref,
            "scale": 1.0,
            "values": {"PF": fit["form"]["range"], "PS": 2 * fit["radius"] - d_ref},
            "warnings": warnings,
            "deviations": fit.get("deviations"),
        }
    )
    return out


def _sphere_scaled(ctx, cloud: PointCloud, plan: Plan, name: str, rule: str) -> dict[str, Any]:
    """Part 3: the cloud holds the probing sphere and scale spheres (ball-plate spheres of
    calibrated diameter) in a reconstruction of arbitrary scale (thesis ch. 4.5.1)."""
    d_ref = plan.required("sphere", "diameter")
    d_scale = plan.value("ball_plate", "sphere_diameter")
    if d_scale is None:
        raise InputError(f"{name}: scaling.sphere is radii but artefacts.ball_plate.sphere_diameter is missing")
    found = scaling.find_spheres_by_ratio(ctx, cloud, name, d_ref, d_scale)
    fits = [_fit(ctx, "fit.sphere", name, cloud=cloud.subset(idx), outliers=rule) for idx in found]
    s = scaling.by_radii([f["radius"] for f in fits[1:]], d_scale / 2)
    main = fits[0]
    out = _sphere_summary(main, s)
    out.update(
        {
            "test": "sphere",
            "outliers": rule,
            "diameter_calibrated": d_ref,
            "scale": s,
            "scaling": "radii",
            "scale_spheres": [_sphere_summary(f, s) for f in fits[1:]],
            "values": {"PF": main["form"]["range"] * s, "PS": 2 * main["radius"] * s - d_ref},
            "warnings": [],
            "deviations": _scaled(main.get("deviations"), s),
        }
    )
    return out


# -- ball bar ---------------------------------------------------------------------------------
def _merge(given: list[PointCloud | None], name: str) -> PointCloud | None:
    clouds = [c for c in given if c is not None]
    if not clouds:
        return None
    return PointCloud(
        np.vstack([c.points for c in clouds]),
        fields={
            "deviation": np.concatenate([c.fields["deviation"] for c in clouds]),
            "sphere": np.concatenate([np.full(c.n_points, i + 1.0) for i, c in enumerate(clouds)]),
        },
        field_units={"deviation": "mm"},
        name=f"{name} deviations",
    )


def evaluate_ball_bar(ctx, cloud: PointCloud, plan: Plan, name: str | None = None) -> dict[str, Any]:
    """SD = L_a - L_r of one ball-bar measurement; both spheres in one cloud, found
    automatically; each fitted with the plan's outlier rule."""
    name = _name(cloud, name)
    l_ref = plan.required("ball_bar", "length")
    d_nom = plan.required("ball_bar", "sphere_diameter")
    rule = plan.rule("ball_bar")
    mode = plan.scaling.get("ball_bar", "none")
    radius = d_nom / 2
    if mode == "none":
        check_extent(cloud, l_ref + d_nom, name, "ball bar")
    else:
        radius = scaling.estimate_radius(ctx, cloud, name)
    parts = detect(ctx, cloud, name, radius, 2, "ball bar")
    fits = [_fit(ctx, "fit.sphere", name, cloud=cloud.subset(idx), outliers=rule) for idx in parts]
    s = scaling.by_radii([f["radius"] for f in fits], d_nom / 2) if mode == "radii" else 1.0
    if mode == "none":
        for f in fits:
            _size_check(2 * f["radius"], d_nom, name, "ball-bar sphere", _unit(cloud))
    axis = np.asarray(fits[1]["center"]) - np.asarray(fits[0]["center"])
    l_a = s * float(np.linalg.norm(axis))
    # the fits' own standard uncertainty of the length (centres along the bar's axis):
    # large when a sphere is seen only as a small cap, which the operator should know
    axis /= np.linalg.norm(axis)
    u_len = s * float(np.sqrt(sum(np.sum((np.asarray(f["std_uncertainty"]["center"]) * axis) ** 2) for f in fits)))
    warnings = []
    mpe = plan.mpe.get("SD")
    if mpe and np.isfinite(u_len) and u_len > 0.1 * mpe:
        worst = min(range(2), key=lambda k: fits[k]["n_points"])
        warnings.append(
            f"{name}: the length is uncertain by {u_len:.4f} mm (more than 1/10 of MPE SD): sphere "
            f"{worst + 1} is seen on {fits[worst]['n_points']} points only; "
            "turn the bar towards the sensor"
        )
    return {
        "test": "ball_bar",
        "outliers": rule,
        "scale": s,
        "scaling": mode,
        "n_points": cloud.n_points,
        "n_assigned": int(sum(len(p) for p in parts)),
        "spheres": [_sphere_summary(f, s) for f in fits],
        "length": l_a,
        "length_calibrated": l_ref,
        "u_length": u_len,
        "values": {"SD": l_a - l_ref},
        "warnings": warnings,
        "deviations": _scaled(_merge([f.get("deviations") for f in fits], name), s),
    }


# -- flat -------------------------------------------------------------------------------------
def evaluate_flat(ctx, cloud: PointCloud, plan: Plan, name: str | None = None) -> dict[str, Any]:
    """F: range of the distances from the least-squares plane after the outlier rule."""
    name = _name(cloud, name)
    length, width = plan.required("flat", "length"), plan.required("flat", "width")
    rule = plan.rule("flat")
    check_extent(cloud, float(np.hypot(length, width)), name, "flat")
    fit = _fit(ctx, "fit.plane", name, cloud=cloud, outliers=rule)
    normal = np.asarray(fit["normal"])
    # the covered length along the flat's long axis; a subsample sees the same extent
    # to within its point spacing, at a fraction of the cost
    x = cloud.points[:: max(1, cloud.n_points // 50_000)] - np.asarray(fit["point"])
    inplane = x - np.outer(x @ normal, normal)
    axis = np.linalg.svd(inplane[:: max(1, len(x) // 5000)], full_matrices=False)[2][0]
    covered = float(np.ptp(inplane @ axis))
    warnings = []
    if covered < 0.5 * plan.diagonal:
        warnings.append(
            f"{name}: the measured part of the flat spans {covered:.4g} mm, less than 0.5 of the "
            f"volume diagonal ({0.5 * plan.diagonal:.4g} mm)"
        )
    return {
        "test": "flat",
        "outliers": rule,
        "point": list(map(float, fit["point"])),
        "normal": normal.tolist(),
        "form": fit["form"],
        "n_points": fit["n_points"],
        "n_used": fit["n_used"],
        "n_removed": fit["n_removed"],
        "covered_length": covered,
        "values": {"F": fit["form"]["range"]},
        "warnings": warnings,
        "deviations": fit.get("deviations"),
    }


# -- ball plate (part 3) ----------------------------------------------------------------------
def evaluate_ball_plate(ctx, cloud: PointCloud, plan: Plan, name: str | None = None) -> dict[str, Any]:
    """SD of the three calibrated lengths of a ball plate (thesis ch. 4.5.2), the
    reconstruction scaled by the plan's rule: ``lengths`` (eqs. 4.10-4.12), ``radii``
    (calibrated sphere diameters) or ``none`` (a metric system)."""
    name = _name(cloud, name)
    d_nom = plan.required("ball_plate", "sphere_diameter")
    l_cal = [plan.required("ball_plate", f"length_{i}") for i in (1, 2, 3)]
    rule = plan.rule("ball_plate")
    mode = plan.scaling.get("ball_plate", "none")
    if mode == "none":
        check_extent(cloud, max(l_cal) + d_nom, name, "ball plate")
        radius = d_nom / 2
    else:
        radius = scaling.estimate_radius(ctx, cloud, name)
    try:
        parts = detect(ctx, cloud, name, radius, 3, "ball plate")
    except GeometryError:
        if mode == "none":
            raise
        # RANSAC can join three noisy caps into one larger sphere; a cloud already in mm
        # (a system that scales its own reconstruction) still has the nominal radius
        parts = detect(ctx, cloud, name, d_nom / 2, 3, "ball plate")
    fits = [_fit(ctx, "fit.sphere", name, cloud=cloud.subset(idx), outliers=rule) for idx in parts]
    centres = np.array([f["center"] for f in fits], dtype=float)
    order = scaling.order_plate(centres, l_cal, name)
    fits = [fits[i] for i in order]
    centres = centres[order]
    l_rec = [float(np.linalg.norm(centres[(k + 1) % 3] - centres[k])) for k in range(3)]
    warnings: list[str] = []
    if mode == "lengths":
        # before they scale anything: are the calibrated lengths this plate's at all?
        w = scaling.check_lengths(plan.source, l_cal, l_rec, [f["radius"] for f in fits], d_nom, name)
        warnings += [w] if w else []
        l_m = scaling.ball_plate_lengths(l_rec, l_cal)
        s = float(np.mean(np.asarray(l_m) / np.asarray(l_rec)))
    else:
        s = scaling.by_radii([f["radius"] for f in fits], d_nom / 2) if mode == "radii" else 1.0
        l_m = [s * x for x in l_rec]
    if mode == "none":
        for f in fits:
            _size_check(2 * f["radius"], d_nom, name, "ball-plate sphere", _unit(cloud))
    sd = [m - c for m, c in zip(l_m, l_cal)]
    return {
        "test": "ball_plate",
        "outliers": rule,
        "scaling": mode,
        "scale": s,
        "n_points": cloud.n_points,
        "spheres": [_sphere_summary(f, s) for f in fits],
        "lengths_reconstructed": l_rec,
        "lengths": l_m,
        "lengths_calibrated": l_cal,
        "values": {"SD": sd},
        "items": {"SD": ["L1", "L2", "L3"]},
        "warnings": warnings,
        "deviations": _scaled(_merge([f.get("deviations") for f in fits], name), s),
    }


EVALUATORS = {
    "sphere": evaluate_sphere,
    "ball_bar": evaluate_ball_bar,
    "flat": evaluate_flat,
    "ball_plate": evaluate_ball_plate,
}


def evaluate(ctx, test: str, cloud: PointCloud, plan: Plan, name: str | None = None) -> dict[str, Any]:
    """One measurement of ``test``; errors other than CamcmmError become one line too."""
    if test not in EVALUATORS:
        raise InputError(f"unknown test {test!r}; use {', '.join(EVALUATORS)}")
    if test not in plan.artefacts:
        raise InputError(f"{_name(cloud, name)}: the plan defines no artefacts.{test}")
    try:
        return EVALUATORS[test](ctx, cloud, plan, name)
    except CamcmmError:
        raise
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        raise GeometryError(f"{_name(cloud, name)}: {test} evaluation failed: {exc}") from None
