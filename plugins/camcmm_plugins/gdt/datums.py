"""Datum reference frames (ISO 5459:2011; ASME Y14.5-2018 §4).

A frame is built from the datum elements in precedence order; each constrains what the
ones before left free:

* orientation — the first datum with a direction (plane normal, axis of a cylinder or
  cone, line, circle/torus axis) fixes the frame's z (2 rotations); the next direction
  not parallel to z fixes x as its part perpendicular to z (the 3rd rotation). When no
  later direction does, a later point-like datum (a sphere centre, or an axis parallel
  to z) off the z axis clocks x towards itself.
* location — a plane fixes the translation along its normal (1), an axis the two
  across it (2), a point, sphere centre, circle or torus centre all three (3); a later
  datum adds only the directions not fixed yet (precedence: the primary is never moved
  by the secondary).

Common datums (``"A-B"``: a label naming several features) are one element: coplanar
planes give the plane through their mean point with the mean normal; coaxial
cylinders/cones the axis through the middles of their axes (for more than two, the
least-squares line through them).

The same construction on the NOMINAL datum features (plan coordinates) gives the nominal
frame N, on the associated ones (the evaluated coordinates) the measured frame M; the
measured directions are oriented like their nominals, and the degrees of freedom the
datums leave free are taken from N (the least change of the evaluated coordinates). The
frame's ``transform`` = N·M⁻¹ maps the evaluated (part) coordinates into the plan's: the
measured datums land on their nominals; ``free`` names the unconstrained degrees of
freedom in plan axes (e.g. ``"rotation z"`` for a single plane datum normal to z).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from camcmm.api import InputError

from . import elements as el
from .model import Associated, DatumFrame, Plan

_PARALLEL = 1e-6  # |sin| below which two directions are taken as parallel


@dataclass
class DatumElement:
    """A datum as the frame uses it: its direction (or None), a point on it and the
    rows (k, 3) of the translation directions it constrains."""

    direction: np.ndarray | None
    point: np.ndarray
    rows: np.ndarray
    kind: str


def _element(etype: str, params: dict, what: str) -> DatumElement:
    el.supported(etype, what)
    d = el.direction(etype, params)
    p = el.location(etype, params)
    if etype == "plane":
        assert d is not None
        return DatumElement(d, p, d[None, :], "plane")
    if etype in ("cylinder", "cone", "line"):
        assert d is not None
        if etype == "cylinder" and params.get("length"):
            p = p + 0.5 * float(params["length"]) * d  # the middle of the axis
        return DatumElement(d, p, el.complement(d), "axis")
    return DatumElement(d, p, np.eye(3), "point")


def _common(parts: list[DatumElement], label: str, where: str) -> DatumElement:
    kinds = {e.kind for e in parts}
    if kinds == {"plane"}:
        n0 = parts[0].direction
        assert n0 is not None
        n = el.unit(sum(np.sign(float(e.direction @ n0)) * e.direction for e in parts if e.direction is not None))
        p = np.mean([e.point for e in parts], axis=0)
        return DatumElement(n, p, n[None, :], "plane")
    if kinds == {"axis"}:
        mids = np.array([e.point for e in parts])
        c = mids.mean(axis=0)
        d0 = parts[0].direction
        assert d0 is not None
        d = el.unit(np.linalg.svd(mids - c)[2][0])
        d = d if d @ d0 >= 0 else -d
        return DatumElement(d, c, el.complement(d), "axis")
    raise InputError(
        f"{where}: datums: common datum {label} needs coplanar planes or coaxial axes, not {sorted(kinds)}"
    )


def _datum_elements(plan: Plan, associated: dict[str, Associated] | None, labels: tuple[str, ...]):
    """(nominal, measured) DatumElements per label; measured None when associated is None."""
    where = plan.source or "plan"
    out = []
    for label in labels:
        fids = plan.datums.get(label)
        if fids is None:
            raise InputError(f"{where}: datums: no datum {label}")
        noms, meas = [], []
        for fid in fids:
            spec = plan.features.get(fid)
            if spec is None:
                raise InputError(f"{where}: datums: {label}: no feature {fid}")
            nom = _element(spec.type, spec.nominal, f"{where}: datums: {label}")
            noms.append(nom)
            if associated is not None:
                a = associated.get(fid)
                if a is None:
                    raise InputError(f"{where}: datums: {label}: feature {fid} was not measured")
                m = _element(a.type, a.params, f"{where}: datums: {label}")
                if m.direction is not None and nom.direction is not None and m.direction @ nom.direction < 0:
                    m.direction = -m.direction
                meas.append(m)
        nom_e = noms[0] if len(noms) == 1 else _common(noms, label, where)
        meas_e = None
        if associated is not None:
            meas_e = meas[0] if len(meas) == 1 else _common(meas, label, where)
            if meas_e.direction is not None and nom_e.direction is not None and meas_e.direction @ nom_e.direction < 0:
                meas_e.direction = -meas_e.direction
        out.append((nom_e, meas_e))
    return out


def _axis_name(v: np.ndarray) -> str:
    for i, name in enumerate("xyz"):
        if abs(abs(v[i]) - 1.0) < 1e-9:
            return name
    return "(" + ", ".join(f"{c:.4g}" for c in v) + ")"


@dataclass
class _Choices:
    """What each datum contributes, decided on the nominal elements and applied alike to
    the measured ones (a measured bore a few µrad off its primary plane's normal must
    not clock the frame when its nominal does not)."""

    rows: list[tuple[int, int]]
    z: int | None
    x: int | None
    x_by_point: bool


def _choose(items: list[DatumElement]) -> _Choices:
    rows: list[np.ndarray] = []
    picked: list[tuple[int, int]] = []
    for i, e in enumerate(items):
        for j, row in enumerate(e.rows):
            if np.linalg.matrix_rank(np.array(rows + [row]), tol=1e-9) > len(rows):
                rows.append(row)
                picked.append((i, j))
    z = next((i for i, e in enumerate(items) if e.direction is not None), None)
    x, by_point = None, False
    if z is not None:
        dz = items[z].direction
        assert dz is not None
        for i in range(z + 1, len(items)):
            d = items[i].direction
            if d is not None and np.linalg.norm(el.cross(dz, d)) > _PARALLEL:
                x = i
                break
        if x is None:
            o = _origin(items, picked, np.zeros(3))
            for i in range(z + 1, len(items)):
                if items[i].kind != "plane" and _off_axis(items[i].point - o, dz) is not None:
                    x, by_point = i, True
                    break
    return _Choices(picked, z, x, by_point)


def _origin(items: list[DatumElement], picked: list[tuple[int, int]], ref_o: np.ndarray) -> np.ndarray:
    if not picked:
        return ref_o.copy()
    a = np.array([items[i].rows[j] for i, j in picked])
    b = np.array([a[k] @ items[i].point for k, (i, _) in enumerate(picked)])
    return ref_o + np.linalg.lstsq(a, b - a @ ref_o, rcond=None)[0]


def _off_axis(v: np.ndarray, z: np.ndarray) -> np.ndarray | None:
    v = v - (v @ z) * z
    return el.unit(v) if np.linalg.norm(v) > 1e-6 else None


def _translation_names(null: np.ndarray) -> list[str]:
    """Names of the translations spanned by the rows of ``null``: the coordinate axes
    when they span it, else the vectors themselves."""
    names = [name for i, name in enumerate("xyz") if np.linalg.norm(null @ np.eye(3)[i]) > 1 - 1e-9]
    if len(names) == len(null):
        return ["translation " + n for n in names]
    return ["translation " + _axis_name(v) for v in null]


def _frame(
    items: list[DatumElement], ch: _Choices, ref_r: np.ndarray, ref_o: np.ndarray
) -> tuple[np.ndarray, list[str]]:
    """(4, 4) frame (columns x, y, z, origin) of the datum elements with the choices
    ``ch``; the free dofs are taken from the reference frame (ref_r columns, ref_o)."""
    free: list[str] = []
    o = _origin(items, ch.rows, ref_o)
    if ch.z is None:
        free += ["rotation x", "rotation y", "rotation z"]
        r = ref_r.copy()
    else:
        z = items[ch.z].direction
        assert z is not None
        x = None
        if ch.x is not None:
            e = items[ch.x]
            if ch.x_by_point:
                x = _off_axis(e.point - o, z)
            elif e.direction is not None:
                x = el.unit(e.direction - (e.direction @ z) * z)
        if x is None:
            ref_x = ref_r[:, 0] if np.linalg.norm(el.cross(ref_r[:, 0], z)) > 1e-3 else ref_r[:, 1]
            x = el.unit(ref_x - (ref_x @ z) * z)
            free.append("rotation " + _axis_name(z))
        r = np.column_stack([x, el.cross(z, x), z])
    if len(ch.rows) < 3:
        a = np.array([items[i].rows[j] for i, j in ch.rows]).reshape(-1, 3)
        null = np.linalg.svd(a)[2][len(ch.rows) :] if len(ch.rows) else np.eye(3)
        free += _translation_names(null)
    f = np.eye(4)
    f[:3, :3] = r
    f[:3, 3] = o
    return f, free


_NOMINAL: dict[tuple[int, tuple[str, ...]], tuple[Plan, _Choices, np.ndarray, list[str]]] = {}


def _nominal(plan: Plan, labels: tuple[str, ...], items: list[DatumElement] | None = None):
    """(choices, N, free) of the nominal datums, kept per plan object and labels (an
    uncertainty propagation rebuilds the measured frame a hundred times)."""
    key = (id(plan), labels)
    hit = _NOMINAL.get(key)
    if hit is not None and hit[0] is plan:
        return hit[1:]
    if items is None:
        items = [n for n, _ in _datum_elements(plan, None, labels)]
    ch = _choose(items)
    nom, free = _frame(items, ch, np.eye(3), np.zeros(3))
    if len(_NOMINAL) > 64:
        _NOMINAL.clear()
    _NOMINAL[key] = (plan, ch, nom, free)
    return ch, nom, free


def primary_kind(plan: Plan, labels: tuple[str, ...]) -> str:
    """What the primary datum of ``labels`` is: "plane", "axis" or "point"."""
    return _datum_elements(plan, None, tuple(labels[:1]))[0][0].kind


def nominal_frame(plan: Plan, labels: tuple[str, ...]) -> tuple[np.ndarray, list[str]]:
    """The nominal frame N (4, 4; columns x, y, z and origin in plan coordinates) of the
    datums ``labels`` and the degrees of freedom they leave free."""
    _, nom, free = _nominal(plan, tuple(labels))
    return nom.copy(), list(free)


def datum_frame(plan: Plan, associated: dict[str, Associated], labels: tuple[str, ...]) -> DatumFrame:
    """The datum reference frame of ``labels`` (primary first) from the associated
    datum features: ``transform`` = N·M⁻¹ from the evaluated into the plan coordinates
    (module docstring). A one-line InputError naming the plan and the datum when a
    label or its feature is missing or a common datum mixes kinds."""
    labels = tuple(labels)
    if not labels:
        return DatumFrame(labels, np.eye(4), [])
    pairs = _datum_elements(plan, associated, labels)
    meas_items = [m for _, m in pairs if m is not None]
    ch, nom, free = _nominal(plan, labels, [n for n, _ in pairs])
    meas, _ = _frame(meas_items, ch, nom[:3, :3], nom[:3, 3])
    return DatumFrame(labels, nom @ np.linalg.inv(meas), list(free))
